// The Pareto and convergence plots of a study (see study_plots.hpp): which runs go where, which
// sweep is the x axis of the convergence, axis scales and labels, and the two PNG files.
#include "pliant/perf/study_plots.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <optional>
#include <set>

#include "pliant/raster/colormap.hpp"
#include "pliant/raster/image.hpp"

namespace pliant::raster {
namespace {
namespace fs = std::filesystem;
using study::RunRecord;
using study::StudyResult;
using study::Sweep;

const Rgba kOtherRuns{150, 152, 160, 255};  // grey: runs off the front
constexpr double kLogSpan = 5;              // an axis is logarithmic when its values span this factor
constexpr std::size_t kLegendInside = 4;    // at most this many series keep their legend in the plot area
constexpr int kLegendRow = 24;              // pixels of a legend row in an 800x600 plot (text 2x, see plot.cpp)

std::string scene_name(const StudyResult& s) {
  const std::string stem = fs::path(s.scene).stem().string();
  return stem.empty() ? s.scene : stem;
}

// Log scale when the positive finite values span kLogSpan or more (errors and costs usually
// span decades; a narrow range reads better on a linear axis).
bool wants_log(const std::vector<double>& values) {
  double lo = INFINITY, hi = 0;
  for (double v : values)
    if (std::isfinite(v) && v > 0) lo = std::min(lo, v), hi = std::max(hi, v);
  return hi > 0 && hi >= kLogSpan * lo;
}

// |relative error| of a run in percent; NaN when it has none (not ok, the reference run, NaN).
double error_percent(const RunRecord& r, double error) {
  if (r.status != "ok" || r.is_reference || !std::isfinite(error)) return NAN;
  return 100 * std::fabs(error);
}

double cost_of(const RunRecord& r, study::CostKind k) {
  return k == study::CostKind::wall ? r.wall_per_sim() : k == study::CostKind::tet_steps ? r.tet_steps() : r.tet_updates;
}

std::optional<double> as_number(const std::string& json) {
  if (json.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(json.c_str(), &end);
  if (end != json.c_str() + json.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

// The unit of a scene value from its last key (docs/scene-format.md); "" when dimensionless or unknown.
std::string scene_unit(const Sweep& sw) {
  std::string key = sw.short_name();
  key = key.substr(0, key.find('['));
  static const std::map<std::string, std::string> kUnits = {
      {"duration", "s"},  {"dt", "s"},         {"gravity", "m/s²"},        {"young", "Pa"},
      {"density", "kg/m³"}, {"cell_size", "m"}, {"mass", "1/s"},          {"stiffness", "s"},
      {"bulk_viscosity", "Pa·s"}, {"shear_viscosity", "Pa·s"}, {"scale", ""}, {"translate", "m"}};
  const auto it = kUnits.find(key);
  return it == kUnits.end() ? "" : it->second;
}

// The settings of a run without sweep k: runs that share it differ only in sweep k.
std::string others_key(const RunRecord& r, std::size_t k) {
  std::string key;
  for (std::size_t i = 0; i < r.settings.size(); ++i)
    if (i != k) key += r.settings[i] + '\x1f';
  return key;
}

std::vector<std::string> without(std::vector<std::string> settings, std::size_t k) {
  if (k < settings.size()) settings.erase(settings.begin() + std::ptrdiff_t(k));
  return settings;
}

// True if runs that differ only in sweep k have different numbers of tets.
bool changes_mesh(const StudyResult& s, std::size_t k) {
  std::map<std::string, std::set<std::size_t>> tets;
  for (const RunRecord& r : s.runs)
    if (r.tets > 0) {
      auto& seen = tets[others_key(r, k)];
      if (seen.insert(r.tets).second && seen.size() > 1) return true;
    }
  return false;
}

std::string reference_note(const StudyResult& s) {
  if (s.reference_kind == "finest") return s.finest >= 0 ? fmt::format("vs run #{}", s.finest + 1) : "vs the finest run";
  if (s.reference_kind == "value") return "vs a given value";
  return "vs analytic";
}

}  // namespace

Plot study_pareto_plot(const StudyResult& s) {
  const std::size_t nq = s.quantities.size();
  Plot p;
  p.x = s.cost == study::CostKind::wall        ? PlotAxis{"cost: wall time per simulated time", "s/s"}
        : s.cost == study::CostKind::tet_steps ? PlotAxis{"cost: tet-steps (tets × steps)", ""}
                                               : PlotAxis{"cost: tet updates (tets computed, every level)", ""};
  p.y = PlotAxis{nq == 1 ? "|relative error| of " + s.quantities[0].name : "largest |relative error|", "%"};

  std::vector<double> cost, error;
  for (const RunRecord& r : s.runs) {
    cost.push_back(cost_of(r, s.cost));
    error.push_back(error_percent(r, r.error));
  }
  p.x.log = wants_log(cost);
  p.y.log = wants_log(error);

  // The runs off the front, then the front cheapest first (drawn on top, joined, labelled).
  PlotSeries others("", {}, {}, SeriesStyle::scatter), front("", {}, {}, SeriesStyle::line_and_markers);  // labelled below
  others.colour = kOtherRuns;
  front.colour = palette(3);
  std::vector<std::size_t> on_front;
  int reference = 0, failed = 0, unmeasured = 0, zero = 0;
  for (std::size_t i = 0; i < s.runs.size(); ++i) {
    const RunRecord& r = s.runs[i];
    if (r.is_reference) ++reference;
    else if (r.status != "ok") ++failed;
    else if (!std::isfinite(error[i]) || !std::isfinite(cost[i])) ++unmeasured;
    else if ((p.y.log && !(error[i] > 0)) || (p.x.log && !(cost[i] > 0))) ++zero;
    else if (r.pareto) on_front.push_back(i);
    else others.x.push_back(cost[i]), others.y.push_back(error[i]);
  }
  std::sort(on_front.begin(), on_front.end(), [&](std::size_t a, std::size_t b) { return cost[a] < cost[b]; });
  for (std::size_t i : on_front) {
    front.x.push_back(cost[i]);
    front.y.push_back(error[i]);
    front.point_labels.push_back(fmt::format("#{}", i + 1));
  }
  others.label = fmt::format("other runs ({})", others.x.size());
  front.label = fmt::format("Pareto front ({} run{})", front.x.size(), front.x.size() == 1 ? "" : "s");
  if (!others.x.empty()) p.series.push_back(std::move(others));
  if (!front.x.empty()) p.series.push_back(std::move(front));

  std::vector<std::string> hidden;
  if (reference) hidden.push_back("the reference run");
  if (failed) hidden.push_back(fmt::format("{} diverged or invalid", failed));
  if (unmeasured) hidden.push_back(fmt::format("{} without a value", unmeasured));
  if (zero) hidden.push_back(fmt::format("{} of zero error", zero));
  p.title = fmt::format("{}: cost against error", scene_name(s));
  for (std::size_t i = 0; i < hidden.size(); ++i) p.title += (i ? ", " : " (not drawn: ") + hidden[i];
  if (!hidden.empty()) p.title += ")";
  return p;
}

ConvergencePlots study_convergence_plots(const StudyResult& s) {
  ConvergencePlots out;
  if (s.sweeps.empty()) {
    out.why_none = "no sweep: nothing converges";
    return out;
  }
  // The x axis: the first sweep that changes the mesh, else the first one of numbers.
  std::optional<std::size_t> axis;
  for (std::size_t k = 0; k < s.sweeps.size() && !axis; ++k)
    if (changes_mesh(s, k)) axis = k, out.x_is_tets = true;
  for (std::size_t k = 0; k < s.sweeps.size() && !axis; ++k) {
    const auto& values = s.sweeps[k].values;
    if (values.size() >= 2 && std::all_of(values.begin(), values.end(), [](const std::string& v) { return as_number(v).has_value(); }))
      axis = k;
  }
  if (!axis) {
    out.why_none = "no sweep changes the mesh or takes two numbers or more";
    return out;
  }
  const std::size_t k = *axis;
  out.sweep = s.sweeps[k].path;
  std::vector<Sweep> other_sweeps = s.sweeps;
  other_sweeps.erase(other_sweeps.begin() + std::ptrdiff_t(k));

  // Runs grouped by the other settings, in grid order.
  std::vector<std::string> keys;
  std::map<std::string, std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < s.runs.size(); ++i) {
    const std::string key = others_key(s.runs[i], k);
    if (!groups.count(key)) keys.push_back(key);
    groups[key].push_back(i);
  }
  auto x_of = [&](const RunRecord& r) {
    if (out.x_is_tets) return r.tets > 0 ? double(r.tets) : NAN;
    return k < r.settings.size() ? as_number(r.settings[k]).value_or(NAN) : NAN;
  };
  std::vector<double> all_x;
  for (const RunRecord& r : s.runs) all_x.push_back(x_of(r));
  const bool x_log = wants_log(all_x);

  for (std::size_t q = 0; q < s.quantities.size(); ++q) {
    Plot p;
    p.x = out.x_is_tets ? PlotAxis{"mesh: number of tets", "", x_log}
                        : PlotAxis{s.sweeps[k].short_name(), scene_unit(s.sweeps[k]), x_log};
    p.y = PlotAxis{"|relative error| of " + s.quantities[q].name, "%"};
    p.title = fmt::format("{}: convergence of {} ({})", scene_name(s), s.quantities[q].name, reference_note(s));
    std::vector<double> all_y;
    for (const std::string& key : keys) {
      std::vector<std::size_t> runs = groups[key];
      std::stable_sort(runs.begin(), runs.end(), [&](std::size_t a, std::size_t b) { return x_of(s.runs[a]) < x_of(s.runs[b]); });
      const std::string label = other_sweeps.empty() ? "" : settings_label(other_sweeps, without(s.runs[runs[0]].settings, k));
      PlotSeries line(label, {}, {}, SeriesStyle::line_and_markers);
      for (std::size_t i : runs) {
        const RunRecord& r = s.runs[i];
        line.x.push_back(x_of(r));
        line.y.push_back(error_percent(r, q < r.errors.size() ? r.errors[q] : NAN));
        all_y.push_back(line.y.back());
      }
      p.series.push_back(std::move(line));
    }
    p.y.log = wants_log(all_y);
    // Many lines: their legend goes below the plot, which grows by a row per line so that the
    // plot area keeps its size and no curve is hidden.
    if (p.series.size() > kLegendInside) {
      p.legend_place = LegendPlace::below;
      p.height += kLegendRow * int(p.series.size());
    }
    out.panels.push_back(std::move(p));
  }
  return out;
}

StudyPlotFiles write_study_plots(const StudyResult& s, const fs::path& dir) {
  StudyPlotFiles out;
  // Plots are small and mostly flat colour: zlib's best level keeps them at a few tens of KB.
  constexpr int kCompression = 9;
  const fs::path pareto = dir / "pareto.png";
  write_png(render_plot(study_pareto_plot(s)), pareto, kCompression);
  out.files.push_back(pareto.string());

  const ConvergencePlots conv = study_convergence_plots(s);
  if (conv.panels.empty()) {
    out.notes.push_back(fmt::format("no convergence.png: {}", conv.why_none));
    return out;
  }
  std::vector<Image> panels;
  int width = 0, height = 0;
  for (const Plot& p : conv.panels) {
    panels.push_back(render_plot(p));
    width += panels.back().width();
    height = std::max(height, panels.back().height());
  }
  Image sheet(width, height);
  int x = 0;
  for (const Image& panel : panels) {
    sheet.blit(panel, x, 0);
    x += panel.width();
  }
  const fs::path convergence = dir / "convergence.png";
  write_png(sheet, convergence, kCompression);
  out.files.push_back(convergence.string());
  return out;
}

}  // namespace pliant::raster
