// capture(): what a picture needs, copied out of a World through its const interface only
// (level<T>() const and snapshot()), so that taking pictures cannot change a simulation. Only
// the boundary nodes are kept (renumbered), which makes a frame a small fraction of the state.
// Also: frames of plain meshes, field and camera names, bounds.
#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cmath>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "pliant/error.hpp"
#include "pliant/kernels/node_passes.hpp"
#include "pliant/mesh_quality.hpp"
#include "pliant/raster/colormap.hpp"
#include "pliant/raster/render.hpp"
#include "pliant/world.hpp"

namespace pliant::raster {
namespace {

// Nodes of a region of the rest configuration, as build_level selects them (inclusive, with a
// relative tolerance of 1e-9 of the body's diagonal). Regions are in the world frame, the level's
// arrays relative to the body origin o.
template <class T>
bool in_region(const RegionDef& r, const Level<T>& L, const Vec3d& o, std::size_t n, double tol) {
  if (r.kind == RegionDef::Kind::nodes) return std::binary_search(r.nodes.begin(), r.nodes.end(), std::int32_t(n));
  const double p[3] = {o[0] + double(L.X[0][n]), o[1] + double(L.X[1][n]), o[2] + double(L.X[2][n])};
  if (r.kind == RegionDef::Kind::box) {
    for (int k = 0; k < 3; ++k)
      if (p[k] < r.min[k] - tol || p[k] > r.max[k] + tol) return false;
    return true;
  }
  const double dx = p[0] - r.center[0], dy = p[1] - r.center[1], dz = p[2] - r.center[2];
  return std::sqrt(dx * dx + dy * dy + dz * dz) <= r.radius + tol;
}

// Surface nodes, triangles renumbered, fixed and driven surface nodes of one level.
template <class T>
std::shared_ptr<const SurfaceTopology> make_topology(const Level<T>& L, const Vec3d& origin, const BodyDef& def) {
  auto topo = std::make_shared<SurfaceTopology>();
  topo->name = def.name;
  std::vector<std::int32_t> index(L.node_count, -1);
  topo->triangles.reserve(L.boundary.size());
  for (const auto& tri : L.boundary) {
    std::array<std::int32_t, 3> t{};
    for (int k = 0; k < 3; ++k) {
      std::int32_t& slot = index[tri[k]];
      if (slot < 0) {
        slot = std::int32_t(topo->source_node.size());
        topo->source_node.push_back(tri[k]);
      }
      t[k] = slot;
    }
    topo->triangles.push_back(t);
  }
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (std::size_t n = 0; n < L.node_count; ++n)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(L.X[k][n]));
      hi[k] = std::max(hi[k], double(L.X[k][n]));
    }
  const double tol = 1e-9 * std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                      (hi[2] - lo[2]) * (hi[2] - lo[2]));
  std::vector<RegionDef> driven = {};
  for (const auto& m : def.prescribed) {
    driven.push_back(m.region);
    std::sort(driven.back().nodes.begin(), driven.back().nodes.end());
  }
  for (std::size_t s = 0; s < topo->source_node.size(); ++s) {
    const std::size_t n = std::size_t(topo->source_node[s]);
    if (L.state.size() <= n || L.state[n] != kNodeFixed) continue;
    bool moved = false;
    for (const auto& r : driven) moved = moved || in_region(r, L, origin, n, tol);
    (moved ? topo->driven : topo->fixed).push_back(std::int32_t(s));
  }
  return topo;
}

template <class T>
SurfaceBody capture_levels(const World& world, BodyId b, Field field);

template <class T>
SurfaceBody capture_body(const World& world, BodyId b, Field field, std::shared_ptr<const SurfaceTopology>& cached) {
  if (world.level_count(b) > 1) return capture_levels<T>(world, b, field);
  const int level = world.level_count(b) - 1;  // the finest level
  const Level<T>& L = world.level<T>(b, level);
  if (!cached || (!cached->source_node.empty() && std::size_t(cached->source_node.back()) >= L.node_count))
    cached = make_topology(L, world.body_origin(b), world.body_def(b));
  SurfaceBody body;
  body.topology = cached;
  const auto& src = cached->source_node;
  const Vec3d o = world.body_origin(b);  // the level's arrays are relative to it; pictures are in the world frame
  body.points.resize(3 * src.size());
  for (std::size_t s = 0; s < src.size(); ++s)
    for (int k = 0; k < 3; ++k) body.points[3 * s + k] = float(o[k] + double(L.x[k][std::size_t(src[s])]));
  if (field == Field::level) {
    body.values.assign(src.size(), float(level));
  } else if (field == Field::displacement) {
    body.values.resize(src.size());
    for (std::size_t s = 0; s < src.size(); ++s) {
      const std::size_t n = std::size_t(src[s]);
      double d2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double d = double(L.x[k][n]) - double(L.X[k][n]);
        d2 += d * d;
      }
      body.values[s] = float(std::sqrt(d2));
    }
  } else if (field == Field::von_mises) {
    // Per-tet von Mises stress averaged over the tets around each surface node.
    const World::Snapshot snap = world.snapshot(b, level);
    std::vector<std::int32_t> index(L.node_count, -1);
    for (std::size_t s = 0; s < src.size(); ++s) index[std::size_t(src[s])] = std::int32_t(s);
    std::vector<double> sum(src.size(), 0.0);
    std::vector<int> count(src.size(), 0);
    for (std::size_t t = 0; t < snap.tets.size(); ++t)
      for (int a = 0; a < 4; ++a) {
        const std::int32_t s = index[std::size_t(snap.tets[t][a])];
        if (s < 0) continue;
        sum[std::size_t(s)] += snap.von_mises[t];
        ++count[std::size_t(s)];
      }
    body.values.resize(src.size());
    for (std::size_t s = 0; s < src.size(); ++s) body.values[s] = count[s] ? float(sum[s] / count[s]) : 0.f;
  }
  return body;
}

// A body of several levels (multiresolution): the boundary of the part each level steps, from the
// level's snapshot (world frame, ghosts where their sources are now), coloured by the field or by
// the level itself. The stepped parts are fixed during a run, but cheap to redo: no cache.
template <class T>
SurfaceBody capture_levels(const World& world, BodyId b, Field field) {
  auto topo = std::make_shared<SurfaceTopology>();
  topo->name = world.body_def(b).name;
  SurfaceBody body;
  const Vec3d origin = world.body_origin(b);
  const double tol = 1e-9;  // m: regions select nodes on their faces (build_level uses 1e-9 of the size)
  for (int l = 0; l < world.level_count(b); ++l) {
    const World::Snapshot snap = world.snapshot(b, l);
    if (snap.tets.empty()) continue;
    const Level<T>& L = world.level<T>(b, l);
    std::vector<std::int32_t> index(L.node_count, -1);
    std::vector<double> vm_sum;
    std::vector<int> vm_count;
    const std::size_t first = topo->source_node.size();
    for (const auto& tri : boundary_triangles(snap.tets)) {
      std::array<std::int32_t, 3> t{};
      for (int k = 0; k < 3; ++k) {
        std::int32_t& slot = index[std::size_t(tri[std::size_t(k)])];
        if (slot < 0) {
          slot = std::int32_t(topo->source_node.size());
          topo->source_node.push_back(tri[std::size_t(k)]);
          const std::size_t n = std::size_t(tri[std::size_t(k)]);
          for (int d = 0; d < 3; ++d) body.points.push_back(float(snap.points[3 * n + std::size_t(d)]));
          if (L.state[n] == kNodeFixed) {
            bool moved = false;
            for (const auto& m : world.body_def(b).prescribed) moved = moved || in_region(m.region, L, origin, n, tol);
            (moved ? topo->driven : topo->fixed).push_back(slot);
          }
        }
        t[std::size_t(k)] = slot;
      }
      topo->triangles.push_back(t);
    }
    const std::size_t count = topo->source_node.size() - first;
    if (field == Field::displacement || field == Field::level) {
      for (std::size_t s = first; s < first + count; ++s) {
        const std::size_t n = std::size_t(topo->source_node[s]);
        const double* d = &snap.displacement[3 * n];
        body.values.push_back(field == Field::level ? float(l) : float(std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])));
      }
    } else if (field == Field::von_mises) {  // averaged over the stepped tets around each surface node
      vm_sum.assign(count, 0.0);
      vm_count.assign(count, 0);
      for (std::size_t t = 0; t < snap.tets.size(); ++t)
        for (int a = 0; a < 4; ++a) {
          const std::int32_t s = index[std::size_t(snap.tets[t][std::size_t(a)])];
          if (s < 0) continue;
          vm_sum[std::size_t(s) - first] += snap.von_mises[t];
          ++vm_count[std::size_t(s) - first];
        }
      for (std::size_t s = 0; s < count; ++s) body.values.push_back(vm_count[s] ? float(vm_sum[s] / vm_count[s]) : 0.f);
    }
  }
  body.topology = topo;
  return body;
}

}  // namespace

Field parse_field(std::string_view name, std::string_view what) {
  if (name == "displacement") return Field::displacement;
  if (name == "von_mises") return Field::von_mises;
  if (name == "level") return Field::level;
  if (name == "none") return Field::none;
  throw InputError(
      fmt::format("{}: unknown field \"{}\"; expected one of displacement, von_mises, level, none", what, name));
}

const char* to_string(Field f) {
  switch (f) {
    case Field::displacement: return "displacement";
    case Field::von_mises: return "von_mises";
    case Field::level: return "level";
    default: return "none";
  }
}
const char* field_unit(Field f) { return f == Field::displacement ? "m" : f == Field::von_mises ? "Pa" : ""; }
const char* field_title(Field f) {
  return f == Field::displacement ? "displacement"
         : f == Field::von_mises  ? "von Mises stress"
         : f == Field::level      ? "level (0 = coarsest)"
                                  : "";
}

CameraPreset parse_camera_preset(std::string_view name, std::string_view what) {
  if (name == "scene") return CameraPreset::scene;
  if (name == "auto") return CameraPreset::automatic;
  if (name == "front") return CameraPreset::front;
  if (name == "side") return CameraPreset::side;
  if (name == "top") return CameraPreset::top;
  throw InputError(fmt::format("{}: unknown camera \"{}\"; expected one of scene, auto, front, side, top", what, name));
}

void validate_camera(const CameraDef& c, std::string_view what) {
  auto finite = [&](const Vec3d& v, const char* field) {
    for (double x : v)
      if (!std::isfinite(x)) throw InputError(fmt::format("{}.{}: must be finite, got [{}]", what, field, fmt::join(v, ", ")));
  };
  finite(c.position, "position");
  finite(c.target, "target");
  finite(c.up, "up");
  if (!(c.fov_deg > 0 && c.fov_deg < 180))
    throw InputError(fmt::format("{}.fov_deg: must be in (0, 180) (degrees), got {}", what, c.fov_deg));
  const Vec3d d{c.target[0] - c.position[0], c.target[1] - c.position[1], c.target[2] - c.position[2]};
  const double dd = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (!(dd > 0)) throw InputError(fmt::format("{}.target: must differ from position", what));
  const Vec3d& u = c.up;
  const double uu = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  if (!(uu > 0)) throw InputError(fmt::format("{}.up: must not be [0, 0, 0]", what));
  const Vec3d x{d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2], d[0] * u[1] - d[1] * u[0]};
  if (!(std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) > 1e-6 * dd * uu))
    throw InputError(fmt::format("{}.up: is along the view direction (target - position)", what));
}

std::array<int, 2> parse_size(std::string_view text, std::string_view what) {
  const std::size_t x = text.find_first_of("xX");
  int v[2] = {0, 0};
  bool ok = x != std::string_view::npos && x > 0 && x + 1 < text.size() && text.size() < 16;
  if (ok) {
    const std::string_view parts[2] = {text.substr(0, x), text.substr(x + 1)};
    for (int k = 0; k < 2 && ok; ++k)
      for (char c : parts[k]) {
        if (c < '0' || c > '9') {
          ok = false;
          break;
        }
        v[k] = v[k] * 10 + (c - '0');
      }
  }
  if (!ok) throw InputError(fmt::format("{}: expected WIDTHxHEIGHT in pixels, like 1280x720; got \"{}\"", what, text));
  for (int k = 0; k < 2; ++k)
    if (v[k] < 16 || v[k] > 16384)
      throw InputError(fmt::format("{}: {} {} is outside [16, 16384] pixels", what, k == 0 ? "width" : "height", v[k]));
  return {v[0], v[1]};
}

Vec3d parse_direction(std::string_view text, std::string_view what) {
  std::string t(text);
  for (char& c : t) c = char(std::tolower(static_cast<unsigned char>(c)));
  const bool neg = !t.empty() && t[0] == '-';
  const std::string axis = neg || (!t.empty() && t[0] == '+') ? t.substr(1) : t;
  if (axis == "x" || axis == "y" || axis == "z") {
    Vec3d v{0, 0, 0};
    v[std::size_t(axis[0] - 'x')] = neg ? -1 : 1;
    return v;
  }
  Vec3d v{};
  std::size_t pos = 0;
  int k = 0;
  bool ok = true;
  for (; k < 3 && ok; ++k) {
    const std::size_t end = k < 2 ? t.find(',', pos) : t.size();
    if (end == std::string::npos) {
      ok = false;
      break;
    }
    const std::string part = t.substr(pos, end - pos);
    char* stop = nullptr;
    v[std::size_t(k)] = std::strtod(part.c_str(), &stop);
    ok = !part.empty() && stop == part.c_str() + part.size() && std::isfinite(v[std::size_t(k)]);
    pos = end + 1;
  }
  if (!ok || k != 3)
    throw InputError(fmt::format("{}: expected an axis (x, y, z, -x, -y, -z) or three numbers X,Y,Z; got \"{}\"", what, text));
  if (!(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] > 0)) throw InputError(fmt::format("{}: must not be 0,0,0", what));
  return v;
}

std::size_t Frame::bytes() const {
  std::size_t n = sizeof(Frame);
  for (const auto& b : bodies) n += sizeof(SurfaceBody) + 4 * (b.points.capacity() + b.values.capacity());
  for (const auto& p : probes) n += sizeof(ProbeMark) + p.name.capacity();
  return n;
}

// A body with a skin (pliant/skin.hpp) is drawn by its skin: the render surface the host gave,
// following the simulated mesh, coloured by its own displacement. Fields defined per element
// (von Mises) or per level are drawn on the tet boundary instead.
static SurfaceBody capture_skin(const World& world, BodyId b, Field field, std::shared_ptr<const SurfaceTopology>& cached) {
  if (!cached || !cached->source_node.empty()) {
    auto topo = std::make_shared<SurfaceTopology>();
    topo->name = world.body_def(b).name;
    topo->triangles = world.skin_triangles(b);
    cached = topo;
  }
  SurfaceBody body;
  body.topology = cached;
  std::vector<double> now;
  world.skin_positions(b, now);
  const std::vector<double>& rest = world.skin_rest_positions(b);
  body.points.assign(now.begin(), now.end());
  if (field == Field::displacement) {
    body.values.resize(now.size() / 3);
    for (std::size_t i = 0; i < body.values.size(); ++i) {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) d2 += (now[3 * i + k] - rest[3 * i + k]) * (now[3 * i + k] - rest[3 * i + k]);
      body.values[i] = float(std::sqrt(d2));
    }
  }
  return body;
}

Frame capture(const World& world, Field field, CaptureCache* cache) {
  Frame f;
  f.time = world.time();
  f.field = field;
  CaptureCache local;
  CaptureCache& c = cache ? *cache : local;
  c.bodies.resize(world.body_count());
  for (std::size_t b = 0; b < world.body_count(); ++b) {
    if (world.has_skin(BodyId(b)) && (field == Field::displacement || field == Field::none)) {
      f.bodies.push_back(capture_skin(world, BodyId(b), field, c.bodies[b]));
      continue;
    }
    if (world.precision() == Precision::float32)
      f.bodies.push_back(capture_body<float>(world, BodyId(b), field, c.bodies[b]));
    else
      f.bodies.push_back(capture_body<double>(world, BodyId(b), field, c.bodies[b]));
  }
  for (std::size_t p = 0; p < world.probe_count(); ++p)
    f.probes.push_back({world.probe_name(int(p)), world.probe_position(int(p))});
  for (const ObstacleDef& o : world.obstacles()) f.obstacles.push_back({o.point, o.normal});
  for (std::size_t t = 0; t < world.tool_count(); ++t) {
    ToolMark m;
    tool_axis(world.tool_def(ToolId(t)).shape, world.tool_pose(ToolId(t)), m.a, m.b);
    m.radius = world.tool_def(ToolId(t)).shape.radius;
    f.tools.push_back(m);
  }
  return f;
}

Frame frame_from_mesh(const TetMesh& mesh, const std::string& name, Field field, const TetMesh* rest,
                      const StoredFields* stored) {
  const bool stored_disp = stored && stored->displacement.size() == 3 * mesh.node_count() && mesh.node_count() > 0;
  const bool stored_vm = stored && stored->von_mises.size() == mesh.tet_count() && mesh.tet_count() > 0;
  const std::string why = stored && !stored->note.empty() ? fmt::format(" ({})", stored->note) : "";
  if (field == Field::von_mises && !stored_vm)
    throw InputError(fmt::format("{}: --field von_mises needs the file's \"von_mises\" cell field, as the .vtu files of "
                                 "`pliant run` store it; this file has none{}; use --field {}",
                                 name, why, stored_disp || rest ? "displacement or none" : "none (or displacement with --rest FILE)"));
  if (field == Field::displacement && !rest && !stored_disp)
    throw InputError(fmt::format("{}: --field displacement needs a \"displacement\" point field, as the .vtu files of "
                                 "`pliant run` store it, or the rest state of the mesh (e.g. the series' first frame, "
                                 "--rest FILE); this file has no such field{}",
                                 name, why));
  if (rest && rest->node_count() != mesh.node_count())
    throw InputError(fmt::format("{}: the rest mesh has {} nodes, this one {}; they must be the same mesh", name,
                                 rest->node_count(), mesh.node_count()));
  auto topo = std::make_shared<SurfaceTopology>();
  topo->name = name;
  std::vector<std::int32_t> index(mesh.node_count(), -1);
  for (const auto& tri : boundary_triangles(mesh.tets)) {
    std::array<std::int32_t, 3> t{};
    for (int k = 0; k < 3; ++k) {
      std::int32_t& slot = index[std::size_t(tri[k])];
      if (slot < 0) {
        slot = std::int32_t(topo->source_node.size());
        topo->source_node.push_back(tri[k]);
      }
      t[k] = slot;
    }
    topo->triangles.push_back(t);
  }
  Frame f;
  f.has_time = stored && stored->time.has_value();
  f.time = f.has_time ? *stored->time : 0.0;
  f.field = field;
  SurfaceBody body;
  body.topology = topo;
  for (std::int32_t n : topo->source_node)
    for (int k = 0; k < 3; ++k) body.points.push_back(float(mesh.points[3 * std::size_t(n) + k]));
  if (field == Field::displacement) {
    for (std::int32_t n : topo->source_node) {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) {
        const std::size_t i = 3 * std::size_t(n) + k;
        const double d = rest ? mesh.points[i] - rest->points[i] : stored->displacement[i];
        d2 += d * d;
      }
      body.values.push_back(float(std::sqrt(d2)));
    }
  } else if (field == Field::von_mises) {
    // Per-tet von Mises stress averaged over the tets around each surface node, as capture() does.
    std::vector<double> sum(topo->source_node.size(), 0.0);
    std::vector<int> count(topo->source_node.size(), 0);
    for (std::size_t t = 0; t < mesh.tets.size(); ++t)
      for (int a = 0; a < 4; ++a) {
        const std::int32_t s = index[std::size_t(mesh.tets[t][a])];
        if (s < 0 || !std::isfinite(stored->von_mises[t])) continue;
        sum[std::size_t(s)] += stored->von_mises[t];
        ++count[std::size_t(s)];
      }
    for (std::size_t s = 0; s < sum.size(); ++s) body.values.push_back(count[s] ? float(sum[s] / count[s]) : 0.f);
  }
  f.bodies.push_back(std::move(body));
  return f;
}

void Bounds::add(const Vec3d& p) {
  for (int k = 0; k < 3; ++k) {
    min[k] = std::min(min[k], p[k]);
    max[k] = std::max(max[k], p[k]);
  }
}
void Bounds::add(const Bounds& b) {
  if (b.empty()) return;
  add(b.min);
  add(b.max);
}

Bounds bounds_of(const Frame& frame) {
  Bounds b;
  for (const auto& body : frame.bodies)
    for (std::size_t i = 0; i + 2 < body.points.size(); i += 3)
      if (std::isfinite(body.points[i]) && std::isfinite(body.points[i + 1]) && std::isfinite(body.points[i + 2]))
        b.add(Vec3d{double(body.points[i]), double(body.points[i + 1]), double(body.points[i + 2])});
  for (const auto& p : frame.probes) b.add(p.position);
  return b;
}

std::vector<Vec3d> framing_sample(const Frame& frame, std::size_t max_points) {
  std::size_t total = 0;
  for (const auto& b : frame.bodies) total += b.points.size() / 3;
  const std::size_t stride = std::max<std::size_t>(1, (total + max_points - 1) / std::max<std::size_t>(max_points, 1));
  std::vector<Vec3d> out;
  out.reserve(total / stride + frame.probes.size() + 1);
  for (const auto& b : frame.bodies)
    for (std::size_t i = 0; 3 * i + 2 < b.points.size(); i += stride) {
      const Vec3d p{double(b.points[3 * i]), double(b.points[3 * i + 1]), double(b.points[3 * i + 2])};
      if (std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])) out.push_back(p);
    }
  for (const auto& p : frame.probes) out.push_back(p.position);
  return out;
}

double max_value(const Frame& frame) {
  double m = 0;
  for (const auto& b : frame.bodies)
    for (float v : b.values)
      if (std::isfinite(v)) m = std::max(m, double(v));
  return m;
}

std::array<double, 2> default_range(const Frame& frame) {
  const double m = max_value(frame);
  if (m > 0) return {0.0, nice_number(m, true)};
  return {0.0, frame.field == Field::von_mises ? 1e3 : 1e-3};
}

}  // namespace pliant::raster
