// Reference files (SCENE.reference.json): what a study measures and the analytic answer, as an
// expression of variables read from the scene, so that a sweep of E or nu changes the reference.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "pliant/error.hpp"
#include "pliant/input_file.hpp"
#include "pliant/perf/study.hpp"

namespace pliant::study {
namespace {

using Json = nlohmann::ordered_json;

bool is_comment(const std::string& key) { return !key.empty() && (key[0] == '_' || key.rfind("//", 0) == 0); }

std::string describe(const Json& v) {
  if (v.is_string()) return fmt::format("string \"{}\"", v.get<std::string>());
  if (v.is_number()) return fmt::format("number {}", v.dump());
  if (v.is_boolean()) return fmt::format("bool {}", v.dump());
  if (v.is_array()) return fmt::format("an array of {}", v.size());
  if (v.is_object()) return "an object";
  return "null";
}

struct Ctx {
  std::string source;
  [[noreturn]] void fail(const std::string& path, const std::string& problem) const {
    throw InputError(fmt::format("{}: {}: {}", source, path.empty() ? "top level" : path, problem));
  }
  void check_keys(const Json& obj, const std::string& path, const std::vector<std::string>& known) const {
    for (auto it = obj.begin(); it != obj.end(); ++it) {
      if (is_comment(it.key())) continue;
      if (std::find(known.begin(), known.end(), it.key()) == known.end())
        fail(path.empty() ? it.key() : path + "." + it.key(),
             fmt::format("unknown key; known keys here: {}", fmt::join(known, ", ")));
    }
  }
  double number(const Json& v, const std::string& path) const {
    if (!v.is_number()) fail(path, fmt::format("expected a number, got {}", describe(v)));
    const double d = v.get<double>();
    if (!std::isfinite(d)) fail(path, "must be finite");
    return d;
  }
  std::string string(const Json& v, const std::string& path) const {
    if (!v.is_string()) fail(path, fmt::format("expected a string, got {}", describe(v)));
    return v.get<std::string>();
  }
  int axis(const Json& v, const std::string& path) const {
    const std::string s = string(v, path);
    if (s == "x") return 0;
    if (s == "y") return 1;
    if (s == "z") return 2;
    fail(path, fmt::format("expected \"x\", \"y\" or \"z\", got \"{}\"", s));
  }
  Vec3d vec3(const Json& v, const std::string& path) const {
    if (!v.is_array() || v.size() != 3) fail(path, fmt::format("expected [x, y, z], got {}", describe(v)));
    return {number(v[0], path + "[0]"), number(v[1], path + "[1]"), number(v[2], path + "[2]")};
  }
};

MeasureDef measure_from(const Json& j, const std::string& path, const Ctx& ctx) {
  if (!j.is_object()) ctx.fail(path, fmt::format("expected an object, got {}", describe(j)));
  if (!j.contains("kind")) ctx.fail(path + ".kind", "required");
  const std::string kind = ctx.string(j["kind"], path + ".kind");
  static const std::vector<std::pair<std::string, MeasureKind>> kinds = {
      {"probe_final", MeasureKind::probe_final},     {"probe_mean", MeasureKind::probe_mean},
      {"probe_period", MeasureKind::probe_period},   {"probe_arrival", MeasureKind::probe_arrival},
      {"probe_rms", MeasureKind::probe_rms},
      {"strain", MeasureKind::strain},               {"poisson_ratio", MeasureKind::poisson_ratio},
      {"volume_change", MeasureKind::volume_change}};
  MeasureDef m;
  auto it = std::find_if(kinds.begin(), kinds.end(), [&](const auto& k) { return k.first == kind; });
  if (it == kinds.end()) {
    std::vector<std::string> names;
    for (const auto& k : kinds) names.push_back(k.first);
    ctx.fail(path + ".kind", fmt::format("unknown measure \"{}\"; known: {}", kind, fmt::join(names, ", ")));
  }
  m.kind = it->second;
  const bool probe_kind = m.kind == MeasureKind::probe_final || m.kind == MeasureKind::probe_mean ||
                          m.kind == MeasureKind::probe_period || m.kind == MeasureKind::probe_arrival ||
                          m.kind == MeasureKind::probe_rms;
  std::vector<std::string> known = {"kind", "scale"};
  if (m.kind == MeasureKind::probe_rms) {
    known.insert(known.end(), {"probe", "from", "every"});  // the whole displacement: no axis
  } else if (probe_kind) {
    known.insert(known.end(), {"probe", "axis"});
    if (m.kind == MeasureKind::probe_mean) known.insert(known.end(), {"from", "whole_periods"});
    if (m.kind == MeasureKind::probe_period) known.insert(known.end(), {"from", "report", "distance"});
    if (m.kind == MeasureKind::probe_arrival) known.insert(known.end(), {"level", "delay", "report", "distance"});
  } else {
    known.insert(known.end(), {"body", "region", "from", "every"});
    if (m.kind == MeasureKind::strain || m.kind == MeasureKind::poisson_ratio) known.push_back("axis");
    if (m.kind == MeasureKind::poisson_ratio) known.push_back("lateral");
  }
  ctx.check_keys(j, path, known);
  auto has = [&](const char* k) { return j.contains(k); };
  if (probe_kind) {
    if (!has("probe")) ctx.fail(path + ".probe", "required: the name of a probe of the scene");
    m.probe = ctx.string(j["probe"], path + ".probe");
    if (m.kind == MeasureKind::probe_rms) m.axis = kDisplacementLength;
    else if (!has("axis")) ctx.fail(path + ".axis", "required: \"x\", \"y\" or \"z\"");
  }
  if (has("axis")) m.axis = ctx.axis(j["axis"], path + ".axis");
  // Numbers that may also be expressions of the variables, evaluated per run.
  auto number_or_expression = [&](const char* key, double& out) {
    const Json& v = j[key];
    if (v.is_string()) {
      m.expressions[key] = v.get<std::string>();
      out = kNaN;
    } else {
      out = ctx.number(v, path + "." + key);
    }
  };
  if (has("scale")) number_or_expression("scale", m.scale);
  if (has("body")) m.body = ctx.string(j["body"], path + ".body");
  if (has("from")) {
    m.from = ctx.number(j["from"], path + ".from");
    if (*m.from < 0) ctx.fail(path + ".from", "must be >= 0 (s)");
  }
  if (has("every")) {
    m.every = ctx.number(j["every"], path + ".every");
    if (m.every < 0) ctx.fail(path + ".every", "must be >= 0 (s)");
  }
  if (has("whole_periods")) {
    if (!j["whole_periods"].is_boolean()) ctx.fail(path + ".whole_periods", "expected true or false");
    m.whole_periods = j["whole_periods"].get<bool>();
  }
  if (has("region")) {
    const Json& r = j["region"];
    if (!r.is_object()) ctx.fail(path + ".region", "expected {\"min\": [x, y, z], \"max\": [x, y, z]}");
    ctx.check_keys(r, path + ".region", {"min", "max"});
    if (!r.contains("min") || !r.contains("max")) ctx.fail(path + ".region", "needs min and max");
    const Vec3d lo = ctx.vec3(r["min"], path + ".region.min"), hi = ctx.vec3(r["max"], path + ".region.max");
    for (int a = 0; a < 3; ++a)
      if (lo[a] > hi[a]) ctx.fail(path + ".region", "min must be <= max in every coordinate");
    m.region = std::array<Vec3d, 2>{lo, hi};
  }
  if (m.kind == MeasureKind::poisson_ratio) {
    if (has("lateral")) {
      const Json& l = j["lateral"];
      if (l.is_string()) m.lateral.push_back(ctx.axis(l, path + ".lateral"));
      else if (l.is_array() && !l.empty())
        for (std::size_t i = 0; i < l.size(); ++i) m.lateral.push_back(ctx.axis(l[i], fmt::format("{}.lateral[{}]", path, i)));
      else ctx.fail(path + ".lateral", "expected an axis or an array of axes");
      for (int a : m.lateral)
        if (a == m.axis) ctx.fail(path + ".lateral", "must differ from axis");
    } else {
      for (int a = 0; a < 3; ++a)
        if (a != m.axis) m.lateral.push_back(a);
    }
  }
  if (m.kind == MeasureKind::probe_period || m.kind == MeasureKind::probe_arrival) {
    const bool period = m.kind == MeasureKind::probe_period;
    m.report = period ? "period" : "time";
    if (has("report")) m.report = ctx.string(j["report"], path + ".report");
    const std::vector<std::string> reports =
        period ? std::vector<std::string>{"period", "frequency", "speed"} : std::vector<std::string>{"time", "speed"};
    if (std::find(reports.begin(), reports.end(), m.report) == reports.end())
      ctx.fail(path + ".report", fmt::format("expected one of {}, got \"{}\"", fmt::join(reports, ", "), m.report));
    if (has("distance")) number_or_expression("distance", m.distance);
    if (m.report == "speed" && !(m.distance > 0) && !m.expressions.count("distance"))
      ctx.fail(path + ".distance", "required with report \"speed\": a distance > 0 (m)");
  }
  if (m.kind == MeasureKind::probe_arrival) {
    if (!has("level")) ctx.fail(path + ".level", "required: the displacement (m) whose first reaching is timed");
    number_or_expression("level", m.level);
    if (m.level == 0) ctx.fail(path + ".level", "must not be 0");
    if (has("delay")) number_or_expression("delay", m.delay);
  }
  return m;
}

QuantityDef quantity_from(const Json& j, const std::string& path, const Ctx& ctx, bool top_level) {
  QuantityDef q;
  if (!j.is_object()) ctx.fail(path, fmt::format("expected an object, got {}", describe(j)));
  if (!top_level) ctx.check_keys(j, path, {"name", "unit", "measure", "reference", "formula", "notes"});
  auto key = [&](const char* k) { return path.empty() ? std::string(k) : path + "." + k; };
  if (j.contains("name")) {
    q.name = ctx.string(j["name"], key("name"));
    if (q.name.empty() || q.name.find_first_of(" ,\"\n") != std::string::npos)
      ctx.fail(key("name"), "must be non-empty, without spaces, commas or quotes (it names CSV columns)");
  }
  if (j.contains("unit")) q.unit = ctx.string(j["unit"], key("unit"));
  if (j.contains("formula")) q.formula = ctx.string(j["formula"], key("formula"));
  if (j.contains("notes")) q.notes = ctx.string(j["notes"], key("notes"));
  if (!j.contains("measure")) ctx.fail(key("measure"), "required");
  q.measure = measure_from(j["measure"], key("measure"), ctx);
  if (j.contains("reference")) {
    const Json& r = j["reference"];
    if (r.is_number()) q.reference = fmt::format("{:.17g}", ctx.number(r, key("reference")));
    else if (r.is_string()) q.reference = r.get<std::string>();
    else ctx.fail(key("reference"), fmt::format("expected a number or an expression string, got {}", describe(r)));
  }
  return q;
}

// ---- expressions --------------------------------------------------------------------------------

class Parser {
 public:
  Parser(std::string_view s, const std::map<std::string, double>& vars, const std::string& where)
      : s_(s), vars_(vars), where_(where) {}
  double parse() {
    const double v = expr();
    skip();
    if (i_ < s_.size()) fail(fmt::format("unexpected '{}'", s_[i_]));
    return v;
  }

 private:
  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(fmt::format("{}: expression \"{}\": {} at character {}", where_, s_, problem, i_ + 1));
  }
  void skip() {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
  }
  bool eat(char c) {
    skip();
    if (i_ < s_.size() && s_[i_] == c) return ++i_, true;
    return false;
  }
  double expr() {
    double v = term();
    for (;;) {
      if (eat('+')) v += term();
      else if (eat('-')) v -= term();
      else return v;
    }
  }
  double term() {
    double v = unary();
    for (;;) {
      if (eat('*')) v *= unary();
      else if (eat('/')) v /= unary();
      else return v;
    }
  }
  double unary() {
    if (eat('-')) return -unary();
    if (eat('+')) return unary();
    return power();
  }
  double power() {
    const double base = primary();
    if (eat('^')) return std::pow(base, unary());  // right-associative; -x^2 = -(x^2)
    return base;
  }
  double primary() {
    skip();
    if (i_ >= s_.size()) fail("unexpected end");
    const char c = s_[i_];
    if (c == '(') {
      ++i_;
      const double v = expr();
      if (!eat(')')) fail("expected ')'");
      return v;
    }
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') {
      const std::string rest(s_.substr(i_));
      char* end = nullptr;
      const double v = std::strtod(rest.c_str(), &end);
      if (end == rest.c_str()) fail("bad number");
      i_ += std::size_t(end - rest.c_str());
      return v;
    }
    if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      const std::size_t start = i_;
      while (i_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[i_])) || s_[i_] == '_')) ++i_;
      const std::string name(s_.substr(start, i_ - start));
      if (eat('(')) {
        std::vector<double> args;
        if (!eat(')')) {
          do args.push_back(expr());
          while (eat(','));
          if (!eat(')')) fail("expected ')' or ','");
        }
        return call(name, args);
      }
      auto it = vars_.find(name);
      if (it != vars_.end()) return it->second;
      if (name == "pi") return 3.14159265358979323846;
      std::string known;
      for (const auto& [k, v] : vars_) known += (known.empty() ? "" : ", ") + k;
      i_ = start;
      fail(fmt::format("unknown variable \"{}\" (variables: {})", name, known.empty() ? "none" : known));
    }
    fail(fmt::format("unexpected '{}'", c));
  }
  double call(const std::string& f, const std::vector<double>& a) {
    auto need = [&](std::size_t n) {
      if (a.size() != n) fail(fmt::format("{}() takes {} argument(s), got {}", f, n, a.size()));
    };
    if (f == "sqrt") return need(1), std::sqrt(a[0]);
    if (f == "abs") return need(1), std::fabs(a[0]);
    if (f == "exp") return need(1), std::exp(a[0]);
    if (f == "log") return need(1), std::log(a[0]);
    if (f == "sin") return need(1), std::sin(a[0]);
    if (f == "cos") return need(1), std::cos(a[0]);
    if (f == "tan") return need(1), std::tan(a[0]);
    if (f == "pow") return need(2), std::pow(a[0], a[1]);
    if (f == "min") return need(2), std::min(a[0], a[1]);
    if (f == "max") return need(2), std::max(a[0], a[1]);
    fail(fmt::format("unknown function \"{}\" (sqrt abs exp log sin cos tan pow min max)", f));
  }

  std::string_view s_;
  std::size_t i_ = 0;
  const std::map<std::string, double>& vars_;
  const std::string& where_;
};

// A scene path ("bodies[0].mesh.box.max[0]") in parsed scene JSON; nullptr when absent.
const Json* find_path(const Json& doc, const std::string& path, bool& malformed) {
  const Json* node = &doc;
  std::size_t i = 0;
  malformed = false;
  while (i < path.size()) {
    if (path[i] == '[') {
      const std::size_t close = path.find(']', i);
      if (close == std::string::npos || close == i + 1) return malformed = true, nullptr;
      std::size_t index = 0;
      for (std::size_t k = i + 1; k < close; ++k) {
        if (!std::isdigit(static_cast<unsigned char>(path[k]))) return malformed = true, nullptr;
        index = index * 10 + std::size_t(path[k] - '0');
      }
      if (!node->is_array() || index >= node->size()) return nullptr;
      node = &(*node)[index];
      i = close + 1;
    } else {
      if (path[i] == '.') ++i;
      const std::size_t end = std::min(path.find_first_of(".[", i), path.size());
      if (end == i) return malformed = true, nullptr;
      const std::string key = path.substr(i, end - i);
      if (!node->is_object() || !node->contains(key)) return nullptr;
      node = &(*node)[key];
      i = end;
    }
  }
  return node;
}

}  // namespace

const char* to_string(MeasureKind k) {
  switch (k) {
    case MeasureKind::probe_final: return "probe_final";
    case MeasureKind::probe_mean: return "probe_mean";
    case MeasureKind::probe_period: return "probe_period";
    case MeasureKind::probe_arrival: return "probe_arrival";
    case MeasureKind::probe_rms: return "probe_rms";
    case MeasureKind::strain: return "strain";
    case MeasureKind::poisson_ratio: return "poisson_ratio";
    case MeasureKind::volume_change: return "volume_change";
  }
  return "?";
}

ReferenceFile parse_reference(std::string_view json_text, const std::string& source) {
  Ctx ctx{source};
  Json doc;
  try {
    doc = Json::parse(json_text, nullptr, true, true);
  } catch (const Json::parse_error& e) {
    throw InputError(fmt::format("{}: invalid JSON: {}", source, e.what()));
  }
  if (!doc.is_object()) ctx.fail("", fmt::format("expected an object, got {}", describe(doc)));
  ReferenceFile ref;
  ref.source = source;
  const bool many = doc.contains("quantities");
  if (many)
    ctx.check_keys(doc, "", {"description", "variables", "quantities"});
  else
    ctx.check_keys(doc, "", {"description", "variables", "name", "unit", "measure", "reference", "formula", "notes"});
  if (doc.contains("description")) ref.description = ctx.string(doc["description"], "description");
  if (doc.contains("variables")) {
    const Json& vars = doc["variables"];
    if (!vars.is_object()) ctx.fail("variables", fmt::format("expected an object, got {}", describe(vars)));
    for (auto it = vars.begin(); it != vars.end(); ++it) {
      if (is_comment(it.key())) continue;
      const std::string p = "variables." + it.key();
      const std::string& name = it.key();
      if (name.empty() || !(std::isalpha(static_cast<unsigned char>(name[0])) || name[0] == '_') ||
          !std::all_of(name.begin(), name.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }))
        ctx.fail(p, "a variable name is letters, digits and _, starting with a letter");
      VariableDef v;
      const Json& val = it.value();
      if (val.is_number()) v.value = ctx.number(val, p);
      else if (val.is_string()) v.path = val.get<std::string>();
      else if (val.is_object()) {
        ctx.check_keys(val, p, {"path", "default", "expr"});
        if (val.contains("expr") == val.contains("path")) ctx.fail(p, "give exactly one of path and expr");
        if (val.contains("path")) v.path = ctx.string(val["path"], p + ".path");
        if (val.contains("expr")) v.expression = ctx.string(val["expr"], p + ".expr");
        if (val.contains("default")) v.fallback = ctx.number(val["default"], p + ".default");
      } else {
        ctx.fail(p, fmt::format("expected a number, a scene path or {{\"path\", \"default\"}} / {{\"expr\"}}, got {}",
                                describe(val)));
      }
      ref.variables.emplace_back(name, std::move(v));
    }
  }
  if (many) {
    const Json& qs = doc["quantities"];
    if (!qs.is_array() || qs.empty()) ctx.fail("quantities", "expected a non-empty array of quantities");
    for (std::size_t i = 0; i < qs.size(); ++i) ref.quantities.push_back(quantity_from(qs[i], fmt::format("quantities[{}]", i), ctx, false));
  } else {
    ref.quantities.push_back(quantity_from(doc, "", ctx, true));
  }
  for (std::size_t i = 0; i < ref.quantities.size(); ++i)
    for (std::size_t k = 0; k < i; ++k)
      if (ref.quantities[i].name == ref.quantities[k].name)
        ctx.fail(fmt::format("quantities[{}].name", i), fmt::format("\"{}\" is used twice", ref.quantities[i].name));
  // Check the expressions now (syntax and variable names), with every variable set to 1.
  std::map<std::string, double> ones;
  for (const auto& [name, v] : ref.variables) ones[name] = 1;
  for (const auto& [name, v] : ref.variables)
    if (!v.expression.empty()) evaluate_expression(v.expression, ones, source + ": variables." + name);
  for (std::size_t i = 0; i < ref.quantities.size(); ++i)
    resolve_measure(ref.quantities[i].measure, ones,
                    source + ": " + (many ? fmt::format("quantities[{}].measure", i) : "measure"));
  for (std::size_t i = 0; i < ref.quantities.size(); ++i)
    if (!ref.quantities[i].reference.empty())
      evaluate_expression(ref.quantities[i].reference, ones,
                          source + ": " + (many ? fmt::format("quantities[{}].reference", i) : "reference"));
  return ref;
}

ReferenceFile load_reference_file(const std::filesystem::path& path) {
  return parse_reference(read_input_file(path, "reference file"), path.string());
}

std::filesystem::path reference_path_for(const std::filesystem::path& scene) {
  std::filesystem::path p = scene;
  p.replace_extension(".reference.json");
  return p;
}

MeasureDef parse_measure(std::string_view json_text, const std::string& source) {
  Ctx ctx{source};
  const Json j = Json::parse(json_text, nullptr, false, true);
  if (j.is_discarded()) throw InputError(fmt::format("{}: invalid JSON: {}", source, json_text));
  return measure_from(j, "measure", ctx);
}

MeasureDef resolve_measure(const MeasureDef& m, const std::map<std::string, double>& variables,
                           const std::string& where) {
  MeasureDef r = m;
  for (const auto& [key, expr] : m.expressions) {
    const double v = evaluate_expression(expr, variables, where + "." + key);
    if (key == "distance") r.distance = v;
    else if (key == "level") r.level = v;
    else if (key == "delay") r.delay = v;
    else if (key == "scale") r.scale = v;
  }
  r.expressions.clear();
  return r;
}

double evaluate_expression(std::string_view expr, const std::map<std::string, double>& variables,
                           const std::string& where) {
  return Parser(expr, variables, where).parse();
}

std::map<std::string, double> bind_variables(const ReferenceFile& ref, std::string_view scene_json) {
  std::map<std::string, double> out;
  if (ref.variables.empty()) return out;
  const Json doc = Json::parse(scene_json, nullptr, false, true);
  if (doc.is_discarded()) throw InputError(fmt::format("{}: the scene is not JSON", ref.source));
  for (const auto& [name, v] : ref.variables) {
    const std::string where = ref.source + ": variables." + name;
    if (v.value) {
      out[name] = *v.value;
    } else if (!v.expression.empty()) {
      out[name] = evaluate_expression(v.expression, out, where);
    } else {
      bool malformed = false;
      const Json* node = find_path(doc, v.path, malformed);
      if (malformed) throw InputError(fmt::format("{}: malformed scene path \"{}\"", where, v.path));
      if (!node) {
        if (!v.fallback)
          throw InputError(fmt::format("{}: the scene has no value at \"{}\" (write it in the scene, or give "
                                       "{{\"path\": \"{}\", \"default\": VALUE}})", where, v.path, v.path));
        out[name] = *v.fallback;
      } else if (!node->is_number()) {
        throw InputError(fmt::format("{}: the scene value at \"{}\" is {}, not a number", where, v.path, describe(*node)));
      } else {
        out[name] = node->get<double>();
      }
    }
  }
  return out;
}

}  // namespace pliant::study
