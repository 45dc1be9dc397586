#include "rangeseg/camera.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace rangeseg {

void validate(const CameraIntrinsics& c) {
  if (!(std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) && std::isfinite(c.cy)) ||
      c.fx <= 0 || c.fy <= 0 || c.width < 0 || c.height < 0) {
    throw std::invalid_argument("camera intrinsics invalid: fx=" + std::to_string(c.fx) +
                                " fy=" + std::to_string(c.fy) + " cx=" + std::to_string(c.cx) +
                                " cy=" + std::to_string(c.cy) + " (need finite, fx, fy > 0)");
  }
}

OrganizedCloud depth_to_cloud(View<const std::uint16_t> depth, const CameraIntrinsics& camera,
                              double depth_scale) {
  validate(camera);
  if (!(depth_scale > 0) || !std::isfinite(depth_scale)) {
    throw std::invalid_argument("depth_to_cloud: depth_scale must be > 0, got " +
                                std::to_string(depth_scale));
  }
  OrganizedCloud cloud(depth.width, depth.height);
  const float inv_fx = static_cast<float>(1.0 / camera.fx),
              inv_fy = static_cast<float>(1.0 / camera.fy);
  const float cx = static_cast<float>(camera.cx), cy = static_cast<float>(camera.cy);
  const float scale = static_cast<float>(depth_scale);
  for (int v = 0; v < depth.height; ++v) {
    const std::uint16_t* d = depth.row(v);
    float* xs = cloud.x.row(v);
    float* ys = cloud.y.row(v);
    float* zs = cloud.z.row(v);
    const float ray_y = (static_cast<float>(v) - cy) * inv_fy;
    for (int u = 0; u < depth.width; ++u) {
      if (d[u] == 0) continue;
      const float z = static_cast<float>(d[u]) * scale;
      xs[u] = (static_cast<float>(u) - cx) * inv_fx * z;
      ys[u] = ray_y * z;
      zs[u] = z;
    }
  }
  return cloud;
}

DepthImage cloud_to_depth(const OrganizedCloud& cloud, double depth_scale) {
  require_consistent(cloud, "cloud_to_depth");
  if (!(depth_scale > 0) || !std::isfinite(depth_scale)) {
    throw std::invalid_argument("cloud_to_depth: depth_scale must be > 0, got " +
                                std::to_string(depth_scale));
  }
  DepthImage depth(cloud.width(), cloud.height(), 0);
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if (!cloud.valid(u, v)) continue;
      const double raw = std::round(static_cast<double>(cloud.z(u, v)) / depth_scale);
      if (raw >= 1 && raw <= 65535) depth(u, v) = static_cast<std::uint16_t>(raw);
    }
  }
  return depth;
}

}  // namespace rangeseg
