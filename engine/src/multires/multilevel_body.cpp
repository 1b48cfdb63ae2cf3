// build_multilevel_body (simulation.hpp): the levels of a multiresolution body made ready to step.
#include <algorithm>
#include <fmt/format.h>

#include "../core/simulation.hpp"
#include "activation.hpp"
#include "adaptivity.hpp"
#include "calibration.hpp"
#include "pliant/error.hpp"
#include "pliant/kernels/element_forces.hpp"

namespace pliant::detail {
namespace {

std::vector<Range> runs_of(const std::vector<std::uint8_t>& mask) {
  std::vector<Range> runs;
  for (std::size_t t = 0; t < mask.size(); ++t) {
    if (!mask[t]) continue;
    if (!runs.empty() && runs.back().end == t)
      ++runs.back().end;
    else
      runs.push_back({t, t + 1});
  }
  return runs;
}

}  // namespace

double tet_rest_volume(const TetMesh& m, std::size_t t) {
  double p[4][3], volume = 0, grad[9];
  for (int a = 0; a < 4; ++a)
    for (int k = 0; k < 3; ++k) p[a][k] = m.points[3 * std::size_t(m.tets[t][std::size_t(a)]) + std::size_t(k)];
  tet_rest_geometry(p[0], p[1], p[2], p[3], &volume, grad);
  return volume;
}

template <class T>
SimBody<T> build_multilevel_body(const Hierarchy& h, const BodyDef& def, double courant, Executor& exec) {
  const std::size_t n = h.levels();
  if (n > std::size_t(kMaxLevels))
    throw InputError(fmt::format("body '{}': {} levels, at most {}", def.name, n, kMaxLevels));
  SimBody<T> body;
  body.def = def;
  body.origin = body_frame_origin(h.meshes.back());  // one body frame for every level: the finest mesh's
  Activation act = activate(h, def.multiresolution.active);
  // Each level's tets reordered, the stepped ones first (in their order), so that the element
  // passes run over one contiguous range: a region picks tets all over the locality order, and runs
  // of a few tets leave the vector lanes of the kernels idle (the organ's split took as long as its
  // whole fine level). Nodes keep their numbers, so ghosts and their sources are unchanged.
  std::vector<TetMesh> meshes(n);
  // An adaptive body keeps the hierarchy's tet order: what it steps changes as it runs.
  const bool adaptive = def.multiresolution.active.kind == ActiveDef::Kind::adaptive;
  for (std::size_t l = 0; l < n; ++l) {
    const TetMesh& src = h.meshes[l];
    auto& stepped = act.levels[l].stepped;
    if (adaptive) {
      meshes[l] = src;
      continue;
    }
    meshes[l].points = src.points;
    meshes[l].tets.reserve(src.tet_count());
    std::vector<std::uint8_t> share;  // the mass shares, in the new order
    share.reserve(src.tet_count());
    for (int pass = 0; pass < 2; ++pass)
      for (std::size_t t = 0; t < src.tet_count(); ++t)
        if (bool(stepped[t]) == (pass == 0)) {
          meshes[l].tets.push_back(src.tets[t]);
          share.push_back(act.levels[l].share[t]);
        }
    act.levels[l].share = std::move(share);
    const std::size_t count = std::size_t(std::count(stepped.begin(), stepped.end(), std::uint8_t(1)));
    std::fill(stepped.begin(), stepped.end(), std::uint8_t(0));
    std::fill(stepped.begin(), stepped.begin() + std::ptrdiff_t(count), std::uint8_t(1));
  }
  // Each level whole, as a single-level body would be (its stable step among others).
  for (std::size_t l = 0; l < n; ++l) {
    std::vector<MotionState> ignored;
    body.levels.push_back(
        build_level<T>(meshes[l], body.origin, def, courant, ignored, exec, /*regions_may_be_empty=*/true));
  }
  // Coarser levels as stiff as the finest under their own weight (calibration.hpp).
  body.stiffness_factors.assign(n, 1.0);
  if (def.multiresolution.calibrate) {
    const Compliance fine = weight_compliance(exec, body.levels[n - 1]);
    std::size_t axis = 0;  // the finest level's softest axis
    for (std::size_t k = 1; k < 3; ++k)
      if (fine.omega2[k] < fine.omega2[axis]) axis = k;
    for (std::size_t l = 0; l + 1 < n && fine.omega2[axis] > 0; ++l) {
      const Compliance c = weight_compliance(exec, body.levels[l]);
      if (!(c.omega2[axis] > 0)) continue;
      body.stiffness_factors[l] = fine.omega2[axis] / c.omega2[axis];
      scale_stiffness(exec, body.levels[l], def.material, body.stiffness_factors[l], courant);
    }
  }

  std::vector<const TetMesh*> order(n);
  for (std::size_t l = 0; l < n; ++l) order[l] = &meshes[l];
  apply_activation(body, act, h, order, 0.0);
  return body;
}

template <class T>
void apply_activation(SimBody<T>& body, const Activation& act, const Hierarchy& h, const std::vector<const TetMesh*>& meshes,
                      double time) {
  const std::size_t n = h.levels();
  const BodyDef& def = body.def;
  // Roles, stepped tets, masses from the stepped tets.
  std::vector<std::vector<double>> mass(n);
  for (std::size_t l = 0; l < n; ++l) {
    Level<T>& L = body.levels[l];
    const LevelActivation& la = act.levels[l];
    const TetMesh& m = *meshes[l];
    L.stepped_runs = runs_of(la.stepped);
    L.stepped_count = std::size_t(std::count(la.stepped.begin(), la.stepped.end(), std::uint8_t(1)));
    for (std::size_t i = 0; i < L.node_count; ++i)
      L.state[i] = la.role[i] == NodeRole::active ? kNodeFree : la.role[i] == NodeRole::ghost ? kNodeGhost : kNodeInactive;
    mass[l].assign(L.node_count, 0.0);
    for (std::size_t t = 0; t < m.tet_count(); ++t)
      if (la.stepped[t]) {
        // rho V / 4, times the tet's mass share (1 unless it overlaps coarser stepped tets)
        const double q = def.material.density * tet_rest_volume(m, t) / 4 * (double(la.share[t]) / kMassShares);
        for (int a = 0; a < 4; ++a) mass[l][std::size_t(m.tets[t][std::size_t(a)])] += q;
      }
    L.ghosts.assign(la.ghosts.begin(), la.ghosts.end());
    L.ghost_offsets.assign(la.source_offsets.begin(), la.source_offsets.end());
    L.ghost_source_level.resize(la.sources.size());
    L.ghost_source_node.resize(la.sources.size());
    L.ghost_weight.resize(la.sources.size());
    for (std::size_t e = 0; e < la.sources.size(); ++e) {
      L.ghost_source_level[e] = la.sources[e].level;
      L.ghost_source_node[e] = la.sources[e].node;
      L.ghost_weight[e] = la.sources[e].weight;
    }
  }
  // A ghost's mass goes to its sources with its weights (the lumped row sums of the constrained
  // mass matrix): the body's mass is the stepped tets' (exactly rho x volume for nested meshes).
  struct Entry {
    std::int32_t node, ghost_level, ghost;
    double weight;
  };
  std::vector<std::vector<Entry>> receive(n);
  for (std::size_t l = 0; l < n; ++l) {
    const LevelActivation& la = act.levels[l];
    for (std::size_t g = 0; g < la.ghosts.size(); ++g) {
      const std::int32_t node = la.ghosts[g];
      for (auto e = la.source_offsets[g]; e < la.source_offsets[g + 1]; ++e) {
        const GhostSource& s = la.sources[std::size_t(e)];
        mass[std::size_t(s.level)][std::size_t(s.node)] += s.weight * mass[l][std::size_t(node)];
        receive[std::size_t(s.level)].push_back({s.node, std::int32_t(l), node, s.weight});
      }
      mass[l][std::size_t(node)] = 0;
    }
  }
  for (std::size_t l = 0; l < n; ++l) {
    Level<T>& L = body.levels[l];
    auto& r = receive[l];
    std::sort(r.begin(), r.end(), [](const Entry& a, const Entry& b) {
      if (a.node != b.node) return a.node < b.node;
      if (a.ghost_level != b.ghost_level) return a.ghost_level < b.ghost_level;
      return a.ghost < b.ghost;
    });
    L.receivers.clear();
    L.receive_offsets.assign(1, 0);
    L.receive_ghost_level.clear();  // applied again when an adaptive body changes
    L.receive_ghost_node.clear();
    L.receive_weight.clear();
    for (const Entry& e : r) {
      if (L.receivers.empty() || L.receivers.back() != e.node) {
        if (!L.receivers.empty()) L.receive_offsets.push_back(std::int32_t(L.receive_ghost_level.size()));
        L.receivers.push_back(e.node);
      }
      L.receive_ghost_level.push_back(e.ghost_level);
      L.receive_ghost_node.push_back(e.ghost);
      L.receive_weight.push_back(e.weight);
    }
    if (!L.receivers.empty()) {
      L.receive_offsets.push_back(std::int32_t(L.receive_ghost_level.size()));
      for (auto& j : L.impulse) j.assign(L.node_count, T(0));
    } else {
      L.receive_offsets.clear();
      for (auto& j : L.impulse) j.clear();
    }
  }

  // Regions on active nodes only: a ghost follows its sources, an inactive node does nothing.
  auto active_in = [&](std::size_t l, const RegionDef& r, const std::string& what) {
    std::vector<std::int32_t> out;
    for (auto i : select_nodes(h.meshes[l], r, what, def.name, true))
      if (act.levels[l].role[std::size_t(i)] == NodeRole::active) out.push_back(i);
    return out;
  };
  auto none = [&](const std::string& what) {
    throw InputError(fmt::format("body '{}': {} selects no node simulated at any level (the region lies where "
                                 "no level is active, or between nodes)",
                                 def.name, what));
  };
  for (std::size_t i = 0; i < def.fixed.size(); ++i) {
    std::size_t count = 0;
    for (std::size_t l = 0; l < n; ++l)
      for (auto v : active_in(l, def.fixed[i], fmt::format("fixed[{}]", i))) {
        body.levels[l].state[std::size_t(v)] = kNodeFixed;
        ++count;
      }
    if (count == 0) none(fmt::format("fixed[{}]", i));
  }
  // Motions keep their state (keyframes, a host's offsets); only their nodes are chosen again.
  body.motions.resize(def.prescribed.size());
  for (std::size_t i = 0; i < def.prescribed.size(); ++i) {
    MotionState& ms = body.motions[i];
    if (ms.host_from.empty()) {
      ms.keyframes = def.prescribed[i].keyframes;
      ms.host_from.assign(n, Vec3d{0, 0, 0});
    }
    ms.nodes.clear();
    std::size_t count = 0;
    const Vec3d o = ms.host_driven ? ms.host_offset : ms.offset_at(time);
    for (std::size_t l = 0; l < n; ++l) {
      ms.nodes.push_back(active_in(l, def.prescribed[i].region, fmt::format("prescribed[{}]", i)));
      Level<T>& L = body.levels[l];
      for (auto v : ms.nodes.back()) {
        L.state[std::size_t(v)] = kNodeFixed;
        for (int k = 0; k < 3; ++k) L.x[k][std::size_t(v)] = L.X[k][std::size_t(v)] + T(o[std::size_t(k)]);
      }
      count += ms.nodes.back().size();
    }
    if (count == 0) none(fmt::format("prescribed[{}]", i));
  }
  for (auto& L : body.levels)
    for (auto& e : L.external) e.clear();
  for (std::size_t i = 0; i < def.loads.size(); ++i) {
    std::vector<std::vector<std::int32_t>> sel(n);
    std::size_t count = 0;
    for (std::size_t l = 0; l < n; ++l) count += (sel[l] = active_in(l, def.loads[i].region, fmt::format("loads[{}]", i))).size();
    if (count == 0) none(fmt::format("loads[{}]", i));
    for (std::size_t l = 0; l < n; ++l) {
      Level<T>& L = body.levels[l];
      if (sel[l].empty()) continue;
      if (L.external[0].empty())
        for (auto& e : L.external) e.assign(L.node_count, T(0));
      for (auto v : sel[l])
        for (int k = 0; k < 3; ++k)
          L.external[k][std::size_t(v)] += T(def.loads[i].total_force[std::size_t(k)] / double(count));
    }
  }
  // Non-nested levels tile the body only up to slivers at their interfaces (overlaps counted twice,
  // gaps not at all: within 2.2% of the organ's volume over 45 splits, tests/multires): scale every
  // mass so that the body weighs rho x the volume of its finest mesh whatever the split. Nested
  // meshes tile exactly, and the factor is 1 to rounding.
  double total = 0, volume = 0;
  for (std::size_t l = 0; l < n; ++l)
    for (double m : mass[l]) total += m;
  for (std::size_t t = 0; t < h.meshes.back().tet_count(); ++t) volume += tet_rest_volume(h.meshes.back(), t);
  const double factor = total > 0 ? def.material.density * volume / total : 1.0;
  for (std::size_t l = 0; l < n; ++l) {
    Level<T>& L = body.levels[l];
    for (double& m : mass[l]) m *= factor;
    for (std::size_t i = 0; i < L.node_count; ++i) {
      L.mass[i] = T(mass[l][i]);
      L.inv_mass[i] = L.state[i] == kNodeFree ? T(1.0 / mass[l][i]) : T(0);
    }
  }
}

template void apply_activation<float>(SimBody<float>&, const Activation&, const Hierarchy&, const std::vector<const TetMesh*>&, double);
template void apply_activation<double>(SimBody<double>&, const Activation&, const Hierarchy&, const std::vector<const TetMesh*>&, double);

template SimBody<float> build_multilevel_body<float>(const Hierarchy&, const BodyDef&, double, Executor&);
template SimBody<double> build_multilevel_body<double>(const Hierarchy&, const BodyDef&, double, Executor&);

}  // namespace pliant::detail
