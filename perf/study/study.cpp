// A study: the grid of runs of one scene, errors against the reference, the Pareto front of cost
// against error, and the CSV and markdown reports.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "pliant/error.hpp"
#include "pliant/input_file.hpp"
#include "pliant/scene.hpp"
#include "pliant/perf/study.hpp"

namespace pliant::study {
namespace fs = std::filesystem;
namespace {

std::string read_text(const fs::path& path) { return read_input_file(path, "scene file"); }

std::optional<double> as_number(const std::string& s) {
  if (s.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

double relative_error(double value, double reference) {
  if (std::isnan(value) || std::isnan(reference)) return kNaN;
  return reference != 0 ? value / reference - 1 : value - reference;
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += "\"\"";
    else if (c == '\n' || c == '\r') out += ' ';
    else out += c;
  }
  return out + "\"";
}

std::string num(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return fmt::format("{:.9g}", v);
}

std::string unquote(const std::string& v) {
  return v.size() >= 2 && v.front() == '"' && v.back() == '"' ? v.substr(1, v.size() - 2) : v;
}

double cost_of(const RunRecord& r, CostKind k) {
  return k == CostKind::wall ? r.wall_per_sim() : k == CostKind::tet_steps ? r.tet_steps() : r.tet_updates;
}

// Markdown numbers: 4 significant digits, errors in percent.
std::string md_value(double v) { return std::isnan(v) ? "—" : fmt::format("{:.5g}", v); }
std::string md_error(double e) {
  if (std::isnan(e)) return "—";
  const double p = 100 * e;
  if (std::fabs(p) >= 10) return fmt::format("{:+.1f}%", p);
  if (std::fabs(p) >= 0.01) return fmt::format("{:+.2f}%", p);
  return fmt::format("{:+.1e}%", p);
}
std::string md_abs_error(double e) {
  if (std::isnan(e)) return "—";
  const double p = 100 * std::fabs(e);
  return p >= 10 ? fmt::format("{:.1f}%", p) : p >= 0.01 ? fmt::format("{:.2f}%", p) : fmt::format("{:.1e}%", p);
}
std::string md_cost(double v) { return std::isnan(v) ? "—" : fmt::format("{:.3g}", v); }

// A unit as part of a CSV column name: "m/s" -> "m_per_s", "kg m^2" -> "kg_m2".
std::string unit_suffix(const std::string& unit) {
  std::string out;
  for (std::size_t i = 0; i < unit.size(); ++i) {
    const char c = unit[i];
    if (c == '/') out += "_per_";
    else if (std::isalnum(static_cast<unsigned char>(c))) out += c;
    else if (c == ' ' || c == '*' || c == '.') out += '_';
  }
  return out;
}

// NAME_UNIT, or NAME without a unit.
std::string with_unit(const std::string& name, const std::string& unit) {
  const std::string u = unit_suffix(unit);
  return u.empty() ? name : name + "_" + u;
}

}  // namespace

std::string to_string(CostKind k) {
  return k == CostKind::wall ? "wall" : k == CostKind::tet_steps ? "tet-steps" : "tet-updates";
}

CostKind parse_cost(const std::string& text) {
  for (CostKind k : {CostKind::wall, CostKind::tet_steps, CostKind::tet_updates})
    if (text == to_string(k)) return k;
  throw InputError(fmt::format("--cost must be wall, tet-steps or tet-updates, got '{}'", text));
}

QuantityDef quantity_for_measure(const MeasureDef& m) {
  static const char* const kAxis[] = {"x", "y", "z", "displacement"};
  QuantityDef q;
  q.measure = m;
  const std::string probe = m.probe + "_" + kAxis[std::clamp(m.axis, 0, 3)];
  const std::string body = (m.body.empty() ? std::string("body") : m.body) + "_";
  switch (m.kind) {
    case MeasureKind::probe_final: q.name = probe, q.unit = "m"; break;
    case MeasureKind::probe_mean: q.name = probe + "_mean", q.unit = "m"; break;
    case MeasureKind::probe_period:
      if (m.report == "frequency") q.name = probe + "_frequency", q.unit = "Hz";
      else if (m.report == "speed") q.name = probe + "_speed", q.unit = "m/s";
      else q.name = probe + "_period", q.unit = "s";
      break;
    case MeasureKind::probe_arrival:
      if (m.report == "speed") q.name = probe + "_speed", q.unit = "m/s";
      else q.name = probe + "_arrival", q.unit = "s";
      break;
    case MeasureKind::probe_rms: q.name = m.probe + "_rms", q.unit = "m"; break;
    case MeasureKind::strain: q.name = body + "strain_" + kAxis[std::clamp(m.axis, 0, 2)]; break;
    case MeasureKind::poisson_ratio: q.name = body + "poisson_ratio"; break;
    case MeasureKind::volume_change: q.name = body + "volume_change"; break;
  }
  // A scale (or an expression of one) makes it another quantity whose unit we cannot know.
  if (m.scale != 1 || m.expressions.count("scale")) q.name += "_scaled", q.unit.clear();
  // Names go into CSV columns: no spaces, commas or quotes.
  for (char& c : q.name)
    if (c == ' ' || c == ',' || c == '"') c = '_';
  return q;
}

std::vector<bool> pareto_front(const std::vector<double>& cost, const std::vector<double>& error, double tolerance) {
  const std::size_t n = std::min(cost.size(), error.size());
  std::vector<bool> front(cost.size(), false);
  auto usable = [&](std::size_t i) { return std::isfinite(cost[i]) && std::isfinite(error[i]); };
  for (std::size_t i = 0; i < n; ++i) {
    if (!usable(i)) continue;
    bool dominated = false;
    for (std::size_t j = 0; j < n && !dominated; ++j) {
      if (j == i || !usable(j)) continue;
      const bool same_error = std::fabs(error[j] - error[i]) <= tolerance * std::max(error[i], error[j]);
      const bool better_error = error[j] < error[i] && !same_error;
      const bool no_worse_error = error[j] <= error[i] || same_error;
      dominated = (cost[j] <= cost[i] && better_error) || (cost[j] < cost[i] && no_worse_error);
    }
    front[i] = !dominated;
  }
  return front;
}

void finish_study(StudyResult& s) {
  const std::size_t nq = s.quantities.size();
  s.finest = -1;
  if (s.reference_kind == "finest") {
    // The run of most tet-steps among those that measured every quantity; ties (the levels of one
    // multiresolution body share its finest mesh) go to the most tet updates, then to the first.
    auto finer = [](const RunRecord& a, const RunRecord& b) {
      return a.tet_steps() > b.tet_steps() || (a.tet_steps() == b.tet_steps() && a.tet_updates > b.tet_updates);
    };
    for (std::size_t i = 0; i < s.runs.size(); ++i) {
      const RunRecord& r = s.runs[i];
      const bool complete = r.status == "ok" && std::none_of(r.values.begin(), r.values.end(), [](double v) { return std::isnan(v); });
      if (complete && (s.finest < 0 || finer(r, s.runs[std::size_t(s.finest)]))) s.finest = int(i);
    }
    for (auto& r : s.runs) {
      r.references.assign(nq, kNaN);
      r.is_reference = false;
      if (s.finest >= 0) r.references = s.runs[std::size_t(s.finest)].values;
    }
    if (s.finest >= 0) s.runs[std::size_t(s.finest)].is_reference = true;
    // probe_rms: each run's track against the finest run's, at the same sample times (over those
    // both have): value = the RMS of the distance (m), reference = the finest run's largest
    // displacement of the probe (m).
    for (std::size_t q = 0; q < nq && s.finest >= 0; ++q) {
      if (s.quantities[q].measure.kind != MeasureKind::probe_rms) continue;
      const RunRecord& f = s.runs[std::size_t(s.finest)];
      const std::vector<double> none;
      const std::vector<double>& ref = q < f.tracks.size() ? f.tracks[q] : none;
      double largest = 0;
      for (std::size_t i = 0; i + 2 < ref.size(); i += 3)
        largest = std::max(largest, std::sqrt(ref[i] * ref[i] + ref[i + 1] * ref[i + 1] + ref[i + 2] * ref[i + 2]));
      for (RunRecord& r : s.runs) {
        r.references[q] = ref.empty() ? kNaN : largest;
        const std::vector<double>& mine = q < r.tracks.size() ? r.tracks[q] : none;
        const std::size_t n = std::min(mine.size(), ref.size()) / 3;
        double sum = 0;
        for (std::size_t i = 0; i < 3 * n; ++i) sum += (mine[i] - ref[i]) * (mine[i] - ref[i]);
        if (q < r.values.size()) r.values[q] = r.status == "ok" && n > 0 ? std::sqrt(sum / double(n)) : kNaN;
      }
    }
  }
  std::vector<double> cost, error;
  for (auto& r : s.runs) {
    r.references.resize(nq, kNaN);
    r.errors.assign(nq, kNaN);
    r.error = nq ? 0 : kNaN;
    for (std::size_t q = 0; q < nq; ++q) {
      const double value = q < r.values.size() ? r.values[q] : kNaN;
      // probe_rms: the value is the distance itself, over the reference's largest displacement.
      r.errors[q] = s.quantities[q].measure.kind == MeasureKind::probe_rms
                        ? (std::isnan(value) || !(r.references[q] > 0) ? kNaN : value / r.references[q])
                        : relative_error(value, r.references[q]);
      r.error = std::isnan(r.errors[q]) || std::isnan(r.error) ? kNaN : std::max(r.error, std::fabs(r.errors[q]));
    }
    if (r.status != "ok") r.error = kNaN;
    cost.push_back(cost_of(r, s.cost));
    // The reference run is exact by construction: it is not a point of the trade.
    error.push_back(r.is_reference ? kNaN : r.error);
  }
  const std::vector<bool> front = pareto_front(cost, error);
  for (std::size_t i = 0; i < s.runs.size(); ++i) s.runs[i].pareto = front[i];
}

PreparedStudy prepare_study(const StudyOptions& o) {
  PreparedStudy prepared;
  StudyResult& s = prepared.result;
  s.scene = o.scene_label.empty() ? o.scene.string() : o.scene_label;
  s.cost = o.cost;
  const std::string source = o.scene.string();
  const std::string text = read_text(o.scene);
  const fs::path base_dir = o.scene.parent_path().empty() ? fs::path(".") : o.scene.parent_path();

  for (const std::string& t : o.sweeps) {
    Sweep sw = parse_sweep(t);
    // Compared as written, "bodies[00]" and "bodies[0]", or a field and its parent, were two
    // sweeps: the later edit overwrote the earlier, whose values study.csv still reported.
    const std::string path = canonical_sweep_path(sw.path);
    for (const Sweep& other : s.sweeps) {
      const std::string before = canonical_sweep_path(other.path);
      if (before == path)
        throw InputError(fmt::format("--sweep '{}': {} is already swept by --sweep '{}'", t, sw.path, other.text));
      const auto inside = [](const std::string& a, const std::string& b) {  // a lies inside b
        return a.size() > b.size() && a.compare(0, b.size(), b) == 0 && (a[b.size()] == '.' || a[b.size()] == '[');
      };
      if (inside(path, before) || inside(before, path))
        throw InputError(fmt::format("--sweep '{}': {} and {} (--sweep '{}') overlap: one sets part of the other", t,
                                     sw.path, other.path, other.text));
    }
    s.sweeps.push_back(std::move(sw));
  }

  // What is measured, and against what.
  ReferenceFile ref;
  const bool finest = o.reference == "finest";
  const std::optional<double> value = as_number(o.reference);
  bool probes_against_finest = false;
  if (!o.measure.empty()) {
    // (A value that was neither a number nor "finest" was dropped here, and the error said that no
    // reference had been given.)
    if (!o.reference.empty() && !finest && !value)
      throw InputError(fmt::format("--reference {}: with --measure, give a number or finest (a reference file holds "
                                   "its own quantities, and is not used with --measure)",
                                   o.reference));
    ref.quantities.push_back(quantity_for_measure(parse_measure(o.measure, "--measure")));
    ref.source = "--measure";
  } else if (!o.reference.empty() && !finest && !value) {
    ref = load_reference_file(o.reference);
  } else {
    const fs::path side = reference_path_for(o.scene);
    if (fs::exists(side)) {
      ref = load_reference_file(side);
    } else {
      // No reference file: measure what the scene names, its probes (the length of each one's
      // displacement at the end), and compare the runs with the finest. Cost and values are still
      // worth having; the error is convergence, not accuracy.
      const SceneDef scene = parse_scene(text, source, base_dir);
      if (scene.probes.empty())
        throw InputError(fmt::format("{}: no reference file {} beside the scene and no probes to measure: add probes "
                                     "to the scene, or give --measure JSON with --reference VALUE|finest, or --reference FILE",
                                     source, side.string()));
      for (const ProbeDef& p : scene.probes) {
        MeasureDef m;
        m.kind = MeasureKind::probe_final;
        m.probe = p.name;
        m.axis = kDisplacementLength;
        ref.quantities.push_back(quantity_for_measure(m));
      }
      ref.source = source + " (its probes)";
      probes_against_finest = !value;
      s.notes.push_back(fmt::format("no reference file {}: measuring the displacement of {} at the end against {}",
                                    side.string(), scene.probes.size() == 1 ? "probe " + scene.probes[0].name
                                                                            : fmt::format("the {} probes", scene.probes.size()),
                                    value ? "--reference " + o.reference : "the finest run"));
    }
  }
  s.description = ref.description;
  s.quantities = ref.quantities;
  for (const QuantityDef& q : s.quantities)
    if (q.measure.kind == MeasureKind::probe_rms && !finest)
      throw InputError(fmt::format("{}: quantity {}: probe_rms compares every run's probe with the finest run's: "
                                   "use --reference finest",
                                   ref.source, q.name));
  if (finest || probes_against_finest) {
    s.reference_kind = "finest";
  } else if (value) {
    if (s.quantities.size() != 1)
      throw InputError(fmt::format("--reference {}: {} defines {} quantities; a single value can only be the "
                                   "reference of one (use --reference finest or a reference file)",
                                   o.reference, ref.source, s.quantities.size()));
    s.quantities[0].reference = fmt::format("{:.17g}", *value);
    s.reference_kind = "value";
  } else {
    for (const QuantityDef& q : s.quantities)
      if (q.reference.empty())
        throw InputError(fmt::format("{}: quantity {} has no reference; give one, or --reference VALUE|finest",
                                     ref.source, q.name));
    s.reference_kind = "analytic";
  }

  // Every scene of the grid is edited, parsed and checked before anything runs.
  for (const auto& overrides : expand_grid(s.sweeps)) {
    StudyPoint p;
    std::string edited;
    for (std::size_t k = 0; k < overrides.size(); ++k) p.settings.push_back(overrides[k].substr(s.sweeps[k].path.size() + 1));
    const std::string label = settings_label(s.sweeps, p.settings);
    try {
      edited = apply_scene_overrides(text, overrides, source);
      p.scene = parse_scene(edited, source, base_dir);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}{}", overrides.empty() ? "" : "with " + label + ": ", e.what()));
    }
    p.scene.source = o.scene;
    check_measures(s.quantities, p.scene, ref.source);
    const auto vars = bind_variables(ref, edited);
    for (const QuantityDef& q : s.quantities) {
      p.quantities.push_back(q);
      p.quantities.back().measure = resolve_measure(q.measure, vars, ref.source + ": " + q.name + ".measure");
      p.references.push_back(s.reference_kind == "finest"
                                 ? kNaN
                                 : evaluate_expression(q.reference, vars, ref.source + ": " + q.name + ".reference"));
    }
    prepared.points.push_back(std::move(p));
  }
  return prepared;
}

RunRecord run_point(const PreparedStudy& prepared, std::size_t i, const StudyOptions& o) {
  const StudyPoint& point = prepared.points.at(i);
  RunRecord r = run_measured(point.scene, point.quantities, o.threads);
  double spent = r.wall_s;
  for (int rep = 1; r.status == "ok" && rep < 5 && spent < o.min_time; ++rep) {
    const RunRecord again = run_measured(point.scene, point.quantities, o.threads);
    spent += again.wall_s;
    bool same = again.status == r.status && again.values.size() == r.values.size();
    for (std::size_t q = 0; same && q < r.values.size(); ++q)
      same = std::memcmp(&again.values[q], &r.values[q], sizeof(double)) == 0;
    if (!same) r.message = "a repeat of this run measured different values: not deterministic";
    r.wall_s = std::min(r.wall_s, again.wall_s);
    r.repeats = rep + 1;
  }
  r.settings = point.settings;
  r.references = point.references;
  return r;
}

std::string progress_line(const StudyResult& s, const RunRecord& r, std::size_t i, std::size_t n) {
  std::string line =
      fmt::format("[{}/{}] {}: ", i + 1, n, s.sweeps.empty() ? std::string("the scene") : settings_label(s.sweeps, r.settings));
  if (r.status != "ok") {
    line += r.status + (r.message.empty() ? "" : " (" + r.message + ")");
  } else {
    for (std::size_t q = 0; q < s.quantities.size() && q < r.values.size(); ++q) {
      if (s.quantities[q].measure.kind == MeasureKind::probe_rms && !r.is_reference && std::isnan(r.references[q])) {
        // Compared with the finest run once every run is in (finish_study): its own motion till then.
        line += fmt::format("{}{}: tracked, RMS displacement {:.6g} m", q ? ", " : "", s.quantities[q].name, r.values[q]);
        continue;
      }
      line += fmt::format("{}{} = {:.6g}", q ? ", " : "", s.quantities[q].name, r.values[q]);
      if (q < r.references.size() && !std::isnan(r.references[q]))
        line += fmt::format(" (ref {:.6g}, {})", r.references[q], md_error(relative_error(r.values[q], r.references[q])));
    }
  }
  line += fmt::format("; {} tets, {} steps, {:.2f} s wall ({:.3g} s per simulated s)", r.tets, r.steps, r.wall_s,
                      r.wall_per_sim());
  return line;
}

void write_study_files(StudyResult& s, const fs::path& out_dir) {
  fs::create_directories(out_dir);
  const std::pair<const char*, std::string> files[] = {{"study.csv", study_csv(s)}, {"study.md", study_markdown(s)}};
  for (const auto& [name, content] : files) {
    std::ofstream out(out_dir / name);
    if (!out) throw InputError(fmt::format("{}: cannot write", (out_dir / name).string()));
    out << content;
    s.files.push_back((out_dir / name).string());
  }
}

StudyResult run_study(const StudyOptions& o) {
  PreparedStudy prepared = prepare_study(o);
  StudyResult& s = prepared.result;
  if (o.progress)
    for (const std::string& note : s.notes) o.progress("pliant: note: " + note);
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < prepared.points.size(); ++i) {
    RunRecord r = run_point(prepared, i, o);
    if (o.progress) o.progress(progress_line(s, r, i, prepared.points.size()));
    s.runs.push_back(std::move(r));
  }
  s.wall_total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  finish_study(s);
  if (o.write_files) write_study_files(s, o.out_dir);
  return std::move(s);
}

std::string study_csv(const StudyResult& s) {
  std::string out = "run";
  for (const Sweep& sw : s.sweeps) out += "," + csv_field(sw.path);
  out += ",status,run_model,run_precision,run_threads,nodes,tets,dt,steps,substeps,simulated_time,setup_s,wall_s,repeats,wall_per_sim_s,tet_steps,tet_updates";
  // Per quantity: its value and reference named with their unit (tip_z_m, tip_z_reference_m),
  // and the relative error (no unit).
  for (const QuantityDef& q : s.quantities)
    out += fmt::format(",{},{},{}_error", with_unit(q.name, q.unit), with_unit(q.name + "_reference", q.unit), q.name);
  out += ",error,pareto,reference_run,message\n";
  for (std::size_t i = 0; i < s.runs.size(); ++i) {
    const RunRecord& r = s.runs[i];
    out += std::to_string(i + 1);
    for (const std::string& v : r.settings) out += "," + csv_field(unquote(v));
    out += fmt::format(",{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}", r.status, r.model, r.precision, r.threads,
                       r.nodes, r.tets, num(r.dt), r.steps, r.substeps, num(r.simulated_time), num(r.setup_s),
                       num(r.wall_s), r.repeats, num(r.wall_per_sim()), num(r.tet_steps()), num(r.tet_updates));
    for (std::size_t q = 0; q < s.quantities.size(); ++q)
      out += fmt::format(",{},{},{}", num(q < r.values.size() ? r.values[q] : kNaN),
                         num(q < r.references.size() ? r.references[q] : kNaN),
                         num(q < r.errors.size() ? r.errors[q] : kNaN));
    out += fmt::format(",{},{},{},{}\n", num(r.error), r.pareto ? 1 : 0, r.is_reference ? 1 : 0, csv_field(r.message));
  }
  return out;
}

std::string study_markdown(const StudyResult& s) {
  std::string md;
  const char* cost_name = s.cost == CostKind::wall        ? "wall s per simulated s"
                          : s.cost == CostKind::tet_steps ? "tet-steps"
                                                          : "tet updates";
  md += fmt::format("Scene `{}`{}. {} run(s) in {:.0f} s.\n\n", s.scene,
                    s.description.empty() ? "" : ": " + s.description, s.runs.size(), s.wall_total_s);
  // Quantities, and their reference when it is the same in every run.
  for (std::size_t q = 0; q < s.quantities.size(); ++q) {
    const QuantityDef& qd = s.quantities[q];
    std::set<double> refs;
    for (const RunRecord& r : s.runs)
      if (q < r.references.size() && !std::isnan(r.references[q])) refs.insert(r.references[q]);
    std::string ref;
    if (s.reference_kind == "finest")
      ref = s.finest >= 0 ? fmt::format("the finest run (#{})", s.finest + 1) : "the finest run (none measured)";
    else if (refs.size() == 1)
      ref = fmt::format("{:.6g}{}", *refs.begin(), qd.unit.empty() ? "" : " " + qd.unit);
    else
      ref = "per run (below)";
    md += fmt::format("- **{}** ({}{}): reference {}{}{}\n", qd.name, to_string(qd.measure.kind),
                      qd.unit.empty() ? "" : ", " + qd.unit, ref, qd.formula.empty() ? "" : "; " + qd.formula,
                      qd.notes.empty() ? "" : ". " + qd.notes);
  }
  md += "\n";

  // One row per run; a reference column for the quantities whose reference varies.
  auto varying = [&](std::size_t q) {
    if (s.reference_kind == "finest") return false;
    std::set<double> refs;
    for (const RunRecord& r : s.runs)
      if (q < r.references.size()) refs.insert(r.references[q]);
    return refs.size() > 1;
  };
  md += "| # |";
  for (const Sweep& sw : s.sweeps) md += fmt::format(" {} |", sw.short_name());
  for (std::size_t q = 0; q < s.quantities.size(); ++q)
    md += fmt::format(" {} |{} error |", s.quantities[q].name, varying(q) ? " reference |" : "");
  md += " tets | steps | wall s / sim s | tet-steps | front |\n|---|";
  for (std::size_t k = 0; k < s.sweeps.size(); ++k) md += "---|";
  for (std::size_t q = 0; q < s.quantities.size(); ++q) md += varying(q) ? "---:|---:|---:|" : "---:|---:|";
  md += "---:|---:|---:|---:|:-:|\n";
  for (std::size_t i = 0; i < s.runs.size(); ++i) {
    const RunRecord& r = s.runs[i];
    md += fmt::format("| {} |", i + 1);
    for (const std::string& v : r.settings) md += fmt::format(" {} |", unquote(v));
    for (std::size_t q = 0; q < s.quantities.size(); ++q) {
      md += fmt::format(" {} |", r.status == "ok" ? md_value(r.values[q]) : r.status);
      if (varying(q)) md += fmt::format(" {} |", md_value(r.references[q]));
      md += fmt::format(" {} |", r.is_reference ? "(reference)" : md_error(r.errors[q]));
    }
    md += fmt::format(" {} | {} | {} | {} | {} |\n", r.tets, r.steps, md_cost(r.wall_per_sim()), md_cost(r.tet_steps()),
                      r.pareto ? "★" : "");
  }
  md += fmt::format("\n★: on the Pareto front of cost ({}) against error (the largest |error| over the quantities): "
                    "no other run is both cheaper and more accurate (errors within 1% of each other count as equal).\n",
                    cost_name);

  // Convergence: the first sweep down, the other sweeps across, for each quantity.
  if (s.sweeps.size() >= 2) {
    std::vector<std::string> columns;
    std::map<std::string, std::size_t> column_of;
    std::vector<std::string> rows;
    for (const RunRecord& r : s.runs) {
      std::vector<std::string> rest(r.settings.begin() + 1, r.settings.end());
      std::vector<Sweep> rest_sweeps(s.sweeps.begin() + 1, s.sweeps.end());
      const std::string col = settings_label(rest_sweeps, rest);
      if (!column_of.count(col)) column_of[col] = columns.size(), columns.push_back(col);
      if (std::find(rows.begin(), rows.end(), r.settings[0]) == rows.end()) rows.push_back(r.settings[0]);
    }
    for (std::size_t q = 0; q < s.quantities.size(); ++q) {
      md += fmt::format("\n{} against {} (value, error):\n\n| {} |", s.quantities[q].name, s.sweeps[0].short_name(),
                        s.sweeps[0].short_name());
      for (const auto& c : columns) md += fmt::format(" {} |", c);
      md += "\n|---|";
      for (std::size_t c = 0; c < columns.size(); ++c) md += "---:|";
      md += "\n";
      for (const std::string& row : rows) {
        std::vector<std::string> cells(columns.size(), "");
        for (const RunRecord& r : s.runs) {
          if (r.settings[0] != row) continue;
          std::vector<std::string> rest(r.settings.begin() + 1, r.settings.end());
          std::vector<Sweep> rest_sweeps(s.sweeps.begin() + 1, s.sweeps.end());
          const std::size_t c = column_of[settings_label(rest_sweeps, rest)];
          cells[c] = r.status != "ok" ? r.status
                     : r.is_reference ? md_value(r.values[q]) + " (reference)"
                                      : md_value(r.values[q]) + " (" + md_error(r.errors[q]) + ")";
        }
        md += fmt::format("| {} |", unquote(row));
        for (const auto& c : cells) md += fmt::format(" {} |", c);
        md += "\n";
      }
    }
  }

  // The front, cheapest first.
  std::vector<std::size_t> front;
  for (std::size_t i = 0; i < s.runs.size(); ++i)
    if (s.runs[i].pareto) front.push_back(i);
  std::sort(front.begin(), front.end(),
            [&](std::size_t a, std::size_t b) { return cost_of(s.runs[a], s.cost) < cost_of(s.runs[b], s.cost); });
  md += fmt::format("\nPareto front ({} against error), cheapest first:\n\n| # | settings | cost | \\|error\\| |\n|---|---|---:|---:|\n",
                    cost_name);
  for (std::size_t i : front)
    md += fmt::format("| {} | {} | {} | {} |\n", i + 1, s.sweeps.empty() ? "" : settings_label(s.sweeps, s.runs[i].settings),
                      md_cost(cost_of(s.runs[i], s.cost)), md_abs_error(s.runs[i].error));
  return md;
}

}  // namespace pliant::study
