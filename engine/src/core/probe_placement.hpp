// Where a probe of a multiresolution body reads (its level, tet and barycentric weights), and
// where it reads again after a change of resolution (Simulation::relocate_probes).
//
// The rule (World::add_probe's): the finest level that steps a tet containing the probe's
// material point X (smallest barycentric weight at least kProbeInside), and in it the stepped tet
// whose smallest weight is largest (the first of equals, in tet order); where no stepped tet of
// any level contains X (the levels' meshes differ at a curved surface), the stepped tet nearest to
// containing it, its weights clamped to the tet.
//
// Why candidates: the rule read every stepped tet of the body at every change, 0.3 ms a change for
// two probes of a 196k-tet bar (frame_probe, 2026-11-29), more as the fine level grows. A tet
// whose smallest weight at X is below kProbeCandidate cannot contain a point within
// ProbeCandidates::reach of X (each weight is affine in the point, with the tet's rest gradient),
// so the rule gives the same choice, to the bit, from the tets of every level whose smallest
// weight at X is at least kProbeCandidate, found once (O(tets of the body)) and kept while the
// point stays within reach; where none of them is stepped and contains the point, the whole scan
// decides as before.
#pragma once
#include <cstddef>

#include "simulation.hpp"

namespace pliant::detail {

inline constexpr double kProbeInside = -1e-6;    // barycentric: a point on a face counts as inside
inline constexpr double kProbeCandidate = -1e-3;  // a tet this far outside is kept as a candidate

// The barycentric weights of X (body frame, at rest) in tet e of L, w_c = g_c . (X - X_0) for
// corners 1..3 and w_0 = 1 - their sum, and the smallest of them.
template <class T>
double probe_weights(const Level<T>& L, std::size_t e, const double X[3], double w[4]) {
  double d[3];
  const auto n0 = std::size_t(L.tet[0][e]);
  for (int k = 0; k < 3; ++k) d[k] = X[k] - double(L.X[k][n0]);
  w[0] = 1;
  for (int c = 0; c < 3; ++c) {
    w[c + 1] = 0;
    for (int k = 0; k < 3; ++k) w[c + 1] += double(L.grad[3 * c + k][e]) * d[k];
    w[0] -= w[c + 1];
  }
  double m = w[0];
  for (int c = 1; c < 4; ++c) m = m < w[c] ? m : w[c];
  return m;
}

// The probe's material point (body frame, at rest) from where it reads now.
template <class T>
void probe_rest_point(const SimBody<T>& body, const ProbeState& p, double X[3]);

// The rule, by scanning every stepped tet of every level.
template <class T>
void place_probe_by_scan(const SimBody<T>& body, const double X[3], ProbeState& p);

// The candidates of X (every tet of every level whose smallest weight at X is at least
// kProbeCandidate) and their reach.
template <class T>
void make_probe_candidates(const SimBody<T>& body, const double X[3], ProbeCandidates& c);

// The rule from p.candidates (made again first if X is beyond their reach): true when a stepped
// candidate contains X (the choice made, the same as place_probe_by_scan's), false when none does
// (nothing changed: the caller scans).
template <class T>
bool place_probe_from_candidates(const SimBody<T>& body, const double X[3], ProbeState& p);

}  // namespace pliant::detail
