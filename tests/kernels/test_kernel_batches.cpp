// The element passes run W tets per vector (one per lane) and the step fuses the gather with
// the integrator. Neither may change a result: a tet's corner forces and rotation must be the
// same bits whether it is computed alone, in a full batch or in a partial one at the end of an
// odd-sized range (the thread split decides which), and the fused node pass must give the bits
// of gather then integrate.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "pliant/kernels/element_forces.hpp"
#include "pliant/kernels/node_passes.hpp"

namespace pliant {
namespace {

enum class Model { linear, stvk, corotational, springs };

// A strip of tets sharing nodes: tet t has nodes t, t+1, t+2, t+3 of a perturbed helix, so
// that gathers hit shared nodes; positions are deformed and rotated, some tets strongly (so
// that the rotation iteration takes different numbers of steps in different lanes), and
// velocities are random (damping terms).
template <class T>
struct Strip {
  std::size_t nt, nn;
  std::vector<T> X[3], x[3], v[3], volume, grad[9], rot[4], cf[12];
  std::vector<std::int32_t> tet[4];
  ElementContext<T> c;

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
    for (auto& a : tet) a.resize(nt);
    volume.resize(nt);
    for (auto& g : grad) g.resize(nt);
    for (auto& q : rot) q.resize(nt);
    for (auto& f : cf) f.assign(nt, T(0));
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
    for (int k = 0; k < 3; ++k) {
      c.X[k] = X[k].data();
      c.x[k] = x[k].data();
      c.v[k] = v[k].data();
    }
    for (int a = 0; a < 4; ++a) c.tet[a] = tet[a].data();
    c.volume = volume.data();
    for (int q = 0; q < 9; ++q) c.grad[q] = grad[q].data();
    for (int k = 0; k < 4; ++k) c.rotation[k] = rot[k].data();
    for (int q = 0; q < 12; ++q) c.corner_force[q] = cf[q].data();
    const double E = 1e6, nu = 0.3;
    c.lambda = T(E * nu / ((1 + nu) * (1 - 2 * nu)));
    c.mu = T(E / (2 * (1 + nu)));
    c.young = T(E);
  }

  void damp() {
    c.bulk_viscosity = T(40);
    c.shear_viscosity = T(25);
    c.spring_damping = T(1e-4);
  }

  void forces(Model m, Range r) {
    switch (m) {
      case Model::linear: element_forces_linear(c, r); break;
      case Model::stvk: element_forces_stvk(c, r); break;
      case Model::corotational: element_forces_corotational(c, r); break;
      case Model::springs: element_forces_springs(c, r); break;
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

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

template <class T>
void check_split_invariance(bool damped) {
  for (Model m : {Model::linear, Model::stvk, Model::corotational, Model::springs}) {
    Strip<T> whole(203, 5), single(203, 5), ragged(203, 5);
    if (damped) {
      whole.damp();
      single.damp();
      ragged.damp();
    }
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
    if (damped) part.damp();
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
  check_split_invariance<float>(false);
  check_split_invariance<float>(true);
}
TEST(KernelBatches, ElementPassesGiveTheSameBitsForAnySplitDouble) {
  check_split_invariance<double>(false);
  check_split_invariance<double>(true);
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

TEST(KernelBatches, FusedPassReportsNonFiniteNodes) {
  const std::int32_t offsets[3] = {0, 0, 0};
  float x[3][2] = {{0, 0}, {0, 0}, {0, 0}}, v[3][2] = {{0, 0}, {0, 0}, {0, 0}}, f[3][2];
  const float inv_mass[2] = {1, 1};
  const std::uint8_t state[2] = {kNodeFree, kNodeFree};
  GatherContext<float> g;
  g.offsets = offsets;
  IntegrateContext<float> ic;
  for (int k = 0; k < 3; ++k) {
    g.f[k] = f[k];
    ic.x[k] = x[k];
    ic.v[k] = v[k];
    ic.f[k] = f[k];
  }
  ic.inv_mass = inv_mass;
  ic.state = state;
  ic.dt = 1e-3f;
  EXPECT_TRUE(gather_integrate_symplectic_euler(g, ic, Range{0, 2}));
  v[1][1] = std::nanf("");
  EXPECT_FALSE(gather_integrate_symplectic_euler(g, ic, Range{0, 2}));
}

}  // namespace
}  // namespace pliant
