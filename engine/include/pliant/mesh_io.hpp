// Readers for volume mesh files. Every reader returns a finalized TetMesh (see
// finalize_tet_mesh) or throws InputError naming the file and the line (or element number).
#pragma once
#include <filesystem>

#include "pliant/tet_mesh.hpp"

namespace pliant {

// Dispatches on the extension: .msh (Gmsh ASCII v1, v2, v4), .vtk (legacy ASCII unstructured
// grid; an XML UnstructuredGrid misnamed .vtk is detected and read as .vtu), .vtu (VTK XML:
// ascii, or base64 binary with or without zlib), .node/.ele (TetGen; either name works).
TetMesh read_tet_mesh(const std::filesystem::path& path, MeshLoadReport* report = nullptr);

TetMesh read_gmsh(const std::filesystem::path& path, MeshLoadReport& report);
TetMesh read_vtk_legacy(const std::filesystem::path& path, MeshLoadReport& report);
TetMesh read_vtu(const std::filesystem::path& path, MeshLoadReport& report);
TetMesh read_tetgen(const std::filesystem::path& path, MeshLoadReport& report);

}  // namespace pliant
