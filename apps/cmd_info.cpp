// `pliant info MESH`: counts, bounding box, volume, quality and the stable step of a mesh.
#include <fmt/format.h>

#include "commands.hpp"
#include "hierarchy_report.hpp"
#include "pliant/error.hpp"
#include "pliant/hierarchy.hpp"
#include "pliant/mesh_io.hpp"
#include "pliant/mesh_quality.hpp"
#include "pliant/world.hpp"

namespace pliant::cli {
namespace {

int command_info(const std::string& mesh_path, double young, double poisson, double density, double courant,
                 int levels, double ratio, const std::string& faces) {
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
  if (levels > 1 || !faces.empty()) {  // the hierarchy a multiresolution body of this mesh would have
    BodyDef def;
    def.mesh.kind = MeshSourceDef::Kind::file;
    def.multiresolution.ratio = ratio;
    if (!faces.empty()) def.multiresolution.faces = parse_counts(faces, "--faces");
    def.multiresolution.levels = faces.empty() ? levels : int(def.multiresolution.faces.size()) + 1;
    if (def.multiresolution.levels > 8) throw InputError(fmt::format("--levels must be in 1..8, got {}", levels));
    fmt::print("  multiresolution hierarchy ({} levels, 0 = coarsest; ratio {}):\n", def.multiresolution.levels, ratio);
    print_hierarchy(build_level_meshes(def, mesh), m, ForceModel::corotational, courant);
  }
  return 0;
}

}  // namespace

Command add_info_command(CLI::App& app) {
  struct Options {
    std::string mesh;
    double young = 1e6, poisson = 0.3, density = 1000, courant = 0.5;
    int levels = 1;
    double ratio = 2;
    std::string faces;
  };
  auto o = std::make_shared<Options>();
  auto* info = app.add_subcommand("info", "Counts, bounding box, volume, quality and stable dt of a mesh");
  info->add_option("MESH", o->mesh, "Volume mesh (.msh .vtk .vtu .node/.ele)")->required();
  info->add_option("--young", o->young, "Young's modulus for the stable dt (Pa)")->capture_default_str();
  info->add_option("--poisson", o->poisson, "Poisson ratio")->capture_default_str();
  info->add_option("--density", o->density, "Density (kg/m^3)")->capture_default_str();
  info->add_option("--courant", o->courant, "Courant number")->capture_default_str();
  info->add_option("--levels", o->levels, "Also print the hierarchy of a multiresolution body of this mesh")
      ->capture_default_str();
  info->add_option("--ratio", o->ratio, "Resolution ratio between levels")->capture_default_str();
  info->add_option("--faces", o->faces, "Triangles of each coarser level's surface, coarse to fine (e.g. 30,130,550)");
  return {info, [o] {
            return command_info(o->mesh, o->young, o->poisson, o->density, o->courant, o->levels, o->ratio, o->faces);
          }};
}

}  // namespace pliant::cli
