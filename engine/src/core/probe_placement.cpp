// Probe placement after a change of resolution (probe_placement.hpp).
#include "probe_placement.hpp"

#include <algorithm>
#include <cmath>

namespace pliant::detail {

template <class T>
void probe_rest_point(const SimBody<T>& body, const ProbeState& p, double X[3]) {
  const Level<T>& L = body.levels[std::size_t(p.level)];
  for (int k = 0; k < 3; ++k) X[k] = 0;
  for (int a = 0; a < 4; ++a)
    for (int k = 0; k < 3; ++k) X[k] += p.weights[std::size_t(a)] * double(L.X[k][std::size_t(L.tet[a][std::size_t(p.tet)])]);
}

template <class T>
void place_probe_by_scan(const SimBody<T>& body, const double X[3], ProbeState& p) {
  double best = -1e300, w[4];
  for (int l = int(body.levels.size()) - 1; l >= 0 && best < kProbeInside; --l) {
    const Level<T>& L = body.levels[std::size_t(l)];
    for (const Range& run : L.stepped_runs)
      for (std::size_t e = run.begin; e < run.end; ++e) {
        const double m = probe_weights(L, e, X, w);
        if (m > best) {
          best = m;
          p.level = l;
          p.tet = std::int32_t(e);
          for (int a = 0; a < 4; ++a) p.weights[std::size_t(a)] = w[a];
        }
      }
  }
  if (best < kProbeInside) {
    double sum = 0;
    for (double& x : p.weights) sum += (x = std::max(x, 0.0));
    for (double& x : p.weights) x /= sum;
  }
}

template <class T>
void make_probe_candidates(const SimBody<T>& body, const double X[3], ProbeCandidates& c) {
  c.tets.assign(body.levels.size(), {});
  double g_max = 0;  // 1/m: the largest weight gradient of any corner of any tet of the body
  double w[4];
  for (std::size_t l = 0; l < body.levels.size(); ++l) {
    const Level<T>& L = body.levels[l];
    for (std::size_t e = 0; e < L.tet_count; ++e) {
      if (probe_weights(L, e, X, w) >= kProbeCandidate) c.tets[l].push_back(std::int32_t(e));
      double g0[3] = {0, 0, 0};
      for (int a = 0; a < 3; ++a) {
        double n2 = 0;
        for (int k = 0; k < 3; ++k) {
          const double g = double(L.grad[3 * a + k][e]);
          n2 += g * g;
          g0[k] -= g;
        }
        g_max = std::max(g_max, std::sqrt(n2));
      }
      g_max = std::max(g_max, std::sqrt(g0[0] * g0[0] + g0[1] * g0[1] + g0[2] * g0[2]));
    }
  }
  for (int k = 0; k < 3; ++k) c.X[std::size_t(k)] = X[k];
  // Within reach each weight moves by less than half the margin between the two thresholds; the
  // other half covers rounding (about 1e-16 of the weights).
  c.reach = g_max > 0 ? 0.5 * (kProbeInside - kProbeCandidate) / g_max : 0.0;
}

template <class T>
bool place_probe_from_candidates(const SimBody<T>& body, const double X[3], ProbeState& p) {
  ProbeCandidates& c = p.candidates;
  const double d2 = (X[0] - c.X[0]) * (X[0] - c.X[0]) + (X[1] - c.X[1]) * (X[1] - c.X[1]) + (X[2] - c.X[2]) * (X[2] - c.X[2]);
  if (c.reach < 0 || c.tets.size() != body.levels.size() || !(std::sqrt(d2) <= c.reach)) make_probe_candidates(body, X, c);
  for (int l = int(body.levels.size()) - 1; l >= 0; --l) {
    const Level<T>& L = body.levels[std::size_t(l)];
    double best = -1e300, w[4], best_w[4] = {0, 0, 0, 0};
    std::int32_t chosen = -1;
    for (const std::int32_t e : c.tets[std::size_t(l)]) {
      if (!L.steps(std::size_t(e))) continue;
      const double m = probe_weights(L, std::size_t(e), X, w);
      if (m > best) {
        best = m;
        chosen = e;
        std::copy(w, w + 4, best_w);
      }
    }
    if (chosen >= 0 && best >= kProbeInside) {
      p.level = l;
      p.tet = chosen;
      for (int a = 0; a < 4; ++a) p.weights[std::size_t(a)] = best_w[a];
      return true;
    }
  }
  return false;
}

#define PLIANT_PROBE_PLACEMENT(T)                                                                 \
  template void probe_rest_point<T>(const SimBody<T>&, const ProbeState&, double[3]);            \
  template void place_probe_by_scan<T>(const SimBody<T>&, const double[3], ProbeState&);         \
  template void make_probe_candidates<T>(const SimBody<T>&, const double[3], ProbeCandidates&);  \
  template bool place_probe_from_candidates<T>(const SimBody<T>&, const double[3], ProbeState&);
PLIANT_PROBE_PLACEMENT(float)
PLIANT_PROBE_PLACEMENT(double)
#undef PLIANT_PROBE_PLACEMENT

}  // namespace pliant::detail
