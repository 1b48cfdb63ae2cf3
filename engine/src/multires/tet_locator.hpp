// Point location in a tet mesh at rest, for the links between the levels of a hierarchy: which
// tet contains a point (or is nearest to it) and with which barycentric weights, and which node
// is nearest to a point. A uniform grid of buckets over the mesh's bounding box; each tet is
// listed in the buckets its bounding box touches. Built once per level (setup, not the step).
// Deterministic: ties go to the lower index.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "pliant/hierarchy.hpp"
#include "pliant/tet_mesh.hpp"

namespace pliant::detail {

class TetLocator {
 public:
  explicit TetLocator(const TetMesh& mesh);
  // The tet containing p (weights >= -1e-10 relative), else the nearest one (weights clamped).
  TetLink locate(const Vec3d& p) const;
  // Among the tets t with mask[t] != 0, one that contains p (the largest smallest weight, lowest
  // index on ties); tet = -1 if none does.
  TetLink containing(const Vec3d& p, const std::vector<std::uint8_t>& mask) const;
  // The same, else the nearest masked tet within `radius` (m) of p (by the distance from p to the
  // point of its clamped weights, in `outside`), with p's own weights there: slightly negative,
  // extrapolating the tet's linear field, so that affine motions (rigid ones among them) are
  // still reproduced exactly. tet = -1 if there is none.
  TetLink containing_or_near(const Vec3d& p, const std::vector<std::uint8_t>& mask, double radius) const;
  // The same answer, to the bit, given a hint: a tet that may contain p (-1: none known; a
  // multiresolution node's link to the coarser level is one). When p lies deeper than `radius`
  // inside it (and than the containment tolerance's reach, slack_), no other tet contains p or
  // comes within `radius` of it, so that tet answers if masked and none does otherwise, without a
  // search. This assumes that the mesh's tets do not overlap (a valid mesh: the hierarchy's levels
  // are Mesh_3's or Kuhn boxes; a folded mesh from a file would break it, and the coverage test
  // relied on it before the hint existed).
  TetLink containing_or_near(const Vec3d& p, const std::vector<std::uint8_t>& mask, double radius, std::int32_t hint) const;
  // Whether containing_or_near(p, mask, radius, hint) would find a tet (tet >= 0), without finding
  // which: the first masked tet that contains p or lies nearer than `radius` answers. (Coverage
  // asks only this, and most of the points it asks about lie in or next to a masked tet.)
  bool covers(const Vec3d& p, const std::vector<std::uint8_t>& mask, double radius, std::int32_t hint = -1) const;
  // Appends to `out` every tet that answers containing_or_near(p, mask, radius, hint) for some
  // mask, in the order it prefers them: for any mask its answer is the first masked tet of the list
  // (with weights(t, p)), none if none is, and covers() is whether one is. The tets containing p
  // within the tolerance first (largest smallest weight first, then lowest index), then the others
  // nearer than `radius` (smallest clamped distance first, then lowest index); a hint p lies deeper
  // than `radius` inside alone. ActivationState lists them once per node: a change then finds a
  // node's ghost source, or whether a stepped tet covers it, from masks alone, without a search.
  void candidates(const Vec3d& p, double radius, std::int32_t hint, std::vector<std::int32_t>& out) const;
  // Barycentric weights of p in tet t (sum 1, any sign).
  std::array<double, 4> weights(std::int32_t t, const Vec3d& p) const;
  // Appends (ascending, each once) the tets within `radius` (m) of p, as containing_or_near measures
  // it, other than those p lies deeper than `radius` inside: the tets whose coverage of p can
  // change without p's own tet changing.
  void near_surface(const Vec3d& p, double radius, std::vector<std::int32_t>& out) const;
  // Distance (m) from p to the nearest face of tet t, negative when p is outside it.
  double depth(std::int32_t t, const Vec3d& p) const;
  // f(data, bytes) for each of its arrays (World::touch_pages keeps them warm).
  template <class F>
  void for_each_array(F&& f) const {
    f(offsets_.data(), offsets_.size() * sizeof(offsets_[0]));
    f(items_.data(), items_.size() * sizeof(items_[0]));
    f(inverse_.data(), inverse_.size() * sizeof(inverse_[0]));
    f(box_.data(), box_.size() * sizeof(box_[0]));
  }

 private:
  // Whether p lies deeper than `radius` + slack_ inside tet `hint` (the hinted shortcut above).
  bool deep_inside(std::int32_t hint, const Vec3d& p, double radius) const {
    return hint >= 0 && !(radius < 0) && depth(hint, p) > radius + slack_;
  }
  using Cell = std::array<int, 3>;
  Cell cell_of(const Vec3d& p) const;
  // Distance (m) from p to the point of tet t its weights give, clamped to >= 0 and renormalised
  // (0 inside; an upper bound of the distance to the tet outside); those weights in *clamped.
  double clamped_distance(std::int32_t t, const Vec3d& p, std::array<double, 4>* clamped = nullptr) const;
  double clamped_distance(std::int32_t t, const Vec3d& p, std::array<double, 4> w, std::array<double, 4>* clamped = nullptr) const;  // w: weights(t, p)
  // f(t) for every tet listed in the buckets of the box of half-side `radius` around p (with
  // repeats: a tet is listed in every bucket its bounding box touches).
  template <class F>
  void each_tet_near(const Vec3d& p, double radius, F&& f) const;
  // The same until f returns true; returns whether it did.
  template <class F>
  bool any_tet_near(const Vec3d& p, double radius, F&& f) const;
  std::size_t bucket(const Cell& c) const { return (std::size_t(c[2]) * dims_[1] + std::size_t(c[1])) * dims_[0] + std::size_t(c[0]); }
  const TetMesh& mesh_;
  Vec3d lo_{}, size_{};
  std::array<int, 3> dims_{1, 1, 1};
  std::vector<std::int32_t> offsets_, items_;    // bucket -> tets (CSR)
  std::vector<std::array<double, 12>> inverse_;  // per tet: rows of Dm^-1 (9) and corner 0 (3)
  std::vector<std::array<double, 6>> box_;       // per tet: its bounding box, lo (3) and hi (3), m
  // m: how far outside a tet containing()'s tolerance reaches, at most (weights >= -tol: the tet
  // scaled by 1 + 4 tol about its centroid; 4 tol times the largest bounding-box diagonal).
  double slack_ = 0;
};

class NodeLocator {
 public:
  explicit NodeLocator(const TetMesh& mesh);
  std::int32_t nearest(const Vec3d& p) const;  // nearest node (lowest index on ties)
  // Appends to `out` the nodes inside the box [lo, hi] (inclusive), in bucket order.
  void in_box(const Vec3d& lo, const Vec3d& hi, std::vector<std::int32_t>& out) const;
  // The same, only the nodes n with keep[n] > 0.
  void in_box(const Vec3d& lo, const Vec3d& hi, const std::vector<std::int32_t>& keep, std::vector<std::int32_t>& out) const;
  template <class F>
  void for_each_array(F&& f) const {  // as TetLocator's
    f(offsets_.data(), offsets_.size() * sizeof(offsets_[0]));
    f(items_.data(), items_.size() * sizeof(items_[0]));
  }

 private:
  template <class Keep>
  void each_in_box(const Vec3d& lo, const Vec3d& hi, Keep&& keep, std::vector<std::int32_t>& out) const;
  const TetMesh& mesh_;
  Vec3d lo_{}, size_{};
  std::array<int, 3> dims_{1, 1, 1};
  std::vector<std::int32_t> offsets_, items_;
};

}  // namespace pliant::detail
