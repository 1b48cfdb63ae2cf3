// `PATH=JSONVALUE` edits of scene text, for parameter sweeps (`pliant study --sweep`). The path
// is checked against the format's key lists (scene_detail.hpp) so that a typo fails here, naming
// the override, instead of later as an unknown key of the rewritten scene. Values are not
// checked here: parse_scene does that on the result.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cctype>
#include <nlohmann/json.hpp>

#include "pliant/error.hpp"
#include "pliant/scene.hpp"
#include "scene_detail.hpp"

namespace pliant {
namespace {

using namespace scene_detail;

struct Segment {
  bool is_index = false;
  std::string key;        // when !is_index
  std::size_t index = 0;  // when is_index
};

// "bodies[0].mesh.box.cells" -> bodies, [0], mesh, box, cells. Returns false when malformed.
bool split_path(std::string_view path, std::vector<Segment>& out) {
  std::size_t i = 0;
  bool expect_key = true;  // at the start and after '.'
  while (i < path.size()) {
    if (path[i] == '[') {
      if (expect_key) return false;  // "[0]" first, or ".[0]"
      std::size_t close = path.find(']', i);
      if (close == std::string_view::npos || close == i + 1) return false;
      Segment s{true, {}, 0};
      for (std::size_t k = i + 1; k < close; ++k) {
        if (!std::isdigit(static_cast<unsigned char>(path[k])) || close - i > 10) return false;
        s.index = s.index * 10 + static_cast<std::size_t>(path[k] - '0');
      }
      out.push_back(s);
      i = close + 1;
    } else if (path[i] == '.') {
      if (expect_key) return false;  // ".x" or "a..b"
      expect_key = true;
      ++i;
    } else {
      if (!expect_key) return false;  // "a[0]b"
      std::size_t end = path.find_first_of(".[]", i);
      if (end == std::string_view::npos) end = path.size();
      out.push_back({false, std::string(path.substr(i, end - i)), 0});
      expect_key = false;
      i = end;
    }
  }
  return !out.empty() && !expect_key;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

// Whether `s` is well-formed UTF-8 (RFC 3629: no overlong forms, no surrogates, at most U+10FFFF),
// as JSON text must be. A key of the path becomes a key of the document, and a document holding a
// key that is not UTF-8 cannot be written out (nlohmann throws its type_error 316 from dump): an
// override "time_step.//x\xef=1" once escaped apply_scene_overrides that way (found by fuzzing).
bool valid_utf8(std::string_view s) {
  std::size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t n = 0;            // continuation bytes
    unsigned char lo = 0x80, hi = 0xBF;  // range of the first continuation byte
    if (c < 0x80) n = 0;
    else if (c >= 0xC2 && c <= 0xDF) n = 1;
    else if (c == 0xE0) n = 2, lo = 0xA0;
    else if (c >= 0xE1 && c <= 0xEC) n = 2;
    else if (c == 0xED) n = 2, hi = 0x9F;  // not the surrogates U+D800..DFFF
    else if (c >= 0xEE && c <= 0xEF) n = 2;
    else if (c == 0xF0) n = 3, lo = 0x90;
    else if (c >= 0xF1 && c <= 0xF3) n = 3;
    else if (c == 0xF4) n = 3, hi = 0x8F;  // at most U+10FFFF
    else return false;
    if (s.size() - i - 1 < n) return false;
    for (std::size_t k = 1; k <= n; ++k) {
      const auto b = static_cast<unsigned char>(s[i + k]);
      if (b < (k == 1 ? lo : 0x80) || b > (k == 1 ? hi : 0xBF)) return false;
    }
    i += n + 1;
  }
  return true;
}

void apply_one(Json& doc, const std::string& text, const std::string& source) {
  auto fail = [&](const std::string& problem) {
    throw InputError(fmt::format("{}: override \"{}\": {}", source, text, problem));
  };
  const std::size_t eq = text.find('=');
  if (eq == std::string::npos) fail("expected PATH=JSONVALUE, e.g. time_step.courant=0.3");
  const std::string_view path = trim(std::string_view(text).substr(0, eq));
  std::vector<Segment> segments;
  if (!split_path(path, segments))
    fail(fmt::format("malformed path \"{}\"; expected keys and indices like bodies[0].material.young", path));
  for (const Segment& s : segments)
    if (!s.is_index && !valid_utf8(s.key)) fail("the path is not valid UTF-8 (JSON keys must be)");

  const std::string_view raw = trim(std::string_view(text).substr(eq + 1));
  Json value = Json::parse(raw, nullptr, false);
  if (value.is_discarded())
    fail(fmt::format("the value is not JSON (strings need double quotes: {}=\"{}\")", path, raw));

  Json* node = &doc;
  std::string shown, pattern;   // the path so far, and with indices as "[]" for the key lists
  bool free_form = false;        // inside a comment key: no key list applies
  for (const Segment& s : segments) {
    if (s.is_index) {
      if (!node->is_array())
        fail(fmt::format("{}: {}, so it has no element [{}]", shown,
                         node->is_null() ? "not in the scene" : "not an array", s.index));
      if (s.index >= node->size())
        fail(fmt::format("{}: index {} out of range; the scene has {} element(s)", shown, s.index,
                         node->size()));
      node = &(*node)[s.index];
      shown += fmt::format("[{}]", s.index);
      pattern += "[]";
      continue;
    }
    const std::string next = shown.empty() ? s.key : shown + "." + s.key;
    if (!free_form && !is_comment_key(s.key)) {
      KeyList keys = object_keys_at(pattern);
      if (keys.empty()) fail(fmt::format("{}: has no field \"{}\"", shown, s.key));
      if (std::find(keys.begin(), keys.end(), s.key) == keys.end())
        fail(fmt::format("{}: unknown key; known keys: {}", next, fmt::join(keys, ", ")));
    }
    free_form = free_form || is_comment_key(s.key);
    if (node->is_null()) *node = Json::object();  // created on the way (e.g. "time_step")
    if (!node->is_object())
      fail(fmt::format("{}: is not an object in the scene", shown.empty() ? "top level" : shown));
    node = &(*node)[s.key];
    shown = next;
    pattern += (pattern.empty() ? "" : ".") + s.key;
  }
  *node = std::move(value);
}

}  // namespace

std::string apply_scene_overrides(std::string_view json_text,
                                  const std::vector<std::string>& overrides,
                                  const std::string& source) {
  const std::string src = source.empty() ? "scene" : source;
  Json doc = parse_json_text(json_text, src);
  for (const std::string& o : overrides) apply_one(doc, o, src);
  return doc.dump(2) + "\n";
}

}  // namespace pliant
