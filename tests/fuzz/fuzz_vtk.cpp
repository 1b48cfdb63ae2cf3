// libFuzzer harness: VTK legacy .vtk (ASCII unstructured grid), through read_tet_mesh, which also
// sniffs an XML grid misnamed .vtk and reads it as .vtu.
#include "fuzz_file.hpp"
#include "pliant/error.hpp"
#include "pliant/mesh_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pliant::fuzz::write_file("input.vtk", pliant::fuzz::as_text(data, size));
  try {
    pliant::MeshLoadReport report;
    (void)pliant::read_tet_mesh(path, &report);
  } catch (const pliant::InputError&) {
  }
  return 0;
}
