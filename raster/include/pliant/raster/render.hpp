// Headless pictures of soft bodies: the boundary surface of every body, smooth-shaded (normals
// averaged over the boundary triangles, split at creases), coloured by a field with a colour
// bar in its units, fixed and driven nodes marked, probes drawn, a ground grid under the lowest
// point, the simulated time printed. OpenGL runs in software through OSMesa (llvmpipe); no
// display, no GPU. OSMesa is used in this module only (renderer.cpp).
//
// Two steps: capture() copies what a picture needs out of a World (read-only, cheap, O(nodes)),
// Renderer::render() draws a captured Frame. Keeping them apart lets `pliant run` capture during
// the run and render afterwards with a camera and colour range common to every frame.
#pragma once
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pliant/defs.hpp"
#include "pliant/raster/image.hpp"
#include "pliant/tet_mesh.hpp"

namespace pliant {
class World;
}

namespace pliant::raster {

// What colours the surface.
// level: the level of a multiresolution body that steps each part of its surface (0 = coarsest).
enum class Field { none, displacement, von_mises, level };
// "displacement" | "von_mises" | "none"; anything else throws InputError naming `what`
// (e.g. "--field") and listing the choices.
Field parse_field(std::string_view name, std::string_view what = "field");
const char* to_string(Field f);
const char* field_unit(Field f);   // "m", "Pa" or ""
const char* field_title(Field f);  // "displacement", "von Mises stress", ""

// The surface of one body at one instant. Topology is shared between the frames of a run.
struct SurfaceTopology {
  std::string name;
  std::vector<std::array<std::int32_t, 3>> triangles;  // outward, indices into the surface nodes
  std::vector<std::int32_t> fixed;       // surface nodes held at rest (drawn magenta, dark outline)
  std::vector<std::int32_t> driven;      // surface nodes moved by prescribed motion (drawn orange)
  std::vector<std::int32_t> source_node; // surface node -> node of the body's level
};
struct SurfaceBody {
  std::shared_ptr<const SurfaceTopology> topology;
  std::vector<float> points;  // x y z per surface node (m)
  std::vector<float> values;  // per surface node, in the field's SI unit; empty for Field::none
};
struct ProbeMark {
  std::string name;
  Vec3d position{};  // m
};
// A static obstacle (WorldDef::obstacles): drawn as a floor patch under the bodies.
struct ObstacleMark {
  Vec3d point{}, normal{0, 0, 1};  // m; normal of unit length, out of the solid
};
// A tool (World tools, docs/tool.md): drawn as a shaded grey sphere or capsule.
struct ToolMark {
  Vec3d a{}, b{};     // m, the ends of its axis (equal for a sphere)
  double radius = 0;  // m
};
struct Frame {
  double time = 0;           // s
  bool has_time = true;      // false: a state of unknown time (a mesh file)
  Field field = Field::none;
  std::vector<SurfaceBody> bodies;
  std::vector<ProbeMark> probes;
  std::vector<ObstacleMark> obstacles;  // drawn instead of the ground grid when there are any
  std::vector<ToolMark> tools;
  std::size_t bytes() const;  // memory held by the frame's own arrays
};

// Copies the surfaces (finest level of each body), field values, probes and time out of a
// world. Never writes to it. `cache` keeps the topology between calls for the same world.
struct CaptureCache {
  std::vector<std::shared_ptr<const SurfaceTopology>> bodies;
};
Frame capture(const World& world, Field field, CaptureCache* cache = nullptr);

// What a result file stores besides its mesh: `pliant run` writes every .vtu with the point
// field "displacement" (3 components, m) and the cell field "von_mises" (Pa), and lists it with
// its simulated time in OUT/series.pvd. Empty vectors when the file has no such field.
struct StoredFields {
  std::vector<double> displacement;  // 3 per node of the mesh as read, or empty
  std::vector<double> von_mises;     // 1 per tet of the mesh as read, or empty
  std::optional<double> time;        // s: a "TimeValue" field-data array, else the .pvd entry
  std::string note;                  // why fields present in the file cannot be used, if so
};
// Reads the fields of a .vtu (inline ascii or base64 binary, zlib or not; a field whose counts
// do not match `mesh`, the file as read by read_tet_mesh, is left out with a note) and its time.
// Never throws for a file it cannot decode: the fields are then absent.
StoredFields read_stored_fields(const std::filesystem::path& file, const TetMesh& mesh);
// The time of `file` in a ParaView .pvd collection of its folder or of the folder above that
// lists it (as `pliant run` writes OUT/series.pvd for OUT/vtu/*.vtu); nullopt if none does.
std::optional<double> series_time(const std::filesystem::path& file);

// A frame of one tet mesh (e.g. a .vtu result): its boundary surface. The displacement field
// is points - rest points with `rest` (same node count, else InputError), else the stored
// displacement; von_mises needs the stored cell field (averaged over the tets around each
// surface node). A field that cannot be had is an InputError saying what is missing. The
// frame's time is the stored one, when known.
Frame frame_from_mesh(const TetMesh& mesh, const std::string& name, Field field,
                      const TetMesh* rest = nullptr, const StoredFields* stored = nullptr);

// "WIDTHxHEIGHT" (e.g. "1280x720"), each in [16, 16384]; else InputError naming `what`.
std::array<int, 2> parse_size(std::string_view text, std::string_view what = "size");

// A direction: an axis ("x", "y", "z", "-x", "-y", "-z") or "X,Y,Z" (not zero); else InputError
// naming `what` (e.g. "--up").
Vec3d parse_direction(std::string_view text, std::string_view what = "direction");

// Up to about `max_points` surface points of a frame (every k-th node, and the probes), for
// RenderOptions::framing_points.
std::vector<Vec3d> framing_sample(const Frame& frame, std::size_t max_points = 4096);

// Axis-aligned bounds of everything a frame shows (m).
struct Bounds {
  Vec3d min{1e300, 1e300, 1e300}, max{-1e300, -1e300, -1e300};
  bool empty() const { return min[0] > max[0]; }
  void add(const Vec3d& p);
  void add(const Bounds& b);
};
Bounds bounds_of(const Frame& frame);

// Camera choices: "scene" (the scene's camera block, or auto without one), "auto" (fits the
// bounds, 3/4 view from above), "front", "side", "top". Anything else throws InputError naming
// `what` and listing the choices.
enum class CameraPreset { scene, automatic, front, side, top };
CameraPreset parse_camera_preset(std::string_view name, std::string_view what = "camera");

// Checks a camera block (finite numbers, position != target, up not along the view, fov in
// (0, 180)); throws InputError "<what>.<field>: ..." naming the bad field.
void validate_camera(const CameraDef& camera, std::string_view what = "camera");

struct RenderOptions {
  int width = 1280, height = 720;                 // pixels, each in [16, 16384]
  CameraPreset preset = CameraPreset::scene;
  std::optional<CameraDef> camera;                // the scene's camera block (used by preset scene)
  Vec3d up{0, 0, 1};                              // world up (from gravity): auto views and grid
  // The automatic camera's direction around the target, in degrees: azimuth about `up`, from the
  // front (0: looking from the -e2 side, with e1, e2 the ground axes of plane_axes, i.e. from -y
  // for z up; 90: from +e1, the side view), elevation above the ground plane (90: from above).
  // When either is set it overrides the preset's direction and the scene's camera block (the
  // other keeps its default of 30 or 25 degrees); the view is still fitted to the bodies.
  std::optional<double> azimuth_deg, elevation_deg;
  std::optional<Bounds> framing;                  // what the grid spans (and the auto camera fits); default: the frame's bounds
  std::vector<Vec3d> framing_points;              // what the auto camera fits, if given (e.g. a sample of a whole run)
  std::optional<std::array<double, 2>> range;     // colour range in SI units; default [0, nice max of the frame]
  std::string title;                              // top-left, after the time
  int caption_height = 0;                         // pixels at the top kept free of bodies (for a caption drawn later)
  // grid: the ground grid under the lowest point, or, when the frame has obstacles, the obstacles
  // (a patch of each plane with its own grid lines) instead.
  bool colour_bar = true, time_label = true, grid = true, marks = true, probe_labels = true, legend = true;
  bool axes = true;       // an x/y/z axis marker, bottom left: the world axes as the camera sees them
  bool scale_bar = true;  // a bar of a round length (1, 2 or 5 x 10^k m, in m, cm, mm or um), bottom right,
                          // true at the depth of the view's target (perspective: nearer things look larger)
  int samples = 4;                                // multisample anti-aliasing (1 = off)
  int text_scale = 0;                             // 0: from the height (1 per 360 px)
};

// The range a frame's field would get by default: [0, nice ceiling of its largest value]
// ([0, 1 mm] or [0, 1 kPa] when everything is zero).
std::array<double, 2> default_range(const Frame& frame);
// Largest field value of a frame (0 if none).
double max_value(const Frame& frame);

// The colour bar drawn by the renderer, for composing (contact sheets): a vertical (or
// horizontal) gradient with ticks and "title [unit]" in a box of the given size.
void draw_colour_bar(Image& image, int x, int y, int w, int h, Field field, std::array<double, 2> range,
                     int text_scale, bool horizontal = false);

// Owns an OSMesa context and its buffers; reuse one for many frames. Not thread-safe: use it
// from one thread. Throws std::runtime_error if OSMesa cannot make a context.
class Renderer {
 public:
  Renderer();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  Image render(const Frame& frame, const RenderOptions& options);
  // Also returns the body's silhouette: one byte per pixel (top row first), 1 where a body
  // surface is the nearest thing, else 0 (for tests and compositing).
  Image render(const Frame& frame, const RenderOptions& options, std::vector<std::uint8_t>* body_mask);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The view Renderer::render uses for a frame (for tests and tools): eye, target, up and vertical
// field of view.
struct View {
  Vec3d position{}, target{}, up{0, 0, 1};
  double fov_deg = 30;
};
View resolve_view(const Frame& frame, const RenderOptions& options);

}  // namespace pliant::raster
