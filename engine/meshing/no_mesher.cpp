// Meshing stub for builds configured with -DPLIANT_WITH_CGAL=OFF: the API exists, reports that
// it is unavailable, and every meshing call throws InputError saying why.
#include <string>

#include "pliant/error.hpp"
#include "pliant/meshing.hpp"

namespace pliant {
namespace {

[[noreturn]] void no_cgal(const std::string& what) {
  throw InputError("this pliant was built without CGAL (PLIANT_WITH_CGAL=OFF): cannot mesh " +
                   what);
}

}  // namespace

bool meshing_available() { return false; }

TetMesh mesh_surface_file(const std::filesystem::path& surface, double /*cell_size*/, bool /*repair*/) {
  no_cgal("surface file '" + surface.string() + "'");
}

SurfaceDiagnosis diagnose_surface(const std::filesystem::path& surface) {
  throw InputError("this pliant was built without CGAL (PLIANT_WITH_CGAL=OFF): cannot read surface file '" +
                   surface.string() + "'");
}

RepairedSurface repair_surface(const std::filesystem::path& surface) {
  throw InputError("this pliant was built without CGAL (PLIANT_WITH_CGAL=OFF): cannot repair surface file '" +
                   surface.string() + "'");
}

TetMesh mesh_implicit_shape(const std::string& name, double /*cell_size*/) {
  no_cgal("implicit shape '" + name + "'");
}

TriangleSurface simplify_surface(const TriangleSurface&, std::size_t, const std::string& what) {
  no_cgal(what + " (simplification for a coarser level)");
}

TetMesh mesh_closed_surface(const TriangleSurface&, double, const std::string& what) { no_cgal(what); }

}  // namespace pliant
