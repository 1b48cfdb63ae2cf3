// libFuzzer harness: `pliant study --sweep` and scene overrides. The input is split at its first
// NUL byte: before it, one `--sweep` text per line (PATH=V1|V2|...); after it, the scene text.
// Each line goes through parse_sweep, the grid through expand_grid, and each point's overrides
// through apply_scene_overrides and then parse_scene, as `pliant study` does before any run.
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_file.hpp"
#include "pliant/error.hpp"
#include "pliant/perf/study.hpp"
#include "pliant/scene.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto text = pliant::fuzz::as_text(data, size);
  const std::size_t cut = text.find('\0');
  std::string_view sweeps_text = text.substr(0, cut);
  const std::string_view scene = cut == std::string_view::npos ? std::string_view{} : text.substr(cut + 1);
  std::vector<pliant::study::Sweep> sweeps;
  while (!sweeps_text.empty()) {
    const std::size_t eol = sweeps_text.find('\n');
    const std::string_view line = sweeps_text.substr(0, eol);
    sweeps_text = eol == std::string_view::npos ? std::string_view{} : sweeps_text.substr(eol + 1);
    try {
      sweeps.push_back(pliant::study::parse_sweep(line));
    } catch (const pliant::InputError&) {
    }
  }
  // The grid is the product of the sweeps' sizes: a user asking for 10^9 runs gets them queued,
  // which is the command line's business, not a parser's; the harness keeps to small grids.
  std::size_t points = 1;
  for (const auto& s : sweeps) {
    points *= s.values.size();
    if (points > 64) return 0;
  }
  for (const auto& point : pliant::study::expand_grid(sweeps)) {
    try {
      const std::string edited = pliant::apply_scene_overrides(scene, point, "fuzz.json");
      (void)pliant::parse_scene(edited, "fuzz.json", PLIANT_FUZZ_SCENES);
    } catch (const pliant::InputError&) {
    }
  }
  return 0;
}
