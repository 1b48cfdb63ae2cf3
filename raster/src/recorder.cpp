// FrameRecorder: numbered frames, the contact sheet and the video of a run (see recorder.hpp).
// Frames are captured during the run (surfaces only) and rendered in finish() with the camera
// fitted to the union of every frame's bounds and one colour range, the run's largest value.
#include "pliant/raster/recorder.hpp"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fmt/format.h>
#include <map>

#include "overlay.hpp"
#include "pliant/error.hpp"
#include "pliant/raster/colormap.hpp"
#include "pliant/raster/text.hpp"
#include "pliant/world.hpp"

extern char** environ;

namespace pliant::raster {
namespace fs = std::filesystem;

std::filesystem::path frame_file(int index) { return fs::path("frames") / fmt::format("frame_{:05d}.png", index); }

bool ffmpeg_available() {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::string_view rest(path);
  while (true) {
    const std::size_t colon = rest.find(':');
    const std::string dir(rest.substr(0, colon));
    const fs::path candidate = fs::path(dir.empty() ? "." : dir) / "ffmpeg";
    if (::access(candidate.c_str(), X_OK) == 0 && !fs::is_directory(candidate)) return true;
    if (colon == std::string_view::npos) return false;
    rest.remove_prefix(colon + 1);
  }
}

struct FrameRecorder::Impl {
  RecorderOptions opt;
  std::optional<CameraDef> scene_camera;
  Vec3d up{0, 0, 1};
  std::string title;
  double duration = 0, every = 0;  // s between captures
  int png_stride = 1;              // every png_stride-th capture is a numbered frame
  int expected = 0;           // frames the run should give
  std::vector<int> planned;   // frame indices planned for the sheet

  // Plans the sheet for the frames a run of `duration` gives with captures every `every` s, at
  // most one per step of `step` s (0: unknown): the runner checks once per step, so an interval
  // below the step gives a frame per step. Clamped: past 1e9 the count only spreads the planned
  // frames (1e-12 s over 0.02 s overflowed int and planned the sheet for frame INT_MIN alone).
  void plan(double step) {
    const double interval = std::max(every, step * (1 - 1e-9));
    const double n = std::floor(duration / interval + 1e-6) + 1;
    expected = n < 1e9 ? int(n) : 1000000000;
    planned = sheet_selection(expected);
  }

  CaptureCache cache;
  struct Pending {
    Frame frame;
    int index;
  };
  std::vector<Pending> pending;
  std::size_t pending_bytes = 0;
  int captured = 0;
  bool frozen = false;  // camera framing and colour range fixed by an early flush
  Bounds framing;
  std::vector<Vec3d> framing_points;  // a sample of every frame's surface, for the camera
  std::array<double, 2> range{0, 1};
  std::map<int, std::pair<double, Image>> thumbs;  // frame index -> (time, thumbnail)
  std::unique_ptr<Renderer> renderer;
  RecorderResult result;
  bool fixed_marks = false, driven_marks = false, probe_marks = false;

  int thumb_height() const { return std::max(16, int(std::lround(double(opt.sheet_thumb_width) * opt.height / opt.width))); }

  std::vector<int> sheet_selection(int n) const {
    std::vector<int> sel;
    const int k = std::max(1, std::min(opt.sheet_frames, n));
    for (int i = 0; i < k; ++i) {
      const int idx = k == 1 ? n - 1 : int(std::lround(double(i) * (n - 1) / (k - 1)));
      if (sel.empty() || sel.back() != idx) sel.push_back(idx);
    }
    return sel;
  }

  RenderOptions frame_options() const {
    RenderOptions r;
    r.width = opt.width;
    r.height = opt.height;
    r.preset = opt.camera;
    r.camera = scene_camera;
    r.up = up;
    r.framing = framing;
    r.framing_points = framing_points;
    r.range = range;
    r.title = title;
    r.azimuth_deg = opt.azimuth_deg;
    r.elevation_deg = opt.elevation_deg;
    r.axes = opt.axes;
    r.scale_bar = opt.scale_bar;
    return r;
  }
  RenderOptions thumb_options() const {
    RenderOptions r = frame_options();
    r.width = opt.sheet_thumb_width;
    r.height = thumb_height();
    r.colour_bar = r.time_label = r.legend = r.probe_labels = r.axes = r.scale_bar = false;
    r.title.clear();
    r.text_scale = 1;
    r.caption_height = 7 + text_height(opt.sheet_thumb_width >= 300 ? 2 : 1);  // the time, drawn by the sheet
    return r;
  }

  void fix_view(const std::vector<Pending>& frames) {
    if (frozen) return;
    Bounds b;
    double vmax = 0;
    Field field = opt.field;
    const std::size_t per_frame = std::max<std::size_t>(64, 200000 / std::max<std::size_t>(frames.size(), 1));
    framing_points.clear();
    for (const auto& p : frames) {
      b.add(bounds_of(p.frame));
      vmax = std::max(vmax, max_value(p.frame));
      const auto sample = framing_sample(p.frame, per_frame);
      framing_points.insert(framing_points.end(), sample.begin(), sample.end());
    }
    framing = b;
    Frame probe;
    probe.field = field;
    range = vmax > 0 ? std::array<double, 2>{0.0, nice_number(vmax, true)} : default_range(probe);
  }

  // Creates the folders on the first write; frames of an earlier run in the same folder would
  // mix with these (and with the video), so they are removed.
  void prepare_folders() {
    fs::create_directories(opt.out_dir);
    if (opt.png_every <= 0) return;
    const fs::path dir = opt.out_dir / "frames";
    fs::create_directories(dir);
    for (const auto& e : fs::directory_iterator(dir)) {
      const std::string n = e.path().filename().string();
      if (e.is_regular_file() && n.starts_with("frame_") && n.ends_with(".png")) fs::remove(e.path());
    }
  }

  void render_frames(std::size_t count, const std::vector<int>& sheet_indices) {
    if (!renderer) {
      prepare_folders();
      renderer = std::make_unique<Renderer>();
    }
    const RenderOptions fo = frame_options(), to = thumb_options();
    for (std::size_t i = 0; i < count; ++i) {
      const Pending& p = pending[i];
      for (const auto& b : p.frame.bodies) {
        fixed_marks = fixed_marks || !b.topology->fixed.empty();
        driven_marks = driven_marks || !b.topology->driven.empty();
      }
      probe_marks = probe_marks || !p.frame.probes.empty();
      if (opt.png_every > 0 && p.index % png_stride == 0) {
        const fs::path name = frame_file(p.index / png_stride);
        write_png(renderer->render(p.frame, fo), opt.out_dir / name, 3);
        ++result.frames;
      }
      if (opt.sheet && std::find(sheet_indices.begin(), sheet_indices.end(), p.index) != sheet_indices.end())
        thumbs[p.index] = {p.frame.time, renderer->render(p.frame, to)};
    }
    pending.erase(pending.begin(), pending.begin() + std::ptrdiff_t(count));
    pending_bytes = 0;
    for (const auto& p : pending) pending_bytes += p.frame.bytes();
  }

  // Over the memory budget: render what we have (keeping the last frame for the sheet), with
  // the framing and range frozen from now on.
  void flush() {
    if (pending.size() < 2) return;
    if (!frozen) {
      fix_view(pending);
      // Leave room for motion still to come.
      for (int k = 0; k < 3; ++k) {
        const double pad = 0.1 * (framing.max[k] - framing.min[k]);
        framing.min[k] -= pad;
        framing.max[k] += pad;
      }
      framing_points.clear();  // fit the padded box instead
      frozen = true;
      result.notes.push_back(fmt::format(
          "the frames of this run exceed {} MiB: frames up to t = {:.4g} s were rendered during the run, and the colour "
          "range [0, {:.4g}] {} and the camera are fixed from them (later values above the range show in the top colour)",
          opt.memory_budget >> 20, pending[pending.size() - 2].frame.time, range[1], field_unit(opt.field)));
    }
    render_frames(pending.size() - 1, planned);
  }

  void write_sheet() {
    if (thumbs.empty()) return;
    // Pick up to sheet_frames of the rendered thumbnails, evenly in frame index.
    std::vector<int> have;
    for (const auto& [i, t] : thumbs) have.push_back(i);
    std::vector<int> chosen;
    for (int pos : sheet_selection(int(have.size()))) chosen.push_back(have[std::size_t(pos)]);
    const int tw = opt.sheet_thumb_width, th = thumb_height(), gap = 8, margin = 12;
    const int cols = std::max(1, std::min(opt.sheet_columns, int(chosen.size())));
    const int rows = (int(chosen.size()) + cols - 1) / cols;
    const int W = 2 * margin + cols * tw + (cols - 1) * gap;
    const int s = W >= 900 ? 2 : 1;  // text scale of the header
    const bool bar = opt.field != Field::none;
    const double t_first = thumbs.at(chosen.front()).first, t_last = thumbs.at(chosen.back()).first;
    const std::string sub = fmt::format("{}{} frames, t = {:.4g} to {:.4g} s",
                                        bar ? std::string(field_title(opt.field)) + ", " : "", chosen.size(),
                                        t_first, t_last);
    // Header: title, subtitle and legend on the left; the colour bar on the right if it fits,
    // else on a row of its own.
    const int legend_w = 232 * s;  // the legend's width with all three items
    const int left_w = std::max({text_width(title, s), text_width(sub, s), legend_w});
    const int bar_w = std::min(440, W - 2 * margin), bar_h = 34 * s;
    const bool bar_beside = bar && left_w + 24 + bar_w <= W - 2 * margin;
    const int header = 38 * s + (bar && !bar_beside ? bar_h + 6 * s : 0) + 6;
    const int H = margin + header + rows * th + (rows - 1) * gap + margin;
    Image sheet(W, H, {246, 246, 248, 255});
    TextStyle big{{24, 26, 32, 255}, s, false};
    draw_text(sheet, margin, margin, title, big);
    draw_text(sheet, margin, margin + 13 * s, sub, big);
    detail::draw_legend(sheet, margin, margin + 26 * s, s, fixed_marks, driven_marks, probe_marks);
    if (bar) {
      if (bar_beside) draw_colour_bar(sheet, W - margin - bar_w, margin, bar_w, bar_h, opt.field, range, s, true);
      else draw_colour_bar(sheet, margin, margin + 38 * s, bar_w, bar_h, opt.field, range, s, true);
    }
    const double step = every;  // the capture interval decides the decimals of the times
    const int ts = tw >= 300 ? 2 : 1;  // as in thumb_options()
    for (std::size_t k = 0; k < chosen.size(); ++k) {
      const auto& [time, img] = thumbs.at(chosen[k]);
      const int x = margin + int(k % cols) * (tw + gap), y = margin + header + int(k / cols) * (th + gap);
      sheet.blit(img, x, y);
      sheet.frame_rect(x - 1, y - 1, tw + 2, th + 2, {170, 172, 180, 255});
      draw_text(sheet, x + 3 * ts, y + 3 * ts, detail::time_label(time, step), {{24, 26, 32, 255}, ts, true});
    }
    write_png(sheet, opt.out_dir / "sheet.png", 9);
    result.files.push_back("sheet.png");
  }

  void write_movie() {
    if (result.frames == 0) {
      result.notes.push_back("--mp4: no frames were written, so there is no movie");
      return;
    }
    const std::string pattern = (opt.out_dir / "frames" / "frame_%05d.png").string();
    const std::string out = (opt.out_dir / "movie.mp4").string();
    const std::string fps = std::to_string(opt.mp4_fps);
    std::vector<std::string> args = {"ffmpeg", "-hide_banner", "-loglevel", "error", "-y", "-framerate", fps, "-i",
                                     pattern, "-c:v", "libx264", "-pix_fmt", "yuv420p", "-vf",
                                     "pad=ceil(iw/2)*2:ceil(ih/2)*2", out};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = 0;
    if (posix_spawnp(&pid, "ffmpeg", nullptr, nullptr, argv.data(), environ) != 0) {
      result.notes.push_back("--mp4: could not start ffmpeg; the frames are in frames/");
      return;
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) result.files.push_back("movie.mp4");
    else
      result.notes.push_back(fmt::format("--mp4: ffmpeg failed (status {}); the frames are in frames/",
                                         WIFEXITED(status) ? WEXITSTATUS(status) : -1));
  }
};

FrameRecorder::FrameRecorder(const SceneDef& scene, RecorderOptions options, double duration)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  if (!(options.png_every >= 0) || !std::isfinite(options.png_every))
    throw InputError(fmt::format("--png-every must be a number of seconds >= 0, got {}", options.png_every));
  if (options.width < 16 || options.height < 16 || options.width > 16384 || options.height > 16384)
    throw InputError(fmt::format("--size {}x{}: width and height must be in [16, 16384] pixels", options.width,
                                 options.height));
  if (options.mp4 && !ffmpeg_available())
    throw InputError(
        "--mp4 needs ffmpeg, which is not installed (on Debian: apt-get install ffmpeg); without it, --png-every S "
        "writes the numbered frames (frames/frame_NNNNN.png) for any video tool");
  if (scene.camera) validate_camera(*scene.camera, "camera");
  m.opt = std::move(options);
  if (m.opt.sheet_thumb_width <= 0) m.opt.sheet_thumb_width = std::max(96, (m.opt.width + 2) / 4);
  m.duration = duration;
  m.scene_camera = scene.camera;
  const Vec3d g = scene.world.gravity;
  const double gn = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  if (gn > 0) m.up = {-g[0] / gn, -g[1] / gn, -g[2] / gn};
  if (m.opt.up) m.up = *m.opt.up;
  m.title = scene.source.empty() ? std::string("scene") : scene.source.filename().string();
  if (m.opt.mp4 && m.opt.png_every <= 0) m.opt.png_every = duration / 60;
  // Captures: at the frame interval; for a sheet also at least sheet_frames over the run
  // (numbered frames are then every png_stride-th capture).
  const double sheet_every = m.opt.sheet ? duration / std::max(m.opt.sheet_frames - 1, 1) : 0;
  if (m.opt.png_every > 0) {
    m.every = m.opt.png_every;
    if (sheet_every > 0 && m.opt.png_every > sheet_every * (1 + 1e-9)) {
      m.png_stride = int(std::ceil(m.opt.png_every / sheet_every - 1e-9));
      m.every = m.opt.png_every / m.png_stride;
    }
  } else {
    m.every = sheet_every;
  }
  if (m.every > 0) {
    m.plan(0);  // again at the first capture, when the step is known
  }
}

FrameRecorder::~FrameRecorder() = default;

bool FrameRecorder::active() const { return impl_->every > 0; }

// A hair below the interval, so that accumulated sums of it never step past the last instant.
double FrameRecorder::frame_every() const { return impl_->every * (1 - 1e-9); }

void FrameRecorder::capture(const World& world) {
  Impl& m = *impl_;
  if (m.every <= 0) return;
  if (m.captured == 0) m.plan(world.dt());
  Frame f = raster::capture(world, m.opt.field, &m.cache);
  m.pending_bytes += f.bytes();
  m.pending.push_back({std::move(f), m.captured++});
  if (m.pending_bytes > m.opt.memory_budget) m.flush();
}

RecorderResult FrameRecorder::finish() {
  Impl& m = *impl_;
  if (m.every <= 0 || (m.pending.empty() && m.thumbs.empty() && m.result.frames == 0)) return m.result;
  m.fix_view(m.pending);
  std::vector<int> selection = m.sheet_selection(m.captured);
  if (m.frozen) selection.insert(selection.end(), m.planned.begin(), m.planned.end());
  m.render_frames(m.pending.size(), selection);
  if (m.opt.png_every > 0 && m.result.frames > 0)
    m.result.files.push_back(fmt::format("frames/frame_00000.png .. frame_{:05d}.png", m.result.frames - 1));
  if (m.opt.sheet) m.write_sheet();
  if (m.opt.mp4) m.write_movie();
  m.every = 0;
  return m.result;
}

}  // namespace pliant::raster
