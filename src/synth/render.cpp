// Rendering a scene into an organized cloud with ground-truth labels.
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "synth/tracer.hpp"

namespace rangeseg::synth {

Rendering render(const Scene& scene, const RenderSettings& settings) {
  const CameraIntrinsics& camera = settings.camera;
  rangeseg::validate(camera);
  if (camera.width <= 0 || camera.height <= 0) {
    throw std::invalid_argument("synth::render: camera size must be positive, got " +
                                std::to_string(camera.width) + "x" + std::to_string(camera.height));
  }
  if (settings.min_surface_pixels < 0) {
    throw std::invalid_argument("synth::render: min_surface_pixels must be >= 0, got " +
                                std::to_string(settings.min_surface_pixels));
  }

  const detail::Tracer tracer(scene);
  const int width = camera.width, height = camera.height;
  Rendering out;
  out.surfaces = tracer.surfaces();
  out.labels.resize(width, height, 0);

  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> depth(static_cast<std::size_t>(width) * height, nan);
  for (int v = 0; v < height; ++v) {
    const double dy = (v - camera.cy) / camera.fy;
    std::int32_t* label_row = out.labels.row(v);
    double* depth_row = depth.data() + static_cast<std::size_t>(v) * width;
    for (int u = 0; u < width; ++u) {
      const Vec3 dir{(u - camera.cx) / camera.fx, dy, 1.0};
      double t = 0;
      const int label = tracer.trace(dir, t);
      if (label != 0) {
        label_row[u] = label;
        depth_row[u] = t;  // dir.z == 1, so the ray parameter is the depth
      }
    }
  }

  if (settings.noise == Noise::kinect) {
    detail::apply_kinect_noise(settings.kinect, camera, settings.seed, depth, out.labels);
  }

  out.pixel_counts.assign(out.surfaces.size(), 0);
  out.cloud.resize(width, height);
  for (int v = 0; v < height; ++v) {
    const double dy = (v - camera.cy) / camera.fy;
    const std::int32_t* label_row = out.labels.row(v);
    const double* depth_row = depth.data() + static_cast<std::size_t>(v) * width;
    float* x_row = out.cloud.x.row(v);
    float* y_row = out.cloud.y.row(v);
    float* z_row = out.cloud.z.row(v);
    for (int u = 0; u < width; ++u) {
      const double z = depth_row[u];
      if (std::isnan(z)) continue;
      x_row[u] = static_cast<float>((u - camera.cx) / camera.fx * z);
      y_row[u] = static_cast<float>(dy * z);
      z_row[u] = static_cast<float>(z);
      if (label_row[u] > 0) ++out.pixel_counts[label_row[u] - 1];
    }
  }

  if (settings.min_surface_pixels > 0) {
    for (int v = 0; v < height; ++v) {
      std::int32_t* label_row = out.labels.row(v);
      for (int u = 0; u < width; ++u) {
        const int label = label_row[u];
        if (label > 0 && out.pixel_counts[label - 1] < settings.min_surface_pixels) {
          label_row[u] = 0;
        }
      }
    }
    for (auto& count : out.pixel_counts) {
      if (count < settings.min_surface_pixels) count = 0;
    }
  }

  out.cloud.label = out.labels;
  return out;
}

}  // namespace rangeseg::synth
