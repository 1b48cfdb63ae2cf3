// Scene files: JSON text -> SceneDef (format: docs/scene-format.md). A Reader walks the document
// carrying the field path of each value ("bodies[0].material.poisson"), so that every error
// says which field is wrong, what was expected and what was found. Errors throw InputError as
// "<source>: <path>: <problem>".
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "pliant/error.hpp"
#include "pliant/input_file.hpp"
#include "pliant/scene.hpp"
#include "scene_detail.hpp"

namespace pliant {
namespace {

using namespace scene_detail;  // Json, KeyList, k*Keys
namespace fs = std::filesystem;

constexpr long long kMaxBoxCells = 50'000'000;

std::string field(const std::string& path, std::string_view key) {
  return path.empty() ? std::string(key) : path + "." + std::string(key);
}
std::string element(const std::string& path, std::size_t i) { return fmt::format("{}[{}]", path, i); }

// A found value, for "got ..." in messages.
std::string describe(const Json& j) {
  switch (j.type()) {
    case Json::value_t::null: return "null";
    case Json::value_t::boolean: return j.get<bool>() ? "true" : "false";
    case Json::value_t::object: return "an object";
    case Json::value_t::array: return fmt::format("an array of {}", j.size());
    case Json::value_t::string: {
      std::string s = j.dump();
      return "string " + (s.size() > 40 ? s.substr(0, 37) + "...\"" : s);
    }
    default: return j.dump();  // numbers as written (shortest round-trip)
  }
}

// Levenshtein distance, for "did you mean" on unknown keys and names.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] != b[j - 1])});
      diag = up;
    }
  }
  return row[b.size()];
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

class Reader {
 public:
  Reader(std::string source, fs::path base_dir)
      : source_(std::move(source)), base_dir_(std::move(base_dir)) {}

  SceneDef scene(const Json& doc) const;

 private:
  [[noreturn]] void fail(const std::string& path, const std::string& problem) const {
    throw InputError(fmt::format("{}: {}: {}", source_, path.empty() ? "top level" : path, problem));
  }

  // --- structure ---
  // Checks that `j` is an object whose keys are all in `keys` (or comments).
  void object(const Json& j, const std::string& path, KeyList keys) const {
    if (!j.is_object()) fail(path, "expected an object, got " + describe(j));
    for (const auto& [key, value] : j.items()) {
      if (is_comment_key(key) || std::find(keys.begin(), keys.end(), key) != keys.end()) continue;
      std::string msg = fmt::format("unknown key; known keys: {}", fmt::join(keys, ", "));
      for (std::string_view k : keys)
        if (edit_distance(key, k) <= 2 && key.size() > 2) msg += fmt::format("; did you mean \"{}\"?", k);
      fail(field(path, key), msg);
    }
  }
  static const Json* find(const Json& obj, std::string_view key) {
    auto it = obj.find(std::string(key));
    return it == obj.end() ? nullptr : &*it;
  }
  const Json& required(const Json& obj, const std::string& path, std::string_view key) const {
    if (const Json* v = find(obj, key)) return *v;
    fail(field(path, key), "missing (required)");
  }
  // Calls read(value, path) when `key` is present.
  template <class F>
  static void optional(const Json& obj, const std::string& path, std::string_view key, F&& read) {
    if (const Json* v = find(obj, key)) read(*v, field(path, key));
  }
  const Json& array(const Json& j, const std::string& path) const {
    if (!j.is_array()) fail(path, "expected an array, got " + describe(j));
    return j;
  }
  // Which of `kinds` the object has; exactly one is required.
  std::string one_of(const Json& j, const std::string& path,
                     std::initializer_list<std::string_view> kinds) const {
    std::vector<std::string_view> present;
    for (auto k : kinds)
      if (j.contains(std::string(k))) present.push_back(k);
    if (present.size() == 1) return std::string(present[0]);
    if (present.empty()) fail(path, fmt::format("needs one of {}", fmt::join(kinds, ", ")));
    fail(path, fmt::format("has {}; give exactly one of {}", fmt::join(present, " and "),
                           fmt::join(kinds, ", ")));
  }

  // --- values ---
  double number(const Json& j, const std::string& path) const {
    if (!j.is_number()) fail(path, "expected a number, got " + describe(j));
    double v = j.get<double>();
    if (!std::isfinite(v)) fail(path, fmt::format("must be finite, got {}", v));
    return v;
  }
  double positive(const Json& j, const std::string& path) const {
    double v = number(j, path);
    if (!(v > 0)) fail(path, fmt::format("must be > 0, got {}", v));
    return v;
  }
  double non_negative(const Json& j, const std::string& path) const {
    double v = number(j, path);
    if (!(v >= 0)) fail(path, fmt::format("must be >= 0, got {}", v));
    return v;
  }
  // An integer in [lo, hi]; 3.0 counts as an integer, 3.5 does not.
  long long integer(const Json& j, const std::string& path, long long lo, long long hi) const {
    long long v = 0;
    if (j.is_number_unsigned() && j.get<unsigned long long>() > static_cast<unsigned long long>(hi)) {
      fail(path, fmt::format("must be <= {}, got {}", hi, j.dump()));
    } else if (j.is_number_integer()) {
      v = j.get<long long>();
    } else if (j.is_number_float() && std::isfinite(j.get<double>()) &&
               j.get<double>() == std::floor(j.get<double>()) && std::abs(j.get<double>()) < 9e15) {
      v = static_cast<long long>(j.get<double>());
    } else {
      fail(path, "expected an integer, got " + describe(j));
    }
    if (v < lo) fail(path, fmt::format("must be >= {}, got {}", lo, v));
    if (v > hi) fail(path, fmt::format("must be <= {}, got {}", hi, v));
    return v;
  }
  Vec3d vec3(const Json& j, const std::string& path) const {
    if (!j.is_array() || j.size() != 3) fail(path, "expected an array of 3 numbers, got " + describe(j));
    return {number(j[0], element(path, 0)), number(j[1], element(path, 1)),
            number(j[2], element(path, 2))};
  }
  std::string string(const Json& j, const std::string& path) const {
    if (!j.is_string()) fail(path, "expected a string, got " + describe(j));
    return j.get<std::string>();
  }
  std::string name(const Json& j, const std::string& path) const {
    std::string s = string(j, path);
    if (s.empty()) fail(path, "must not be empty");
    return s;
  }
  bool boolean(const Json& j, const std::string& path) const {
    if (!j.is_boolean()) fail(path, "expected true or false, got " + describe(j));
    return j.get<bool>();
  }
  // A string from a fixed set, returned as its index.
  std::size_t choice(const Json& j, const std::string& path, std::string_view what,
                     std::initializer_list<std::string_view> names) const {
    std::string s = string(j, path);
    auto it = std::find(names.begin(), names.end(), s);
    if (it == names.end())
      fail(path, fmt::format("unknown {} \"{}\"; expected one of {}", what, s, fmt::join(names, ", ")));
    return static_cast<std::size_t>(it - names.begin());
  }
  // An existing file with one of `exts`, resolved against the scene's folder.
  fs::path existing_file(const Json& j, const std::string& path,
                         std::initializer_list<std::string_view> exts) const {
    std::string s = name(j, path);
    fs::path p(s);
    std::string ext = lower(p.extension().string());
    if (std::find(exts.begin(), exts.end(), ext) == exts.end())
      fail(path, fmt::format("\"{}\": unsupported extension \"{}\"; expected {}", s, ext,
                             fmt::join(exts, ", ")));
    if (p.is_relative()) p = base_dir_ / p;
    std::error_code ec;
    fs::path abs = fs::absolute(p, ec);
    p = (ec ? p : abs).lexically_normal();
    if (!fs::exists(p, ec)) fail(path, fmt::format("file not found: {}", p.string()));
    try {
      check_input_file(p, "file");  // a regular file (a FIFO or a device would hang the reader)
    } catch (const InputError& e) {
      fail(path, e.what());
    }
    return p;
  }

  // --- parts of the format ---
  TimeStepDef time_step(const Json& j, const std::string& path) const;
  BodyDef body(const Json& j, const std::string& path, std::size_t index) const;
  MeshSourceDef mesh(const Json& j, const std::string& path) const;
  MultiresolutionDef multiresolution(const Json& j, const std::string& path) const;
  MaterialDef material(const Json& j, const std::string& path) const;
  RegionDef region(const Json& j, const std::string& path) const;
  PrescribedMotionDef prescribed(const Json& j, const std::string& path) const;
  NodalLoadDef load(const Json& j, const std::string& path) const;
  ProbeDef probe(const Json& j, const std::string& path, std::size_t index) const;
  CameraDef camera(const Json& j, const std::string& path) const;
  ObstacleDef obstacle(const Json& j, const std::string& path) const;
  ToolDef tool(const Json& j, const std::string& path, std::size_t index) const;
  std::vector<ToolKeyframeDef> tool_csv(const fs::path& file, const std::string& path) const;

  std::string source_;
  fs::path base_dir_;
};

SceneDef Reader::scene(const Json& doc) const {
  object(doc, "", kSceneKeys);
  SceneDef s;
  optional(doc, "", "duration", [&](const auto& v, const auto& p) { s.duration = positive(v, p); });
  optional(doc, "", "gravity", [&](const auto& v, const auto& p) { s.world.gravity = vec3(v, p); });
  optional(doc, "", "precision", [&](const auto& v, const auto& p) {
    s.world.precision = choice(v, p, "precision", {"float", "double"}) == 0 ? Precision::float32
                                                                            : Precision::float64;
  });
  optional(doc, "", "threads", [&](const auto& v, const auto& p) {
    s.world.threads = static_cast<int>(integer(v, p, 0, 1 << 16));
  });
  optional(doc, "", "time_step", [&](const auto& v, const auto& p) { s.world.time_step = time_step(v, p); });
  optional(doc, "", "schedule", [&](const auto& v, const auto& p) {
    s.world.schedule = choice(v, p, "schedule", {"staggered", "naive"}) == 0 ? Schedule::staggered : Schedule::naive;
  });
  optional(doc, "", "packed_corners", [&](const auto& v, const auto& p) {
    const PackedCorners modes[] = {PackedCorners::automatic, PackedCorners::on, PackedCorners::off};
    s.world.packed_corners = modes[choice(v, p, "packed_corners", {"auto", "on", "off"})];
  });

  const Json& bodies = array(required(doc, "", "bodies"), "bodies");
  if (bodies.empty()) fail("bodies", "must list at least one body");
  std::map<std::string, std::size_t> body_index;
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const std::string p = element("bodies", i);
    s.bodies.push_back(body(bodies[i], p, i));
    auto [it, fresh] = body_index.emplace(s.bodies.back().name, i);
    if (!fresh)
      fail(field(p, "name"), fmt::format("duplicate body name \"{}\" (also bodies[{}])",
                                         it->first, it->second));
  }

  optional(doc, "", "probes", [&](const auto& v, const auto& path) {
    std::map<std::string, std::size_t> seen;
    for (std::size_t i = 0; i < array(v, path).size(); ++i) {
      const std::string p = element(path, i);
      ProbeDef pr = probe(v[i], p, i);
      if (!body_index.count(pr.body)) {
        std::vector<std::string> names;
        for (const auto& b : s.bodies) names.push_back(b.name);
        fail(field(p, "body"), fmt::format("no body named \"{}\"; bodies: {}", pr.body,
                                           fmt::join(names, ", ")));
      }
      auto [it, fresh] = seen.emplace(pr.name, i);
      if (!fresh)
        fail(field(p, "name"), fmt::format("duplicate probe name \"{}\" (also probes[{}])",
                                           it->first, it->second));
      s.probes.push_back(std::move(pr));
    }
  });

  optional(doc, "", "tools", [&](const auto& v, const auto& path) {
    std::map<std::string, std::size_t> seen;
    for (std::size_t i = 0; i < array(v, path).size(); ++i) {
      const std::string p = element(path, i);
      ToolDef t = tool(v[i], p, i);
      for (std::size_t b = 0; b < t.bodies.size(); ++b)
        if (!body_index.count(t.bodies[b])) {
          std::vector<std::string> names;
          for (const auto& body : s.bodies) names.push_back(body.name);
          fail(element(field(p, "bodies"), b),
               fmt::format("no body named \"{}\"; bodies: {}", t.bodies[b], fmt::join(names, ", ")));
        }
      auto [it, fresh] = seen.emplace(t.name, i);
      if (!fresh)
        fail(field(p, "name"), fmt::format("duplicate tool name \"{}\" (also tools[{}])", it->first, it->second));
      s.tools.push_back(std::move(t));
    }
  });

  optional(doc, "", "output", [&](const auto& v, const auto& p) {
    object(v, p, kOutputKeys);
    optional(v, p, "vtu_every", [&](const auto& x, const auto& q) { s.output.vtu_every = non_negative(x, q); });
    optional(v, p, "probe_every", [&](const auto& x, const auto& q) { s.output.probe_every = non_negative(x, q); });
    optional(v, p, "sheet", [&](const auto& x, const auto& q) { s.output.sheet = boolean(x, q); });
  });
  optional(doc, "", "camera", [&](const auto& v, const auto& p) { s.camera = camera(v, p); });
  optional(doc, "", "realtime", [&](const auto& v, const auto& p) { s.realtime = boolean(v, p); });
  optional(doc, "", "realtime_frame", [&](const auto& v, const auto& p) { s.realtime_frame = non_negative(v, p); });
  optional(doc, "", "obstacles", [&](const auto& v, const auto& path) {
    for (std::size_t i = 0; i < array(v, path).size(); ++i) s.world.obstacles.push_back(obstacle(v[i], element(path, i)));
  });
  return s;
}

CameraDef Reader::camera(const Json& j, const std::string& path) const {
  object(j, path, kCameraKeys);
  CameraDef c;
  c.position = vec3(required(j, path, "position"), field(path, "position"));
  c.target = vec3(required(j, path, "target"), field(path, "target"));
  optional(j, path, "up", [&](const auto& v, const auto& p) { c.up = vec3(v, p); });
  optional(j, path, "fov_deg", [&](const auto& v, const auto& p) {
    c.fov_deg = number(v, p);
    if (!(c.fov_deg > 0 && c.fov_deg < 180)) fail(p, fmt::format("must be in (0, 180) (degrees), got {}", c.fov_deg));
  });
  const Vec3d d{c.target[0] - c.position[0], c.target[1] - c.position[1], c.target[2] - c.position[2]};
  const double dd = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (!(dd > 0)) fail(field(path, "target"), "must differ from position (the camera looks from position to target)");
  const Vec3d& u = c.up;
  const double uu = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  if (!(uu > 0)) fail(field(path, "up"), "must not be [0, 0, 0]");
  const Vec3d x{d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2], d[0] * u[1] - d[1] * u[0]};
  if (!(std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) > 1e-6 * dd * uu))
    fail(field(path, "up"), "is along the view direction (target - position); give a direction across it");
  return c;
}

ObstacleDef Reader::obstacle(const Json& j, const std::string& path) const {
  object(j, path, kObstacleKeys);
  ObstacleDef o;
  const std::string pp = field(path, "plane");
  const Json& plane = required(j, path, "plane");
  object(plane, pp, kPlaneKeys);
  o.point = vec3(required(plane, pp, "point"), field(pp, "point"));
  o.normal = vec3(required(plane, pp, "normal"), field(pp, "normal"));
  if (!(o.normal[0] * o.normal[0] + o.normal[1] * o.normal[1] + o.normal[2] * o.normal[2] > 0))
    fail(field(pp, "normal"), "must not be [0, 0, 0] (it points out of the solid, into the free side)");
  optional(j, path, "friction", [&](const auto& v, const auto& p) { o.friction = non_negative(v, p); });
  return o;
}

TimeStepDef Reader::time_step(const Json& j, const std::string& path) const {
  object(j, path, kTimeStepKeys);
  TimeStepDef t;
  optional(j, path, "dt", [&](const auto& v, const auto& p) {
    if (v.is_string() && v.template get<std::string>() == "auto") t.dt.reset();
    else if (v.is_number()) t.dt = positive(v, p);
    else fail(p, "expected \"auto\" or a number > 0 (s), got " + describe(v));
  });
  optional(j, path, "courant", [&](const auto& v, const auto& p) {
    t.courant = number(v, p);
    if (!(t.courant > 0 && t.courant <= 1)) fail(p, fmt::format("must be in (0, 1], got {}", t.courant));
  });
  optional(j, path, "substep", [&](const auto& v, const auto& p) { t.substep = boolean(v, p); });
  optional(j, path, "adapt", [&](const auto& v, const auto& p) { t.adapt = boolean(v, p); });
  return t;
}

BodyDef Reader::body(const Json& j, const std::string& path, std::size_t index) const {
  object(j, path, kBodyKeys);
  BodyDef b;
  b.name = fmt::format("body{}", index);
  optional(j, path, "name", [&](const auto& v, const auto& p) { b.name = name(v, p); });
  b.mesh = mesh(required(j, path, "mesh"), field(path, "mesh"));
  optional(j, path, "material", [&](const auto& v, const auto& p) { b.material = material(v, p); });
  optional(j, path, "model", [&](const auto& v, const auto& p) {
    b.model = static_cast<ForceModel>(
        choice(v, p, "model", {"linear", "stvk", "corotational", "springs"}));
  });
  optional(j, path, "fixed", [&](const auto& v, const auto& p) {
    for (std::size_t i = 0; i < array(v, p).size(); ++i) b.fixed.push_back(region(v[i], element(p, i)));
  });
  optional(j, path, "prescribed", [&](const auto& v, const auto& p) {
    for (std::size_t i = 0; i < array(v, p).size(); ++i)
      b.prescribed.push_back(prescribed(v[i], element(p, i)));
  });
  optional(j, path, "loads", [&](const auto& v, const auto& p) {
    for (std::size_t i = 0; i < array(v, p).size(); ++i) b.loads.push_back(load(v[i], element(p, i)));
  });
  optional(j, path, "multiresolution", [&](const auto& v, const auto& p) { b.multiresolution = multiresolution(v, p); });
  optional(j, path, "skin", [&](const auto& v, const auto& p) { b.skin = existing_file(v, p, {".obj"}); });
  // A box without tets_per_cell: 5 tets per cell (docs/validation.md: less locking in bending than
  // 6, -3.4% against -5.1% at 80x8x8, and 17% fewer tets), but 6 for a multiresolution body, whose
  // box levels nest exactly only with Kuhn cells (docs/multiresolution.md).
  if (b.mesh.kind == MeshSourceDef::Kind::box && !j.at("mesh").at("box").contains("tets_per_cell"))
    b.mesh.tets_per_cell = j.contains("multiresolution") ? 6 : 5;
  return b;
}

// "multiresolution": {"levels": N | [MESH, ...], "ratio": r,
//                     "active": "finest" | "coarsest" | K | [{"level": K, "region": REGION}, ...]}
MultiresolutionDef Reader::multiresolution(const Json& j, const std::string& path) const {
  constexpr long long kMaxLevels = 8;  // ratio 2: 8 levels span 128x in size, 2e6x in tets
  object(j, path, kMultiresKeys);
  MultiresolutionDef m;
  optional(j, path, "levels", [&](const auto& v, const auto& p) {
    if (v.is_array()) {  // the coarser levels, coarse to fine; the body's mesh is the finest
      if (v.empty()) fail(p, "must list at least one coarser mesh (the body's \"mesh\" is the finest level)");
      if (static_cast<long long>(v.size()) + 1 > kMaxLevels)
        fail(p, fmt::format("{} coarser meshes: at most {} levels in all", v.size(), kMaxLevels));
      for (std::size_t i = 0; i < v.size(); ++i) m.coarser.push_back(mesh(v[i], element(p, i)));
      m.levels = static_cast<int>(v.size()) + 1;
    } else {
      m.levels = static_cast<int>(integer(v, p, 1, kMaxLevels));
    }
  });
  optional(j, path, "ratio", [&](const auto& v, const auto& p) {
    m.ratio = number(v, p);
    if (!(m.ratio > 1 && m.ratio <= 16)) fail(p, fmt::format("must be in (1, 16], got {}", m.ratio));
    if (!m.coarser.empty()) fail(p, "not used when \"levels\" lists the coarser meshes");
  });
  optional(j, path, "calibrate", [&](const auto& v, const auto& p) { m.calibrate = boolean(v, p); });
  optional(j, path, "faces", [&](const auto& v, const auto& p) {
    if (!m.coarser.empty()) fail(p, "not used when \"levels\" lists the coarser meshes");
    if (static_cast<long long>(array(v, p).size()) != m.levels - 1)
      fail(p, fmt::format("needs {} counts (one per coarser level, coarse to fine), got {}", m.levels - 1, v.size()));
    for (std::size_t i = 0; i < v.size(); ++i) {
      m.faces.push_back(static_cast<std::size_t>(integer(v[i], element(p, i), 4, 100'000'000)));
      if (i > 0 && m.faces[i] <= m.faces[i - 1])
        fail(element(p, i), fmt::format("must grow from coarse to fine: {} after {}", m.faces[i], m.faces[i - 1]));
    }
  });
  optional(j, path, "active", [&](const auto& v, const auto& p) {
    const std::string levels = fmt::format("0 (coarsest) .. {} (finest)", m.levels - 1);
    if (v.is_string()) {
      const std::size_t c = choice(v, p, "active level", {"finest", "coarsest", "adaptive"});
      m.active.kind = c == 0 ? ActiveDef::Kind::finest : c == 1 ? ActiveDef::Kind::coarsest : ActiveDef::Kind::adaptive;
      if (c == 2 && m.levels < 2) fail(p, "\"adaptive\" needs at least 2 levels");
    } else if (v.is_number()) {
      m.active.kind = ActiveDef::Kind::level;
      m.active.level = static_cast<int>(integer(v, p, 0, m.levels - 1));
    } else if (v.is_array()) {
      m.active.kind = ActiveDef::Kind::regions;
      if (v.empty()) fail(p, "must list at least one {\"level\", \"region\"}");
      for (std::size_t i = 0; i < v.size(); ++i) {
        const std::string q = element(p, i);
        object(v[i], q, kActiveRegionKeys);
        ActiveRegionDef a;
        a.level = static_cast<int>(integer(required(v[i], q, "level"), field(q, "level"), 0, m.levels - 1));
        a.region = region(required(v[i], q, "region"), field(q, "region"));
        m.active.regions.push_back(std::move(a));
      }
    } else {
      fail(p, "expected \"finest\", \"coarsest\", a level number in " + levels +
                  " or a list of {\"level\", \"region\"}, got " + describe(v));
    }
  });
  optional(j, path, "adapt", [&](const auto& v, const auto& p) {
    if (m.active.kind != ActiveDef::Kind::adaptive) fail(p, "only with \"active\": \"adaptive\"");
    object(v, p, kAdaptKeys);
    AdaptDef& a = m.active.adapt;
    optional(v, p, "refine_above", [&](const auto& x, const auto& q) { a.refine_above = positive(x, q); });
    optional(v, p, "coarsen_below", [&](const auto& x, const auto& q) { a.coarsen_below = non_negative(x, q); });
    optional(v, p, "min_dwell", [&](const auto& x, const auto& q) { a.min_dwell = non_negative(x, q); });
    optional(v, p, "check_every", [&](const auto& x, const auto& q) { a.check_every = non_negative(x, q); });
    optional(v, p, "measure", [&](const auto& x, const auto& q) {
      if (x.is_string() && x.template get<std::string>() == "relative")
        a.measure = AdaptDef::Measure::relative;
      else if (x.is_string() && x.template get<std::string>() == "absolute")
        a.measure = AdaptDef::Measure::absolute;
      else
        fail(q, "expected \"relative\" (thresholds as fractions of the body's peak strain) or \"absolute\", got " + describe(x));
    });
    optional(v, p, "refine_near", [&](const auto& x, const auto& q) {
      if (x.is_string() && x.template get<std::string>() == "auto")
        a.refine_near = -1;
      else
        a.refine_near = non_negative(x, q);
    });
    if (!(a.coarsen_below < a.refine_above))
      fail(field(p, "coarsen_below"),
           fmt::format("must be below refine_above ({} >= {}): a node would split and merge at once", a.coarsen_below, a.refine_above));
  });
  return m;
}

MeshSourceDef Reader::mesh(const Json& j, const std::string& path) const {
  object(j, path, kMeshKeys);
  MeshSourceDef m;
  const std::string kind = one_of(j, path, {"box", "file", "surface", "implicit"});
  const std::string kp = field(path, kind);
  const Json& v = j.at(kind);
  if (kind == "box") {
    m.kind = MeshSourceDef::Kind::box;
    object(v, kp, kMeshBoxKeys);
    optional(v, kp, "min", [&](const auto& x, const auto& q) { m.min = vec3(x, q); });
    optional(v, kp, "max", [&](const auto& x, const auto& q) { m.max = vec3(x, q); });
    for (int c = 0; c < 3; ++c)
      if (!(m.min[c] < m.max[c]))
        fail(field(kp, "max"), fmt::format("must be > min in every coordinate; {}: max {} <= min {}",
                                           "xyz"[c], m.max[c], m.min[c]));
    optional(v, kp, "cells", [&](const auto& x, const auto& q) {
      if (!x.is_array() || x.size() != 3) fail(q, "expected an array of 3 integers, got " + describe(x));
      for (int c = 0; c < 3; ++c) m.cells[c] = static_cast<int>(integer(x[c], element(q, c), 1, kMaxBoxCells));
      const long long total = 1LL * m.cells[0] * m.cells[1] * m.cells[2];
      if (total > kMaxBoxCells)
        fail(q, fmt::format("{} x {} x {} = {} cells, more than the limit of {}", m.cells[0],
                            m.cells[1], m.cells[2], total, kMaxBoxCells));
    });
    optional(v, kp, "tets_per_cell", [&](const auto& x, const auto& q) {
      m.tets_per_cell = static_cast<int>(integer(x, q, 0, 1000));
      if (m.tets_per_cell != 5 && m.tets_per_cell != 6) fail(q, fmt::format("must be 5 or 6, got {}", m.tets_per_cell));
    });
  } else if (kind == "file") {
    m.kind = MeshSourceDef::Kind::file;
    m.path = existing_file(v, kp, {".msh", ".vtk", ".vtu", ".node", ".ele"});
  } else if (kind == "surface") {
    m.kind = MeshSourceDef::Kind::surface;
    m.path = existing_file(v, kp, {".obj", ".off", ".stl", ".ply"});
  } else {
    m.kind = MeshSourceDef::Kind::implicit;
    m.shape = name(v, kp);
  }
  if (kind == "surface" || kind == "implicit")
    m.cell_size = positive(required(j, path, "cell_size"), field(path, "cell_size"));
  else if (j.contains("cell_size"))
    fail(field(path, "cell_size"), "only used with surface and implicit meshes");
  if (kind == "surface")
    optional(j, path, "repair", [&](const auto& x, const auto& q) { m.repair = boolean(x, q); });
  else if (j.contains("repair"))
    fail(field(path, "repair"), "only used with surface meshes");
  optional(j, path, "scale", [&](const auto& x, const auto& q) { m.scale = positive(x, q); });
  optional(j, path, "translate", [&](const auto& x, const auto& q) { m.translate = vec3(x, q); });
  return m;
}

MaterialDef Reader::material(const Json& j, const std::string& path) const {
  object(j, path, kMaterialKeys);
  MaterialDef m;
  optional(j, path, "young", [&](const auto& v, const auto& p) { m.young = positive(v, p); });
  optional(j, path, "poisson", [&](const auto& v, const auto& p) {
    m.poisson = number(v, p);
    if (!(m.poisson >= 0 && m.poisson < 0.5)) fail(p, fmt::format("must be in [0, 0.5), got {}", m.poisson));
  });
  optional(j, path, "density", [&](const auto& v, const auto& p) { m.density = positive(v, p); });
  optional(j, path, "damping", [&](const auto& d, const auto& dp) {
    object(d, dp, kDampingKeys);
    optional(d, dp, "mass", [&](const auto& v, const auto& p) { m.damping.mass = non_negative(v, p); });
    optional(d, dp, "stiffness", [&](const auto& v, const auto& p) { m.damping.stiffness = non_negative(v, p); });
    optional(d, dp, "bulk_viscosity", [&](const auto& v, const auto& p) { m.damping.bulk_viscosity = non_negative(v, p); });
    optional(d, dp, "shear_viscosity", [&](const auto& v, const auto& p) { m.damping.shear_viscosity = non_negative(v, p); });
  });
  return m;
}

RegionDef Reader::region(const Json& j, const std::string& path) const {
  object(j, path, kRegionKeys);
  RegionDef r;
  const std::string kind = one_of(j, path, {"box", "sphere", "nodes"});
  const std::string kp = field(path, kind);
  const Json& v = j.at(kind);
  if (kind == "box") {
    r.kind = RegionDef::Kind::box;
    object(v, kp, kRegionBoxKeys);
    r.min = vec3(required(v, kp, "min"), field(kp, "min"));
    r.max = vec3(required(v, kp, "max"), field(kp, "max"));
    for (int c = 0; c < 3; ++c)  // min == max is allowed: a plane of nodes
      if (!(r.min[c] <= r.max[c]))
        fail(field(kp, "max"), fmt::format("must be >= min in every coordinate; {}: max {} < min {}",
                                           "xyz"[c], r.max[c], r.min[c]));
  } else if (kind == "sphere") {
    r.kind = RegionDef::Kind::sphere;
    object(v, kp, kSphereKeys);
    r.center = vec3(required(v, kp, "center"), field(kp, "center"));
    r.radius = positive(required(v, kp, "radius"), field(kp, "radius"));
  } else {
    r.kind = RegionDef::Kind::nodes;
    if (array(v, kp).empty()) fail(kp, "must list at least one node");
    for (std::size_t i = 0; i < v.size(); ++i)
      r.nodes.push_back(static_cast<std::int32_t>(
          integer(v[i], element(kp, i), 0, std::numeric_limits<std::int32_t>::max())));
  }
  return r;
}

PrescribedMotionDef Reader::prescribed(const Json& j, const std::string& path) const {
  object(j, path, kPrescribedKeys);
  PrescribedMotionDef m;
  m.region = region(required(j, path, "region"), field(path, "region"));
  const std::string kp = field(path, "keyframes");
  const Json& keys = array(required(j, path, "keyframes"), kp);
  if (keys.empty()) fail(kp, "must list at least one keyframe");
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const std::string p = element(kp, i);
    object(keys[i], p, kKeyframeKeys);
    KeyframeDef k;
    k.time = number(required(keys[i], p, "time"), field(p, "time"));
    k.offset = vec3(required(keys[i], p, "offset"), field(p, "offset"));
    if (i > 0 && k.time < m.keyframes.back().time)
      fail(field(p, "time"), fmt::format("keyframe times must not decrease; {} comes after {}",
                                         k.time, m.keyframes.back().time));
    m.keyframes.push_back(k);
  }
  return m;
}

NodalLoadDef Reader::load(const Json& j, const std::string& path) const {
  object(j, path, kLoadKeys);
  NodalLoadDef l;
  l.region = region(required(j, path, "region"), field(path, "region"));
  l.total_force = vec3(required(j, path, "force"), field(path, "force"));
  return l;
}

ToolDef Reader::tool(const Json& j, const std::string& path, std::size_t index) const {
  object(j, path, kToolKeys);
  ToolDef t;
  t.name = fmt::format("tool{}", index);
  optional(j, path, "name", [&](const auto& v, const auto& q) { t.name = name(v, q); });
  const std::string sp = field(path, "shape");
  const Json& shape = required(j, path, "shape");
  object(shape, sp, kToolShapeKeys);
  if (shape.size() != 1) fail(sp, "expected exactly one of \"sphere\" or \"capsule\"");
  if (shape.contains("sphere")) {
    const std::string p = field(sp, "sphere");
    object(shape["sphere"], p, kToolSphereKeys);
    t.shape.kind = ToolShapeDef::Kind::sphere;
    t.shape.radius = positive(required(shape["sphere"], p, "radius"), field(p, "radius"));
  } else {
    const std::string p = field(sp, "capsule");
    object(shape["capsule"], p, kToolCapsuleKeys);
    t.shape.kind = ToolShapeDef::Kind::capsule;
    t.shape.radius = positive(required(shape["capsule"], p, "radius"), field(p, "radius"));
    t.shape.length = positive(required(shape["capsule"], p, "length"), field(p, "length"));
  }
  const std::string pp = field(path, "path");
  const Json& motion = required(j, path, "path");
  object(motion, pp, kToolPathKeys);
  if (motion.size() != 1) fail(pp, "expected exactly one of \"keyframes\" or \"csv\"");
  if (motion.contains("csv")) {
    t.keyframes = tool_csv(existing_file(motion["csv"], field(pp, "csv"), {".csv"}), field(pp, "csv"));
  } else {
    const std::string kp = field(pp, "keyframes");
    const Json& keys = array(motion["keyframes"], kp);
    if (keys.empty()) fail(kp, "must list at least one keyframe");
    for (std::size_t i = 0; i < keys.size(); ++i) {
      const std::string p = element(kp, i);
      object(keys[i], p, kToolKeyframeKeys);
      ToolKeyframeDef k;
      k.time = number(required(keys[i], p, "time"), field(p, "time"));
      k.position = vec3(required(keys[i], p, "position"), field(p, "position"));
      optional(keys[i], p, "orientation", [&](const auto& v, const auto& q) {
        if (!v.is_array() || v.size() != 4) fail(q, "expected a quaternion [w, x, y, z], got " + describe(v));
        double n = 0;
        for (std::size_t c = 0; c < 4; ++c) {
          k.orientation[c] = number(v[c], element(q, c));
          n += k.orientation[c] * k.orientation[c];
        }
        if (!(n > 1e-24)) fail(q, "must not be the zero quaternion");
      });
      if (i > 0 && !(k.time > t.keyframes.back().time))
        fail(field(p, "time"), fmt::format("keyframe times must increase; {} comes after {}", k.time, t.keyframes.back().time));
      t.keyframes.push_back(k);
    }
  }
  optional(j, path, "bodies", [&](const auto& v, const auto& q) {
    // An empty list read as no list: the tool touched every body. Left out, it does.
    if (array(v, q).empty()) fail(q, "must name at least one body (leave it out for every body)");
    for (std::size_t i = 0; i < v.size(); ++i) t.bodies.push_back(name(v[i], element(q, i)));
  });
  return t;
}

// A tool path as CSV: a header naming the columns (time,x,y,z and optionally qw,qx,qy,qz, in any
// order), then one row per keyframe; times increasing. Errors name the file and line.
std::vector<ToolKeyframeDef> Reader::tool_csv(const fs::path& file, const std::string& path) const {
  const std::string text = read_input_file(file, "tool path");
  std::vector<ToolKeyframeDef> keys;
  std::vector<std::string> header;
  std::size_t line_no = 0, pos = 0;
  auto where = [&](std::size_t line) { return fmt::format("{}:{}", file.string(), line); };
  int col[8];
  const char* names[8] = {"time", "x", "y", "z", "qw", "qx", "qy", "qz"};
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::size_t a = 0;
    for (;;) {
      const std::size_t b = line.find(',', a);
      std::string c = line.substr(a, b == std::string::npos ? std::string::npos : b - a);
      c.erase(0, c.find_first_not_of(" \t"));
      c.erase(c.find_last_not_of(" \t") + 1);
      cells.push_back(c);
      if (b == std::string::npos) break;
      a = b + 1;
    }
    if (header.empty()) {
      header = cells;
      for (int k = 0; k < 8; ++k) {
        const auto it = std::find(header.begin(), header.end(), names[k]);
        col[k] = it == header.end() ? -1 : int(it - header.begin());
      }
      for (int k = 0; k < 4; ++k)
        if (col[k] < 0) fail(path, fmt::format("{}: the header must name the columns time,x,y,z (and optionally qw,qx,qy,qz); no \"{}\"", where(line_no), names[k]));
      const bool any_q = col[4] >= 0 || col[5] >= 0 || col[6] >= 0 || col[7] >= 0;
      const bool all_q = col[4] >= 0 && col[5] >= 0 && col[6] >= 0 && col[7] >= 0;
      if (any_q && !all_q) fail(path, fmt::format("{}: an orientation needs all of qw,qx,qy,qz", where(line_no)));
      continue;
    }
    if (cells.size() != header.size())
      fail(path, fmt::format("{}: {} values where the header has {} columns", where(line_no), cells.size(), header.size()));
    double v[8] = {0, 0, 0, 0, 1, 0, 0, 0};
    for (int k = 0; k < 8; ++k) {
      if (col[k] < 0) continue;
      const std::string& c = cells[std::size_t(col[k])];
      char* stop = nullptr;
      v[k] = std::strtod(c.c_str(), &stop);
      if (c.empty() || *stop != '\0' || !std::isfinite(v[k]))
        fail(path, fmt::format("{}: column {} is \"{}\", not a finite number", where(line_no), names[k], c));
    }
    ToolKeyframeDef k;
    k.time = v[0];
    k.position = {v[1], v[2], v[3]};
    k.orientation = {v[4], v[5], v[6], v[7]};
    if (!(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7] > 1e-24))
      fail(path, fmt::format("{}: the orientation is the zero quaternion", where(line_no)));
    if (!keys.empty() && !(k.time > keys.back().time))
      fail(path, fmt::format("{}: times must increase ({} after {})", where(line_no), k.time, keys.back().time));
    keys.push_back(k);
  }
  if (keys.empty()) fail(path, fmt::format("{}: no keyframe rows", file.string()));
  return keys;
}

ProbeDef Reader::probe(const Json& j, const std::string& path, std::size_t index) const {
  object(j, path, kProbeKeys);
  ProbeDef p;
  p.name = fmt::format("probe{}", index);
  optional(j, path, "name", [&](const auto& v, const auto& q) { p.name = name(v, q); });
  p.body = name(required(j, path, "body"), field(path, "body"));
  p.point = vec3(required(j, path, "point"), field(path, "point"));
  optional(j, path, "refine", [&](const auto& v, const auto& q) { p.refine = boolean(v, q); });
  return p;
}

}  // namespace

SceneDef parse_scene(std::string_view json_text, const std::string& source,
                     const std::filesystem::path& base_dir) {
  const std::string src = source.empty() ? "scene" : source;
  const Json doc = parse_json_text(json_text, src);
  SceneDef s = Reader(src, base_dir).scene(doc);
  s.source = source;
  return s;
}

SceneDef load_scene_file(const std::filesystem::path& path) {
  const std::string source = path.string();
  const std::string text = read_input_file(path, "scene file");  // regular files only
  SceneDef s = parse_scene(text, source, path.parent_path());
  s.source = path;
  return s;
}

}  // namespace pliant
