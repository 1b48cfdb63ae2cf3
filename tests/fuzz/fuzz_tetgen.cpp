// libFuzzer harness: TetGen .node/.ele pairs. The input is split at its first NUL byte: before it
// the .node file, after it the .ele file (no NUL: an empty .ele). Seeds are made that way by
// scripts/fuzz.sh from the pairs in tests/data/mesh.
#include <cstring>

#include "fuzz_file.hpp"
#include "pliant/error.hpp"
#include "pliant/mesh_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto text = pliant::fuzz::as_text(data, size);
  const std::size_t cut = text.find('\0');
  const std::string_view node = text.substr(0, cut);
  const std::string_view ele = cut == std::string_view::npos ? std::string_view{} : text.substr(cut + 1);
  const auto path = pliant::fuzz::write_file("input.node", node);
  pliant::fuzz::write_file("input.ele", ele);
  try {
    pliant::MeshLoadReport report;
    (void)pliant::read_tet_mesh(path, &report);
  } catch (const pliant::InputError&) {
  }
  return 0;
}
