// Embree behind a small interface: a BVH over one surface's triangles, refit each step from the
// surface's current vertex positions, asked for the triangles near a sphere. The only header
// that knows Embree exists is its implementation (surface_bvh.cpp); nothing else includes
// embree3/ (DESIGN.md §7). Errors Embree reports through its device callback come back as
// InputError at construction and as a message from refit() (never an exception in a step).
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace pliant {
class Executor;
}

namespace pliant::detail {

// One Embree device per World that has tools. Its threads are ours: commits run through
// Executor::run_isolated (the device is created without a `threads=` setting, which would cap
// TBB for the whole process).
class EmbreeDevice {
 public:
  EmbreeDevice();
  ~EmbreeDevice();
  EmbreeDevice(const EmbreeDevice&) = delete;
  EmbreeDevice& operator=(const EmbreeDevice&) = delete;
  void* handle() const { return device_; }
  // The last error Embree reported ("" if none), cleared by the call.
  std::string take_error();
  struct ErrorSink;

 private:
  void* device_ = nullptr;
  std::unique_ptr<ErrorSink> errors_;
};

class SurfaceBvh {
 public:
  // triangles index vertices 0 .. vertex_count-1. The vertex buffer has 4 floats per vertex plus
  // 4 floats of padding (Embree reads its last vertex with a 16-byte load).
  SurfaceBvh(EmbreeDevice& device, const std::vector<std::array<std::int32_t, 3>>& triangles,
             std::size_t vertex_count);
  ~SurfaceBvh();
  SurfaceBvh(const SurfaceBvh&) = delete;
  SurfaceBvh& operator=(const SurfaceBvh&) = delete;

  // Write positions here (m, body frame: x, y, z, unused), then call refit().
  float* vertices() { return vertices_.data(); }
  std::size_t vertex_count() const { return vertex_count_; }
  std::size_t triangle_count() const { return triangle_count_; }

  // Rebuilds the BVH's bounds from the vertex buffer (RTC_BUILD_QUALITY_REFIT: same topology),
  // on the executor's threads. Returns false with Embree's message if it reported an error.
  bool refit(Executor& exec, std::string& error);

  // The triangles whose bounding boxes meet the ball (centre, radius) (m, body frame), sorted by
  // index, into `out` (cleared first). A superset of the triangles within `radius` of centre.
  void triangles_near(const float centre[3], float radius, std::vector<std::uint32_t>& out) const;

 private:
  EmbreeDevice& device_;
  void* scene_ = nullptr;
  std::size_t vertex_count_ = 0, triangle_count_ = 0;
  std::vector<float> vertices_;              // 4 per vertex + 4 padding
  std::vector<std::uint32_t> indices_;       // 3 per triangle
  bool committed_ = false;
};

}  // namespace pliant::detail
