// print_hierarchy and parse_counts (hierarchy_report.hpp).
#include "hierarchy_report.hpp"

#include <fmt/format.h>

#include "pliant/error.hpp"
#include "pliant/mesh_quality.hpp"
#include "pliant/world.hpp"

namespace pliant::cli {

void print_hierarchy(const std::vector<TetMesh>& meshes, const MaterialDef& material, ForceModel model, double courant) {
  fmt::print("  level  nodes    tets  surface tris  volume (m^3)  dihedral (deg)  stable dt (s)\n");
  for (std::size_t l = 0; l < meshes.size(); ++l) {
    const MeshQuality q = compute_mesh_quality(meshes[l]);
    WorldDef wd;
    wd.threads = 1;
    wd.time_step.courant = courant;
    World w(wd);
    BodyDef b;
    b.name = fmt::format("level {}", l);
    b.material = material;
    b.model = model;
    w.add_body(b, meshes[l]);
    fmt::print("  {:5}  {:5}  {:6}  {:12}  {:12.5g}  {:5.1f} .. {:5.1f}  {:.4g}\n", l, q.nodes, q.tets,
               q.boundary_triangles, q.volume, q.min_dihedral_deg, q.max_dihedral_deg, w.stable_dt());
  }
}

std::vector<std::size_t> parse_counts(const std::string& text, const std::string& option) {
  std::vector<std::size_t> out;
  std::size_t i = 0;
  while (i <= text.size()) {
    const std::size_t j = std::min(text.find(',', i), text.size());
    const std::string part = text.substr(i, j - i);
    std::size_t used = 0;
    unsigned long long v = 0;
    try {
      v = std::stoull(part, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (part.empty() || used != part.size() || v < 4 || v > 100'000'000)
      throw InputError(fmt::format("{}: expected counts from 4 to 1e8 separated by commas, like 30,130,550; got \"{}\"",
                                   option, text));
    // As the scene reader's multiresolution.faces: coarse to fine (10,5 made a "coarser" level
    // finer than the one after it).
    if (!out.empty() && std::size_t(v) <= out.back())
      throw InputError(fmt::format("{}: the counts must grow from coarse to fine: {} after {} in \"{}\"", option, v,
                                   out.back(), text));
    out.push_back(std::size_t(v));
    i = j + 1;
  }
  return out;
}

}  // namespace pliant::cli
