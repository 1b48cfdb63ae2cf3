// libFuzzer harness: the scene parser (parse_scene), JSON text to a validated SceneDef. Mesh paths
// are resolved against scenes/ (so that the shipped scenes parse whole) and only checked to be
// regular files, never read, so the scene is parsed from memory.
#include <string>
#include <string_view>

#include "fuzz_file.hpp"
#include "pliant/error.hpp"
#include "pliant/scene.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    (void)pliant::parse_scene(pliant::fuzz::as_text(data, size), "fuzz.json", PLIANT_FUZZ_SCENES);
  } catch (const pliant::InputError&) {
  }
  return 0;
}
