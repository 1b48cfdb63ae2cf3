// `pliant mesh`: tetrahedralise a closed surface or a shipped shape, or convert a volume mesh, to .vtu.
#include <cctype>
#include <fmt/format.h>

#include "commands.hpp"
#include "pliant/error.hpp"
#include "pliant/mesh_io.hpp"
#include "pliant/mesh_quality.hpp"
#include "pliant/meshing.hpp"
#include "pliant/vtu_writer.hpp"

namespace pliant::cli {
namespace {
namespace fs = std::filesystem;

int command_mesh(const std::string& input, const std::string& implicit, double cell_size, bool repair,
                 const std::string& output) {
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
  write_vtu(output, mesh.points, mesh.tets, {}, VtuEncoding::base64_zlib);
  const MeshQuality q = compute_mesh_quality(mesh);
  fmt::print("{}: {} nodes, {} tets, volume {:.6g} m^3, dihedral {:.1f}..{:.1f} deg\n", output, q.nodes, q.tets,
             q.volume, q.min_dihedral_deg, q.max_dihedral_deg);
  return 0;
}

}  // namespace

Command add_mesh_command(CLI::App& app) {
  struct Options {
    std::string input, implicit, output;
    double cell_size = 0;
    bool repair = false;
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
  return {mesh, [o] { return command_mesh(o->input, o->implicit, o->cell_size, o->repair, o->output); }};
}

}  // namespace pliant::cli
