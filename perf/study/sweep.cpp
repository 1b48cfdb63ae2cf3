// `--sweep PATH=V1|V2|...`: parsing and the grid of runs.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <nlohmann/json.hpp>

#include "pliant/error.hpp"
#include "pliant/perf/study.hpp"

namespace pliant::study {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

// Splits at '|' outside JSON strings and outside [] / {}.
std::vector<std::string_view> split_values(std::string_view s) {
  std::vector<std::string_view> out;
  int depth = 0;
  bool in_string = false, escaped = false;
  std::size_t start = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    else if (c == '[' || c == '{') ++depth;
    else if ((c == ']' || c == '}') && depth > 0) --depth;
    else if (c == '|' && depth == 0) {
      out.push_back(s.substr(start, i - start));
      start = i + 1;
    }
  }
  out.push_back(s.substr(start));
  return out;
}

}  // namespace

std::string Sweep::short_name() const {
  const std::size_t dot = path.rfind('.');
  std::string last = dot == std::string::npos ? path : path.substr(dot + 1);
  return last.empty() ? path : last;
}

Sweep parse_sweep(std::string_view text) {
  auto fail = [&](const std::string& problem) {
    throw InputError(fmt::format("--sweep '{}': {}", text, problem));
  };
  Sweep s;
  s.text = std::string(text);
  const std::size_t eq = text.find('=');
  if (eq == std::string_view::npos)
    fail("expected PATH=V1|V2|..., e.g. 'bodies[0].mesh.box.cells=[20,2,2]|[40,4,4]'");
  s.path = std::string(trim(text.substr(0, eq)));
  if (s.path.empty()) fail("the path before '=' is empty");
  if (s.path.find_first_of(" \t|") != std::string::npos) fail(fmt::format("malformed path \"{}\"", s.path));
  const std::string_view rest = text.substr(eq + 1);
  const auto parts = split_values(rest);
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const std::string_view v = trim(parts[i]);
    if (v.empty()) fail(fmt::format("value {} is empty (values are separated by '|')", i + 1));
    const auto j = nlohmann::json::parse(v, nullptr, false);
    if (j.is_discarded())
      fail(fmt::format("value {} ({}) is not JSON; strings need double quotes, e.g. {}=\"{}\"", i + 1, v, s.path, v));
    // Repeated as JSON, not as text: 1e6 and 1000000 gave two runs of the same scene, reported as
    // two settings.
    std::string value(v);
    for (std::size_t k = 0; k < s.values.size(); ++k)
      if (nlohmann::json::parse(s.values[k]) == j)
        fail(fmt::format("value {} ({}) is repeated (value {} is {})", i + 1, v, k + 1, s.values[k]));
    s.values.push_back(std::move(value));
  }
  // A key beginning with '_' is a comment: sweeping it changes nothing but the label.
  for (std::size_t k = 0; k < s.path.size(); ++k)
    if (s.path[k] == '_' && (k == 0 || s.path[k - 1] == '.'))
      fail(fmt::format("{} is a comment key (it begins with '_'): sweeping it changes nothing", s.path));
  return s;
}

std::string canonical_sweep_path(std::string_view path) {
  std::string out;
  for (std::size_t i = 0; i < path.size(); ++i) {
    out += path[i];
    if (path[i] != '[') continue;
    std::size_t j = i + 1;
    while (j + 1 < path.size() && path[j] == '0' && std::isdigit(static_cast<unsigned char>(path[j + 1]))) ++j;
    i = j - 1;  // leading zeros of an index dropped: [00] -> [0], [007] -> [7]
  }
  return out;
}

std::vector<std::vector<std::string>> expand_grid(const std::vector<Sweep>& sweeps) {
  std::vector<std::vector<std::string>> grid{{}};
  for (const Sweep& s : sweeps) {
    std::vector<std::vector<std::string>> next;
    next.reserve(grid.size() * s.values.size());
    for (const auto& point : grid)
      for (const std::string& v : s.values) {
        auto p = point;
        p.push_back(s.path + "=" + v);
        next.push_back(std::move(p));
      }
    grid = std::move(next);
  }
  return grid;
}

std::string settings_label(const std::vector<Sweep>& sweeps, const std::vector<std::string>& settings) {
  std::string out;
  for (std::size_t i = 0; i < sweeps.size() && i < settings.size(); ++i) {
    std::string v = settings[i];
    if (v.size() >= 2 && v.front() == '"' && v.back() == '"') v = v.substr(1, v.size() - 2);
    // Two sweeps with the same last key (bodies[0].model, bodies[1].model) show their whole path.
    bool clash = false;
    for (std::size_t k = 0; k < sweeps.size(); ++k)
      clash = clash || (k != i && sweeps[k].short_name() == sweeps[i].short_name());
    out += fmt::format("{}{}={}", out.empty() ? "" : ", ", clash ? sweeps[i].path : sweeps[i].short_name(), v);
  }
  return out;
}

}  // namespace pliant::study
