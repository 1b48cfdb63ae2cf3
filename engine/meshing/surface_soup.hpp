// Private to pliant_meshing (CGAL builds): reading a polygon surface file into a soup of points
// and faces, shared by the mesher (cgal_mesher.cpp) and the surface checks (surface_check.cpp).
// CGAL-free types, so that including it costs nothing.
#pragma once
#include <array>
#include <cstddef>
#include <string>
#include <vector>

namespace pliant::meshing_detail {

struct SurfaceSoup {
  std::vector<std::array<double, 3>> points;
  std::vector<std::vector<std::size_t>> faces;  // indices into points, 3 or more per face
};

// Reads .obj, .off, .stl or .ply (CGAL's readers; for .obj a lenient fallback keeps "v" and "f"
// lines when CGAL refuses a line it does not know). Throws InputError "surface file '<file>': ..."
// for a missing, empty, unsupported, unreadable or faceless file and for non-finite coordinates.
SurfaceSoup read_surface_soup(const std::string& file);

}  // namespace pliant::meshing_detail
