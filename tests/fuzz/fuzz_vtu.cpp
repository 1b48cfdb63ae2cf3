// libFuzzer harness: VTK XML .vtu, ascii, base64 binary and base64 zlib-compressed (the encoding is
// read from the text; seeds hold each). The point/cell data arrays are read too (VtuData), as
// `pliant render` does.
#include "fuzz_file.hpp"
#include "pliant/error.hpp"
#include "pliant/mesh_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pliant::fuzz::write_file("input.vtu", pliant::fuzz::as_text(data, size));
  try {
    pliant::MeshLoadReport report;
    pliant::VtuData arrays;
    (void)pliant::read_vtu(path, report, &arrays);
  } catch (const pliant::InputError&) {
  }
  return 0;
}
