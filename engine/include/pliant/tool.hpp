// What a host reads from and writes to a tool (ToolDef in defs.hpp; docs/tool.md).
#pragma once
#include <cstdint>
#include "pliant/defs.hpp"

namespace pliant {

// A rigid placement of a tool: its centre (m, world frame) and orientation (unit quaternion
// w, x, y, z; a capsule's axis is its local z).
struct ToolPose {
  Vec3d position{};
  Quatd orientation{1, 0, 0, 0};
};

// What the bodies did to a tool in the last step.
struct ToolReading {
  double time = 0;             // s, simulated time of the reading (end of the step)
  Vec3d force{};               // N, world frame: the force the bodies exert on the tool (pressing
                               //   down into a body reads +z). The reaction of the nodes the tool
                               //   holds: the sum of the internal (elastic + viscous) forces and
                               //   loads on them (Newton's third law; docs/tool.md)
  double work = 0;             // J, the work the tool did on the bodies in the last step: its motion
                               //   against the held nodes' forces and against the impulses it gave
                               //   them (docs/tool.md); 0 for a tool at rest. What an energy
                               //   budget counts (pliant stress --tools, a haptic passivity check)
  double work_total = 0;       // J, `work` summed over every step so far (sub-steps included)
  int contacts = 0;            // surface triangles touched (or swept through) in the last step
  int held_nodes = 0;          // nodes the tool moved in the last step
  double max_penetration = 0;  // m, deepest triangle inside the tool after the response
  std::int64_t refits = 0;     // BVH refits so far, over its levels (a surface is refit only once a
  std::int64_t queries = 0;    //   vertex moved a quarter edge; queries: contact passes so far)
};

// The tool's pose at time t (s) along keyframes (position linear, orientation spherical-linear,
// held outside their time span). Keyframes sorted by time, at least one.
ToolPose tool_pose_at(const std::vector<ToolKeyframeDef>& keyframes, double t);

// The two ends of a tool's axis (m, world frame) at a pose: equal for a sphere.
void tool_axis(const ToolShapeDef& shape, const ToolPose& pose, Vec3d& a, Vec3d& b);

}  // namespace pliant
