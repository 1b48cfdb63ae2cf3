// The shared pieces of scene reading (see scene_detail.hpp): the strict JSON reader, which turns
// nlohmann's byte offsets into line:column and rejects duplicate keys (nlohmann silently keeps
// the last one), and the table of which keys each object of the format accepts.
#include "scene_detail.hpp"

#include <fmt/format.h>

#include <nlohmann/json.hpp>
#include <utility>
#include <vector>

#include "pliant/error.hpp"

namespace pliant::scene_detail {

KeyList object_keys_at(std::string_view pattern) {
  static const std::pair<std::string_view, KeyList> table[] = {
      {"", kSceneKeys},
      {"time_step", kTimeStepKeys},
      {"output", kOutputKeys},
      {"camera", kCameraKeys},
      {"obstacles[]", kObstacleKeys},
      {"obstacles[].plane", kPlaneKeys},
      {"probes[]", kProbeKeys},
      {"tools[]", kToolKeys},
      {"tools[].shape", kToolShapeKeys},
      {"tools[].shape.sphere", kToolSphereKeys},
      {"tools[].shape.capsule", kToolCapsuleKeys},
      {"tools[].path", kToolPathKeys},
      {"tools[].path.keyframes[]", kToolKeyframeKeys},
      {"bodies[]", kBodyKeys},
      {"bodies[].mesh", kMeshKeys},
      {"bodies[].mesh.box", kMeshBoxKeys},
      {"bodies[].material", kMaterialKeys},
      {"bodies[].material.damping", kDampingKeys},
      {"bodies[].fixed[]", kRegionKeys},
      {"bodies[].prescribed[]", kPrescribedKeys},
      {"bodies[].prescribed[].region", kRegionKeys},
      {"bodies[].prescribed[].keyframes[]", kKeyframeKeys},
      {"bodies[].loads[]", kLoadKeys},
      {"bodies[].loads[].region", kRegionKeys},
      {"bodies[].multiresolution", kMultiresKeys},
      {"bodies[].multiresolution.adapt", kAdaptKeys},
      {"bodies[].multiresolution.levels[]", kMeshKeys},
      {"bodies[].multiresolution.levels[].box", kMeshBoxKeys},
      {"bodies[].multiresolution.active[]", kActiveRegionKeys},
      {"bodies[].multiresolution.active[].region", kRegionKeys},
  };
  for (const auto& [p, keys] : table)
    if (p == pattern) return keys;
  // The box and sphere of any region.
  for (std::string_view region : {"bodies[].fixed[]", "bodies[].prescribed[].region",
                                  "bodies[].loads[].region",
                                  "bodies[].multiresolution.active[].region"}) {
    if (!pattern.starts_with(region)) continue;
    std::string_view rest = pattern.substr(region.size());
    if (rest == ".box") return kRegionBoxKeys;
    if (rest == ".sphere") return kSphereKeys;
  }
  return {};
}

std::string line_column(std::string_view text, std::size_t byte) {
  std::size_t line = 1, column = 1;
  for (std::size_t i = 0; i < byte && i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c == '\n') {
      ++line;
      column = 1;
    } else if ((c & 0xC0) != 0x80) {  // not a UTF-8 continuation byte
      ++column;
    }
  }
  return fmt::format("{}:{}", line, column);
}

namespace {

// Walks the parser's events to know the field path of each key, and rejects repeated keys.
class DuplicateKeyCheck {
 public:
  explicit DuplicateKeyCheck(const std::string& source) : source_(source) {}

  bool operator()(int /*depth*/, nlohmann::detail::parse_event_t event, Json& parsed) {
    using E = nlohmann::detail::parse_event_t;
    switch (event) {
      case E::object_start: frames_.push_back(Frame{}); break;
      case E::array_start: frames_.push_back(Frame{true, 0, {}, {}}); break;
      case E::key: {
        Frame& f = frames_.back();
        f.key = parsed.get<std::string>();
        for (const auto& k : f.seen)
          if (k == f.key) throw InputError(fmt::format("{}: {}: duplicate key", source_, path()));
        f.seen.push_back(f.key);
        break;
      }
      case E::value: count_element(); break;
      case E::object_end:
      case E::array_end:
        frames_.pop_back();
        count_element();
        break;
    }
    return true;
  }

 private:
  struct Frame {
    bool array = false;
    std::size_t count = 0;           // arrays: elements completed so far
    std::string key;                 // objects: the key being parsed
    std::vector<std::string> seen;   // objects: keys so far (objects are small)
  };
  void count_element() {
    if (!frames_.empty() && frames_.back().array) ++frames_.back().count;
  }
  std::string path() const {
    std::string p;
    for (const Frame& f : frames_) {
      if (f.array) p += fmt::format("[{}]", f.count);
      else p += (p.empty() ? "" : ".") + f.key;
    }
    return p;
  }
  const std::string& source_;
  std::vector<Frame> frames_;
};

// nlohmann's message without its "[json.exception...] parse error at line L, column C: " head.
std::string strip_prefix(std::string_view what) {
  if (auto c = what.find("column "); c != std::string_view::npos)
    if (auto s = what.find(": ", c); s != std::string_view::npos) return std::string(what.substr(s + 2));
  if (auto b = what.find("] "); b != std::string_view::npos) return std::string(what.substr(b + 2));
  return std::string(what);
}

}  // namespace

Json parse_json_text(std::string_view text, const std::string& source) {
  // The parser stopped at a NUL byte and took the text before it as the whole document.
  if (const auto nul = text.find('\0'); nul != std::string_view::npos)
    throw InputError(fmt::format("{}:{}: a NUL byte: a scene is a JSON text file", source, line_column(text, nul)));
  try {
    return Json::parse(text.begin(), text.end(), DuplicateKeyCheck(source));
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte is the 1-based index of the last character read (size + 1 at end of input).
    const std::size_t at = e.byte > 0 ? e.byte - 1 : 0;
    throw InputError(fmt::format("{}:{}: invalid JSON: {}", source, line_column(text, at),
                                 strip_prefix(e.what())));
  } catch (const nlohmann::json::exception& e) {
    // e.g. "number overflow parsing '1e400'": no position given; find the quoted literal.
    std::string msg = strip_prefix(e.what());
    std::string where;
    if (auto q = msg.find('\''); q != std::string::npos)
      if (auto q2 = msg.find('\'', q + 1); q2 != std::string::npos)
        if (auto at = text.find(std::string_view(msg).substr(q + 1, q2 - q - 1));
            at != std::string_view::npos)
          where = ":" + line_column(text, at);
    throw InputError(fmt::format("{}{}: invalid JSON: {}", source, where, msg));
  }
}

}  // namespace pliant::scene_detail
