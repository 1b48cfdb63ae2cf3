// Scene files: JSON -> SceneDef. The format is documented in docs/scene-format.md.
// Validation errors name the file and the field path, e.g.
//   "beam.json: bodies[0].material.poisson: must be in [0, 0.5), got 0.7"
#pragma once
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "pliant/defs.hpp"

namespace pliant {

// Reads and validates a scene file. Relative mesh paths are resolved against the file's folder.
SceneDef load_scene_file(const std::filesystem::path& path);

// Same from text; `source` names it in messages, `base_dir` resolves relative paths.
SceneDef parse_scene(std::string_view json_text, const std::string& source,
                     const std::filesystem::path& base_dir);

// Edits scene JSON text before parsing (`pliant study --sweep`). Each override is
// PATH=JSONVALUE, e.g. `bodies[0].mesh.box.cells=[20,2,2]`, `precision="float"`,
// `time_step.courant=0.3`. PATH names a field of the format (missing objects on the way are
// created); an index must exist in the text. Returns the edited text (indented JSON).
// A malformed override, unknown field or out-of-range index throws InputError naming it;
// `source` names the scene in messages. Values are checked later, by parse_scene.
std::string apply_scene_overrides(std::string_view json_text,
                                  const std::vector<std::string>& overrides,
                                  const std::string& source);

}  // namespace pliant
