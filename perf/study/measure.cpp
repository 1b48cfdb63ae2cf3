// One measured run: build the world, step it for the scene's duration (timing the steps only),
// sample what the quantities need, and reduce the samples to one value per quantity.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "pliant/error.hpp"
#include "pliant/run.hpp"
#include "pliant/perf/study.hpp"
#include "pliant/world.hpp"

namespace pliant::study {
namespace {

using Clock = std::chrono::steady_clock;

// Integral of the piecewise-linear signal over [a, b] (inside the sampled span).
double integrate(const std::vector<double>& t, const std::vector<double>& y, double a, double b) {
  double sum = 0;
  for (std::size_t i = 1; i < t.size(); ++i) {
    const double lo = std::max(a, t[i - 1]), hi = std::min(b, t[i]);
    if (hi <= lo) continue;
    const double h = t[i] - t[i - 1];
    auto at = [&](double s) { return h > 0 ? y[i - 1] + (y[i] - y[i - 1]) * (s - t[i - 1]) / h : y[i]; };
    sum += 0.5 * (hi - lo) * (at(lo) + at(hi));
  }
  return sum;
}

bool in_box(const Vec3d& p, const std::optional<std::array<Vec3d, 2>>& box) {
  if (!box) return true;
  for (int a = 0; a < 3; ++a)
    if (p[a] < (*box)[0][a] || p[a] > (*box)[1][a]) return false;
  return true;
}

// Slope of u against X (least squares) over the selected nodes: the mean engineering strain.
template <class T>
double strain_of(const Level<T>& L, int axis, const std::vector<std::size_t>& nodes) {
  double sx = 0, su = 0;
  for (auto n : nodes) {
    sx += double(L.X[axis][n]);
    su += double(L.x[axis][n]) - double(L.X[axis][n]);
  }
  const double mx = sx / double(nodes.size()), mu = su / double(nodes.size());
  double sxx = 0, sxu = 0;
  for (auto n : nodes) {
    const double dx = double(L.X[axis][n]) - mx, du = double(L.x[axis][n]) - double(L.X[axis][n]) - mu;
    sxx += dx * dx;
    sxu += dx * du;
  }
  return sxx > 0 ? sxu / sxx : kNaN;
}

template <class T>
double volume_change_of(const Level<T>& L) {
  double v0 = 0, dv = 0;
  for (std::size_t e = 0; e < L.tet_count; ++e) {
    const std::int32_t c[4] = {L.tet[0][e], L.tet[1][e], L.tet[2][e], L.tet[3][e]};
    auto vol = [&](const AlignedVector<T>* P) {
      double a[3], b[3], d[3];
      for (int k = 0; k < 3; ++k) {
        a[k] = double(P[k][c[1]]) - double(P[k][c[0]]);
        b[k] = double(P[k][c[2]]) - double(P[k][c[0]]);
        d[k] = double(P[k][c[3]]) - double(P[k][c[0]]);
      }
      return (a[0] * (b[1] * d[2] - b[2] * d[1]) - a[1] * (b[0] * d[2] - b[2] * d[0]) +
              a[2] * (b[0] * d[1] - b[1] * d[0])) / 6;
    };
    const double rest = vol(L.X), now = vol(L.x);
    v0 += rest;
    dv += now - rest;
  }
  return dv / v0;
}

// What one quantity records during a run.
class Observer {
 public:
  Observer(const MeasureDef& m, const SceneDef& scene, const World& world, double duration)
      : m_(m), duration_(duration) {
    if (is_probe_kind()) {
      for (std::size_t p = 0; p < world.probe_count(); ++p)
        if (world.probe_name(int(p)) == m.probe) probe_ = int(p);
      for (const ProbeDef& p : scene.probes)
        if (p.name == m.probe) rest_ = p.point;
    } else {
      body_ = m.body.empty() ? 0 : world.find_body(m.body);
      for (std::size_t n = 0; n < world.node_count(body_); ++n)
        if (in_box(world.node_rest_position(body_, n), m.region)) nodes_.push_back(n);
      if (m.from) {
        next_sample_ = *m.from;
        every_ = m.every > 0 ? m.every : std::max(duration - *m.from, 0.0) / 50;
      }
    }
  }

  bool is_probe_kind() const {
    return m_.kind == MeasureKind::probe_final || m_.kind == MeasureKind::probe_mean ||
           m_.kind == MeasureKind::probe_period || m_.kind == MeasureKind::probe_arrival ||
           m_.kind == MeasureKind::probe_rms;
  }

  // probe_rms: the displacement at the sample times from + k every (1 ms by default), linear
  // between the steps around each (runs of different steps are compared at the same times).
  static constexpr double kTrackEvery = 1e-3;  // s
  void track(const World& w) {
    const double t = w.time();
    const Vec3d x = w.probe_position(probe_);
    Vec3d u;
    for (std::size_t a = 0; a < 3; ++a) u[a] = x[a] - rest_[a];
    const double every = m_.every > 0 ? m_.every : kTrackEvery;
    const double from = m_.from.value_or(0.0);
    for (;;) {
      const double due = from + double(track_.size() / 3) * every;
      if (due > t + 1e-12 * every) break;
      // Between the last step (t_last_, u_last_) and this one; at or before the first, as it is.
      const double s = have_last_ && t > t_last_ ? std::clamp((due - t_last_) / (t - t_last_), 0.0, 1.0) : 1.0;
      for (std::size_t a = 0; a < 3; ++a) track_.push_back(have_last_ ? u_last_[a] + s * (u[a] - u_last_[a]) : u[a]);
    }
    t_last_ = t;
    u_last_ = u;
    have_last_ = true;
  }
  std::vector<double> take_track() { return std::move(track_); }

  void sample(const World& w) {
    if (m_.kind == MeasureKind::probe_rms) {
      track(w);
    } else if (is_probe_kind()) {
      t_.push_back(w.time());
      const Vec3d x = w.probe_position(probe_);
      if (m_.axis == kDisplacementLength) {  // |u| (m)
        double s = 0;
        for (std::size_t a = 0; a < 3; ++a) s += (x[a] - rest_[a]) * (x[a] - rest_[a]);
        y_.push_back(std::sqrt(s));
      } else {
        y_.push_back(x[std::size_t(m_.axis)] - rest_[std::size_t(m_.axis)]);
      }
    } else if (m_.from && w.time() + 1e-12 >= next_sample_) {
      body_values_.push_back(body_value(w));
      while (next_sample_ <= w.time() + 1e-12) next_sample_ += every_ > 0 ? every_ : 1e300;
    }
  }

  double finish(const World& w) {
    return m_.scale * raw(w);
  }

 private:
  double raw(const World& w) {
    switch (m_.kind) {
      case MeasureKind::probe_final: return y_.empty() ? kNaN : y_.back();
      case MeasureKind::probe_mean: {
        const auto [t, y] = window();
        if (m_.whole_periods) return analyse_oscillation(t, y).mean;
        if (t.size() < 2 || t.back() <= t.front()) return y.empty() ? kNaN : y.back();
        return integrate(t, y, t.front(), t.back()) / (t.back() - t.front());
      }
      case MeasureKind::probe_period: {
        const auto [t, y] = window();
        const double period = analyse_oscillation(t, y).period;
        if (m_.report == "frequency") return 1 / period;
        if (m_.report == "speed") return m_.distance / period;
        return period;
      }
      case MeasureKind::probe_rms: {  // until finish_study compares it: the RMS of its own track (m)
        double sum = 0;
        for (const double u : track_) sum += u * u;
        return track_.empty() ? kNaN : std::sqrt(sum / double(track_.size() / 3));
      }
      case MeasureKind::probe_arrival: {
        for (std::size_t i = 1; i < y_.size(); ++i) {
          const double a = (y_[i - 1] - m_.level) * (m_.level > 0 ? 1 : -1);
          const double b = (y_[i] - m_.level) * (m_.level > 0 ? 1 : -1);
          if (a < 0 && b >= 0) {
            const double time = t_[i - 1] + (t_[i] - t_[i - 1]) * a / (a - b) - m_.delay;
            return m_.report == "speed" ? m_.distance / time : time;
          }
        }
        return kNaN;
      }
      default: {
        if (!m_.from || body_values_.empty()) return body_value(w);
        double s = 0;
        for (double v : body_values_) s += v;
        return s / double(body_values_.size());
      }
    }
  }

  std::pair<std::vector<double>, std::vector<double>> window() const {
    if (!m_.from) return {t_, y_};
    std::vector<double> t, y;
    for (std::size_t i = 0; i < t_.size(); ++i)
      if (t_[i] + 1e-12 >= *m_.from) t.push_back(t_[i]), y.push_back(y_[i]);
    return {t, y};
  }

  double body_value(const World& w) const {
    if (w.precision() == Precision::float32) return body_value_of(w.level<float>(body_));
    return body_value_of(w.level<double>(body_));
  }
  template <class T>
  double body_value_of(const Level<T>& L) const {
    switch (m_.kind) {
      case MeasureKind::strain: return strain_of(L, m_.axis, nodes_);
      case MeasureKind::poisson_ratio: {
        double lat = 0;
        for (int a : m_.lateral) lat += strain_of(L, a, nodes_);
        lat /= double(m_.lateral.size());
        return -lat / strain_of(L, m_.axis, nodes_);
      }
      case MeasureKind::volume_change: return volume_change_of(L);
      default: return kNaN;
    }
  }

  MeasureDef m_;
  double duration_;
  int probe_ = -1;
  Vec3d rest_{};  // the probe's point (m)
  BodyId body_ = 0;
  std::vector<std::size_t> nodes_;
  std::vector<double> t_, y_, body_values_;
  std::vector<double> track_;  // probe_rms: x y z per sample (m)
  double t_last_ = 0;
  Vec3d u_last_{};
  bool have_last_ = false;
  double next_sample_ = 0, every_ = 0;
};

}  // namespace

std::vector<double> level_crossings(const std::vector<double>& t, const std::vector<double>& y, double level,
                                    double band) {
  std::vector<double> out;
  int state = 0;
  double pending = kNaN;
  for (std::size_t i = 0; i < y.size(); ++i) {
    const double b = y[i] - level;
    if (i > 0) {
      const double a = y[i - 1] - level;
      if ((a < 0 && b >= 0) || (a >= 0 && b < 0)) pending = a == b ? t[i] : t[i - 1] + (t[i] - t[i - 1]) * a / (a - b);
    }
    if (b > band && state != 1) {
      if (state == -1 && !std::isnan(pending)) out.push_back(pending);
      state = 1;
    } else if (b < -band && state != -1) {
      if (state == 1 && !std::isnan(pending)) out.push_back(pending);
      state = -1;
    }
  }
  return out;
}

Oscillation analyse_oscillation(const std::vector<double>& t, const std::vector<double>& y, double hysteresis) {
  Oscillation o;
  if (y.size() < 3) return o;
  const auto [lo, hi] = std::minmax_element(y.begin(), y.end());
  o.amplitude = 0.5 * (*hi - *lo);
  if (!(o.amplitude > 0)) return o;
  double mean = 0.5 * (*lo + *hi);
  for (int iteration = 0; iteration < 5; ++iteration) {
    const std::vector<double> c = level_crossings(t, y, mean, hysteresis * o.amplitude);
    if (c.size() < 3) return Oscillation{kNaN, kNaN, o.amplitude, 0};
    const int periods = int(c.size() - 1) / 2;
    const double t0 = c.front(), t1 = c[std::size_t(2 * periods)];
    o.period = (t1 - t0) / periods;
    o.periods = periods;
    mean = integrate(t, y, t0, t1) / (t1 - t0);
  }
  o.mean = mean;
  return o;
}

void check_measures(const std::vector<QuantityDef>& quantities, const SceneDef& scene, const std::string& source) {
  for (const QuantityDef& q : quantities) {
    const MeasureDef& m = q.measure;
    const bool probe_kind = m.kind == MeasureKind::probe_final || m.kind == MeasureKind::probe_mean ||
                            m.kind == MeasureKind::probe_period || m.kind == MeasureKind::probe_arrival ||
                            m.kind == MeasureKind::probe_rms;
    if (probe_kind) {
      std::string names;
      bool found = false;
      for (const ProbeDef& p : scene.probes) {
        found = found || p.name == m.probe;
        names += (names.empty() ? "" : ", ") + p.name;
      }
      if (!found)
        throw InputError(fmt::format("{}: quantity {}: the scene {} has no probe named \"{}\"; probes: {}", source,
                                     q.name, scene.source.string(), m.probe, names.empty() ? "none" : names));
    } else if (!m.body.empty()) {
      std::string names;
      bool found = false;
      for (const BodyDef& b : scene.bodies) {
        found = found || b.name == m.body;
        names += (names.empty() ? "" : ", ") + b.name;
      }
      if (!found)
        throw InputError(fmt::format("{}: quantity {}: the scene {} has no body named \"{}\"; bodies: {}", source,
                                     q.name, scene.source.string(), m.body, names));
    }
  }
}

RunRecord run_measured(const SceneDef& scene, const std::vector<QuantityDef>& quantities,
                       std::optional<int> threads) {
  RunRecord r;
  r.values.assign(quantities.size(), kNaN);
  const auto t_setup = Clock::now();
  RunOptions ro;
  ro.threads = threads;
  ro.write_files = false;
  std::optional<World> world;
  try {
    world.emplace(make_world(scene, ro));
  } catch (const InputError& e) {
    r.status = "invalid";
    r.message = e.what();
    return r;
  }
  World& w = *world;
  r.precision = to_string(w.precision());
  r.threads = w.threads();
  r.dt = w.dt();
  r.substeps = w.substeps();
  for (std::size_t b = 0; b < w.body_count(); ++b) {
    const int finest = w.level_count(BodyId(b)) - 1;  // the body's mesh (a multiresolution body's finest level)
    r.nodes += w.node_count(BodyId(b), finest);
    r.tets += w.tet_count(BodyId(b), finest);
    const std::string m = to_string(w.body_def(BodyId(b)).model);
    if (r.model.find(m) == std::string::npos) r.model += (r.model.empty() ? "" : "+") + m;
  }
  const double duration = scene.duration;
  std::vector<Observer> observers;
  for (const QuantityDef& q : quantities) {
    observers.emplace_back(q.measure, scene, w, duration);
    observers.back().sample(w);
  }
  r.setup_s = std::chrono::duration<double>(Clock::now() - t_setup).count();
  // As run_scene: the last step reaches or passes the duration.
  const std::int64_t total_steps = std::int64_t(std::ceil(duration / w.dt() - 1e-9));
  Clock::duration stepping{};
  try {
    for (std::int64_t i = 0; i < total_steps; ++i) {
      const auto a = Clock::now();
      w.step();
      stepping += Clock::now() - a;
      for (Observer& o : observers) o.sample(w);
    }
  } catch (const DivergenceError& e) {
    r.status = "diverged";
    r.message = e.what();
  }
  r.wall_s = std::chrono::duration<double>(stepping).count();
  r.steps = w.steps();
  r.tet_updates = w.tick_stats().tet_updates();
  r.simulated_time = w.time();
  r.tracks.assign(quantities.size(), {});
  if (r.status == "ok")
    for (std::size_t q = 0; q < observers.size(); ++q) {
      r.values[q] = observers[q].finish(w);
      if (quantities[q].measure.kind == MeasureKind::probe_rms) r.tracks[q] = observers[q].take_track();
    }
  return r;
}

}  // namespace pliant::study
