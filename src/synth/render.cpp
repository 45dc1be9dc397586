// Rendering a scene into an organized cloud with ground-truth labels.
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "synth/tracer.hpp"

namespace rangeseg::synth {
namespace {

/// Gives every 8-connected part of a surface but its largest its own label (appended to
/// `surfaces`, a copy of the surface's description named "<name>#k"). Runs on the noise-free
/// labels, so only occlusion splits a surface, not drop-outs.
void split_disconnected_parts(LabelImage& labels, std::vector<Surface>& surfaces,
                              std::vector<std::int32_t>& part_of) {
  const int width = labels.width(), height = labels.height();
  const auto at = [&](int u, int v) -> std::int32_t& { return labels.row(v)[u]; };
  std::vector<std::int32_t> part(static_cast<std::size_t>(width) * height, -1);
  struct Part {
    std::int32_t label;
    std::int64_t pixels;
  };
  std::vector<Part> parts;
  std::vector<std::pair<int, int>> stack;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const std::int32_t label = at(u, v);
      if (label == 0 || part[static_cast<std::size_t>(v) * width + u] >= 0) continue;
      const auto id = static_cast<std::int32_t>(parts.size());
      parts.push_back({label, 0});
      part[static_cast<std::size_t>(v) * width + u] = id;
      stack.assign(1, {u, v});
      while (!stack.empty()) {
        const auto [pu, pv] = stack.back();
        stack.pop_back();
        ++parts[id].pixels;
        for (int dv = -1; dv <= 1; ++dv) {
          for (int du = -1; du <= 1; ++du) {
            const int nu = pu + du, nv = pv + dv;
            if (nu < 0 || nv < 0 || nu >= width || nv >= height || at(nu, nv) != label) continue;
            std::int32_t& p = part[static_cast<std::size_t>(nv) * width + nu];
            if (p >= 0) continue;
            p = id;
            stack.emplace_back(nu, nv);
          }
        }
      }
    }
  }
  // The largest part keeps the surface's label (the first in scan order among equals).
  std::vector<std::int32_t> largest(surfaces.size() + 1, -1);
  for (std::size_t i = 0; i < parts.size(); ++i) {
    std::int32_t& best = largest[parts[i].label];
    if (best < 0 || parts[i].pixels > parts[best].pixels) best = static_cast<std::int32_t>(i);
  }
  std::vector<std::int32_t> new_label(parts.size());
  std::vector<int> count(surfaces.size() + 1, 1);
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const std::int32_t label = parts[i].label;
    if (largest[label] == static_cast<std::int32_t>(i)) {
      new_label[i] = label;
      continue;
    }
    Surface copy = surfaces[label - 1];
    copy.name.append(1, '#').append(std::to_string(++count[label]));
    surfaces.push_back(std::move(copy));
    part_of.push_back(label);
    new_label[i] = static_cast<std::int32_t>(surfaces.size());
  }
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const std::int32_t p = part[static_cast<std::size_t>(v) * width + u];
      if (p >= 0) at(u, v) = new_label[p];
    }
  }
}

}  // namespace

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

  out.part_of.resize(out.surfaces.size());
  for (std::size_t i = 0; i < out.part_of.size(); ++i) {
    out.part_of[i] = static_cast<std::int32_t>(i + 1);
  }
  if (settings.split_disconnected) {
    split_disconnected_parts(out.labels, out.surfaces, out.part_of);
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
