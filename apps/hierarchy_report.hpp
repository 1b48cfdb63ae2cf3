// The levels of a multiresolution hierarchy as `pliant mesh` and `pliant info` print them: per level
// nodes, tets, boundary triangles, volume, quality and the stable step it would have on its own.
#pragma once
#include <string>
#include <vector>

#include "pliant/defs.hpp"
#include "pliant/tet_mesh.hpp"

namespace pliant::cli {

// meshes: coarse to fine. material/model/courant: for the stable steps.
void print_hierarchy(const std::vector<TetMesh>& meshes, const MaterialDef& material, ForceModel model, double courant);

// "30,130,550" -> {30, 130, 550}; InputError naming `option` on anything else.
std::vector<std::size_t> parse_counts(const std::string& text, const std::string& option);

}  // namespace pliant::cli
