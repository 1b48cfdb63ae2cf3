// Plain definitions a host fills in (or a scene file produces) to create worlds and bodies.
// Every field has a sane default; units are SI.
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "pliant/tet_mesh.hpp"

namespace pliant {

enum class Precision { float32, float64 };
enum class ForceModel { linear, stvk, corotational, springs };

const char* to_string(Precision p);   // "float" | "double"
const char* to_string(ForceModel m);  // "linear" | "stvk" | "corotational" | "springs"

struct DampingDef {
  double mass = 0.0;        // alpha (1/s): force -alpha m v on every node
  double stiffness = 0.0;   // beta (s): Rayleigh stiffness factor, viscous stress with phi = beta*lambda, psi = beta*mu
  // Viscous stress coefficients of the thesis (ch.2 §4), Pa*s: phi tr(eps_dot) I + 2 psi eps_dot.
  // When set they replace beta*lambda and beta*mu.
  std::optional<double> bulk_viscosity;   // phi
  std::optional<double> shear_viscosity;  // psi
};

struct MaterialDef {
  double young = 1e6;     // E (Pa), > 0
  double poisson = 0.3;   // nu, in [0, 0.5)
  double density = 1000;  // rho (kg/m^3), > 0
  DampingDef damping;
};

// A region of a body's rest configuration: which nodes it selects.
struct RegionDef {
  enum class Kind { box, sphere, nodes } kind = Kind::box;
  Vec3d min{}, max{};                 // box (m), inclusive
  Vec3d center{}; double radius = 0;  // sphere (m), inclusive
  std::vector<std::int32_t> nodes;    // explicit node indices (0-based, after loading)
};

// A keyframed rigid translation of a region, relative to its rest position; linear interpolation
// between keyframes, held constant after the last one (and before the first).
struct KeyframeDef {
  double time = 0;      // s
  Vec3d offset{};       // m
};
struct PrescribedMotionDef {
  RegionDef region;
  std::vector<KeyframeDef> keyframes;  // sorted by time, at least one
};

// A constant external force spread equally over the nodes of a region.
struct NodalLoadDef {
  RegionDef region;
  Vec3d total_force{};  // N, sum over the region's nodes
};

// Where a body's mesh comes from.
struct MeshSourceDef {
  enum class Kind { box, file, surface, implicit } kind = Kind::box;
  // box
  Vec3d min{0, 0, 0}, max{1, 0.1, 0.1};
  std::array<int, 3> cells{10, 1, 1};
  int tets_per_cell = 6;  // 5 or 6
  // file (volume mesh) or surface (closed triangle surface meshed by CGAL); absolute after loading
  std::filesystem::path path;
  // surface or implicit: target cell size (m) of the body as simulated, after scale (the mesher
  // gets cell_size / scale in the units of the surface or shape)
  double cell_size = 0;
  // implicit: name of a shipped shape ("organ", ...)
  std::string shape;
  // applied after loading, to any kind: x <- scale * x + translate
  double scale = 1.0;
  Vec3d translate{0, 0, 0};
};

struct BodyDef {
  std::string name = "body";
  MeshSourceDef mesh;
  MaterialDef material;
  ForceModel model = ForceModel::corotational;
  std::vector<RegionDef> fixed;                 // nodes held at their rest position
  std::vector<PrescribedMotionDef> prescribed;  // nodes moved along keyframes
  std::vector<NodalLoadDef> loads;
};

struct TimeStepDef {
  std::optional<double> dt;   // s; empty = "auto" (the stable step)
  double courant = 0.5;       // C in dt <= C h_min sqrt(rho / (lambda + 2 mu)), in (0, 1]
  bool substep = false;       // an explicit dt above the bound is split into stable sub-steps instead of refused
  // Follow the deformation: every few steps, measure how much stiffer the elements are than at
  // rest (stvk and corotational stiffen under large stretch and inversion) and split the step
  // into more sub-steps when the rest-state step would no longer be stable. Reported in
  // World::substeps() / max_substeps(). Off: the step stays as chosen at load, whatever happens.
  bool adapt = true;
};

struct WorldDef {
  Vec3d gravity{0, 0, -9.81};   // m/s^2
  Precision precision = Precision::float64;
  int threads = 0;              // 0: all cores the process may use; more than those is clamped to them
                                //   (World::threads() reports the number used)
  TimeStepDef time_step;
};

struct ProbeDef {
  std::string name;
  std::string body;   // body name
  Vec3d point{};      // rest position (m); the probe follows this material point
};

struct OutputDef {
  double vtu_every = 0;   // s between VTU frames; 0 = no VTU output
  double probe_every = 0; // s between probe rows; 0 = every step
  bool sheet = false;     // `pliant run` also writes a contact sheet (sheet.png), as with --sheet
};

// Where pictures are taken from (`pliant run --png-every/--sheet`, `pliant render`).
struct CameraDef {
  Vec3d position{};     // m, the eye
  Vec3d target{};       // m, the point at the centre of the picture
  Vec3d up{0, 0, 1};    // the direction shown upwards (not along target - position)
  double fov_deg = 40;  // vertical field of view (degrees), in (0, 180)
};

// A whole scene: what `pliant run` executes.
struct SceneDef {
  double duration = 1.0;  // s
  WorldDef world;
  std::vector<BodyDef> bodies;
  std::vector<ProbeDef> probes;
  OutputDef output;
  std::optional<CameraDef> camera;  // none: pictures frame the bodies automatically
  std::filesystem::path source;  // the scene file, for messages ("" when built in code)
};

}  // namespace pliant
