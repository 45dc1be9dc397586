#include "rangeseg/pipeline.hpp"

#include <chrono>

namespace rangeseg {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point& start) {
  const Clock::time_point now = Clock::now();
  const double ms = std::chrono::duration<double, std::milli>(now - start).count();
  start = now;
  return ms;
}

}  // namespace

void set_noise(PipelineSettings& settings, const SensorNoise& noise) {
  settings.segmentation.noise = noise;
  settings.smoothing.noise = noise;
}

PipelineSettings pipeline_preset(std::string_view sensor) {
  PipelineSettings s;
  s.segmentation = preset(sensor);
  set_noise(s, s.segmentation.noise);
  // Angle between neighbouring pixel rays: 1 / focal length in pixels.
  if (sensor == "abw") s.smoothing.pixel_angle = 1.0f / 1586.0f;
  if (sensor == "laser") s.smoothing.pixel_angle = 0.0087f;  // 0.5 degree scan resolution
  return s;
}

Pipeline::Pipeline(const PipelineSettings& settings)
    : settings_(settings), smoother_(settings.smoothing) {}

void Pipeline::process(const OrganizedCloud& cloud) {
  require_organized(cloud, "Pipeline::process");
  input_ = &cloud;
  times_ = {};
  Clock::time_point t = Clock::now();
  const Clock::time_point start = t;
  build_mesh(cloud, settings_.mesh, mesh_);
  times_.mesh = ms_since(t);
  compute_normals(cloud, mesh_, settings_.normals, raw_normals_);
  times_.normals = ms_since(t);
  if (settings_.smooth) {
    smoother_.run(cloud, mesh_, raw_normals_, smoothed_cloud_, smoothed_normals_);
    times_.smoothing = ms_since(t);
  }
  if (settings_.segment) {
    segmenter_.segment(this->cloud(), mesh_, normals(), settings_.segmentation, segmentation_);
    times_.segmentation = ms_since(t);
  } else {
    segmentation_.labels.clear();
    segmentation_.segments.clear();
  }
  times_.total = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace rangeseg
