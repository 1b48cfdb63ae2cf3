// The Embree side of collision (surface_bvh.hpp). Embree 3.13 from Debian (libembree-dev),
// built with TBB tasking: commits run inside our executor's arena, isolated.
#include "surface_bvh.hpp"

#include <algorithm>
#include <embree3/rtcore.h>
#include <fmt/format.h>

#include "pliant/error.hpp"
#include "pliant/scheduler/executor.hpp"

namespace pliant::detail {

struct EmbreeDevice::ErrorSink {
  std::string last;
};

namespace {

void on_error(void* user, RTCError code, const char* message) {
  auto* sink = static_cast<EmbreeDevice::ErrorSink*>(user);
  sink->last = fmt::format("Embree error {}: {}", int(code), message ? message : "");
}

struct QueryState {
  std::vector<std::uint32_t>* out;
};

// Called for every triangle whose bounds meet the query ball: collect it (the exact test is the
// caller's). Returning false keeps the query radius as it is.
bool collect(RTCPointQueryFunctionArguments* args) {
  static_cast<QueryState*>(args->userPtr)->out->push_back(args->primID);
  return false;
}

}  // namespace

EmbreeDevice::EmbreeDevice() : errors_(std::make_unique<ErrorSink>()) {
  // No "threads=": that would set TBB's global concurrency for the whole process.
  RTCDevice d = rtcNewDevice("verbose=0");
  if (!d) throw InputError(fmt::format("could not create an Embree device (error {})", int(rtcGetDeviceError(nullptr))));
  rtcSetDeviceErrorFunction(d, &on_error, errors_.get());
  device_ = d;
}

EmbreeDevice::~EmbreeDevice() {
  if (device_) rtcReleaseDevice(static_cast<RTCDevice>(device_));
}

std::string EmbreeDevice::take_error() {
  std::string e;
  e.swap(errors_->last);
  return e;
}

SurfaceBvh::SurfaceBvh(EmbreeDevice& device, const std::vector<std::array<std::int32_t, 3>>& triangles,
                       std::size_t vertex_count)
    : device_(device), vertex_count_(vertex_count), triangle_count_(triangles.size()) {
  vertices_.assign(4 * vertex_count + 4, 0.0f);
  indices_.reserve(3 * triangles.size());
  for (const auto& t : triangles)
    for (int k = 0; k < 3; ++k) {
      if (t[std::size_t(k)] < 0 || std::size_t(t[std::size_t(k)]) >= vertex_count)
        throw InputError(fmt::format("surface triangle refers to vertex {} of {}", t[std::size_t(k)], vertex_count));
      indices_.push_back(std::uint32_t(t[std::size_t(k)]));
    }
  RTCDevice d = static_cast<RTCDevice>(device.handle());
  RTCScene scene = rtcNewScene(d);
  // REFIT needs the scene built at LOW quality; dynamic because it changes every step.
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_LOW);
  rtcSetSceneFlags(scene, RTC_SCENE_FLAG_DYNAMIC);
  RTCGeometry g = rtcNewGeometry(d, RTC_GEOMETRY_TYPE_TRIANGLE);
  rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, vertices_.data(), 0, 4 * sizeof(float),
                             vertex_count);
  rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, indices_.data(), 0, 3 * sizeof(std::uint32_t),
                             triangles.size());
  rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_REFIT);
  rtcCommitGeometry(g);
  rtcAttachGeometryByID(scene, g, 0);
  rtcReleaseGeometry(g);
  scene_ = scene;
  const std::string e = device.take_error();
  if (!e.empty()) throw InputError("building a collision surface: " + e);
}

SurfaceBvh::~SurfaceBvh() {
  if (scene_) rtcReleaseScene(static_cast<RTCScene>(scene_));
}

bool SurfaceBvh::refit(Executor& exec, std::string& error) {
  RTCScene scene = static_cast<RTCScene>(scene_);
  if (committed_) rtcUpdateGeometryBuffer(rtcGetGeometry(scene, 0), RTC_BUFFER_TYPE_VERTEX, 0);
  if (committed_) rtcCommitGeometry(rtcGetGeometry(scene, 0));
  exec.run_isolated([](void* s) { rtcCommitScene(static_cast<RTCScene>(s)); }, scene);
  committed_ = true;
  error = device_.take_error();
  return error.empty();
}

void SurfaceBvh::triangles_near(const float centre[3], float radius, std::vector<std::uint32_t>& out) const {
  out.clear();
  RTCPointQuery q;
  q.x = centre[0];
  q.y = centre[1];
  q.z = centre[2];
  q.radius = radius;
  q.time = 0;
  RTCPointQueryContext ctx;
  rtcInitPointQueryContext(&ctx);
  QueryState state{&out};
  rtcPointQuery(static_cast<RTCScene>(scene_), &q, &ctx, &collect, &state);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

}  // namespace pliant::detail
