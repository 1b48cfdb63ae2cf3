// Private to pliant_scene: what the scene parser (scene_json.cpp) and the override editor
// (scene_overrides.cpp) share: the key lists of every object of the format, so that both reject
// the same unknown keys, and the strict JSON reader that reports line:column. Only the cheap
// nlohmann forward header is included here; json.hpp stays in the .cpp files.
#pragma once
#include <span>
#include <string>
#include <string_view>

#include <nlohmann/json_fwd.hpp>

namespace pliant::scene_detail {

using Json = nlohmann::ordered_json;  // keeps the file's key order (messages, rewritten text)
using KeyList = std::span<const std::string_view>;

inline constexpr std::string_view kSceneKeys[] = {"duration", "gravity",  "precision", "threads",
                                                  "time_step", "bodies", "probes",    "output",
                                                  "camera",    "schedule",  "obstacles", "tools", "realtime", "realtime_frame",
                                                  "packed_corners"};
inline constexpr std::string_view kTimeStepKeys[] = {"dt", "courant", "substep", "adapt"};
inline constexpr std::string_view kBodyKeys[] = {"name",  "mesh",       "material", "model",
                                                 "fixed", "prescribed", "loads",    "multiresolution", "skin"};
inline constexpr std::string_view kMultiresKeys[] = {"levels", "ratio", "faces", "calibrate", "active", "adapt"};
inline constexpr std::string_view kAdaptKeys[] = {"measure", "refine_above", "coarsen_below", "min_dwell", "check_every", "refine_near"};
inline constexpr std::string_view kActiveRegionKeys[] = {"level", "region"};
inline constexpr std::string_view kMeshKeys[] = {"box",       "file",  "surface",  "implicit",
                                                 "cell_size", "scale", "translate", "repair"};
inline constexpr std::string_view kMeshBoxKeys[] = {"min", "max", "cells", "tets_per_cell"};
inline constexpr std::string_view kMaterialKeys[] = {"young", "poisson", "density", "damping"};
inline constexpr std::string_view kDampingKeys[] = {"mass", "stiffness", "bulk_viscosity",
                                                    "shear_viscosity"};
inline constexpr std::string_view kRegionKeys[] = {"box", "sphere", "nodes"};
inline constexpr std::string_view kRegionBoxKeys[] = {"min", "max"};
inline constexpr std::string_view kSphereKeys[] = {"center", "radius"};
inline constexpr std::string_view kPrescribedKeys[] = {"region", "keyframes"};
inline constexpr std::string_view kKeyframeKeys[] = {"time", "offset"};
inline constexpr std::string_view kLoadKeys[] = {"region", "force"};
inline constexpr std::string_view kProbeKeys[] = {"name", "body", "point", "refine"};
inline constexpr std::string_view kOutputKeys[] = {"vtu_every", "probe_every", "sheet"};
inline constexpr std::string_view kCameraKeys[] = {"position", "target", "up", "fov_deg"};
inline constexpr std::string_view kObstacleKeys[] = {"plane", "friction"};
inline constexpr std::string_view kPlaneKeys[] = {"point", "normal"};
inline constexpr std::string_view kToolKeys[] = {"name", "shape", "path", "bodies"};
inline constexpr std::string_view kToolShapeKeys[] = {"sphere", "capsule"};
inline constexpr std::string_view kToolSphereKeys[] = {"radius"};
inline constexpr std::string_view kToolCapsuleKeys[] = {"radius", "length"};
inline constexpr std::string_view kToolPathKeys[] = {"keyframes", "csv"};
inline constexpr std::string_view kToolKeyframeKeys[] = {"time", "position", "orientation"};

// Keys starting with "_" or "//" are comments, ignored everywhere.
inline bool is_comment_key(std::string_view k) {
  return k.starts_with("_") || k.starts_with("//");
}

// The keys of the object at `pattern`, a field path with indices written "[]"
// ("bodies[].material"); an empty list when the format has no object there.
KeyList object_keys_at(std::string_view pattern);

// Parses JSON text, rejecting duplicate keys. Errors: "<source>:<line>:<column>: invalid JSON: ...".
Json parse_json_text(std::string_view text, const std::string& source);

// 1-based "line:column" of the character at 0-based byte offset `byte` (columns count UTF-8
// characters, not bytes).
std::string line_column(std::string_view text, std::size_t byte);

}  // namespace pliant::scene_detail
