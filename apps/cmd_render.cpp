// `pliant render SCENE|MESH -o OUT.png`: one picture. A scene file is shown in its rest state
// (the world is built, never stepped), with its fixed and driven regions and probes marked; a
// volume mesh file (e.g. a .vtu frame of a run, whose points are already displaced) is shown as
// stored, coloured by the displacement it stores (a run's .vtu files do; else --rest gives the
// rest state) or by its stored von Mises stress, with its time when a .pvd series lists it.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>

#include "commands.hpp"
#include "pliant/error.hpp"
#include "pliant/mesh_io.hpp"
#include "pliant/raster/image.hpp"
#include "pliant/raster/render.hpp"
#include "pliant/run.hpp"
#include "pliant/scene.hpp"

namespace pliant::cli {
namespace {
namespace fs = std::filesystem;

struct RenderArgs {
  std::string input, output, field, size = "1280x720", camera = "scene", rest, up;
  std::optional<double> azimuth, elevation;  // degrees
  bool quiet = false;
};

}  // namespace

void refuse_overwriting_input(const std::string& input, const std::string& output, const char* option) {
  if (input.empty() || output.empty()) return;
  std::error_code ec;
  if (std::filesystem::equivalent(input, output, ec))
    throw InputError(fmt::format("{} {}: is the input file; give another path for the output", option, output));
}

void set_view(std::optional<double>& azimuth_out, std::optional<double>& elevation_out, std::optional<double> azimuth,
              std::optional<double> elevation) {
  if (azimuth && !std::isfinite(*azimuth)) throw InputError(fmt::format("--azimuth must be finite (degrees), got {}", *azimuth));
  if (elevation && !(*elevation >= -90 && *elevation <= 90))
    throw InputError(fmt::format("--elevation must be in [-90, 90] (degrees), got {}", *elevation));
  azimuth_out = azimuth;
  elevation_out = elevation;
}

namespace {

int command_render(const RenderArgs& a) {
  std::string ext = fs::path(a.input).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  const auto size = raster::parse_size(a.size, "--size");
  raster::RenderOptions ro;
  ro.width = size[0];
  ro.height = size[1];
  ro.preset = raster::parse_camera_preset(a.camera, "--camera");
  ro.title = fs::path(a.input).filename().string();
  set_view(ro.azimuth_deg, ro.elevation_deg, a.azimuth, a.elevation);
  std::optional<raster::Field> field;
  if (!a.field.empty()) field = raster::parse_field(a.field, "--field");
  const fs::path out = a.output.empty() ? fs::path(a.input).stem().concat(".png") : fs::path(a.output);
  refuse_overwriting_input(a.input, out.string(), "-o");

  raster::Frame frame;
  if (ext == ".json") {
    if (!a.rest.empty()) throw InputError("--rest is for mesh files; a scene is rendered in its rest state");
    const SceneDef scene = load_scene_file(a.input);
    if (scene.camera) ro.camera = scene.camera;
    const Vec3d g = scene.world.gravity;
    const double gn = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    if (gn > 0) ro.up = {-g[0] / gn, -g[1] / gn, -g[2] / gn};
    if (!a.up.empty()) ro.up = raster::parse_direction(a.up, "--up");
    RunOptions run;
    run.threads = 1;  // building the world only: no stepping
    const World world = make_world(scene, run);
    frame = raster::capture(world, field.value_or(raster::Field::none));
  } else {
    if (!a.up.empty()) ro.up = raster::parse_direction(a.up, "--up");
    const TetMesh mesh = read_tet_mesh(a.input);
    std::optional<TetMesh> rest;
    if (!a.rest.empty()) rest = read_tet_mesh(a.rest);
    // A run's .vtu stores its displacement and von Mises fields, and its .pvd the time.
    const raster::StoredFields stored = raster::read_stored_fields(a.input, mesh);
    const bool has_disp = rest || !stored.displacement.empty();
    frame = raster::frame_from_mesh(mesh, fs::path(a.input).filename().string(),
                                    field.value_or(has_disp ? raster::Field::displacement : raster::Field::none),
                                    rest ? &*rest : nullptr, &stored);
    if (!a.quiet && !stored.note.empty()) fmt::print(stderr, "pliant: note: {}\n", stored.note);
  }
  raster::Renderer renderer;
  const raster::Image image = renderer.render(frame, ro);
  raster::write_png(image, out);
  if (!a.quiet)
    fmt::print("wrote {} ({}x{}, {}{})\n", out.string(), image.width(), image.height(), to_string(frame.field),
               frame.has_time ? fmt::format(", t = {:.4g} s", frame.time) : "");
  return 0;
}

}  // namespace

void add_view_options(CLI::App* sub, std::string& up, std::optional<double>& azimuth, std::optional<double>& elevation) {
  sub->add_option("--up", up, "The direction shown upwards: x, y, z, -x, -y, -z or X,Y,Z (default: against gravity; z for a mesh)");
  sub->add_option("--azimuth", azimuth,
                  "View direction around the up axis, degrees: 0 from the front (from -y when z is up), 90 from the side "
                  "(+x); default 30. Overrides --camera's direction and the scene's camera; the view still fits the bodies");
  sub->add_option("--elevation", elevation, "View elevation above the ground plane, degrees in [-90, 90] (90: from above); default 25");
}

Command add_render_command(CLI::App& app) {
  auto a = std::make_shared<RenderArgs>();
  auto* sub = app.add_subcommand("render", "Render a scene (rest state) or a volume mesh file (e.g. a .vtu result) to PNG");
  sub->add_option("INPUT", a->input, "Scene file (.json) or volume mesh (.vtu, .vtk, .msh, .node/.ele)")->required();
  sub->add_option("--output,-o", a->output, "PNG file to write (default: INPUT's name with .png, here)");
  sub->add_option("--field", a->field,
                  "displacement, von_mises or none (default: none for a scene; for a mesh, displacement when it stores one or --rest is given)");
  sub->add_option("--size", a->size, "Picture size WIDTHxHEIGHT in pixels")->capture_default_str();
  sub->add_option("--camera", a->camera, "scene (the scene's camera block, else auto), auto, front, side or top")
      ->capture_default_str();
  add_view_options(sub, a->up, a->azimuth, a->elevation);
  sub->add_option("--rest", a->rest, "For a mesh: its rest state (same nodes), to colour by displacement when the file stores none");
  sub->add_flag("--quiet,-q", a->quiet, "Print nothing");
  return {sub, [a] { return command_render(*a); }};
}

}  // namespace pliant::cli
