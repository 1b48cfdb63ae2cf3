// EnergyMonitor: the "energy bounded" criterion shared by the stability matrix and the stress
// runs (definition in pliant/stability.hpp).
#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "pliant/kernels/node_passes.hpp"
#include "pliant/perf/stability.hpp"

namespace pliant::stability {
namespace {

template <class F>
void for_each_level(const World& w, F&& f) {
  for (std::size_t b = 0; b < w.body_count(); ++b)
    for (int l = 0; l < w.level_count(BodyId(b)); ++l) {
      if (w.precision() == Precision::float32)
        f(w.level<float>(BodyId(b), l));
      else
        f(w.level<double>(BodyId(b), l));
    }
}

}  // namespace

const char* to_string(Outcome o) {
  switch (o) {
    case Outcome::stable: return "stable";
    case Outcome::clamped: return "clamped";
    case Outcome::refused: return "refused";
    case Outcome::diverged: return "diverged";
  }
  return "?";
}

double body_mass(const World& w, BodyId body) {
  double total = 0;
  for (int l = 0; l < w.level_count(body); ++l) {
    if (w.precision() == Precision::float32) {
      for (float m : w.level<float>(body, l).mass) total += double(m);
    } else {
      for (double m : w.level<double>(body, l).mass) total += m;
    }
  }
  return total;
}

void EnergyMonitor::start(const World& w) {
  *this = EnergyMonitor{};
  const Energies e = w.energies();
  m0_ = e.kinetic + e.elastic;
  p0_ = e.potential;
  double mass = 0, diag2 = 0, strain_floor = 0;
  for_each_level(w, [&](const auto& L) {
    // Energy of a uniform strain at rounding-noise level (1e-4 in float, 1e-7 in double): below it
    // an energy ratio says nothing about stability. Over the stepped tets only: a multiresolution
    // body steps part of each level (all of a single level).
    using T = std::remove_cv_t<std::remove_reference_t<decltype(L.mass[0])>>;
    const double eps = sizeof(T) == 4 ? 1e-4 : 1e-7;
    double volume = 0;
    for (const Range& run : L.stepped_runs)
      for (std::size_t t = run.begin; t < run.end; ++t) volume += double(L.volume[t]);
    const double modulus = L.model == ForceModel::springs ? 3.0 * double(L.young) : double(L.lambda) + 2 * double(L.mu);
    strain_floor += 0.5 * modulus * eps * eps * volume;
    // Every node's position, so that the work of driven nodes is measured even when an adaptive
    // body changes which nodes are driven, ghosts or inactive (their count changes).
    std::vector<double> xs(3 * L.node_count), ms(L.node_count, 0.0);
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (std::size_t n = 0; n < L.node_count; ++n) {
      mass += double(L.mass[n]);
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], double(L.X[k][n]));
        hi[k] = std::max(hi[k], double(L.X[k][n]));
        xs[3 * n + std::size_t(k)] = double(L.x[k][n]);
      }
      if (L.state[n] == kNodeFixed) ms[n] = double(L.mass[n]);
    }
    diag2 = std::max(diag2, (hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                (hi[2] - lo[2]) * (hi[2] - lo[2]));
    last_x_.push_back(std::move(xs));
    last_m_.push_back(std::move(ms));
  });
  floor_ = 1e-9 * mass * 9.81 * std::sqrt(diag2) + strain_floor;
  kinetic_.push_back(e.kinetic);
  if (!std::isfinite(m0_) || !std::isfinite(p0_)) why_ = "non-finite initial energy";
}

void EnergyMonitor::after_step(const World& w) {
  std::size_t li = 0;
  const Vec3d g = w.gravity();
  const double dt = w.dt();
  double driven_k_old = 0, driven_k_new = 0;  // J, of the driven nodes' velocities with their last and new masses
  for_each_level(w, [&](const auto& L) {
    const std::vector<double>& xs = last_x_[li];
    std::vector<double>& ms = last_m_[li++];
    double power = 0;  // of gravity and loads on the free nodes (W)
    for (std::size_t n = 0; n < L.node_count; ++n) {
      const double m_new = L.state[n] == kNodeFixed ? double(L.mass[n]) : 0.0;
      if (ms[n] != m_new) {
        double v2 = 0;
        for (int k = 0; k < 3; ++k) v2 += double(L.v[k][n]) * double(L.v[k][n]);
        driven_k_old += 0.5 * ms[n] * v2;
        driven_k_new += 0.5 * m_new * v2;
        ms[n] = m_new;
      }
      if (L.state[n] == kNodeFree) {
        for (int k = 0; k < 3; ++k) {
          const double f = double(L.mass[n]) * g[k] + (L.external[k].empty() ? 0.0 : double(L.external[k][n]));
          power += f * double(L.v[k][n]);
        }
        continue;
      }
      // Fixed and prescribed nodes drive the body (ghosts: below; inactive nodes have no force).
      if (L.state[n] != kNodeFixed) continue;
      double dw = 0;
      for (int k = 0; k < 3; ++k) dw += double(L.f[k][n]) * (double(L.x[k][n]) - xs[3 * n + std::size_t(k)]);
      work_ += std::abs(dw);
    }
    load_work_ += dt * power;
  });
  // A multiresolution body: the forces on a ghost go to the coarser nodes it follows, with its
  // weights, and a fixed or prescribed one takes its share as part of its reaction without it
  // being in its f. The share that goes to driven nodes is work they do on the body: w f_g . dx_s
  // for each driven source s (the rest, handed to free nodes, is internal and not counted).
  std::size_t base = 0;
  for (std::size_t b = 0; b < w.body_count(); ++b) {
    const int levels = w.level_count(BodyId(b));
    for (int l = 0; l < levels; ++l) {
      auto ghosts = [&](const auto& L, auto tag) {
        using T = decltype(tag);
        for (std::size_t i = 0; i < L.ghosts.size(); ++i) {
          const auto gn = std::size_t(L.ghosts[i]);
          double dw = 0;
          for (auto e = L.ghost_offsets[i]; e < L.ghost_offsets[i + 1]; ++e) {
            const int sl = L.ghost_source_level[std::size_t(e)];
            const auto sn = std::size_t(L.ghost_source_node[std::size_t(e)]);
            const Level<T>& S = w.level<T>(BodyId(b), sl);
            if (S.state[sn] != kNodeFixed) continue;
            const std::vector<double>& sx = last_x_[base + std::size_t(sl)];
            for (int k = 0; k < 3; ++k)
              dw += L.ghost_weight[std::size_t(e)] * double(L.f[k][gn]) * (double(S.x[k][sn]) - sx[3 * sn + std::size_t(k)]);
          }
          work_ += std::abs(dw);
        }
      };
      if (w.precision() == Precision::float32)
        ghosts(w.level<float>(BodyId(b), l), float{});
      else
        ghosts(w.level<double>(BodyId(b), l), double{});
    }
    base += std::size_t(levels);
  }
  li = 0;
  for_each_level(w, [&](const auto& L) {
    std::vector<double>& xs = last_x_[li++];
    for (std::size_t n = 0; n < L.node_count; ++n)
      for (int k = 0; k < 3; ++k) xs[3 * n + std::size_t(k)] = double(L.x[k][n]);
  });
  // An adaptive body's split or merge moves mass between driven nodes and free ones (the lumped
  // masses follow the stepped tets): mass that leaves a pushed face takes the face's velocity,
  // and its kinetic energy, into the free body. The driven nodes gave that energy; the budget
  // counts it (their kinetic energy itself is only in S while they carry it). Zero when no mass
  // changes (every body but an adaptive one).
  if (driven_k_old > driven_k_new) work_ += driven_k_old - driven_k_new;
}

bool EnergyMonitor::sample(const World& w) {
  if (!why_.empty()) return false;
  const Energies e = w.energies();
  double k_nonfree = 0;
  for_each_level(w, [&](const auto& L) {
    for (std::size_t n = 0; n < L.node_count; ++n) {
      if (L.state[n] != kNodeFixed) continue;  // driven nodes (ghosts follow free ones)
      double v2 = 0;
      for (int k = 0; k < 3; ++k) v2 += double(L.v[k][n]) * double(L.v[k][n]);
      k_nonfree += 0.5 * double(L.mass[n]) * v2;
    }
  });
  const double m = e.kinetic + e.elastic;
  if (!std::isfinite(m) || !std::isfinite(e.potential)) {
    why_ = fmt::format("non-finite energy (kinetic {}, elastic {}, potential {}) without a DivergenceError",
                       e.kinetic, e.elastic, e.potential);
    return false;
  }
  // The energy given by gravity and loads: the change of their potential, or their work from
  // the velocities, whichever is larger. The two agree (x_{n+1} - x_n = dt v_{n+1}) unless float
  // positions stagnate: with a tiny step, dt v below half the float spacing of the coordinates
  // (3.7e-9 m at 0.1 m), x + dt v rounds back to x, the velocities grow and the positions do not
  // follow, so the potential misses the energy the velocities received (docs/stress.md).
  const double given = std::max(std::abs(e.potential - p0_), std::abs(load_work_));
  const double scale = m0_ + given + work_ + k_nonfree + floor_;
  last_scale_ = scale;
  kinetic_.push_back(e.kinetic);
  const double ratio = m / scale;
  peak_ratio_ = std::max(peak_ratio_, ratio);
  if (ratio > kBoundFactor) {
    why_ = fmt::format(
        "energy unbounded: kinetic + elastic = {:.4g} J > {} x (initial {:.4g} J + |potential change| or |load work| {:.4g} J + "
        "work of driven nodes {:.4g} J)",
        m, kBoundFactor, m0_, given, work_ + k_nonfree);
    return false;
  }
  return true;
}

bool EnergyMonitor::finish() {
  if (!why_.empty()) return false;
  const std::size_t n = kinetic_.size();
  if (n < 4) return true;
  double first = 0, second = 0;
  for (std::size_t i = 0; i < n / 2; ++i) first = std::max(first, kinetic_[i]);
  for (std::size_t i = n / 2; i < n; ++i) second = std::max(second, kinetic_[i]);
  growth_ = first > 0 ? second / first : 0;
  if (second > kGrowthFactor * first + last_scale_) {
    why_ = fmt::format("kinetic energy grows: max {:.4g} J over the second half vs {:.4g} J over the first", second,
                       first);
    return false;
  }
  return true;
}

}  // namespace pliant::stability
