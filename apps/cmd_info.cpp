// `pliant info FILE`: what a mesh file is before it is used.
//   A volume mesh (.msh .vtk .vtu .node/.ele): counts, bounding box, volume, quality and the
//   stable step for a material.
//   A surface (.obj .off .stl .ply): counts, bounding box, whether it bounds a volume and, if not,
//   why and where (holes, non-manifold edges and vertices, self-intersections), its volume, and
//   what a --cell-size would give (the tet count estimated from the volume, then the mesh itself:
//   counts, quality and stable step). With --repair, the surface after CGAL's repair.
// --scale multiplies the file's coordinates, as "scale" in a scene does, so that every length
// printed is the one a scene would simulate (m).
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>

#include "commands.hpp"
#include "hierarchy_report.hpp"
#include "pliant/hierarchy.hpp"
#include "pliant/error.hpp"
#include "pliant/mesh_io.hpp"
#include "pliant/mesh_quality.hpp"
#include "pliant/meshing.hpp"
#include "pliant/world.hpp"

namespace pliant::cli {
namespace {
namespace fs = std::filesystem;

constexpr double kTetsPerCellVolume = 4.3;  // Mesh_3 gives about 4.3 V / s^3 (cgal_mesher.cpp)
constexpr double kMeshAtMost = 1e6;         // tets: above, --cell-size only estimates (meshing takes minutes)

struct InfoArgs {
  std::string file;
  double scale = 1, young = 1e6, poisson = 0.3, density = 1000, courant = 0.5;
  std::optional<double> cell_size;
  bool repair = false;
  int levels = 1;       // also the hierarchy of a multiresolution body of this mesh
  double ratio = 2;
  std::string faces;    // "30,130,550"
};

// A count to two significant digits: "4300", "12000", "1.3 million".
std::string two_digits(double n) {
  const double p = std::pow(10.0, std::floor(std::log10(std::max(n, 1.0))) - 1);
  const double r = std::max(1.0, std::round(n / p) * p);
  return r < 1e6 ? fmt::format("{:.0f}", r) : fmt::format("{:.2g} million", r / 1e6);
}

// The hierarchy a multiresolution body of this mesh would have (--levels, --ratio, --faces).
void print_levels(const TetMesh& mesh, const InfoArgs& a) {
  if (a.levels <= 1 && a.faces.empty()) return;
  BodyDef def;
  def.mesh.kind = MeshSourceDef::Kind::file;
  def.multiresolution.ratio = a.ratio;
  if (!a.faces.empty()) def.multiresolution.faces = parse_counts(a.faces, "--faces");
  def.multiresolution.levels = a.faces.empty() ? a.levels : int(def.multiresolution.faces.size()) + 1;
  if (def.multiresolution.levels > 8)
    throw InputError(fmt::format("--levels must be in 1..8, got {}", def.multiresolution.levels));
  MaterialDef m;
  m.young = a.young;
  m.poisson = a.poisson;
  m.density = a.density;
  fmt::print("  multiresolution hierarchy ({} levels, 0 = coarsest; ratio {}):\n", def.multiresolution.levels, a.ratio);
  print_hierarchy(build_level_meshes(def, mesh), m, ForceModel::corotational, a.courant);
}

void print_volume_mesh(const TetMesh& mesh, const InfoArgs& a, const std::string& indent) {
  const MeshQuality q = compute_mesh_quality(mesh);
  fmt::print("{}nodes {}  tets {}  boundary triangles {}\n", indent, q.nodes, q.tets, q.boundary_triangles);
  fmt::print("{}bounding box [{:.6g}, {:.6g}, {:.6g}] .. [{:.6g}, {:.6g}, {:.6g}] m ({:.4g} x {:.4g} x {:.4g} m)\n", indent,
             q.bbox_min[0], q.bbox_min[1], q.bbox_min[2], q.bbox_max[0], q.bbox_max[1], q.bbox_max[2],
             q.bbox_max[0] - q.bbox_min[0], q.bbox_max[1] - q.bbox_min[1], q.bbox_max[2] - q.bbox_min[2]);
  fmt::print("{}volume {:.6g} m^3\n", indent, q.volume);
  fmt::print("{}edges {:.4g} .. {:.4g} m, smallest altitude {:.4g} m\n", indent, q.min_edge, q.max_edge, q.min_altitude);
  fmt::print("{}dihedral angles {:.2f} .. {:.2f} deg, worst aspect ratio {:.3g}\n", indent, q.min_dihedral_deg,
             q.max_dihedral_deg, q.worst_aspect_ratio);
  WorldDef wd;
  wd.threads = 1;
  wd.time_step.courant = a.courant;
  World w(wd);
  BodyDef b;
  b.name = "mesh";
  b.material.young = a.young;
  b.material.poisson = a.poisson;
  b.material.density = a.density;
  w.add_body(b, mesh);
  fmt::print("{}stable dt {:.4g} s (E = {:.4g} Pa, nu = {}, rho = {} kg/m^3, Courant {})\n", indent, w.stable_dt(), a.young,
             a.poisson, a.density, a.courant);
}

void print_diagnosis(const SurfaceDiagnosis& d, double scale) {
  fmt::print("  vertices {}  faces {}  triangles {}\n", d.vertices, d.faces, d.triangles);
  const Vec3d lo{scale * d.min[0], scale * d.min[1], scale * d.min[2]}, hi{scale * d.max[0], scale * d.max[1], scale * d.max[2]};
  fmt::print("  bounding box [{:.6g}, {:.6g}, {:.6g}] .. [{:.6g}, {:.6g}, {:.6g}] m ({:.4g} x {:.4g} x {:.4g} m)\n", lo[0],
             lo[1], lo[2], hi[0], hi[1], hi[2], hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  if (d.bounds_volume()) {
    fmt::print("  watertight: yes (closed, manifold, oriented, no self-intersection); volume {:.6g} m^3\n",
               d.volume * scale * scale * scale);
    return;
  }
  if (d.closed)
    fmt::print("  watertight: closed and manifold, volume {:.6g} m^3, but faces intersect (meshing removes local "
               "self-intersections first, as far as CGAL can):\n", d.volume * scale * scale * scale);
  else
    fmt::print("  watertight: no, it does not bound a volume:\n");
  for (const std::string& p : d.problems) fmt::print("    {}\n", p);
  if (scale != 1) fmt::print("    (positions above in the file's units, before --scale)\n");
}

int info_surface(const InfoArgs& a) {
  fmt::print("{}{}\n", a.file, a.scale != 1 ? fmt::format(" (x {:g})", a.scale) : "");
  SurfaceDiagnosis d = diagnose_surface(a.file);
  print_diagnosis(d, a.scale);
  if (a.repair) {
    const RepairedSurface r = repair_surface(a.file);
    fmt::print("after --repair:\n");
    for (const std::string& s : r.steps) fmt::print("  {}\n", s);
    d = r.after;
    print_diagnosis(d, a.scale);
  }
  if (!a.cell_size) {
    if (d.closed) fmt::print("  --cell-size H (m) tells how many tets meshing it at H gives, and their stable dt\n");
    else if (!a.repair) fmt::print("  --repair shows whether CGAL's repair makes it bound a volume\n");
    return 0;
  }
  if (!d.closed) {
    fmt::print("  --cell-size: a surface that does not bound a volume cannot be meshed{}\n",
               a.repair ? "" : " (try --repair)");
    return 0;
  }
  const double volume = d.volume * a.scale * a.scale * a.scale;
  const double estimate = kTetsPerCellVolume * volume / std::pow(*a.cell_size, 3);
  fmt::print("cell size {:g} m: about {} tets (Mesh_3 gives about 4.3 volume / cell_size^3)\n", *a.cell_size,
             two_digits(estimate));
  if (estimate > kMeshAtMost) {
    fmt::print("  not meshed here (more than {:.0f} million tets take minutes): `pliant mesh` does it\n", kMeshAtMost / 1e6);
    return 0;
  }
  // The mesher works in the file's units: the cell size there is cell_size / scale.
  TetMesh mesh = mesh_surface_file(a.file, *a.cell_size / a.scale, a.repair);
  if (a.scale != 1) transform_mesh(mesh, a.scale, {0, 0, 0});
  fmt::print("  meshed:\n");
  print_volume_mesh(mesh, a, "  ");
  print_levels(mesh, a);
  return 0;
}

int command_info(const InfoArgs& a) {
  if (!(a.scale > 0 && std::isfinite(a.scale)))
    throw InputError(fmt::format("--scale must be a finite number > 0, got {}", a.scale));
  if (a.cell_size && !(*a.cell_size > 0 && std::isfinite(*a.cell_size)))
    throw InputError(fmt::format("--cell-size must be a finite length > 0 (m), got {}", *a.cell_size));
  std::string ext = fs::path(a.file).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext == ".obj" || ext == ".off" || ext == ".stl" || ext == ".ply") return info_surface(a);
  if (a.cell_size) throw InputError("--cell-size is for surface files (.obj .off .stl .ply): a volume mesh has its cells");
  if (a.repair) throw InputError("--repair is for surface files (.obj .off .stl .ply)");
  MeshLoadReport report;
  TetMesh mesh = read_tet_mesh(a.file, &report);
  if (a.scale != 1) transform_mesh(mesh, a.scale, {0, 0, 0});
  fmt::print("{}{}\n", a.file, a.scale != 1 ? fmt::format(" (x {:g})", a.scale) : "");
  if (report.skipped_cells || report.reoriented_tets || report.dropped_vertices)
    fmt::print("  on load: {} non-tet cells skipped, {} tets re-oriented, {} unused vertices dropped\n",
               report.skipped_cells, report.reoriented_tets, report.dropped_vertices);
  print_volume_mesh(mesh, a, "  ");
  print_levels(mesh, a);
  return 0;
}

}  // namespace

Command add_info_command(CLI::App& app) {
  auto a = std::make_shared<InfoArgs>();
  auto* info = app.add_subcommand(
      "info", "What a mesh file is: a volume mesh's counts, size, quality and stable dt; a surface's size, watertightness "
              "(and why not, where) and what a cell size would give");
  info->add_option("FILE", a->file, "Volume mesh (.msh .vtk .vtu .node/.ele) or surface (.obj .off .stl .ply)")->required();
  info->add_option("--scale", a->scale, "Multiplies the file's coordinates (as \"scale\" in a scene; 0.001 for a file in mm)")
      ->capture_default_str();
  info->add_option("--cell-size", a->cell_size, "For a surface: the cell size (m, after --scale) to estimate and mesh at");
  info->add_flag("--repair", a->repair, "For a surface: also show it after CGAL's repair (stitch, orient, fill holes, ...)");
  info->add_option("--young", a->young, "Young's modulus for the stable dt (Pa)")->capture_default_str();
  info->add_option("--poisson", a->poisson, "Poisson ratio")->capture_default_str();
  info->add_option("--density", a->density, "Density (kg/m^3)")->capture_default_str();
  info->add_option("--courant", a->courant, "Courant number")->capture_default_str();
  info->add_option("--levels", a->levels, "Also print the hierarchy of a multiresolution body of this mesh")
      ->capture_default_str();
  info->add_option("--ratio", a->ratio, "Resolution ratio between levels")->capture_default_str();
  info->add_option("--faces", a->faces, "Triangles of each coarser level's surface, coarse to fine (e.g. 30,130,550)");
  return {info, [a] { return command_info(*a); }};
}

}  // namespace pliant::cli
