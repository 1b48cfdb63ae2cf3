// pliant — the command line: run a scene, inspect a mesh, make a mesh.
// Exit codes: 0 success, 2 invalid input (message on stderr), 3 the simulation diverged.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <fmt/format.h>
#include <unistd.h>

#include "pliant/mesh_io.hpp"
#include "pliant/mesh_quality.hpp"
#include "pliant/meshing.hpp"
#include "pliant/run.hpp"
#include "pliant/scene.hpp"
#include "pliant/vtu_writer.hpp"
#include "pliant/world.hpp"

namespace {

using namespace pliant;
namespace fs = std::filesystem;

constexpr int kExitInput = 2;
constexpr int kExitDiverged = 3;

int command_run(const std::string& scene_path, const std::string& out, std::optional<int> threads,
                const std::string& precision, std::optional<double> duration, bool quiet) {
  SceneDef scene = load_scene_file(scene_path);
  RunOptions opt;
  opt.out_dir = out;
  opt.threads = threads;
  if (precision == "float") opt.precision = Precision::float32;
  else if (precision == "double") opt.precision = Precision::float64;
  else if (!precision.empty()) throw InputError(fmt::format("--precision must be float or double, got '{}'", precision));
  opt.duration = duration;
  opt.progress = !quiet && isatty(STDERR_FILENO);
  if (!quiet) fmt::print(stderr, "pliant: running {} ...\n", scene_path);
  const RunSummary s = run_scene(scene, opt);
  if (!quiet) {
    fmt::print("{} nodes, {} tets ({}, {}), {} threads\n", s.nodes, s.tets, s.model, s.precision, s.threads);
    fmt::print("{} steps of {:.4g} s (stable bound {:.4g} s) to t = {:.4g} s in {:.2f} s wall: {:.0f} steps/s\n",
               s.steps, s.dt, s.stable_dt, s.simulated_time, s.wall_time_s, s.steps_per_second);
    fmt::print("max displacement {:.4g} m, kinetic {:.4g} J, elastic {:.4g} J, state hash {}\n", s.max_displacement,
               s.kinetic_energy, s.elastic_energy, s.state_hash);
    fmt::print("results in {}/ (summary.json{}{})\n", fs::path(out).string(),
               s.files.size() > 1 && std::find(s.files.begin(), s.files.end(), "probes.csv") != s.files.end()
                   ? ", probes.csv" : "",
               scene.output.vtu_every > 0 ? ", series.pvd + vtu/" : "");
  }
  return 0;
}

int command_info(const std::string& mesh_path, double young, double poisson, double density, double courant) {
  MeshLoadReport report;
  const TetMesh mesh = read_tet_mesh(mesh_path, &report);
  const MeshQuality q = compute_mesh_quality(mesh);
  fmt::print("{}\n", mesh_path);
  fmt::print("  nodes {}  tets {}  boundary triangles {}\n", q.nodes, q.tets, q.boundary_triangles);
  if (report.skipped_cells || report.reoriented_tets || report.dropped_vertices)
    fmt::print("  on load: {} non-tet cells skipped, {} tets re-oriented, {} unused vertices dropped\n",
               report.skipped_cells, report.reoriented_tets, report.dropped_vertices);
  fmt::print("  bounding box [{:.6g}, {:.6g}, {:.6g}] .. [{:.6g}, {:.6g}, {:.6g}] m\n", q.bbox_min[0], q.bbox_min[1],
             q.bbox_min[2], q.bbox_max[0], q.bbox_max[1], q.bbox_max[2]);
  fmt::print("  volume {:.6g} m^3\n", q.volume);
  fmt::print("  edges {:.4g} .. {:.4g} m, smallest altitude {:.4g} m\n", q.min_edge, q.max_edge, q.min_altitude);
  fmt::print("  dihedral angles {:.2f} .. {:.2f} deg, worst aspect ratio {:.3g}\n", q.min_dihedral_deg,
             q.max_dihedral_deg, q.worst_aspect_ratio);
  MaterialDef m;
  m.young = young;
  m.poisson = poisson;
  m.density = density;
  WorldDef wd;
  wd.threads = 1;
  wd.time_step.courant = courant;
  World w(wd);
  BodyDef b;
  b.name = "mesh";
  b.material = m;
  w.add_body(b, mesh);
  fmt::print("  stable dt {:.4g} s (E = {:.4g} Pa, nu = {}, rho = {} kg/m^3, Courant {})\n", w.stable_dt(), young,
             poisson, density, courant);
  return 0;
}

int command_mesh(const std::string& input, const std::string& implicit, double cell_size, const std::string& output) {
  TetMesh mesh;
  if (!implicit.empty()) {
    mesh = mesh_implicit_shape(implicit, cell_size);
  } else {
    if (input.empty()) throw InputError("pliant mesh: give a SURFACE file (or a volume mesh to convert), or --implicit NAME");
    std::string ext = fs::path(input).extension().string();
    for (auto& c : ext) c = char(std::tolower(c));
    if (ext == ".obj" || ext == ".off" || ext == ".stl" || ext == ".ply") {
      if (!(cell_size > 0)) throw InputError("pliant mesh: --cell-size H (m, > 0) is required to mesh a surface");
      mesh = mesh_surface_file(input, cell_size);
    } else {
      mesh = read_tet_mesh(input);  // conversion of a volume mesh
    }
  }
  write_vtu(output, mesh.points, mesh.tets, {}, VtuEncoding::base64_zlib);
  const MeshQuality q = compute_mesh_quality(mesh);
  fmt::print("{}: {} nodes, {} tets, volume {:.6g} m^3, dihedral {:.1f}..{:.1f} deg\n", output, q.nodes, q.tets,
             q.volume, q.min_dihedral_deg, q.max_dihedral_deg);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pliant: real-time soft elastic bodies (explicit FEM after Debunne 2000)"};
  app.require_subcommand(1);

  std::string scene_path, out = "out", precision;
  std::optional<int> threads;
  std::optional<double> duration;
  bool quiet = false;
  auto* run = app.add_subcommand("run", "Run a scene file and write its results");
  run->add_option("SCENE", scene_path, "Scene file (JSON, see docs/scene-format.md)")->required();
  run->add_option("--out,-o", out, "Output folder")->capture_default_str();
  run->add_option("--threads", threads, "Worker threads (overrides the scene; 0 = all cores)");
  run->add_option("--precision", precision, "float or double (overrides the scene)");
  run->add_option("--duration", duration, "Simulated seconds (overrides the scene)");
  run->add_flag("--quiet,-q", quiet, "No progress line and no report");

  std::string mesh_path;
  double young = 1e6, poisson = 0.3, density = 1000, courant = 0.5;
  auto* info = app.add_subcommand("info", "Counts, bounding box, volume, quality and stable dt of a mesh");
  info->add_option("MESH", mesh_path, "Volume mesh (.msh .vtk .vtu .node/.ele)")->required();
  info->add_option("--young", young, "Young's modulus for the stable dt (Pa)")->capture_default_str();
  info->add_option("--poisson", poisson, "Poisson ratio")->capture_default_str();
  info->add_option("--density", density, "Density (kg/m^3)")->capture_default_str();
  info->add_option("--courant", courant, "Courant number")->capture_default_str();

  std::string input, implicit, output;
  double cell_size = 0;
  auto* mesh = app.add_subcommand("mesh", "Tetrahedralise a closed surface or a shipped shape, or convert a volume mesh, to .vtu");
  mesh->add_option("INPUT", input, "Surface (.obj .off .stl .ply) or volume mesh to convert");
  mesh->add_option("--implicit", implicit, "A shipped implicit shape instead of a file (organ, sphere, capsule)");
  mesh->add_option("--cell-size", cell_size, "Target cell size (m)");
  mesh->add_option("-o,--output", output, "Output .vtu")->required();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitInput;
  }
  try {
    if (*run) return command_run(scene_path, out, threads, precision, duration, quiet);
    if (*info) return command_info(mesh_path, young, poisson, density, courant);
    if (*mesh) return command_mesh(input, implicit, cell_size, output);
  } catch (const InputError& e) {
    fmt::print(stderr, "pliant: error: {}\n", e.what());
    return kExitInput;
  } catch (const DivergenceError& e) {
    fmt::print(stderr, "\npliant: {}\n", e.what());
    return kExitDiverged;
  } catch (const std::exception& e) {
    fmt::print(stderr, "pliant: error: {}\n", e.what());
    return kExitInput;
  }
  return 0;
}
