// Pictures of a run: what `pliant run --png-every S --sheet --mp4` does, callable from code.
// capture() is the runner's frame callback (RunOptions::on_frame); it copies the surfaces and
// never writes to the world, so results (the state hash) are the same with or without pictures.
// finish() renders after the run, so that every frame shares one camera (fitted to the motion
// of the whole run) and one colour range (the run's largest value): frames compare at a glance.
// If the captured frames would take more than `memory_budget` bytes, the frames so far are
// rendered at once and the range is frozen there (a note says so).
#pragma once
#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "pliant/defs.hpp"
#include "pliant/raster/render.hpp"

namespace pliant {
class World;
}

namespace pliant::raster {

struct RecorderOptions {
  std::filesystem::path out_dir = "out";
  double png_every = 0;         // s between numbered frames OUT/frames/frame_NNNNN.png; 0 = none
  bool sheet = false;           // OUT/sheet.png: a grid of up to sheet_frames pictures with their times, taken
                                //   at least every duration / (sheet_frames - 1), however sparse png_every is
  bool mp4 = false;             // OUT/movie.mp4 from the frames at mp4_fps, with ffmpeg (png_every 0: duration / 60)
  int width = 1280, height = 720;  // frame size (pixels)
  Field field = Field::displacement;
  CameraPreset camera = CameraPreset::scene;
  std::optional<Vec3d> up;                         // the picture's up; default: against gravity
  std::optional<double> azimuth_deg, elevation_deg;  // view direction (RenderOptions)
  bool axes = true, scale_bar = true;              // on the numbered frames (never on sheet thumbnails)
  int sheet_frames = 12;        // at most this many pictures on the sheet
  int sheet_columns = 4;
  int sheet_thumb_width = 0;    // pixels; 0: a quarter of the frame width; the height follows the frame aspect
  int mp4_fps = 30;
  std::size_t memory_budget = std::size_t(1) << 30;  // bytes of captured frames kept for finish()
};

struct RecorderResult {
  std::vector<std::string> files;  // written, relative to out_dir
  std::vector<std::string> notes;  // things the user should know (range frozen, ...)
  int frames = 0;
};

// The sub-folder, names and video a recorder writes.
std::filesystem::path frame_file(int index);  // "frames/frame_00012.png"

// True if an executable named `ffmpeg` is on PATH.
bool ffmpeg_available();

class FrameRecorder {
 public:
  // Checks the options (InputError naming --png-every, --size, ... on bad values; --mp4 without
  // ffmpeg on PATH is an InputError too, before any work is done).
  FrameRecorder(const SceneDef& scene, RecorderOptions options, double duration);
  ~FrameRecorder();
  FrameRecorder(const FrameRecorder&) = delete;
  FrameRecorder& operator=(const FrameRecorder&) = delete;

  bool active() const;         // anything to record at all
  double frame_every() const;  // s, for RunOptions::frame_every (0 when inactive)
  void capture(const World& world);
  RecorderResult finish();     // renders and writes; call once, also after a divergence

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pliant::raster
