// A host application embedding pliant without any scene file: it builds a soft block from
// code, chooses its own thread count, steps the world from its own loop, moves a prescribed
// region (a "finger" pressing on the top face) and reads node positions through zero-copy
// arrays. ctest runs it; it exits non-zero if what it observes is physically wrong.
#include <cmath>
#include <cstdio>

#include "pliant/world.hpp"

int main() {
  using namespace pliant;
  try {
    WorldDef world_def;
    world_def.threads = 2;                // the host decides
    world_def.gravity = {0, 0, -9.81};    // m/s^2
    world_def.precision = Precision::float32;
    World world(world_def);

    // A 10 x 10 x 5 cm block of soft tissue, clamped at the bottom, pressed at the top centre.
    TetMesh block = make_box_mesh({0, 0, 0}, {0.1, 0.1, 0.05}, {10, 10, 5});
    BodyDef body;
    body.name = "block";
    body.material.young = 5e3;     // Pa
    body.material.poisson = 0.45;
    body.material.density = 1000;  // kg/m^3
    body.material.damping.stiffness = 0.01;  // s
    RegionDef bottom;
    bottom.min = {-1, -1, -1};
    bottom.max = {1, 1, 1e-6};
    body.fixed.push_back(bottom);
    PrescribedMotionDef finger;
    finger.region.kind = RegionDef::Kind::sphere;
    finger.region.center = {0.05, 0.05, 0.05};
    finger.region.radius = 0.012;
    finger.keyframes = {{0.0, {0, 0, 0}}};  // the host drives it below
    body.prescribed.push_back(finger);
    const BodyId id = world.add_body(body, block);

    // Zero-copy, read-only views of the body's SoA arrays (one span per axis), valid while the body
    // exists: they always show the current state, no copy is made per frame. They are in the body
    // frame: relative to world.body_origin(id) (the centre of its rest bounding box, in double), so that float
    // keeps its resolution wherever the host places a body. World position = origin + span value.
    const auto rest = world.rest_positions<float>(id);
    const auto x = world.positions<float>(id);
    const Vec3d origin = world.body_origin(id);  // (0.05, 0.05, 0.025) m for this block
    std::size_t probe = x[0].size();  // the node at the middle of the top face's edge at x = 0.1 (world frame)
    for (std::size_t n = 0; n < x[0].size(); ++n)
      if (std::fabs(origin[0] + rest[0][n] - 0.1) < 1e-6 && std::fabs(origin[1] + rest[1][n] - 0.05) < 1e-6 &&
          std::fabs(origin[2] + rest[2][n] - 0.05) < 1e-6)
        probe = n;
    if (probe == x[0].size()) {
      std::fprintf(stderr, "no node at (0.1, 0.05, 0.05)\n");
      return 1;
    }

    // The host's loop: 0.5 s at 60 frames per second; the finger goes down 1 cm over 0.25 s.
    const double frame = 1.0 / 60.0;
    for (int f = 1; f <= 30; ++f) {
      const double t_end = f * frame;
      const double depth = 0.01 * std::fmin(1.0, t_end / 0.25);
      world.set_motion_offset(id, 0, {0, 0, -depth});
      while (world.time() < t_end) world.step();
      if (f % 10 == 0)
        std::printf("t = %.3f s  finger depth %.4f m  edge node z = %.5f m  (%lld steps)\n", world.time(), depth,
                    origin[2] + x[2][probe], (long long)world.steps());
    }
    const Energies e = world.energies();
    std::printf("kinetic %.3g J, elastic %.3g J, state hash %016llx\n", e.kinetic, e.elastic,
                (unsigned long long)world.state_hash());

    // What a user would check: the top face sagged under the finger, the body did not explode,
    // and the clamped bottom did not move.
    const float sag = rest[2][probe] - x[2][probe];
    if (!(sag > 1e-5f && sag < 0.01f)) {
      std::fprintf(stderr, "unexpected sag of the top edge: %g m\n", double(sag));
      return 1;
    }
    for (std::size_t n = 0; n < x[2].size(); ++n)
      if (std::fabs(origin[2] + rest[2][n]) < 1e-6 && x[2][n] != rest[2][n]) {  // on the clamped bottom
        std::fprintf(stderr, "clamped node %zu moved\n", n);
        return 1;
      }
    std::printf("ok\n");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "embed_example: %s\n", e.what());
    return 2;
  }
}
