// TetLocator and NodeLocator (tet_locator.hpp): uniform bucket grids over a mesh at rest.
#include "tet_locator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "pliant/kernels/element_forces.hpp"

namespace pliant::detail {
namespace {

constexpr double kInsideTolerance = 1e-10;  // barycentric weight: on a face counts as inside
constexpr std::size_t kMaxBuckets = std::size_t(1) << 22;

// A grid of about `items` buckets over [lo, hi] (cubic buckets, at least one per axis).
void size_grid(const Vec3d& lo, const Vec3d& hi, std::size_t items, Vec3d& size, std::array<int, 3>& dims) {
  const double ext[3] = {std::max(hi[0] - lo[0], 1e-300), std::max(hi[1] - lo[1], 1e-300), std::max(hi[2] - lo[2], 1e-300)};
  const double target = double(std::clamp<std::size_t>(items, 1, kMaxBuckets));
  const double h = std::cbrt(ext[0] * ext[1] * ext[2] / target);
  for (int k = 0; k < 3; ++k) {
    dims[k] = std::clamp(int(std::ceil(ext[k] / std::max(h, 1e-300))), 1, 1 << 10);
    size[k] = ext[k] / dims[k];
  }
}

void bounds(const TetMesh& m, Vec3d& lo, Vec3d& hi) {
  lo = {1e300, 1e300, 1e300};
  hi = {-1e300, -1e300, -1e300};
  for (std::size_t i = 0; i < m.node_count(); ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], m.points[3 * i + k]);
      hi[k] = std::max(hi[k], m.points[3 * i + k]);
    }
}

std::array<int, 3> cell(const Vec3d& p, const Vec3d& lo, const Vec3d& size, const std::array<int, 3>& dims) {
  std::array<int, 3> c{};
  for (int k = 0; k < 3; ++k) {
    const double f = (p[k] - lo[k]) / size[k];
    c[k] = std::isfinite(f) ? int(std::clamp(std::floor(f), 0.0, double(dims[k] - 1))) : 0;
  }
  return c;
}

// Calls visit(bucket index) for the buckets at Chebyshev distance exactly `s` from c.
template <class F>
void shell(const std::array<int, 3>& c, int s, const std::array<int, 3>& dims, F&& visit) {
  for (int z = c[2] - s; z <= c[2] + s; ++z) {
    if (z < 0 || z >= dims[2]) continue;
    for (int y = c[1] - s; y <= c[1] + s; ++y) {
      if (y < 0 || y >= dims[1]) continue;
      const bool face = z == c[2] - s || z == c[2] + s || y == c[1] - s || y == c[1] + s;
      for (int x = c[0] - s; x <= c[0] + s; x += (face || s == 0) ? 1 : 2 * s) {
        if (x >= 0 && x < dims[0]) visit((std::size_t(z) * std::size_t(dims[1]) + std::size_t(y)) * std::size_t(dims[0]) + std::size_t(x));
        if (s == 0) break;
      }
    }
  }
}

int max_shell(const std::array<int, 3>& dims) { return std::max({dims[0], dims[1], dims[2]}); }

}  // namespace

TetLocator::TetLocator(const TetMesh& mesh) : mesh_(mesh) {
  Vec3d hi;
  bounds(mesh, lo_, hi);
  size_grid(lo_, hi, mesh.tet_count(), size_, dims_);
  const std::size_t nb = std::size_t(dims_[0]) * std::size_t(dims_[1]) * std::size_t(dims_[2]);
  inverse_.resize(mesh.tet_count());
  box_.resize(mesh.tet_count());
  std::vector<std::array<Cell, 2>> range(mesh.tet_count());
  offsets_.assign(nb + 1, 0);
  for (std::size_t t = 0; t < mesh.tet_count(); ++t) {
    double p[4][3];
    Vec3d a{1e300, 1e300, 1e300}, b{-1e300, -1e300, -1e300};
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 3; ++k) {
        p[c][k] = mesh.points[3 * std::size_t(mesh.tets[t][std::size_t(c)]) + std::size_t(k)];
        a[k] = std::min(a[k], p[c][k]);
        b[k] = std::max(b[k], p[c][k]);
      }
    double volume;
    auto& inv = inverse_[t];
    tet_rest_geometry(p[0], p[1], p[2], p[3], &volume, inv.data());
    for (int k = 0; k < 3; ++k) inv[9 + std::size_t(k)] = p[0][k];
    box_[t] = {a[0], a[1], a[2], b[0], b[1], b[2]};
    slack_ = std::max(slack_, 4 * kInsideTolerance * std::hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]));
    range[t] = {cell_of(a), cell_of(b)};
    for (int z = range[t][0][2]; z <= range[t][1][2]; ++z)
      for (int y = range[t][0][1]; y <= range[t][1][1]; ++y)
        for (int x = range[t][0][0]; x <= range[t][1][0]; ++x) ++offsets_[bucket({x, y, z}) + 1];
  }
  for (std::size_t i = 0; i < nb; ++i) offsets_[i + 1] += offsets_[i];
  items_.resize(std::size_t(offsets_[nb]));
  std::vector<std::int32_t> cursor(offsets_.begin(), offsets_.end() - 1);
  for (std::size_t t = 0; t < mesh.tet_count(); ++t)
    for (int z = range[t][0][2]; z <= range[t][1][2]; ++z)
      for (int y = range[t][0][1]; y <= range[t][1][1]; ++y)
        for (int x = range[t][0][0]; x <= range[t][1][0]; ++x)
          items_[std::size_t(cursor[bucket({x, y, z})]++)] = std::int32_t(t);
}

TetLocator::Cell TetLocator::cell_of(const Vec3d& p) const { return cell(p, lo_, size_, dims_); }

std::array<double, 4> TetLocator::weights(std::int32_t t, const Vec3d& p) const {
  const auto& g = inverse_[std::size_t(t)];
  const double d[3] = {p[0] - g[9], p[1] - g[10], p[2] - g[11]};
  std::array<double, 4> w{};
  w[0] = 1;
  for (int a = 0; a < 3; ++a) {
    w[std::size_t(a) + 1] = g[3 * std::size_t(a)] * d[0] + g[3 * std::size_t(a) + 1] * d[1] + g[3 * std::size_t(a) + 2] * d[2];
    w[0] -= w[std::size_t(a) + 1];
  }
  return w;
}

double TetLocator::depth(std::int32_t t, const Vec3d& p) const {
  // Weight k is the distance to face k over the altitude onto it, and its gradient's norm is one
  // over that altitude: the distance to face k is w_k / |grad w_k| (negative outside that face).
  const auto& g = inverse_[std::size_t(t)];
  const std::array<double, 4> w = weights(t, p);
  double grad0[3] = {0, 0, 0};
  double d = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    const double* r = &g[3 * std::size_t(a)];
    d = std::min(d, w[std::size_t(a) + 1] / std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]));
    for (int k = 0; k < 3; ++k) grad0[k] -= r[k];
  }
  return std::min(d, w[0] / std::sqrt(grad0[0] * grad0[0] + grad0[1] * grad0[1] + grad0[2] * grad0[2]));
}

TetLink TetLocator::locate(const Vec3d& p) const {
  TetLink best;
  const Cell c = cell_of(p);
  // Inside: a tet whose bounding box holds p is listed in p's bucket.
  double best_min = -std::numeric_limits<double>::infinity();
  for (std::int32_t i = offsets_[bucket(c)]; i < offsets_[bucket(c) + 1]; ++i) {
    const std::int32_t t = items_[std::size_t(i)];
    const auto w = weights(t, p);
    const double m = std::min({w[0], w[1], w[2], w[3]});
    if (m > best_min || (m == best_min && t < best.tet)) {
      best_min = m;
      best.tet = t;
      best.weights = w;
    }
  }
  if (best.tet >= 0 && best_min >= -kInsideTolerance) return best;

  // Outside every tet: the nearest by the distance to the point of clamped weights, over growing
  // shells of buckets until no closer bucket can remain.
  best = TetLink{};
  double best_d = std::numeric_limits<double>::infinity();
  const double step = std::min({size_[0], size_[1], size_[2]});
  for (int s = 0; s <= max_shell(dims_); ++s) {
    if (best.tet >= 0 && double(s - 1) * step > best_d) break;
    shell(c, s, dims_, [&](std::size_t b) {
      for (std::int32_t i = offsets_[b]; i < offsets_[b + 1]; ++i) {
        const std::int32_t t = items_[std::size_t(i)];
        std::array<double, 4> w;
        const double d = clamped_distance(t, p, &w);
        if (d < best_d || (d == best_d && t < best.tet)) {
          best_d = d;
          best.tet = t;
          best.weights = w;
        }
      }
    });
  }
  best.outside = best_d;
  return best;
}

TetLink TetLocator::containing(const Vec3d& p, const std::vector<std::uint8_t>& mask) const {
  TetLink best;
  const Cell c = cell_of(p);
  double best_min = -kInsideTolerance;
  for (std::int32_t i = offsets_[bucket(c)]; i < offsets_[bucket(c) + 1]; ++i) {
    const std::int32_t t = items_[std::size_t(i)];
    if (!mask[std::size_t(t)]) continue;
    const auto w = weights(t, p);
    const double m = std::min({w[0], w[1], w[2], w[3]});
    if (m > best_min || (m == best_min && best.tet >= 0 && t < best.tet) || (m >= best_min && best.tet < 0)) {
      best_min = m;
      best.tet = t;
      best.weights = w;
    }
  }
  return best;
}

double TetLocator::clamped_distance(std::int32_t t, const Vec3d& p, std::array<double, 4>* clamped) const {
  return clamped_distance(t, p, weights(t, p), clamped);
}

double TetLocator::clamped_distance(std::int32_t t, const Vec3d& p, std::array<double, 4> w, std::array<double, 4>* clamped) const {
  double sum = 0;
  for (double& v : w) sum += (v = std::max(v, 0.0));
  for (double& v : w) v /= sum;
  Vec3d q{0, 0, 0};
  for (int c = 0; c < 4; ++c)
    for (int d = 0; d < 3; ++d) q[std::size_t(d)] += w[std::size_t(c)] * mesh_.points[3 * std::size_t(mesh_.tets[std::size_t(t)][std::size_t(c)]) + std::size_t(d)];
  if (clamped) *clamped = w;
  return std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]);
}

template <class F>
bool TetLocator::any_tet_near(const Vec3d& p, double radius, F&& f) const {
  const Vec3d lo{p[0] - radius, p[1] - radius, p[2] - radius}, hi{p[0] + radius, p[1] + radius, p[2] + radius};
  const Cell a = cell_of(lo), b = cell_of(hi);
  for (int z = a[2]; z <= b[2]; ++z)
    for (int y = a[1]; y <= b[1]; ++y)
      for (int x = a[0]; x <= b[0]; ++x) {
        const std::size_t k = bucket({x, y, z});
        for (std::int32_t i = offsets_[k]; i < offsets_[k + 1]; ++i)
          if (f(items_[std::size_t(i)])) return true;
      }
  return false;
}

template <class F>
void TetLocator::each_tet_near(const Vec3d& p, double radius, F&& f) const {
  any_tet_near(p, radius, [&](std::int32_t t) {
    f(t);
    return false;
  });
}

void TetLocator::near_surface(const Vec3d& p, double radius, std::vector<std::int32_t>& out) const {
  const std::size_t first = out.size();
  each_tet_near(p, radius, [&](std::int32_t t) {
    if (depth(t, p) > radius) return;  // deep inside t
    if (clamped_distance(t, p) <= radius) out.push_back(t);
  });
  std::sort(out.begin() + std::ptrdiff_t(first), out.end());
  out.erase(std::unique(out.begin() + std::ptrdiff_t(first), out.end()), out.end());
}

TetLink TetLocator::containing_or_near(const Vec3d& p, const std::vector<std::uint8_t>& mask, double radius) const {
  TetLink best = containing(p, mask);
  if (best.tet >= 0 || !(radius > 0)) return best;
  double best_d = radius;
  each_tet_near(p, radius, [&](std::int32_t t) {
    if (!mask[std::size_t(t)]) return;
    // The distance to the tet's bounding box is at most its distance, which is at most
    // clamped_distance: a tet whose box is clearly farther than the best so far cannot win (the
    // margin covers the rounding of the two, so the answer is the same tet, to the bit). Most tets
    // of the search box are skipped this way (a change's node evaluations spent most of their time
    // in clamped_distance: about 2 us per node on the 50k-tet organ).
    const auto& bx = box_[std::size_t(t)];
    double gap2 = 0;
    for (std::size_t d = 0; d < 3; ++d) {
      const double g = std::max({bx[d] - p[d], 0.0, p[d] - bx[3 + d]});
      gap2 += g * g;
    }
    const double bound = best_d * (1 + 1e-9);
    if (gap2 > bound * bound) return;
    const double dist = clamped_distance(t, p);
    if (dist < best_d || (dist == best_d && best.tet >= 0 && t < best.tet)) {
      best_d = dist;
      best.tet = t;
      best.weights = weights(t, p);  // extrapolated, not clamped: still exact for affine motions
      best.outside = dist;
    }
  });
  return best;
}

TetLink TetLocator::containing_or_near(const Vec3d& p, const std::vector<std::uint8_t>& mask, double radius, std::int32_t hint) const {
  if (!deep_inside(hint, p, radius)) return containing_or_near(p, mask, radius);
  // containing(p, mask) finds the hint (no other tet contains p, even within the tolerance: see
  // slack_) with these weights, or nothing; then no masked tet is within `radius` (every other
  // tet is farther than p's depth).
  TetLink link;
  if (mask[std::size_t(hint)]) {
    link.tet = hint;
    link.weights = weights(hint, p);
  }
  return link;
}

bool TetLocator::covers(const Vec3d& p, const std::vector<std::uint8_t>& mask, double radius, std::int32_t hint) const {
  if (deep_inside(hint, p, radius)) return mask[std::size_t(hint)] != 0;
  // containing_or_near finds a tet when containing(p, mask) does (a masked tet of p's bucket with
  // every weight at least -kInsideTolerance), else when a masked tet's clamped distance is below
  // `radius` (strictly: its search starts at best = radius, and its bounding-box test never skips
  // such a tet). Each test here is the same, and the first tet that passes answers.
  const Cell c = cell_of(p);
  for (std::int32_t i = offsets_[bucket(c)]; i < offsets_[bucket(c) + 1]; ++i) {
    const std::int32_t t = items_[std::size_t(i)];
    if (!mask[std::size_t(t)]) continue;
    const auto w = weights(t, p);
    if (std::min({w[0], w[1], w[2], w[3]}) >= -kInsideTolerance) return true;
  }
  if (!(radius > 0)) return false;
  const double bound = radius * (1 + 1e-9);
  return any_tet_near(p, radius, [&](std::int32_t t) {
    if (!mask[std::size_t(t)]) return false;
    const auto& bx = box_[std::size_t(t)];
    double gap2 = 0;
    for (std::size_t d = 0; d < 3; ++d) {
      const double g = std::max({bx[d] - p[d], 0.0, p[d] - bx[3 + d]});
      gap2 += g * g;
    }
    if (gap2 > bound * bound) return false;
    return clamped_distance(t, p) < radius;
  });
}

void TetLocator::candidates(const Vec3d& p, double radius, std::int32_t hint, std::vector<std::int32_t>& out) const {
  if (deep_inside(hint, p, radius)) {  // no other tet contains p or comes within radius
    out.push_back(hint);
    return;
  }
  // containing(): the tets of p's bucket whose smallest weight is >= -kInsideTolerance, by that
  // weight (largest first; equal weights by index), as its comparisons rank them.
  std::vector<std::pair<double, std::int32_t>> inside, near;
  const Cell c = cell_of(p);
  for (std::int32_t i = offsets_[bucket(c)]; i < offsets_[bucket(c) + 1]; ++i) {
    const std::int32_t t = items_[std::size_t(i)];
    const auto w = weights(t, p);
    const double m = std::min({w[0], w[1], w[2], w[3]});
    if (m >= -kInsideTolerance) inside.push_back({-m, t});
  }
  std::sort(inside.begin(), inside.end());
  // The near search: every tet with a clamped distance below radius (its search starts at best =
  // radius and never skips such a tet), by distance, equal distances by index; those found above
  // come first already (when one is masked, the near search does not run).
  if (radius > 0)
    each_tet_near(p, radius, [&](std::int32_t t) {
      const double d = clamped_distance(t, p);
      if (d < radius) near.push_back({d, t});
    });
  std::sort(near.begin(), near.end());
  near.erase(std::unique(near.begin(), near.end()), near.end());  // a tet is listed in every bucket it touches
  for (const auto& e : inside) out.push_back(e.second);
  for (const auto& e : near)
    if (std::none_of(inside.begin(), inside.end(), [&](const auto& x) { return x.second == e.second; })) out.push_back(e.second);
}

NodeLocator::NodeLocator(const TetMesh& mesh) : mesh_(mesh) {
  Vec3d hi;
  bounds(mesh, lo_, hi);
  size_grid(lo_, hi, mesh.node_count(), size_, dims_);
  const std::size_t nb = std::size_t(dims_[0]) * std::size_t(dims_[1]) * std::size_t(dims_[2]);
  offsets_.assign(nb + 1, 0);
  std::vector<std::size_t> b(mesh.node_count());
  for (std::size_t i = 0; i < mesh.node_count(); ++i) {
    const auto c = cell(mesh.point(i), lo_, size_, dims_);
    b[i] = (std::size_t(c[2]) * std::size_t(dims_[1]) + std::size_t(c[1])) * std::size_t(dims_[0]) + std::size_t(c[0]);
    ++offsets_[b[i] + 1];
  }
  for (std::size_t i = 0; i < nb; ++i) offsets_[i + 1] += offsets_[i];
  items_.resize(mesh.node_count());
  std::vector<std::int32_t> cursor(offsets_.begin(), offsets_.end() - 1);
  for (std::size_t i = 0; i < mesh.node_count(); ++i) items_[std::size_t(cursor[b[i]]++)] = std::int32_t(i);
}

template <class Keep>
void NodeLocator::each_in_box(const Vec3d& lo, const Vec3d& hi, Keep&& keep, std::vector<std::int32_t>& out) const {
  const auto a = cell(lo, lo_, size_, dims_), b = cell(hi, lo_, size_, dims_);
  for (int z = a[2]; z <= b[2]; ++z)
    for (int y = a[1]; y <= b[1]; ++y)
      for (int x = a[0]; x <= b[0]; ++x) {
        const std::size_t k = (std::size_t(z) * std::size_t(dims_[1]) + std::size_t(y)) * std::size_t(dims_[0]) + std::size_t(x);
        for (std::int32_t i = offsets_[k]; i < offsets_[k + 1]; ++i) {
          const std::int32_t n = items_[std::size_t(i)];
          if (!keep(n)) continue;
          const Vec3d q = mesh_.point(std::size_t(n));
          if (q[0] >= lo[0] && q[0] <= hi[0] && q[1] >= lo[1] && q[1] <= hi[1] && q[2] >= lo[2] && q[2] <= hi[2])
            out.push_back(n);
        }
      }
}

void NodeLocator::in_box(const Vec3d& lo, const Vec3d& hi, std::vector<std::int32_t>& out) const {
  each_in_box(lo, hi, [](std::int32_t) { return true; }, out);
}

void NodeLocator::in_box(const Vec3d& lo, const Vec3d& hi, const std::vector<std::int32_t>& keep, std::vector<std::int32_t>& out) const {
  each_in_box(lo, hi, [&](std::int32_t n) { return keep[std::size_t(n)] > 0; }, out);
}

std::int32_t NodeLocator::nearest(const Vec3d& p) const {
  const auto c = cell(p, lo_, size_, dims_);
  std::int32_t best = -1;
  double best_d2 = std::numeric_limits<double>::infinity();
  const double step = std::min({size_[0], size_[1], size_[2]});
  for (int s = 0; s <= max_shell(dims_); ++s) {
    if (best >= 0 && double(s - 1) * step > std::sqrt(best_d2)) break;
    shell(c, s, dims_, [&](std::size_t b) {
      for (std::int32_t i = offsets_[b]; i < offsets_[b + 1]; ++i) {
        const std::int32_t n = items_[std::size_t(i)];
        const Vec3d q = mesh_.point(std::size_t(n));
        const double d2 = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]);
        if (d2 < best_d2 || (d2 == best_d2 && n < best)) {
          best_d2 = d2;
          best = n;
        }
      }
    });
  }
  return best;
}

}  // namespace pliant::detail
