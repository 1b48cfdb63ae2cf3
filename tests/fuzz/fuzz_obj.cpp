// libFuzzer harness: OBJ surfaces (read_obj_surface, pliant/skin.hpp: the skins of bodies), the
// surface format pliant reads without CGAL. CGAL's own readers (.off/.stl/.obj surfaces to mesh)
// are not fuzzed here: the fuzz build has no CGAL.
#include "fuzz_file.hpp"
#include "pliant/error.hpp"
#include "pliant/skin.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = pliant::fuzz::write_file("input.obj", pliant::fuzz::as_text(data, size));
  try {
    (void)pliant::read_obj_surface(path);
  } catch (const pliant::InputError&) {
  }
  return 0;
}
