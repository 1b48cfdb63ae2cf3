// `pliant mesh`: tetrahedralise a closed surface or a shipped shape, or convert a volume mesh, to .vtu.
#include <cctype>
#include <fmt/format.h>

#include <chrono>

#include "commands.hpp"
#include "hierarchy_report.hpp"
#include "pliant/hierarchy.hpp"
#include "pliant/world.hpp"
#include "pliant/error.hpp"
#include "pliant/mesh_io.hpp"
#include "pliant/mesh_quality.hpp"
#include "pliant/meshing.hpp"
#include "pliant/vtu_writer.hpp"

namespace pliant::cli {
namespace {
namespace fs = std::filesystem;

struct LevelOptions {
  int levels = 1;
  double ratio = 2;
  std::string faces;  // "30,130,550"
};

int command_mesh(const std::string& input, const std::string& implicit, double cell_size, bool repair,
                 const std::string& output, const LevelOptions& lo) {
  // (A file given with --implicit was ignored without a word.)
  if (!implicit.empty() && !input.empty())
    throw InputError(fmt::format("pliant mesh: give a file ({}) or --implicit {}, not both", input, implicit));
  refuse_overwriting_input(input, output, "-o");
  const auto start = std::chrono::steady_clock::now();
  TetMesh mesh;
  if (!implicit.empty()) {
    mesh = mesh_implicit_shape(implicit, cell_size);
  } else {
    if (input.empty()) throw InputError("pliant mesh: give a SURFACE file (or a volume mesh to convert), or --implicit NAME");
    std::string ext = fs::path(input).extension().string();
    for (auto& c : ext) c = char(std::tolower(c));
    if (ext == ".obj" || ext == ".off" || ext == ".stl" || ext == ".ply") {
      if (!(cell_size > 0)) throw InputError("pliant mesh: --cell-size H (m, > 0) is required to mesh a surface");
      mesh = mesh_surface_file(input, cell_size, repair);
    } else {
      mesh = read_tet_mesh(input);  // conversion of a volume mesh
    }
  }
  const double finest_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  write_vtu(output, mesh.points, mesh.tets, {}, VtuEncoding::base64_zlib);
  const MeshQuality q = compute_mesh_quality(mesh);
  fmt::print("{}: {} nodes, {} tets, volume {:.6g} m^3, dihedral {:.1f}..{:.1f} deg\n", output, q.nodes, q.tets,
             q.volume, q.min_dihedral_deg, q.max_dihedral_deg);
  if (lo.levels > 1 || !lo.faces.empty()) {
    // The coarser levels of a multiresolution body made from this mesh (docs/multiresolution.md).
    BodyDef def;
    def.mesh.kind = implicit.empty() ? MeshSourceDef::Kind::file : MeshSourceDef::Kind::implicit;
    def.multiresolution.ratio = lo.ratio;
    if (!lo.faces.empty()) def.multiresolution.faces = parse_counts(lo.faces, "--faces");
    def.multiresolution.levels = lo.faces.empty() ? lo.levels : int(def.multiresolution.faces.size()) + 1;
    if (def.multiresolution.levels < 1 || def.multiresolution.levels > 8)
      throw InputError(fmt::format("--levels must be in 1..8, got {}", def.multiresolution.levels));
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<TetMesh> levels = build_level_meshes(def, mesh);
    const double coarse_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const fs::path out(output);
    for (std::size_t l = 0; l + 1 < levels.size(); ++l) {
      const fs::path file = out.parent_path() / fmt::format("{}_L{}{}", out.stem().string(), l, out.extension().string());
      write_vtu(file, levels[l].points, levels[l].tets, {}, VtuEncoding::base64_zlib);
      fmt::print("{}: level {}\n", file.string(), l);
    }
    fmt::print("hierarchy of {} levels (0 = coarsest; the last is {}), stable dt for E = 1 MPa, nu = 0.3, rho = 1000:\n",
               levels.size(), output);
    print_hierarchy(levels, MaterialDef{}, ForceModel::corotational, 0.5);
    fmt::print("time: finest {:.3f} s, coarser levels {:.3f} s ({:.2f}x the finest alone)\n", finest_s, coarse_s,
               (finest_s + coarse_s) / finest_s);
  }
  return 0;
}

}  // namespace

Command add_mesh_command(CLI::App& app) {
  struct Options {
    std::string input, implicit, output;
    double cell_size = 0;
    bool repair = false;
    LevelOptions levels;
  };
  auto o = std::make_shared<Options>();
  auto* mesh = app.add_subcommand(
      "mesh", "Tetrahedralise a closed surface or a shipped shape, or convert a volume mesh, to .vtu");
  mesh->add_option("INPUT", o->input, "Surface (.obj .off .stl .ply) or volume mesh to convert");
  mesh->add_option("--implicit", o->implicit, "A shipped implicit shape instead of a file (organ, sphere, capsule)");
  mesh->add_option("--cell-size", o->cell_size, "Target cell size (m)");
  mesh->add_flag("--repair", o->repair,
                 "Repair a surface that does not bound a volume first (CGAL: stitch, orient, fill holes, remove "
                 "self-intersections)");
  mesh->add_option("-o,--output", o->output, "Output .vtu")->required();
  mesh->add_option("--levels", o->levels.levels,
                   "Also make the coarser levels of a multiresolution hierarchy (OUTPUT_L0.vtu .. ) and print them");
  mesh->add_option("--ratio", o->levels.ratio, "Resolution ratio between levels (surfaces: 1/ratio^2 of the faces)")
      ->capture_default_str();
  mesh->add_option("--faces", o->levels.faces,
                   "Triangles of each coarser level's surface, coarse to fine, e.g. 30,130,550 (sets the levels)");
  return {mesh, [o] { return command_mesh(o->input, o->implicit, o->cell_size, o->repair, o->output, o->levels); }};
}

}  // namespace pliant::cli
