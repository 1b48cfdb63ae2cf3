// Pictures of bodies: a render of a known scene is not blank, shows the body where the camera
// looks, has the requested size and matches a committed reference within a tolerance meant to
// survive Mesa/llvmpipe versions (mean absolute difference and silhouette overlap, not bytes);
// bad field and camera names are clear errors; taking pictures during a run leaves the state
// hash unchanged; the recorder writes numbered frames and a contact sheet.
//
// To regenerate the reference after an intended change of the pictures:
//   PLIANT_UPDATE_REFERENCE=1 ./test_render --gtest_filter='*Reference*'
// and look at tests/raster/data/beam_reference.png before committing it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "../support/special_files.hpp"
#include "pliant/error.hpp"
#include "pliant/mesh_io.hpp"
#include "pliant/raster/image.hpp"
#include "pliant/raster/recorder.hpp"
#include "pliant/raster/render.hpp"
#include "pliant/run.hpp"
#include "pliant/scene.hpp"
#include "pliant/vtu_writer.hpp"
#include "pliant/world.hpp"
// White box: the overlay helpers (raster/src/, private).
#include "../../raster/src/overlay.hpp"

namespace {
// Removes this process's scratch folder when the tests end.
struct ScratchCleanup : ::testing::Environment {
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(std::filesystem::temp_directory_path() / ("pliant_test_raster_" + std::to_string(::getpid())), ec);
  }
};
const auto* const kCleanup = ::testing::AddGlobalTestEnvironment(new ScratchCleanup);

using namespace pliant;
using namespace pliant::raster;
namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kData = fs::path(PLIANT_SOURCE_DIR) / "tests" / "raster" / "data";

fs::path scratch(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("pliant_test_raster_" + std::to_string(::getpid())) / name;
  fs::create_directories(p);
  return p;
}

// A 1 m x 0.1 m x 0.1 m beam bent downwards along x (an analytic shape, no simulation), fixed
// at x = 0, a probe at its tip, coloured by displacement.
Frame bent_beam(Field field = Field::displacement) {
  TetMesh rest = make_box_mesh({0, 0, 0}, {1, 0.1, 0.1}, {20, 2, 2}, 6);
  TetMesh bent = rest;
  for (std::size_t i = 0; i < bent.node_count(); ++i) {
    const double x = rest.points[3 * i];
    bent.points[3 * i + 2] -= 0.25 * x * x;
  }
  Frame f = frame_from_mesh(bent, "beam", field, field == Field::displacement ? &rest : nullptr);
  // Mark the clamped end as fixed, as a world would.
  auto topo = std::make_shared<SurfaceTopology>(*f.bodies[0].topology);
  for (std::size_t s = 0; s < topo->source_node.size(); ++s)
    if (rest.points[3 * std::size_t(topo->source_node[s])] == 0.0) topo->fixed.push_back(std::int32_t(s));
  f.bodies[0].topology = topo;
  f.has_time = true;
  f.time = 0.25;
  f.probes.push_back({"tip", {1.0, 0.05, 0.05 - 0.25}});
  return f;
}

std::size_t count(const std::vector<std::uint8_t>& mask) {
  std::size_t n = 0;
  for (auto m : mask) n += m;
  return n;
}

Renderer& renderer() {
  static Renderer r;
  return r;
}

TEST(Render, NotBlankAndOfTheRequestedSize) {
  const Frame f = bent_beam();
  for (auto [w, h] : {std::pair{320, 180}, {200, 300}, {641, 377}}) {
    RenderOptions o;
    o.width = w;
    o.height = h;
    std::vector<std::uint8_t> mask;
    const Image img = renderer().render(f, o, &mask);
    EXPECT_EQ(img.width(), w);
    EXPECT_EQ(img.height(), h);
    ASSERT_EQ(mask.size(), std::size_t(w) * h);
    const double covered = double(count(mask)) / double(mask.size());
    EXPECT_GT(covered, 0.03) << w << "x" << h;
    EXPECT_LT(covered, 0.8) << w << "x" << h;
    // Many distinct colours (shading, colour map), not a flat picture.
    std::vector<std::uint32_t> colours;
    for (int y = 0; y < h; y += 3)
      for (int x = 0; x < w; x += 3) {
        const Rgba c = img.get(x, y);
        colours.push_back(std::uint32_t(c.r) << 16 | std::uint32_t(c.g) << 8 | c.b);
      }
    std::sort(colours.begin(), colours.end());
    colours.erase(std::unique(colours.begin(), colours.end()), colours.end());
    EXPECT_GT(colours.size(), 100u);
    // The written file has the size too.
    const fs::path png = scratch("size") / "beam.png";
    write_png(img, png);
    const Image back = read_png(png);
    EXPECT_EQ(back.width(), w);
    EXPECT_EQ(back.height(), h);
    EXPECT_EQ(back.bytes(), img.bytes());
  }
}

TEST(Render, BodyIsWhereTheCameraLooks) {
  const Frame f = bent_beam();
  RenderOptions o;
  o.width = 400;
  o.height = 300;
  o.colour_bar = o.time_label = o.legend = false;  // the view fills the picture: target at its centre
  o.camera = CameraDef{{0.5, -1.2, 0.4}, {0.5, 0.05, 0.05 - 0.0625}, {0, 0, 1}, 35};
  std::vector<std::uint8_t> mask;
  renderer().render(f, o, &mask);
  EXPECT_EQ(resolve_view(f, o).position, o.camera->position);
  EXPECT_EQ(resolve_view(f, o).target, o.camera->target);
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx) EXPECT_EQ(mask[std::size_t(150 + dy) * 400 + 200 + dx], 1);
  // Looking the other way: no body at all.
  o.camera = CameraDef{{0.5, -1.2, 0.4}, {0.5, -3, 0.4}, {0, 0, 1}, 35};
  renderer().render(f, o, &mask);
  EXPECT_EQ(count(mask), 0u);
  // The automatic camera frames the whole body: silhouette inside, touching no edge; it looks
  // from above, from the front (-y) side.
  o.camera.reset();
  const View v = resolve_view(f, o);
  EXPECT_GT(v.position[2], v.target[2]);
  EXPECT_LT(v.position[1], v.target[1]);
  renderer().render(f, o, &mask);
  ASSERT_GT(count(mask), 0u);
  for (int x = 0; x < 400; ++x) {
    EXPECT_EQ(mask[std::size_t(x)], 0);
    EXPECT_EQ(mask[std::size_t(299) * 400 + x], 0);
  }
  for (int y = 0; y < 300; ++y) {
    EXPECT_EQ(mask[std::size_t(y) * 400], 0);
    EXPECT_EQ(mask[std::size_t(y) * 400 + 399], 0);
  }
}

// The unit vector from the target to the eye of a view.
Vec3d eye_direction(const View& v) {
  Vec3d d{v.position[0] - v.target[0], v.position[1] - v.target[1], v.position[2] - v.target[2]};
  const double n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  for (double& c : d) c /= n;
  return d;
}

TEST(Render, AzimuthAndElevationChooseTheViewDirection) {
  const Frame f = bent_beam();
  RenderOptions o;
  o.width = 320;
  o.height = 240;
  struct Case {
    double az, el;
    Vec3d eye, up;  // expected, z up: azimuth 0 looks from -y, 90 from +x
  };
  const double c = std::sqrt(0.5);
  for (const Case& k : {Case{0, 0, {0, -1, 0}, {0, 0, 1}}, Case{90, 0, {1, 0, 0}, {0, 0, 1}},
                        Case{180, 45, {0, c, c}, {0, 0, 1}}, Case{0, 90, {0, 0, 1}, {0, 1, 0}},
                        Case{90, -90, {0, 0, -1}, {-1, 0, 0}}}) {
    o.azimuth_deg = k.az;
    o.elevation_deg = k.el;
    const View v = resolve_view(f, o);
    const Vec3d d = eye_direction(v);
    for (int i = 0; i < 3; ++i) {
      // measured 1.1e-16 (182), 6.1e-17 (183)
      EXPECT_NEAR(d[i], k.eye[i], 1e-15) << "azimuth " << k.az << " elevation " << k.el << " component " << i;
      EXPECT_NEAR(v.up[i], k.up[i], 6e-16) << "azimuth " << k.az << " elevation " << k.el << " up " << i;
    }
    std::vector<std::uint8_t> mask;
    renderer().render(f, o, &mask);
    EXPECT_GT(count(mask), 500u) << "the body is in view";
  }
  // A given direction overrides the scene's camera block; without one the block is used.
  o.camera = CameraDef{{0.5, -1.2, 0.4}, {0.5, 0.05, 0}, {0, 0, 1}, 35};
  o.azimuth_deg = 90;
  o.elevation_deg.reset();  // the default elevation, 25 degrees
  const Vec3d d = eye_direction(resolve_view(f, o));
  EXPECT_NEAR(d[2], std::sin(25 * std::acos(-1.0) / 180), 1e-15);  // measured 0
  // measured 5.5e-17
  EXPECT_NEAR(d[1], 0, 5e-16);
  o.azimuth_deg.reset();
  EXPECT_EQ(resolve_view(f, o).position, o.camera->position);
  // The up direction is the world's up of the options (y up: the eye is above in y).
  o.camera.reset();
  o.up = {0, 1, 0};
  o.elevation_deg = 60;
  EXPECT_NEAR(eye_direction(resolve_view(f, o))[1], std::sin(60 * std::acos(-1.0) / 180), 1e-15);  // measured 0
}

TEST(Render, TheScaleBarIsTrueAtTheTargetsDepth) {
  // A 1 m x 2 mm x 30 cm plate seen square on from the front: its silhouette's width (1 m, 1 mm
  // in front of the target's depth) against the bar's length.
  const Frame f = frame_from_mesh(make_box_mesh({0, 0, 0}, {1, 0.002, 0.3}, {10, 1, 3}, 6), "plate", Field::none);
  RenderOptions o;
  o.width = 800;
  o.height = 400;
  o.text_scale = 2;
  o.azimuth_deg = 0;
  o.elevation_deg = 0;
  o.grid = o.legend = o.time_label = o.axes = o.marks = false;
  std::vector<std::uint8_t> mask;
  const Image img = renderer().render(f, o, &mask);
  int left = o.width, right = -1;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x)
      if (mask[std::size_t(y) * o.width + x]) left = std::min(left, x), right = std::max(right, x);
  const double beam_px = right - left + 1;  // 1 m
  // The bar: a dark run on the row 9 text units above the bottom, ending 10 units from the right.
  const int s = 2, row = o.height - 8 * s - 1;
  int x1 = o.width - 10 * s - 1, x0 = x1;
  const auto dark = [&](int x) { const Rgba p = img.get(x, row); return p.r < 80 && p.g < 80 && p.b < 80; };
  ASSERT_TRUE(dark(x1));
  while (x0 > 0 && dark(x0 - 1)) --x0;
  const double bar_m = (x1 - x0 + 1) / beam_px;  // the bar's length in metres, as the beam measures it
  // A round length (here 10 cm: 1, 2 or 5 x 10^k m, at most a sixth of the width). Measured: 0.0997 m
  // (the silhouette's edge pixels).
  EXPECT_NEAR(bar_m, 0.1, 0.001) << "plate " << beam_px << " px, bar " << x1 - x0 + 1 << " px";
  // Without the bar, nothing dark there.
  o.scale_bar = false;
  const Image plain = renderer().render(f, o, &mask);
  const Rgba p = plain.get(x1, row);
  EXPECT_FALSE(p.r < 80 && p.g < 80 && p.b < 80);
}

TEST(Render, TheAxisMarkerShowsTheWorldAxes) {
  // From the front (azimuth 0, elevation 0, z up): x points right, z up, y into the picture.
  RenderOptions o;
  o.width = 400;
  o.height = 300;
  o.text_scale = 2;
  o.azimuth_deg = 0;
  o.elevation_deg = 0;
  o.legend = false;
  const Frame f = bent_beam(Field::none);
  const Image img = renderer().render(f, o);
  o.axes = false;
  const Image plain = renderer().render(f, o);
  // The marker's origin: 10 + 16 text units from the left, 8 + 16 units above the bottom.
  const int s = 2, ox = 26 * s, oy = o.height - 24 * s;
  const auto reddish = [](Rgba c) { return c.r > 150 && c.g < 100 && c.b < 100; };
  const auto bluish = [](Rgba c) { return c.b > 130 && c.r < 90; };
  EXPECT_TRUE(reddish(img.get(ox + 10 * s, oy))) << "x to the right";
  EXPECT_TRUE(bluish(img.get(ox, oy - 10 * s))) << "z upwards";
  EXPECT_FALSE(reddish(plain.get(ox + 10 * s, oy)));
  EXPECT_FALSE(bluish(plain.get(ox, oy - 10 * s)));
}

TEST(Render, ObstaclesAreDrawnAsTheFloorTheBodiesRestOn) {
  // The table-top colour of an obstacle patch (renderer.cpp), unlit.
  const auto table = [](Rgba c) { return std::abs(c.r - 204) < 6 && std::abs(c.g - 189) < 6 && std::abs(c.b - 163) < 6; };
  const auto count_table = [&](const Image& img) {
    std::size_t n = 0;
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x) n += table(img.get(x, y));
    return n;
  };
  Frame f = bent_beam(Field::none);
  RenderOptions o;
  o.width = 320;
  o.height = 180;
  EXPECT_EQ(count_table(renderer().render(f, o)), 0u);
  f.obstacles.push_back({{0, 0, -0.2}, {0, 0, 1}});  // a floor under the beam's tip
  const std::size_t with = count_table(renderer().render(f, o));
  EXPECT_GT(with, std::size_t(0.1 * 320 * 180));
  o.grid = false;
  EXPECT_EQ(count_table(renderer().render(f, o)), 0u);
  // A world's obstacles are captured with its bodies.
  WorldDef wd;
  wd.obstacles.push_back({{0, 0, -1}, {0, 0, 2}, 0.3});
  World w(wd);
  BodyDef b;
  b.name = "box";
  w.add_body(b);
  const Frame captured = capture(w, Field::none);
  ASSERT_EQ(captured.obstacles.size(), 1u);
  EXPECT_EQ(captured.obstacles[0].point, (Vec3d{0, 0, -1}));
  EXPECT_EQ(captured.obstacles[0].normal, (Vec3d{0, 0, 1}));  // of unit length
}

TEST(Render, ScaleBarLabelsReadInTheirUnit) {
  EXPECT_EQ(detail::length_label(2), "2 m");
  EXPECT_EQ(detail::length_label(0.1), "10 cm");
  EXPECT_EQ(detail::length_label(0.02), "2 cm");
  EXPECT_EQ(detail::length_label(0.005), "5 mm");
  EXPECT_EQ(detail::length_label(5e-4), "500 \u00B5m");
}

TEST(Render, DirectionsAreParsedWithClearErrors) {
  EXPECT_EQ(parse_direction("z"), (Vec3d{0, 0, 1}));
  EXPECT_EQ(parse_direction("-Y"), (Vec3d{0, -1, 0}));
  EXPECT_EQ(parse_direction("+x"), (Vec3d{1, 0, 0}));
  EXPECT_EQ(parse_direction("0.5,0,-2"), (Vec3d{0.5, 0, -2}));
  for (const char* bad : {"", "w", "1,2", "1,2,3,4", "a,b,c", "0,0,0", "1,,2"}) {
    try {
      parse_direction(bad, "--up");
      ADD_FAILURE() << "no error for '" << bad << "'";
    } catch (const InputError& e) {
      EXPECT_THAT(e.what(), HasSubstr("--up: ")) << bad;
    }
  }
}

TEST(Render, PresetsAndFieldsRender) {
  for (const char* cam : {"auto", "front", "side", "top", "scene"})
    for (Field field : {Field::none, Field::displacement}) {
      RenderOptions o;
      o.width = 160;
      o.height = 120;
      o.preset = parse_camera_preset(cam);
      std::vector<std::uint8_t> mask;
      renderer().render(bent_beam(field), o, &mask);
      EXPECT_GT(count(mask), 100u) << cam << " " << to_string(field);
    }
}

// How far a picture is from another: mean absolute difference of the colour channels (0..1)
// and intersection over union of the body silhouettes.
struct Difference {
  double mad = 1, iou = 0;
};
Difference compare(const Image& img, const std::vector<std::uint8_t>& mask, const Image& want, const Image& want_mask) {
  Difference d;
  if (want.width() != img.width() || want.height() != img.height()) return d;
  double sum = 0;
  for (std::size_t i = 0; i < img.bytes().size(); ++i)
    if (i % 4 != 3) sum += std::abs(int(img.bytes()[i]) - int(want.bytes()[i]));
  d.mad = sum / double(img.bytes().size() * 3 / 4) / 255.0;
  std::size_t inter = 0, uni = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      const bool a = mask[std::size_t(y) * img.width() + x] != 0, b = want_mask.get(x, y).r > 127;
      inter += a && b;
      uni += a || b;
    }
  d.iou = uni ? double(inter) / double(uni) : 0;
  return d;
}

RenderOptions reference_options() {
  RenderOptions o;
  o.width = 480;
  o.height = 270;
  return o;
}

TEST(Render, MatchesTheReferenceImage) {
  const Frame f = bent_beam();
  const RenderOptions o = reference_options();
  std::vector<std::uint8_t> mask;
  const Image img = renderer().render(f, o, &mask);
  const fs::path ref = kData / "beam_reference.png", ref_mask = kData / "beam_reference_mask.png";
  if (std::getenv("PLIANT_UPDATE_REFERENCE")) {
    Image mask_img(o.width, o.height, {0, 0, 0, 255});
    for (int y = 0; y < o.height; ++y)
      for (int x = 0; x < o.width; ++x)
        if (mask[std::size_t(y) * o.width + x]) mask_img.set(x, y, {255, 255, 255, 255});
    write_png(img, ref, 9);
    write_png(mask_img, ref_mask, 9);
    GTEST_SKIP() << "reference written to " << ref;
  }
  const Image want = read_png(ref), want_mask = read_png(ref_mask);
  ASSERT_EQ(want.width(), img.width());
  ASSERT_EQ(want.height(), img.height());
  // Tolerances meant to survive llvmpipe's rasterisation and multisampling changes, not bytes.
  const Difference d = compare(img, mask, want, want_mask);
  // (Measured 0 against a reference drawn on this machine: the margin is for other rasterisers.)
  EXPECT_LT(d.mad, 0.03) << "mean absolute difference";
  EXPECT_GT(d.iou, 0.95) << "silhouette overlap";
}

TEST(Render, ReferenceToleranceSeparatesRasterisationFromContent) {
  const Image want = read_png(kData / "beam_reference.png"), want_mask = read_png(kData / "beam_reference_mask.png");
  std::vector<std::uint8_t> mask;
  // Another rasterisation of the same picture (no multisampling: every edge pixel differs) passes...
  RenderOptions o = reference_options();
  o.samples = 1;
  Image img = renderer().render(bent_beam(), o, &mask);
  Difference d = compare(img, mask, want, want_mask);
  EXPECT_LT(d.mad, 0.03);
  EXPECT_GT(d.iou, 0.95);
  std::printf("no multisampling: mean abs diff %.4f, silhouette IoU %.4f\n", d.mad, d.iou);
  // ... a different colouring fails ...
  img = renderer().render(bent_beam(Field::none), reference_options(), &mask);
  EXPECT_GT(compare(img, mask, want, want_mask).mad, 0.03);
  // ... and so does a body in another place.
  Frame moved = bent_beam();
  for (std::size_t i = 2; i < moved.bodies[0].points.size(); i += 3) moved.bodies[0].points[i] += 0.08f;
  o = reference_options();
  o.framing = bounds_of(bent_beam());  // the reference's camera and grid
  o.framing_points = framing_sample(bent_beam(), 20000);
  img = renderer().render(moved, o, &mask);
  d = compare(img, mask, want, want_mask);
  EXPECT_LT(d.iou, 0.95);
  EXPECT_GT(d.iou, 0.2);  // same camera: the silhouettes still overlap
}

TEST(Render, IsDeterministic) {
  const Frame f = bent_beam();
  RenderOptions o;
  o.width = 300;
  o.height = 200;
  EXPECT_EQ(renderer().render(f, o).bytes(), renderer().render(f, o).bytes());
}

TEST(Render, BadNamesAndValuesAreClearErrors) {
  try {
    parse_field("stress", "--field");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("--field: unknown field \"stress\""));
    EXPECT_THAT(e.what(), HasSubstr("displacement, von_mises, level, none"));
  }
  try {
    parse_camera_preset("iso", "--camera");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("--camera: unknown camera \"iso\""));
    EXPECT_THAT(e.what(), HasSubstr("scene, auto, front, side, top"));
  }
  auto camera_error = [](CameraDef c) {
    try {
      validate_camera(c, "camera");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_THAT(camera_error({{0, 0, 1}, {0, 0, 0}, {0, 0, 1}, 40}), HasSubstr("camera.up"));
  EXPECT_THAT(camera_error({{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, 40}), HasSubstr("camera.target"));
  EXPECT_THAT(camera_error({{0, -1, 0}, {0, 0, 0}, {0, 0, 1}, 0}), HasSubstr("camera.fov_deg"));
  EXPECT_THAT(camera_error({{0, -1, 0}, {0, 0, 0}, {0, 0, 1}, 180}), HasSubstr("camera.fov_deg"));
  EXPECT_THAT(camera_error({{0, -1, 0}, {0, 0, 0}, {0, 0, 0}, 40}), HasSubstr("camera.up"));
  EXPECT_EQ(camera_error({{0, -1, 0}, {0, 0, 0}, {0, 0, 1}, 40}), "");
  // A bad camera in the options of a render is refused the same way.
  RenderOptions o;
  o.camera = CameraDef{{0, 0, 1}, {0, 0, 0}, {0, 0, 1}, 40};
  EXPECT_THROW(renderer().render(bent_beam(), o), InputError);
  o.camera.reset();
  o.width = 8;
  EXPECT_THROW(renderer().render(bent_beam(), o), InputError);
  // Fields a mesh file cannot give.
  const TetMesh m = make_box_mesh({0, 0, 0}, {1, 1, 1}, {1, 1, 1}, 6);
  EXPECT_THROW(frame_from_mesh(m, "m.vtu", Field::von_mises), InputError);
  EXPECT_THROW(frame_from_mesh(m, "m.vtu", Field::displacement), InputError);
  EXPECT_NO_THROW(frame_from_mesh(m, "m.vtu", Field::none));
}

// Fixed nodes are drawn bright (magenta over a dark outline), on the dark low end of the colour
// map too, and the legend shows the same colour.
TEST(Render, FixedMarksStandOutAndMatchTheLegend) {
  RenderOptions o;
  o.width = 640;
  o.height = 360;
  const Image img = renderer().render(bent_beam(), o);
  const int s = 1;  // text scale at 360 px
  auto magenta = [](Rgba c) { return c.r > 200 && c.g < 120 && c.b > 140; };
  const Rgba exact{255, 40, 200, 255};  // the fixed marks' colour, in the picture and in the legend
  std::size_t on_body = 0, in_legend = 0, exact_body = 0, exact_legend = 0;
  const int legend_top = o.height - 14 * s;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      const bool legend = y >= legend_top && x < 120;
      if (magenta(img.get(x, y))) ++(legend ? in_legend : on_body);
      if (img.get(x, y) == exact) ++(legend ? exact_legend : exact_body);
    }
  EXPECT_GT(on_body, 20u) << "fixed marks on the clamped end";
  EXPECT_GT(in_legend, 3u) << "the legend's fixed mark";
  EXPECT_GT(exact_body, 5u);
  EXPECT_GT(exact_legend, 3u);
  // Nothing else in the picture is magenta: without marks there is none.
  o.marks = false;
  const Image plain = renderer().render(bent_beam(), o);
  std::size_t none = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) none += magenta(plain.get(x, y));
  EXPECT_EQ(none, 0u);
}

// ---- scene camera block ----

std::string scene_error(const std::string& camera) {
  const std::string text = R"({"bodies": [{"mesh": {"box": {}}}], "camera": )" + camera + "}";
  try {
    parse_scene(text, "s.json", ".");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(SceneCamera, ParsedWithDefaults) {
  const SceneDef s = parse_scene(
      R"({"bodies": [{"mesh": {"box": {}}}], "camera": {"position": [1, -2, 0.5], "target": [0.5, 0, 0]}})", "s.json", ".");
  ASSERT_TRUE(s.camera.has_value());
  EXPECT_EQ(s.camera->position, (Vec3d{1, -2, 0.5}));
  EXPECT_EQ(s.camera->target, (Vec3d{0.5, 0, 0}));
  EXPECT_EQ(s.camera->up, (Vec3d{0, 0, 1}));
  EXPECT_EQ(s.camera->fov_deg, 40);
  const SceneDef t = parse_scene(
      R"({"bodies": [{"mesh": {"box": {}}}], "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "up": [0, 1, 0], "fov_deg": 25}})",
      "s.json", ".");
  EXPECT_EQ(t.camera->up, (Vec3d{0, 1, 0}));
  EXPECT_EQ(t.camera->fov_deg, 25);
  EXPECT_FALSE(parse_scene(R"({"bodies": [{"mesh": {"box": {}}}]})", "s.json", ".").camera.has_value());
  EXPECT_TRUE(parse_scene(R"({"bodies": [{"mesh": {"box": {}}}], "output": {"sheet": true}})", "s.json", ".").output.sheet);
}

TEST(SceneCamera, ErrorsNameTheField) {
  EXPECT_THAT(scene_error(R"({"target": [0, 0, 0]})"), HasSubstr("s.json: camera.position: missing (required)"));
  EXPECT_THAT(scene_error(R"({"position": [0, 0, 1], "target": [0, 0, 1]})"), HasSubstr("s.json: camera.target: must differ"));
  EXPECT_THAT(scene_error(R"({"position": [0, 0, 1], "target": [0, 0, 0]})"),
              HasSubstr("s.json: camera.up: is along the view direction"));
  EXPECT_THAT(scene_error(R"({"position": [0, -1, 0], "target": [0, 0, 0], "fov_deg": 180})"),
              HasSubstr("s.json: camera.fov_deg: must be in (0, 180)"));
  EXPECT_THAT(scene_error(R"({"position": [0, -1, 0], "target": [0, 0, 0], "fov_dg": 30})"),
              HasSubstr("camera.fov_dg: unknown key; known keys: position, target, up, fov_deg; did you mean \"fov_deg\"?"));
  EXPECT_THAT(scene_error(R"({"position": [0, -1], "target": [0, 0, 0]})"),
              HasSubstr("camera.position: expected an array of 3 numbers"));
  EXPECT_THAT(scene_error(R"("front")"), HasSubstr("camera: expected an object"));
  // Overrides reach the camera block too.
  const std::string edited = apply_scene_overrides(
      R"({"bodies": [{"mesh": {"box": {}}}], "camera": {"position": [0, -1, 0], "target": [0, 0, 0]}})",
      {"camera.fov_deg=20"}, "s.json");
  EXPECT_EQ(parse_scene(edited, "s.json", ".").camera->fov_deg, 20);
}

// ---- pictures during a run ----

SceneDef small_scene() {
  return parse_scene(R"({
    "duration": 0.02, "threads": 2,
    "bodies": [{"name": "b", "mesh": {"box": {"min": [0,0,0], "max": [0.2,0.05,0.05], "cells": [8,2,2]}},
                "material": {"young": 1e5},
                "fixed": [{"box": {"min": [-1,-1,-1], "max": [0.0001,1,1]}}],
                "prescribed": [{"region": {"box": {"min": [0.19,-1,-1], "max": [1,1,1]}},
                                "keyframes": [{"time": 0, "offset": [0,0,0]}, {"time": 0.02, "offset": [0,0,-0.01]}]}]}],
    "probes": [{"name": "mid", "body": "b", "point": [0.1, 0.025, 0.025]}]
  })",
                     "small.json", ".");
}

TEST(Recorder, PicturesDoNotChangeTheSimulation) {
  const SceneDef scene = small_scene();
  RunOptions plain;
  plain.write_files = false;
  const std::string hash = run_scene(scene, plain).state_hash;
  for (Field field : {Field::displacement, Field::von_mises}) {
    RecorderOptions ro;
    ro.out_dir = scratch(std::string("hash_") + to_string(field));
    ro.png_every = 0.005;
    ro.sheet = true;
    ro.width = 160;
    ro.height = 90;
    ro.sheet_thumb_width = 120;
    ro.field = field;
    FrameRecorder rec(scene, ro, scene.duration);
    RunOptions with = plain;
    with.frame_every = rec.frame_every();
    with.on_frame = [&](const World& w) { rec.capture(w); };
    EXPECT_EQ(run_scene(scene, with).state_hash, hash) << to_string(field);
    const RecorderResult r = rec.finish();
    EXPECT_EQ(r.frames, 5);  // t = 0, 0.005, ..., 0.02
    for (int i = 0; i < 5; ++i) {
      const Image img = read_png(ro.out_dir / frame_file(i));
      EXPECT_EQ(img.width(), 160);
      EXPECT_EQ(img.height(), 90);
    }
    EXPECT_FALSE(fs::exists(ro.out_dir / frame_file(5)));
    const Image sheet = read_png(ro.out_dir / "sheet.png");
    EXPECT_GT(sheet.width(), 4 * 120);
    EXPECT_GT(sheet.height(), 2 * 68);
  }
}

TEST(Recorder, CapturedFrameMarksFixedDrivenAndProbes) {
  World world = make_world(small_scene());
  const Frame f = capture(world, Field::displacement);
  ASSERT_EQ(f.bodies.size(), 1u);
  const auto& topo = *f.bodies[0].topology;
  EXPECT_GT(topo.fixed.size(), 0u);
  EXPECT_GT(topo.driven.size(), 0u);
  EXPECT_EQ(f.probes.size(), 1u);
  EXPECT_EQ(f.bodies[0].points.size(), 3 * topo.source_node.size());
  EXPECT_EQ(f.bodies[0].values.size(), topo.source_node.size());
  EXPECT_EQ(max_value(f), 0.0);  // rest state
}

// The engine keeps a body's positions relative to its origin (World::body_origin); a picture is
// in the world frame: captured points are the world positions, and the fixed and driven marks
// are the nodes the scene's world-frame regions select (the 3 x 3 nodes of each end face).
TEST(Recorder, CapturedPointsAndMarksAreInTheWorldFrame) {
  World world = make_world(small_scene());
  world.step();  // away from rest
  const Frame f = capture(world, Field::displacement);
  ASSERT_EQ(f.bodies.size(), 1u);
  const auto& topo = *f.bodies[0].topology;
  EXPECT_EQ(topo.fixed.size(), 9u);
  EXPECT_EQ(topo.driven.size(), 9u);
  for (std::int32_t s : topo.fixed) EXPECT_LT(world.node_rest_position(0, std::size_t(topo.source_node[s]))[0], 1e-9);
  for (std::int32_t s : topo.driven) EXPECT_GT(world.node_rest_position(0, std::size_t(topo.source_node[s]))[0], 0.2 - 1e-9);
  for (std::size_t s = 0; s < topo.source_node.size(); ++s) {
    const Vec3d x = world.node_position(0, std::size_t(topo.source_node[s]));
    for (int k = 0; k < 3; ++k) EXPECT_EQ(f.bodies[0].points[3 * s + k], float(x[k])) << "surface node " << s;
  }
}

TEST(Recorder, SheetGetsItsOwnFramesWhenNumberedFramesAreFew) {
  const SceneDef scene = small_scene();
  RecorderOptions ro;
  ro.out_dir = scratch("sparse_frames");
  ro.png_every = 0.01;  // 3 numbered frames; the sheet still gets about 12 pictures
  ro.sheet = true;
  ro.width = 160;
  ro.height = 90;
  ro.sheet_thumb_width = 100;
  FrameRecorder rec(scene, ro, scene.duration);
  EXPECT_LE(rec.frame_every(), 0.02 / 11);
  RunOptions opt;
  opt.write_files = false;
  opt.frame_every = rec.frame_every();
  opt.on_frame = [&](const World& w) { rec.capture(w); };
  run_scene(scene, opt);
  const RecorderResult r = rec.finish();
  EXPECT_EQ(r.frames, 3);
  EXPECT_TRUE(fs::exists(ro.out_dir / frame_file(2)));
  EXPECT_FALSE(fs::exists(ro.out_dir / frame_file(3)));
  const Image sheet = read_png(ro.out_dir / "sheet.png");
  EXPECT_GT(sheet.height(), 3 * 56);  // three rows of thumbnails
}

TEST(Recorder, SheetOnlyRunWritesNoFrames) {
  const SceneDef scene = small_scene();
  RecorderOptions ro;
  ro.out_dir = scratch("sheet_only");
  ro.sheet = true;
  ro.width = 160;
  ro.height = 90;
  ro.sheet_thumb_width = 100;
  FrameRecorder rec(scene, ro, scene.duration);
  RunOptions opt;
  opt.write_files = false;
  opt.frame_every = rec.frame_every();
  opt.on_frame = [&](const World& w) { rec.capture(w); };
  run_scene(scene, opt);
  const RecorderResult r = rec.finish();
  EXPECT_EQ(r.frames, 0);
  EXPECT_FALSE(fs::exists(ro.out_dir / frame_file(0)));
  EXPECT_TRUE(fs::exists(ro.out_dir / "sheet.png"));
}

TEST(Recorder, TinyMemoryBudgetStillWritesEverything) {
  const SceneDef scene = small_scene();
  RecorderOptions ro;
  ro.out_dir = scratch("budget");
  ro.png_every = 0.002;
  ro.sheet = true;
  ro.width = 96;
  ro.height = 64;
  ro.sheet_thumb_width = 64;
  ro.memory_budget = 1;  // flush at every frame
  FrameRecorder rec(scene, ro, scene.duration);
  RunOptions opt;
  opt.write_files = false;
  opt.frame_every = rec.frame_every();
  opt.on_frame = [&](const World& w) { rec.capture(w); };
  run_scene(scene, opt);
  const RecorderResult r = rec.finish();
  EXPECT_EQ(r.frames, 11);
  EXPECT_TRUE(fs::exists(ro.out_dir / frame_file(10)));
  EXPECT_TRUE(fs::exists(ro.out_dir / "sheet.png"));
  EXPECT_FALSE(r.notes.empty());
}

// A frame interval far below the step (1e-12 s over a 0.02 s run: 2e10 frames "expected", past
// int) gives a frame per step and a sheet of the whole run, also when frames are flushed during it.
TEST(Recorder, FrameIntervalFarBelowTheStepGivesAFramePerStepAndASheet) {
  const SceneDef scene = small_scene();
  RecorderOptions ro;
  ro.out_dir = scratch("tiny_interval");
  ro.png_every = 1e-12;
  ro.sheet = true;
  ro.width = 32;
  ro.height = 32;
  ro.sheet_thumb_width = 32;
  ro.memory_budget = 1;  // flush at every frame: the planned sheet frames are used
  FrameRecorder rec(scene, ro, scene.duration);
  RunOptions opt;
  opt.write_files = false;
  opt.frame_every = rec.frame_every();
  opt.on_frame = [&](const World& w) { rec.capture(w); };
  const RunSummary s = run_scene(scene, opt);
  const RecorderResult r = rec.finish();
  EXPECT_EQ(r.frames, s.steps + 1);
  ASSERT_TRUE(fs::exists(ro.out_dir / "sheet.png"));
  // Four columns of 32-pixel thumbnails (margins 12, gaps 8): the sheet shows the run, not one
  // picture (the frame count overflowed int and planned the sheet for frame INT_MIN: 56 px wide).
  EXPECT_GE(read_png(ro.out_dir / "sheet.png").width(), 2 * 12 + 4 * 32 + 3 * 8);
}

TEST(Recorder, BadOptionsAreRefused) {
  const SceneDef scene = small_scene();
  RecorderOptions ro;
  ro.out_dir = scratch("bad");
  ro.png_every = -1;
  EXPECT_THROW(FrameRecorder(scene, ro, 1.0), InputError);
  ro.png_every = 0.1;
  ro.width = 10;
  EXPECT_THROW(FrameRecorder(scene, ro, 1.0), InputError);
}

// ---- stored states: a run's .vtu files ----

// The .pvd files next to a stored frame are read to find its time: a FIFO or a link to /dev/zero
// named .pvd there is skipped without being opened (it hung `pliant render`), and the time still
// comes from the real series.pvd.
TEST(StoredState, SpecialFilesNamedPvdBesideAFrameAreSkipped) {
  SceneDef scene = small_scene();
  scene.output.vtu_every = 0.01;
  RunOptions opt;
  opt.out_dir = scratch("stored_special");
  run_scene(scene, opt);
  const fs::path frame = opt.out_dir / "vtu" / "b_00001.vtu";
  special::link_to_dev_zero(opt.out_dir / "a_zero.pvd");
  const special::Fifo fifo(opt.out_dir / "vtu" / "a_fifo.pvd");
  const StoredFields f = read_stored_fields(frame, read_tet_mesh(frame));
  EXPECT_FALSE(fifo.opened());
  ASSERT_TRUE(f.time.has_value());
  // The step at or after 0.01 s: measured 5.7e-4 s after (9.1e-5 s in an earlier build of the same
  // source; why is not understood, so the tolerance stays at 1e-3 s, within 2x of the larger).
  EXPECT_NEAR(*f.time, 0.01, 1e-3);
}

TEST(StoredState, RunFramesCarryDisplacementVonMisesAndTime) {
  SceneDef scene = small_scene();
  scene.output.vtu_every = 0.01;
  RunOptions opt;
  opt.out_dir = scratch("stored_run");
  run_scene(scene, opt);
  const fs::path first = opt.out_dir / "vtu" / "b_00000.vtu", last = opt.out_dir / "vtu" / "b_00002.vtu";
  const TetMesh rest = read_tet_mesh(first), mesh = read_tet_mesh(last);
  const StoredFields f = read_stored_fields(last, mesh);
  EXPECT_EQ(f.displacement.size(), 3 * mesh.node_count());
  EXPECT_EQ(f.von_mises.size(), mesh.tet_count());
  ASSERT_TRUE(f.time.has_value());
  EXPECT_NEAR(*f.time, 0.02, 1e-3);  // from series.pvd, one folder up: the step at or after 0.02 s
  EXPECT_TRUE(f.note.empty()) << f.note;
  const double t1 = series_time(opt.out_dir / "vtu" / "b_00001.vtu").value_or(-1);
  EXPECT_NEAR(t1, 0.01, 1e-3);  // measured 5.7e-4 s (as above)
  EXPECT_LT(t1, *f.time);
  EXPECT_EQ(series_time(first), 0.0);
  EXPECT_FALSE(series_time(scratch("stored_elsewhere") / "b_00001.vtu").has_value());

  // The stored displacement is the points minus the first frame's (the rest state).
  const Frame stored = frame_from_mesh(mesh, "b", Field::displacement, nullptr, &f);
  const Frame with_rest = frame_from_mesh(mesh, "b", Field::displacement, &rest);
  ASSERT_EQ(stored.bodies[0].values.size(), with_rest.bodies[0].values.size());
  EXPECT_GT(max_value(stored), 1e-4);  // the driven end moved 1 cm
  for (std::size_t i = 0; i < stored.bodies[0].values.size(); ++i)
    EXPECT_NEAR(stored.bodies[0].values[i], with_rest.bodies[0].values[i], 1e-15 * max_value(stored));  // measured 0
  EXPECT_TRUE(stored.has_time);
  EXPECT_EQ(stored.time, *f.time);
  EXPECT_FALSE(with_rest.has_time);
  const Frame vm = frame_from_mesh(mesh, "b", Field::von_mises, nullptr, &f);
  EXPECT_GT(max_value(vm), 0.0);
  EXPECT_EQ(vm.bodies[0].values.size(), vm.bodies[0].topology->source_node.size());

  // The time is printed on the picture: the top line differs from the same frame without it.
  RenderOptions o;
  o.width = 320;
  o.height = 180;
  o.title = "b_00002.vtu";
  Frame timeless = stored;
  timeless.has_time = false;
  const Image a = renderer().render(stored, o), b = renderer().render(timeless, o);
  std::size_t differ = 0;
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 120; ++x) differ += !(a.get(x, y) == b.get(x, y));
  EXPECT_GT(differ, 20u);

  // A mesh without fields: displacement needs --rest, von Mises cannot be had.
  const StoredFields none = read_stored_fields(first, rest);  // t = 0: fields present, all zero
  EXPECT_EQ(none.displacement.size(), 3 * rest.node_count());
  const StoredFields empty;
  try {
    frame_from_mesh(mesh, "copy.vtu", Field::von_mises, nullptr, &empty);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("copy.vtu: --field von_mises needs the file's \"von_mises\" cell field"));
  }
  try {
    frame_from_mesh(mesh, "copy.vtu", Field::displacement, nullptr, &empty);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("--rest FILE"));
  }
}

TEST(StoredState, EveryInlineEncodingReadsBack) {
  const TetMesh mesh = make_box_mesh({0, 0, 0}, {1, 0.5, 0.5}, {3, 2, 2}, 6);
  std::vector<double> disp(3 * mesh.node_count()), vm(mesh.tet_count());
  for (std::size_t i = 0; i < disp.size(); ++i) disp[i] = 1e-3 * std::sin(double(i)) / 3.0;
  for (std::size_t t = 0; t < vm.size(); ++t) vm[t] = 1e3 + 17.25 * double(t) + 1.0 / 7.0;
  for (VtuEncoding enc : {VtuEncoding::ascii, VtuEncoding::base64, VtuEncoding::base64_zlib}) {
    const fs::path file = scratch("encodings") / ("m" + std::to_string(int(enc)) + ".vtu");
    write_vtu(file, mesh.points, mesh.tets,
              {{"displacement", 3, false, disp}, {"von_mises", 1, true, vm}, {"stress", 9, true, std::vector<double>(9 * vm.size(), 1.0)}},
              enc);
    const TetMesh back = read_tet_mesh(file);
    const StoredFields f = read_stored_fields(file, back);
    EXPECT_EQ(f.displacement, disp) << int(enc);
    EXPECT_EQ(f.von_mises, vm) << int(enc);
    EXPECT_FALSE(f.time.has_value());
    EXPECT_TRUE(f.note.empty()) << f.note;
  }
  // A hand-written file: a time in field data, and a vertex no tet uses (dropped by the mesh
  // reader), so that the fields no longer match the mesh: left out, with a note.
  const fs::path file = scratch("encodings") / "hand.vtu";
  auto write = [&](int points, const char* extra_point) {
    std::ofstream out(file);
    out << R"(<?xml version="1.0"?>
<!-- a <Piece> in a comment is not one -->
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian">
  <UnstructuredGrid>
    <FieldData><DataArray type="Float64" Name="TimeValue" NumberOfTuples="1" format="ascii">0.25</DataArray></FieldData>
    <Piece NumberOfPoints=")" << points << R"(" NumberOfCells="1">
      <PointData><DataArray type="Float32" Name="displacement" NumberOfComponents="3" format="ascii">
        0 0 0  0.001 0 0  0 0.002 0  0 0 0.003 )" << extra_point << R"(</DataArray></PointData>
      <CellData><DataArray type="Float64" Name="von_mises" format="ascii">1500</DataArray></CellData>
      <Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">0 0 0 1 0 0 0 1 0 0 0 1 )"
        << (points == 5 ? "5 5 5" : "") << R"(</DataArray></Points>
      <Cells>
        <DataArray type="Int32" Name="connectivity" format="ascii">0 1 2 3</DataArray>
        <DataArray type="Int32" Name="offsets" format="ascii">4</DataArray>
        <DataArray type="UInt8" Name="types" format="ascii">10</DataArray>
      </Cells>
    </Piece>
  </UnstructuredGrid>
</VTKFile>
)";
  };
  write(4, "");
  TetMesh m = read_tet_mesh(file);
  StoredFields f = read_stored_fields(file, m);
  EXPECT_EQ(f.time.value_or(-1), 0.25);
  ASSERT_EQ(f.displacement.size(), 12u);
  EXPECT_FLOAT_EQ(float(f.displacement[7]), 0.002f);
  EXPECT_THAT(f.von_mises, ::testing::ElementsAre(1500));
  write(5, "9 9 9");
  m = read_tet_mesh(file);
  f = read_stored_fields(file, m);
  EXPECT_TRUE(f.displacement.empty());
  EXPECT_TRUE(f.von_mises.empty());
  EXPECT_THAT(f.note, HasSubstr("do not match the mesh"));
  EXPECT_EQ(f.time.value_or(-1), 0.25);
}

}  // namespace
