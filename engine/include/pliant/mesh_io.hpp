// Readers for volume mesh files. Every reader returns a finalized TetMesh (see
// finalize_tet_mesh) or throws InputError naming the file and the line (or element number).
#pragma once
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "pliant/tet_mesh.hpp"

namespace pliant {

// Dispatches on the extension: .msh (Gmsh ASCII v1, v2, v4), .vtk (legacy ASCII unstructured
// grid; an XML UnstructuredGrid misnamed .vtk is detected and read as .vtu), .vtu (VTK XML:
// ascii, or base64 binary with or without zlib), .node/.ele (TetGen; either name works).
TetMesh read_tet_mesh(const std::filesystem::path& path, MeshLoadReport* report = nullptr);

TetMesh read_gmsh(const std::filesystem::path& path, MeshLoadReport& report);
TetMesh read_vtk_legacy(const std::filesystem::path& path, MeshLoadReport& report);
TetMesh read_vtu(const std::filesystem::path& path, MeshLoadReport& report);

// What a .vtu holds besides its mesh (pliant run writes "displacement" per point and
// "von_mises" per cell, see vtu_writer.hpp): every DataArray of <PointData> and <CellData>, over
// all pieces in file order, and the <FieldData> of the grid ("TimeValue"), as doubles. Indices
// are those of the file: point i is mesh node i, cell c is mesh tet c, only when the file's
// counts equal the mesh's (no cell skipped, no vertex dropped). An array that cannot be read
// (appended data, wrong length, a non-number) is left out and named in `notes`: the mesh still loads.
struct VtuArray {
  int components = 1;
  std::vector<double> values;  // components per tuple, tuple-major
};
struct VtuData {
  std::map<std::string, VtuArray> point, cell, field;
  std::size_t points = 0, cells = 0;  // in the file, over all pieces
  std::vector<std::string> notes;
};
TetMesh read_vtu(const std::filesystem::path& path, MeshLoadReport& report, VtuData* data);
TetMesh read_tetgen(const std::filesystem::path& path, MeshLoadReport& report);

}  // namespace pliant
