// libFuzzer harness: Gmsh ASCII .msh, versions 1, 2 and 4 (the version is read from the text, so
// one harness covers all three; the seed corpus holds each). Any exception other than InputError,
// any sanitizer report, leak or hang is a defect.
#include "fuzz_file.hpp"
#include "pliant/error.hpp"
#include "pliant/mesh_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pliant::fuzz::write_file("input.msh", pliant::fuzz::as_text(data, size));
  try {
    pliant::MeshLoadReport report;
    (void)pliant::read_tet_mesh(path, &report);
  } catch (const pliant::InputError&) {
  }
  return 0;
}
