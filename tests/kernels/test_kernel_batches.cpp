// The element passes run W tets per vector (one per lane) and the step fuses the gather with
// the integrator. Neither may change a result: a tet's corner forces and rotation must be the
// same bits whether it is computed alone, in a full batch or in a partial one at the end of an
// odd-sized range (the thread split decides which), and the fused node pass must give the bits
// of gather then integrate.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <limits>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "../support/same_bits.hpp"
#include "../support/element_arrays.hpp"
#include "pliant/kernels/element_forces.hpp"
#include "pliant/kernels/node_passes.hpp"
// White box: the scalar rotation iteration and its batched twin (kernels/src/, private).
#include "../../kernels/src/tet_batch.hpp"

namespace pliant {
namespace {

enum class Model { linear, stvk, corotational, springs };

// A strip of tets sharing nodes: tet t has nodes t, t+1, t+2, t+3 of a perturbed helix, so
// that gathers hit shared nodes; positions are deformed and rotated, some tets strongly (so
// that the rotation iteration takes different numbers of steps in different lanes), and
// velocities are random (damping terms).
template <class T>
struct Strip : test::ElementArrays<T> {
  using test::ElementArrays<T>::X, test::ElementArrays<T>::x, test::ElementArrays<T>::v, test::ElementArrays<T>::volume,
      test::ElementArrays<T>::grad, test::ElementArrays<T>::rot, test::ElementArrays<T>::cf, test::ElementArrays<T>::tet,
      test::ElementArrays<T>::c;
  std::size_t nt, nn;

  Strip(std::size_t tets, unsigned seed) : nt(tets), nn(tets + 3) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<double> P(3 * nn);
    for (std::size_t i = 0; i < nn; ++i) {
      const double a = 2.1 * double(i);
      P[3 * i] = 0.1 * std::cos(a) + 0.01 * u(rng);
      P[3 * i + 1] = 0.1 * std::sin(a) + 0.01 * u(rng);
      P[3 * i + 2] = 0.03 * double(i) + 0.01 * u(rng);
    }
    for (int k = 0; k < 3; ++k) {
      X[k].resize(nn);
      x[k].resize(nn);
      v[k].resize(nn);
    }
    for (std::size_t i = 0; i < nn; ++i) {
      // Rigid rotation about z by an angle that grows along the strip, plus a strain.
      const double ang = 0.002 * double(i * i % 997), s = std::sin(ang), co = std::cos(ang);
      const double d = i % 7 == 0 ? 0.2 : 0.01;
      for (int k = 0; k < 3; ++k) X[k][i] = T(P[3 * i + k]);
      x[0][i] = T(co * P[3 * i] - s * P[3 * i + 1] + d * 0.1 * u(rng));
      x[1][i] = T(s * P[3 * i] + co * P[3 * i + 1] + d * 0.1 * u(rng));
      x[2][i] = T(P[3 * i + 2] + d * 0.1 * u(rng));
      for (int k = 0; k < 3; ++k) v[k][i] = T(0.5 * u(rng));
    }
    this->size_tets(nt);
    for (std::size_t t = 0; t < nt; ++t) {
      std::int32_t n[4] = {std::int32_t(t), std::int32_t(t + 1), std::int32_t(t + 2), std::int32_t(t + 3)};
      double p[4][3];
      for (int a = 0; a < 4; ++a)
        for (int k = 0; k < 3; ++k) p[a][k] = P[3 * std::size_t(n[a]) + k];
      double vol, g[9];
      if (!tet_rest_geometry(p[0], p[1], p[2], p[3], &vol, g)) {
        std::swap(n[2], n[3]);
        for (int k = 0; k < 3; ++k) std::swap(p[2][k], p[3][k]);
        EXPECT_TRUE(tet_rest_geometry(p[0], p[1], p[2], p[3], &vol, g));
      }
      for (int a = 0; a < 4; ++a) tet[a][t] = n[a];
      volume[t] = T(vol);
      for (int q = 0; q < 9; ++q) grad[q][t] = T(g[q]);
      // Warm starts: identity for most, a random unit quaternion for some.
      double q[4] = {1, 0, 0, 0};
      if (t % 5 == 0) {
        double nq = 0;
        for (double& e : q) {
          e = u(rng);
          nq += e * e;
        }
        for (double& e : q) e /= std::sqrt(nq);
      }
      for (int k = 0; k < 4; ++k) rot[k][t] = T(q[k]);
    }
    this->wire();
  }

  // The interleaved copies of x and (with velocities) v (ElementContext::xp, vp) the step's pack
  // writes; the passes read them.
  std::vector<T> xp, vp;
  void pack(bool velocities = false) {
    xp.assign(4 * nn, T(-7));
    PackContext<T> pc;
    for (int k = 0; k < 3; ++k) pc.x[k] = x[k].data();
    pc.xp = xp.data();
    if (velocities) {
      vp.assign(4 * nn, T(-7));
      for (int k = 0; k < 3; ++k) pc.v[k] = v[k].data();
      pc.vp = vp.data();
    }
    pack_positions(pc, Range{0, nn / 2});
    pack_positions(pc, Range{nn / 2, nn});
    c.xp = xp.data();
    c.vp = velocities ? vp.data() : nullptr;
  }

  // Viscosities phi, psi apart (40, 25 Pa s), or (rayleigh) beta = 1e-4 s times the Lamé moduli
  // with ElementContext::rayleigh set, as the engine sets it: the passes' one-Hooke-law path.
  void damp(bool rayleigh = false) {
    c.bulk_viscosity = T(40);
    c.shear_viscosity = T(25);
    c.spring_damping = T(1e-4);
    if (rayleigh) {
      c.bulk_viscosity = T(1e-4) * c.lambda;
      c.shear_viscosity = T(1e-4) * c.mu;
      c.rayleigh = rayleigh_factor(c.lambda, c.mu, c.bulk_viscosity, c.shear_viscosity);
      EXPECT_NE(c.rayleigh, T(0));
    }
  }
  enum class Damp { none, viscous, rayleigh };
  void damp(Damp d) {
    if (d != Damp::none) damp(d == Damp::rayleigh);
  }

  void forces(Model m, Range r) {
    switch (m) {
      case Model::linear: element_forces_linear(c, r); break;
      case Model::stvk: element_forces_stvk(c, r); break;
      case Model::corotational: element_forces_corotational(c, r); break;
      case Model::springs: element_forces_springs(c, r); break;
    }
  }

  void forces_listed(Model m, const std::vector<std::int32_t>& ids, Range r) {
    switch (m) {
      case Model::linear: element_forces_linear_listed(c, ids.data(), r); break;
      case Model::stvk: element_forces_stvk_listed(c, ids.data(), r); break;
      case Model::corotational: element_forces_corotational_listed(c, ids.data(), r); break;
      case Model::springs: element_forces_springs_listed(c, ids.data(), r); break;
    }
  }

  // Runs the pass over [0, nt) in pieces of the given sizes (cycled).
  void forces_in_pieces(Model m, const std::vector<std::size_t>& sizes) {
    std::size_t t = 0;
    for (std::size_t i = 0; t < nt; ++i) {
      const std::size_t e = std::min(nt, t + sizes[i % sizes.size()]);
      forces(m, Range{t, e});
      t = e;
    }
  }
};

using test::same_bits;

template <class T>
using Damp = typename Strip<T>::Damp;

template <class T>
void check_split_invariance(Damp<T> damped) {
  for (Model m : {Model::linear, Model::stvk, Model::corotational, Model::springs}) {
    Strip<T> whole(203, 5), single(203, 5), ragged(203, 5);
    whole.damp(damped);
    single.damp(damped);
    ragged.damp(damped);
    whole.forces(m, Range{0, whole.nt});
    single.forces_in_pieces(m, {1});
    ragged.forces_in_pieces(m, {7, 13, 1, 32, 5, 64, 3});
    for (int q = 0; q < 12; ++q) {
      EXPECT_TRUE(same_bits(whole.cf[q], single.cf[q])) << "model " << int(m) << " component " << q;
      EXPECT_TRUE(same_bits(whole.cf[q], ragged.cf[q])) << "model " << int(m) << " component " << q;
    }
    for (int k = 0; k < 4; ++k) {
      EXPECT_TRUE(same_bits(whole.rot[k], single.rot[k])) << "model " << int(m);
      EXPECT_TRUE(same_bits(whole.rot[k], ragged.rot[k])) << "model " << int(m);
    }
    double max_force = 0;
    for (int q = 0; q < 12; ++q)
      for (T f : whole.cf[q]) max_force = std::max(max_force, std::fabs(double(f)));
    EXPECT_GT(max_force, 0.0);
    // A partial batch does not write past the end of its range.
    Strip<T> part(203, 5);
    part.damp(damped);
    part.forces(m, Range{10, 17});
    for (int q = 0; q < 12; ++q) {
      for (std::size_t t = 0; t < part.nt; ++t) {
        if (t >= 10 && t < 17) {
          EXPECT_EQ(part.cf[q][t], whole.cf[q][t]);
        } else {
          EXPECT_EQ(part.cf[q][t], T(0)) << "tet " << t;
        }
      }
    }
  }
}

TEST(KernelBatches, ElementPassesGiveTheSameBitsForAnySplitFloat) {
  for (auto d : {Damp<float>::none, Damp<float>::viscous, Damp<float>::rayleigh}) check_split_invariance<float>(d);
}
TEST(KernelBatches, ElementPassesGiveTheSameBitsForAnySplitDouble) {
  for (auto d : {Damp<double>::none, Damp<double>::viscous, Damp<double>::rayleigh}) check_split_invariance<double>(d);
}

// The passes over listed tets (a multiresolution level's stepped tets, scattered over its mesh):
// each listed tet gets the bits the range pass gives it, in any list order and cut, and no other
// tet is written. The list skips tets in runs of 1 to 5 (as stepped runs do) and is shuffled, so
// that lanes of one batch hold tets far apart, and a batch is partial at each cut. With
// rest_listed, the rest data comes from copies in list order (ElementContext::listed_tet ...),
// as a listed level's in the engine.
// forces_listed: the corner forces stored by list position (ElementContext::listed_corner_forces,
// as a listed level of the step keeps them), each the bits of its tet's in the range pass.
// rotations_listed: the warm starts read and written in list order (ElementContext::
// listed_rotation), written back by tet after the passes, as the step does.
template <class T>
void check_listed(Damp<T> damped, bool packed, bool rest_listed = false, bool forces_listed = false,
                  bool rotations_listed = false) {
  for (Model m : {Model::linear, Model::stvk, Model::corotational, Model::springs}) {
    Strip<T> whole(203, 5), listed(203, 5);
    whole.damp(damped);
    listed.damp(damped);
    if (packed) listed.pack();
    whole.forces(m, Range{0, whole.nt});
    std::vector<std::int32_t> ids;
    std::vector<bool> in(listed.nt, false);
    for (std::size_t t = 0; t < listed.nt; t += 1 + t % 5) {
      ids.push_back(std::int32_t(t));
      in[t] = true;
    }
    std::mt19937 rng(3);
    std::shuffle(ids.begin(), ids.end(), rng);
    if (rest_listed) listed.list_rest(ids);
    if (rotations_listed) listed.list_rotations(ids);
    listed.c.listed_corner_forces = forces_listed;
    for (std::size_t i = 0; i < ids.size();) {  // cuts of 7, 13, 1, 32, ... list positions
      static const std::size_t cuts[] = {7, 13, 1, 32, 5, 64, 3};
      const std::size_t e = std::min(ids.size(), i + cuts[i % 7]);
      listed.forces_listed(m, ids, Range{i, e});
      i = e;
    }
    if (rotations_listed) listed.write_back_rotations(ids);
    std::size_t checked = 0;
    const Strip<T> fresh(203, 5);  // the warm starts before any pass
    for (std::size_t t = 0; t < listed.nt; ++t) {
      for (int q = 0; q < 12; ++q) {
        // By list position t (after the list: untouched), or by tet.
        const T expect = forces_listed ? (t < ids.size() ? whole.cf[q][std::size_t(ids[t])] : T(0))
                                       : in[t] ? whole.cf[q][t] : T(0);
        EXPECT_EQ(std::memcmp(&listed.cf[q][t], &expect, sizeof(T)), 0) << "model " << int(m) << " tet " << t << " component " << q;
      }
      for (int k = 0; k < 4; ++k) {
        const T expect = in[t] ? whole.rot[k][t] : fresh.rot[k][t];
        EXPECT_EQ(std::memcmp(&listed.rot[k][t], &expect, sizeof(T)), 0) << "model " << int(m) << " tet " << t;
      }
      checked += in[t];
    }
    EXPECT_EQ(checked, ids.size());
    EXPECT_GT(ids.size(), 60u);
  }
}

template <class T>
void check_listed_every_damping(bool rest_listed, bool forces_listed, bool rotations_listed = false) {
  for (auto d : {Damp<T>::none, Damp<T>::viscous, Damp<T>::rayleigh})
    for (bool packed : {false, true}) check_listed<T>(d, packed, rest_listed, forces_listed, rotations_listed);
}

TEST(KernelBatches, ListedPassesGiveEachTetTheBitsOfTheRangePassFloat) { check_listed_every_damping<float>(false, false); }
TEST(KernelBatches, ListedPassesGiveEachTetTheBitsOfTheRangePassDouble) { check_listed_every_damping<double>(false, false); }
TEST(KernelBatches, ListedPassesWithRestDataInListOrderGiveTheSameBits) {
  check_listed_every_damping<float>(true, false);
  check_listed_every_damping<double>(true, false);
}

TEST(KernelBatches, ListedPassesStoringForcesByListPositionGiveTheSameBits) {
  check_listed_every_damping<float>(true, true);
  check_listed_every_damping<double>(true, true);
}

TEST(KernelBatches, ListedPassesWithRotationsInListOrderGiveTheSameBits) {
  check_listed_every_damping<float>(true, true, true);
  check_listed_every_damping<double>(true, true, true);
}

// Corner positions (and, with velocities, corner velocities) read from the interleaved copies
// (one load per node and a transpose with AVX-512 and AVX2) must be the values the gathers from
// x[3][n] and v[3][n] read: the same bits out, any split.
template <class T>
void check_packed_positions(Damp<T> damped, bool velocities = false) {
  for (Model m : {Model::linear, Model::stvk, Model::corotational, Model::springs}) {
    Strip<T> soa(203, 5), packed(203, 5);
    soa.damp(damped);
    packed.damp(damped);
    packed.pack(velocities);
    soa.forces(m, Range{0, soa.nt});
    packed.forces_in_pieces(m, {7, 13, 1, 32, 5, 64, 3});
    for (int q = 0; q < 12; ++q)
      EXPECT_TRUE(same_bits(soa.cf[q], packed.cf[q])) << "model " << int(m) << " component " << q;
    for (int k = 0; k < 4; ++k) EXPECT_TRUE(same_bits(soa.rot[k], packed.rot[k])) << "model " << int(m);
  }
}

TEST(KernelBatches, PackedPositionsGiveTheBitsOfTheGathersFloat) {
  for (auto d : {Damp<float>::none, Damp<float>::viscous, Damp<float>::rayleigh}) check_packed_positions<float>(d);
}
TEST(KernelBatches, PackedPositionsGiveTheBitsOfTheGathersDouble) {
  for (auto d : {Damp<double>::none, Damp<double>::viscous, Damp<double>::rayleigh}) check_packed_positions<double>(d);
}

TEST(KernelBatches, PackedVelocitiesGiveTheBitsOfTheGathersFloat) {
  check_packed_positions<float>(Damp<float>::viscous, true);
  check_packed_positions<float>(Damp<float>::rayleigh, true);
}
TEST(KernelBatches, PackedVelocitiesGiveTheBitsOfTheGathersDouble) {
  check_packed_positions<double>(Damp<double>::viscous, true);
  check_packed_positions<double>(Damp<double>::rayleigh, true);
}

// The damped passes do read the velocities' copy when they are given one (else the test above
// would pass with it ignored): a copy whose velocities differ from v changes the forces.
TEST(KernelBatches, DampedPassesReadThePackedVelocities) {
  for (bool rayleigh : {false, true}) {
    for (Model m : {Model::linear, Model::stvk, Model::corotational, Model::springs}) {
      Strip<float> soa(40, 5), packed(40, 5);
      soa.damp(rayleigh);
      packed.damp(rayleigh);
      packed.pack(true);
      // x velocity + n x 0.1 m/s in the copy only (not uniform: a uniform velocity is a rigid
      // translation, which the viscous stress rightly ignores)
      for (std::size_t n = 0; n < packed.nn; ++n) packed.vp[4 * n] += 0.1f * float(n);
      soa.forces(m, Range{0, soa.nt});
      packed.forces(m, Range{0, packed.nt});
      EXPECT_FALSE(same_bits(soa.cf[0], packed.cf[0])) << "model " << int(m) << (rayleigh ? " rayleigh" : "");
    }
  }
}

TEST(KernelBatches, PackWritesXyzAndZeroOnItsRangeOnly) {
  Strip<float> s(40, 3);
  s.xp.assign(4 * s.nn, -7.0f);
  PackContext<float> pc;
  for (int k = 0; k < 3; ++k) pc.x[k] = s.x[k].data();
  pc.xp = s.xp.data();
  s.vp.assign(4 * s.nn, -7.0f);
  for (int k = 0; k < 3; ++k) pc.v[k] = s.v[k].data();
  pc.vp = s.vp.data();
  pack_positions(pc, Range{5, 20});
  for (std::size_t n = 0; n < s.nn; ++n) {
    const bool in = n >= 5 && n < 20;
    for (int k = 0; k < 3; ++k) EXPECT_EQ(s.xp[4 * n + std::size_t(k)], in ? s.x[k][n] : -7.0f) << "node " << n;
    EXPECT_EQ(s.xp[4 * n + 3], in ? 0.0f : -7.0f) << "node " << n;
    for (int k = 0; k < 3; ++k) EXPECT_EQ(s.vp[4 * n + std::size_t(k)], in ? s.v[k][n] : -7.0f) << "node " << n;
    EXPECT_EQ(s.vp[4 * n + 3], in ? 0.0f : -7.0f) << "node " << n;
  }
}

TEST(KernelBatches, CorotationalRotationsAreTheOnesTheEnergyUses) {
  // The energy pass refines the stored rotation (scalar code) on a copy: after a force pass the
  // stored rotation is converged, so the energy pass must agree with a fresh force pass.
  Strip<double> s(64, 9);
  s.forces(Model::corotational, Range{0, s.nt});
  std::vector<double> e1(s.nt), e2(s.nt);
  element_energy_corotational(s.c, Range{0, s.nt}, e1.data());
  s.forces(Model::corotational, Range{0, s.nt});
  element_energy_corotational(s.c, Range{0, s.nt}, e2.data());
  for (std::size_t t = 0; t < s.nt; ++t) EXPECT_NEAR(e1[t], e2[t], 1e-12 * std::fabs(e1[t]) + 1e-300);
}

// The corotational energy in lanes (a change of resolution measures the body's energy twice) gives
// the scalar loop's bits per tet, over a range cut anywhere and over a shuffled list, and leaves the
// stored rotations as they were (it refines a copy). The strip has strongly deformed tets and
// random warm starts, so lanes of one batch take different numbers of iterations.
template <class T>
void check_energy_lanes() {
  Strip<T> s(203, 5);
  const Strip<T> fresh(203, 5);
  std::vector<double> scalar(s.nt, -1), ranged(s.nt, -1), listed(s.nt, -1);
  element_energy_corotational_scalar(s.c, Range{0, s.nt}, scalar.data());
  for (std::size_t t = 0, i = 0; t < s.nt; ++i) {
    static const std::size_t cuts[] = {7, 13, 1, 32, 5, 64, 3};
    const std::size_t e = std::min(s.nt, t + cuts[i % 7]);
    element_energy_corotational(s.c, Range{t, e}, ranged.data());
    t = e;
  }
  std::vector<std::int32_t> ids;
  for (std::size_t t = 0; t < s.nt; t += 1 + t % 3) ids.push_back(std::int32_t(t));
  std::shuffle(ids.begin(), ids.end(), std::mt19937(4));
  element_energy_corotational_listed(s.c, ids.data(), Range{0, ids.size() / 2}, listed.data());
  element_energy_corotational_listed(s.c, ids.data(), Range{ids.size() / 2, ids.size()}, listed.data());
  // The same with the warm starts in list order (ElementContext::listed_rotation), never written.
  std::vector<double> listed_rotations(s.nt, -1);
  s.list_rotations(ids);
  element_energy_corotational_listed(s.c, ids.data(), Range{0, ids.size()}, listed_rotations.data());
  EXPECT_TRUE(same_bits(listed_rotations, listed));
  for (int k = 0; k < 4; ++k)
    for (std::size_t i = 0; i < ids.size(); ++i) EXPECT_EQ(s.listed_rot[k][i], fresh.rot[k][std::size_t(ids[i])]);
  s.list_rotations({});
  std::vector<bool> in(s.nt, false);
  for (auto t : ids) in[std::size_t(t)] = true;
  std::size_t positive = 0;
  for (std::size_t t = 0; t < s.nt; ++t) {
    EXPECT_EQ(std::memcmp(&ranged[t], &scalar[t], sizeof(double)), 0) << "tet " << t << ": " << ranged[t] << " vs " << scalar[t];
    const double want = in[t] ? scalar[t] : -1.0;
    EXPECT_EQ(std::memcmp(&listed[t], &want, sizeof(double)), 0) << "tet " << t;
    positive += scalar[t] > 0;
  }
  EXPECT_EQ(positive, s.nt);  // every tet of the strip is strained
  for (int k = 0; k < 4; ++k) EXPECT_TRUE(same_bits(s.rot[k], fresh.rot[k]));
}

TEST(KernelBatches, CorotationalEnergyLanesGiveTheScalarBitsFloat) { check_energy_lanes<float>(); }
TEST(KernelBatches, CorotationalEnergyLanesGiveTheScalarBitsDouble) { check_energy_lanes<double>(); }

// The rotation iteration, scalar and batched, on hard cases from the identity warm start: half
// turns about the axes and about arbitrary axes (a saddle of tr(R^T F): zero gradient, indefinite
// Hessian), half turns of strained tets, inverted and flattened tets, NaN, and ordinary ones mixed
// in, so that escaping lanes share batches with Newton lanes. Every lane must give the bits of the
// scalar code, and the half turns must be found.
template <class T>
void check_rotation_lanes() {
  using V = typename simd::Pack<T>::V;
  constexpr int W = simd::Pack<T>::W;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  auto axis_angle = [](const double a[3], double angle, double R[3][3]) {
    const double n = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    const double k[3] = {a[0] / n, a[1] / n, a[2] / n}, c = std::cos(angle), s = std::sin(angle);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const double cross = i == j ? 0 : ((i + 1) % 3 == j ? -k[3 - i - j] : k[3 - i - j]);
        R[i][j] = (i == j ? c : 0) + (1 - c) * k[i] * k[j] + s * cross;
      }
  };
  std::vector<detail::Mat3<T>> F;
  std::vector<std::array<double, 4>> expect;  // (0, axis) for pure half turns, else empty (w = 9)
  const double axes[][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}, {0.3, -0.8, 0.5}, {-1, 2, 0.5}};
  for (const auto& a : axes)
    for (int strained = 0; strained < 2; ++strained) {
      double R[3][3];
      axis_angle(a, 3.141592653589793, R);
      const double S[3][3] = {{strained ? 1.1 : 1.0, strained ? 0.03 : 0.0, 0},
                              {strained ? 0.03 : 0.0, strained ? 0.9 : 1.0, 0},
                              {0, 0, strained ? 1.05 : 1.0}};
      detail::Mat3<T> m;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) m.m[i][j] = T(R[i][0] * S[0][j] + R[i][1] * S[1][j] + R[i][2] * S[2][j]);
      F.push_back(m);
      const double n = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
      expect.push_back(strained ? std::array<double, 4>{9, 0, 0, 0} : std::array<double, 4>{0, a[0] / n, a[1] / n, a[2] / n});
    }
  // Inverted (one or three stretches negative), flat (rank 2 and rank 1), zero, NaN.
  const double diags[][3] = {{1, 1, -0.5}, {-1, 0.8, 0.9}, {-0.5, -1, -1}, {1, 1, 0}, {1, 0, 0}, {0, 0, 0}};
  for (const auto& d : diags) {
    double R[3][3];
    const double a[3] = {u(rng), u(rng), u(rng)};
    axis_angle(a, 2.0 * u(rng), R);
    detail::Mat3<T> m;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m.m[i][j] = T(R[i][j] * d[j]);
    F.push_back(m);
    expect.push_back({9, 0, 0, 0});
  }
  detail::Mat3<T> nan_m{};
  nan_m.m[1][2] = std::numeric_limits<T>::quiet_NaN();
  F.push_back(nan_m);
  expect.push_back({9, 0, 0, 0});
  while (F.size() % W != 3 % W || F.size() < 40) {  // ordinary ones: a random rotation, small strain
    double R[3][3];
    const double a[3] = {u(rng), u(rng), u(rng)};
    axis_angle(a, 3.0 * u(rng), R);
    detail::Mat3<T> m;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m.m[i][j] = T(R[i][j] + 0.05 * u(rng));
    F.push_back(m);
    expect.push_back({9, 0, 0, 0});
  }
  // Shuffle so that every kind lands in lanes of every position.
  std::vector<std::size_t> order(F.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), rng);
  // Scalar.
  std::vector<std::array<T, 4>> qs(F.size());
  for (std::size_t i = 0; i < F.size(); ++i) {
    T q[4] = {1, 0, 0, 0};
    detail::extract_rotation(F[order[i]], q);
    for (int k = 0; k < 4; ++k) qs[i][k] = q[k];
  }
  // Batched, W at a time (the last batch partial, lanes past the end repeating the last one).
  for (std::size_t b0 = 0; b0 < F.size(); b0 += W) {
    detail::Mat3<V> A[1] = {};
    V q[1][4] = {};
    for (int l = 0; l < W; ++l) {
      const std::size_t i = std::min(F.size() - 1, b0 + std::size_t(l));
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) A[0].m[r][c][l] = F[order[i]].m[r][c];
      q[0][0][l] = T(1);
      q[0][1][l] = q[0][2][l] = q[0][3][l] = T(0);
    }
    detail::Mat3<V> R[1];
    detail::extract_rotation_batches<T, 1>(A, q, R);
    for (int l = 0; l < W && b0 + std::size_t(l) < F.size(); ++l) {
      const std::size_t i = b0 + std::size_t(l);
      for (int k = 0; k < 4; ++k) {
        const T a = q[0][k][l], b = qs[i][k];
        EXPECT_EQ(std::memcmp(&a, &b, sizeof(T)), 0) << "case " << order[i] << " lane " << l << " component " << k;
      }
    }
  }
  // The half turns were found (scalar; the lanes are the same bits).
  const double tol = sizeof(T) == 4 ? 1.2e-7 : 1e-15;  // measured 2.6e-8 (float), 2.2e-16 (double)
  for (std::size_t i = 0; i < F.size(); ++i) {
    const auto& e = expect[order[i]];
    if (e[0] != 0) continue;
    const double dot = double(qs[i][1]) * e[1] + double(qs[i][2]) * e[2] + double(qs[i][3]) * e[3];
    EXPECT_NEAR(std::fabs(dot), 1.0, tol) << "case " << order[i];
  }
}

TEST(KernelBatches, RotationLanesGiveTheScalarBitsOnHardCasesFloat) { check_rotation_lanes<float>(); }
TEST(KernelBatches, RotationLanesGiveTheScalarBitsOnHardCasesDouble) { check_rotation_lanes<double>(); }

template <class T>
void check_fused_node_pass(bool external) {
  Strip<T> s(300, 3);
  s.forces(Model::corotational, Range{0, s.nt});
  // Incidence of the strip: node n is corner a of tet n - a.
  std::vector<std::int32_t> offsets(s.nn + 1, 0), incidence;
  for (std::size_t n = 0; n < s.nn; ++n) {
    for (int a = 0; a < 4; ++a) {
      const std::int64_t t = std::int64_t(n) - a;
      if (t >= 0 && std::size_t(t) < s.nt) incidence.push_back(std::int32_t(4 * t + a));
    }
    std::sort(incidence.begin() + offsets[n], incidence.end());
    offsets[n + 1] = std::int32_t(incidence.size());
  }
  std::vector<T> ext[3], inv_mass(s.nn);
  std::vector<std::uint8_t> state(s.nn, kNodeFree);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0.5, 2);
  for (auto& e : ext) e.resize(s.nn);
  for (std::size_t n = 0; n < s.nn; ++n) {
    inv_mass[n] = T(u(rng));
    for (auto& e : ext) e[n] = T(u(rng) - 1.2);
    if (n % 11 == 0) state[n] = kNodeFixed;
  }
  auto run = [&](bool fused, std::vector<T> x[3], std::vector<T> v[3], std::vector<T> f[3]) {
    for (int k = 0; k < 3; ++k) {
      x[k] = s.x[k];
      v[k] = s.v[k];
      f[k].assign(s.nn, T(0));
    }
    GatherContext<T> g;
    g.offsets = offsets.data();
    g.incidence = incidence.data();
    for (int q = 0; q < 12; ++q) g.corner_force[q] = s.cf[q].data();
    IntegrateContext<T> ic;
    for (int k = 0; k < 3; ++k) {
      g.external[k] = external ? ext[k].data() : nullptr;
      g.f[k] = f[k].data();
      ic.x[k] = x[k].data();
      ic.v[k] = v[k].data();
      ic.f[k] = f[k].data();
    }
    ic.inv_mass = inv_mass.data();
    ic.state = state.data();
    ic.dt = T(1e-4);
    ic.gravity[2] = T(-9.81);
    ic.mass_damping = T(0.7);
    bool ok = true;
    for (std::size_t b = 0; b < s.nn; b += 37) {  // ragged node ranges, as threads would cut them
      const Range r{b, std::min(s.nn, b + 37)};
      if (fused) {
        ok &= gather_integrate_symplectic_euler(g, ic, r);
      } else {
        gather_forces(g, r);
        ok &= integrate_symplectic_euler(ic, r);
      }
    }
    return ok;
  };
  std::vector<T> x1[3], v1[3], f1[3], x2[3], v2[3], f2[3];
  EXPECT_TRUE(run(false, x1, v1, f1));
  EXPECT_TRUE(run(true, x2, v2, f2));
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(same_bits(x1[k], x2[k]));
    EXPECT_TRUE(same_bits(v1[k], v2[k]));
    EXPECT_TRUE(same_bits(f1[k], f2[k]));
  }
  EXPECT_NE(x1[0], s.x[0]);
}

TEST(KernelBatches, FusedGatherIntegrateGivesTheBitsOfTheTwoPasses) {
  check_fused_node_pass<float>(false);
  check_fused_node_pass<float>(true);
  check_fused_node_pass<double>(false);
  check_fused_node_pass<double>(true);
}

// A finite but runaway state (an unstable mode on its way to overflow: 1e160 m/s is finite in
// double) counts as diverged at once: both node passes report it, in float and double.
template <class T>
void check_runaway(T value, bool velocity) {
  const std::int32_t offsets[3] = {0, 0, 0};
  T x[3][2] = {{0, 0}, {0, 0}, {0, 0}}, v[3][2] = {{0, 0}, {0, 0}, {0, 0}}, f[3][2] = {};
  const T inv_mass[2] = {1, 1};
  const std::uint8_t state[2] = {kNodeFree, kNodeFree};
  GatherContext<T> g;
  g.offsets = offsets;
  IntegrateContext<T> ic;
  for (int k = 0; k < 3; ++k) {
    g.f[k] = f[k];
    ic.x[k] = x[k];
    ic.v[k] = v[k];
    ic.f[k] = f[k];
  }
  ic.inv_mass = inv_mass;
  ic.state = state;
  ic.dt = T(1e-3);
  EXPECT_TRUE(gather_integrate_symplectic_euler(g, ic, Range{0, 2}));
  EXPECT_TRUE(integrate_symplectic_euler(ic, Range{0, 2}));
  (velocity ? v : x)[2][1] = value;
  EXPECT_FALSE(gather_integrate_symplectic_euler(g, ic, Range{0, 2})) << double(value);
  EXPECT_FALSE(integrate_symplectic_euler(ic, Range{0, 2})) << double(value);
  EXPECT_TRUE(gather_integrate_symplectic_euler(g, ic, Range{0, 1}));  // node 0 alone is fine
}

TEST(KernelBatches, FusedPassReportsNonFiniteNodes) {
  for (bool velocity : {true, false}) {
    check_runaway<float>(std::nanf(""), velocity);
    check_runaway<double>(std::numeric_limits<double>::infinity(), velocity);
  }
}

TEST(KernelBatches, NodePassesReportRunawayFiniteStates) {
  for (bool velocity : {true, false}) {
    check_runaway<double>(1e160, velocity);
    check_runaway<double>(-2 * kDivergedMagnitude, velocity);
    check_runaway<float>(1e30f, velocity);
    check_runaway<float>(-2e15f, velocity);
  }
  // Just below the bound is still a state (a fixed node may also sit anywhere: not checked).
  EXPECT_TRUE(within_bounds(0.5 * kDivergedMagnitude, -0.5 * kDivergedMagnitude));
  EXPECT_FALSE(within_bounds(std::nan(""), 0.0));
  EXPECT_FALSE(within_bounds(0.0, -std::numeric_limits<double>::infinity()));
}

// The multiply-adds of the kernels (simd.hpp): each lane gives the bits of the scalar helper, and
// with PLIANT_FMA both round once. (1 + e)(1 - e) - 1 = -e^2 exactly; rounded twice it is 0, so
// this fails if either the scalar or the lane version is not fused where it should be (or is
// where it should not: a build without PLIANT_FMA must keep the unfused result).
template <class T>
void check_mul_add_lanes() {
  using V = typename simd::Pack<T>::V;
  constexpr int W = simd::Pack<T>::W;
  const T e = std::numeric_limits<T>::epsilon();
  const T fused = PLIANT_FMA ? -e * e : T(0);
  const T a = T(1) + e, b = T(1) - e, one = T(1);
  EXPECT_EQ(simd::mul_add(a, b, -one), fused);
  EXPECT_EQ(simd::mul_sub(a, b, one), fused);
  EXPECT_EQ(simd::neg_mul_add(a, b, one), -fused);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int round = 0; round < 50; ++round) {
    V va, vb, vc;
    for (int l = 0; l < W; ++l) {
      va[l] = T(u(rng));
      vb[l] = T(u(rng));
      vc[l] = T(u(rng));
    }
    if (round == 0) {  // the exact case in lane W - 1
      va[W - 1] = a;
      vb[W - 1] = b;
      vc[W - 1] = one;
    }
    const V r0 = simd::mul_add(va, vb, vc), r1 = simd::mul_sub(va, vb, vc), r2 = simd::neg_mul_add(va, vb, vc);
    for (int l = 0; l < W; ++l) {
      const T s0 = simd::mul_add(va[l], vb[l], vc[l]), s1 = simd::mul_sub(va[l], vb[l], vc[l]),
              s2 = simd::neg_mul_add(va[l], vb[l], vc[l]);
      EXPECT_EQ(std::memcmp(&r0[l], &s0, sizeof(T)), 0) << "lane " << l;
      EXPECT_EQ(std::memcmp(&r1[l], &s1, sizeof(T)), 0) << "lane " << l;
      EXPECT_EQ(std::memcmp(&r2[l], &s2, sizeof(T)), 0) << "lane " << l;
      if (PLIANT_FMA) {
        EXPECT_EQ(s0, std::fma(va[l], vb[l], vc[l]));
      }
    }
    if (round == 0) {
      EXPECT_EQ(r1[W - 1], fused);
    }
  }
}

TEST(KernelBatches, MulAddLanesGiveTheScalarBitsFloat) { check_mul_add_lanes<float>(); }
TEST(KernelBatches, MulAddLanesGiveTheScalarBitsDouble) { check_mul_add_lanes<double>(); }

}  // namespace
}  // namespace pliant
