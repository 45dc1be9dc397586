#include "rangeseg/camera.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "detail/fit_camera.hpp"
#include "detail/number_text.hpp"

namespace rangeseg {

void validate(const CameraIntrinsics& c) {
  const auto fail = [&](const char* what) {
    std::ostringstream message;
    message << "camera intrinsics: " << what << " (fx " << c.fx << ", fy " << c.fy << ", cx "
            << c.cx << ", cy " << c.cy << ", width " << c.width << ", height " << c.height << ")";
    throw std::invalid_argument(message.str());
  };
  if (!(std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) && std::isfinite(c.cy))) {
    fail("fx, fy, cx and cy must be finite");
  }
  if (!(c.fx > 0) || !(c.fy > 0)) fail("fx and fy must be > 0 [pixel]");
  if (c.width < 0 || c.height < 0) fail("width and height must be >= 0 (0: any size)");
}

namespace {

void require_scale(double depth_scale) {
  if (!(depth_scale > 0) || !std::isfinite(depth_scale)) {
    throw std::invalid_argument(
        "depth_to_cloud: depth_scale [m per unit] must be finite and > 0, got " +
        rangeseg::detail::number_text(depth_scale));
  }
}

template <class T>
void require_view(View<const T> depth) {
  if (depth.width < 0 || depth.height < 0 || depth.stride < depth.width ||
      (depth.data == nullptr && !depth.empty())) {
    throw std::invalid_argument("depth_to_cloud: invalid depth view " +
                                std::to_string(depth.width) + " x " + std::to_string(depth.height) +
                                ", stride " + std::to_string(depth.stride) +
                                (depth.data == nullptr ? ", no data" : ""));
  }
}

template <class T>
void require_rows(View<const T> depth, const OrganizedCloud& cloud, int row_begin, int row_end) {
  require_view(depth);
  if (cloud.width() != depth.width || cloud.height() != depth.height || row_begin < 0 ||
      row_end > depth.height || row_begin > row_end) {
    throw std::invalid_argument("depth_to_cloud_rows: rows [" + std::to_string(row_begin) + ", " +
                                std::to_string(row_end) + ") of a " + std::to_string(depth.width) +
                                " x " + std::to_string(depth.height) + " depth image into a " +
                                std::to_string(cloud.width()) + " x " +
                                std::to_string(cloud.height()) + " cloud");
  }
}

/// Every pixel of the rows is written: a valid depth z = metres(raw) > 0 gives the point on the
/// pixel's ray, anything else NaN.
/// validate(camera), and a size the camera states must be the depth image's: intrinsics of
/// another resolution (a colour camera's, a scaled stream's) put every point off its ray.
template <class T>
void require_camera_for(const CameraIntrinsics& camera, View<const T> depth) {
  validate(camera);
  if ((camera.width != 0 && camera.width != depth.width) ||
      (camera.height != 0 && camera.height != depth.height)) {
    const auto side = [](int size) {
      return size == 0 ? std::string("any") : std::to_string(size);
    };
    throw std::invalid_argument("the camera intrinsics are for a " + side(camera.width) + " x " +
                                side(camera.height) + " image, the depth image is " +
                                std::to_string(depth.width) + " x " + std::to_string(depth.height));
  }
}

template <class T, class Metres>
void convert_rows(View<const T> depth, const CameraIntrinsics& camera, Metres metres,
                  OrganizedCloud& cloud, int row_begin, int row_end) {
  const float inv_fx = static_cast<float>(1.0 / camera.fx),
              inv_fy = static_cast<float>(1.0 / camera.fy);
  const float cx = static_cast<float>(camera.cx), cy = static_cast<float>(camera.cy);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int v = row_begin; v < row_end; ++v) {
    const T* d = depth.row(v);
    float* xs = cloud.x.row(v);
    float* ys = cloud.y.row(v);
    float* zs = cloud.z.row(v);
    const float ray_y = (static_cast<float>(v) - cy) * inv_fy;
    for (int u = 0; u < depth.width; ++u) {
      const float z = metres(d[u]);
      const bool valid = z > 0 && z <= std::numeric_limits<float>::max();
      xs[u] = valid ? (static_cast<float>(u) - cx) * inv_fx * z : nan;
      ys[u] = valid ? ray_y * z : nan;
      zs[u] = valid ? z : nan;
    }
  }
}

/// Gives `cloud` the size of `depth` with x, y, z only, allocating only when the size changes.
template <class T>
void prepare(OrganizedCloud& cloud, View<const T> depth) {
  require_view(depth);
  const int width = depth.width, height = depth.height;
  cloud.intensity.clear();
  cloud.r.clear();
  cloud.g.clear();
  cloud.b.clear();
  cloud.label.clear();
  if (cloud.width() != width || cloud.height() != height || cloud.x.width() != width ||
      cloud.y.width() != width || cloud.x.height() != height || cloud.y.height() != height) {
    cloud.resize(width, height);
  }
}

auto raw_metres(double depth_scale) {
  const float scale = static_cast<float>(depth_scale);
  return [scale](std::uint16_t raw) { return raw == 0 ? 0.0f : static_cast<float>(raw) * scale; };
}

constexpr auto kMetres = [](float z) { return z; };

}  // namespace

void depth_to_cloud_rows(View<const std::uint16_t> depth, const CameraIntrinsics& camera,
                         double depth_scale, OrganizedCloud& cloud, int row_begin, int row_end) {
  require_camera_for(camera, depth);
  require_scale(depth_scale);
  require_rows(depth, cloud, row_begin, row_end);
  convert_rows(depth, camera, raw_metres(depth_scale), cloud, row_begin, row_end);
}

void depth_to_cloud_rows(View<const float> depth, const CameraIntrinsics& camera,
                         OrganizedCloud& cloud, int row_begin, int row_end) {
  require_camera_for(camera, depth);
  require_rows(depth, cloud, row_begin, row_end);
  convert_rows(depth, camera, kMetres, cloud, row_begin, row_end);
}

void depth_to_cloud(View<const std::uint16_t> depth, const CameraIntrinsics& camera,
                    double depth_scale, OrganizedCloud& cloud) {
  require_camera_for(camera, depth);
  require_scale(depth_scale);
  prepare(cloud, depth);
  convert_rows(depth, camera, raw_metres(depth_scale), cloud, 0, depth.height);
}

void depth_to_cloud(View<const float> depth, const CameraIntrinsics& camera,
                    OrganizedCloud& cloud) {
  require_camera_for(camera, depth);
  prepare(cloud, depth);
  convert_rows(depth, camera, kMetres, cloud, 0, depth.height);
}

OrganizedCloud depth_to_cloud(View<const std::uint16_t> depth, const CameraIntrinsics& camera,
                              double depth_scale) {
  OrganizedCloud cloud;
  depth_to_cloud(depth, camera, depth_scale, cloud);
  return cloud;
}

bool fit_intrinsics(const OrganizedCloud& cloud, CameraIntrinsics& camera, double tolerance,
                    double* max_error) {
  require_consistent(cloud, "fit_intrinsics");
  return detail::fit_intrinsics_every(cloud, 1, camera, tolerance, max_error);
}

bool detail::fit_intrinsics_every(const OrganizedCloud& cloud, int step, CameraIntrinsics& camera,
                                  double tolerance, double* max_error) {
  assert(step >= 1);
  if (max_error != nullptr) *max_error = std::numeric_limits<double>::infinity();
  // Per axis, t = x / z (or y / z) against the pixel coordinate s: t = a s + b, so that
  // f = 1 / a and c = -b / a. Sums in double, about the first sample to keep them well scaled.
  struct Line {
    double n = 0, s0 = 0, ss = 0, st = 0, t = 0, s = 0;
    bool two = false;
    void add(double s_, double t_) {
      if (n == 0) s0 = s_;
      two = two || s_ != s0;
      s_ -= s0;
      n += 1;
      s += s_;
      t += t_;
      ss += s_ * s_;
      st += s_ * t_;
    }
    bool fit(double& f, double& c) const {
      const double det = n * ss - s * s;
      if (!two || !(det > 0)) return false;
      const double a = (n * st - s * t) / det;
      const double b = (t - a * s) / n;
      if (!(a > 0) || !std::isfinite(a) || !std::isfinite(b)) return false;
      f = 1 / a;
      c = s0 - b / a;
      return std::isfinite(f) && std::isfinite(c);
    }
  } along_u, along_v;
  for (int v = 0; v < cloud.height(); v += step) {
    for (int u = 0; u < cloud.width(); u += step) {
      if (!cloud.valid(u, v) || !(cloud.z(u, v) > 0)) continue;
      const double z = cloud.z(u, v);
      along_u.add(u, cloud.x(u, v) / z);
      along_v.add(v, cloud.y(u, v) / z);
    }
  }
  CameraIntrinsics fitted;
  if (!along_u.fit(fitted.fx, fitted.cx) || !along_v.fit(fitted.fy, fitted.cy)) return false;
  fitted.width = cloud.width();
  fitted.height = cloud.height();
  double worst = 0;
  for (int v = 0; v < cloud.height(); v += step) {
    for (int u = 0; u < cloud.width(); u += step) {
      if (!cloud.valid(u, v) || !(cloud.z(u, v) > 0)) continue;
      const double z = cloud.z(u, v);
      const double du = fitted.fx * cloud.x(u, v) / z + fitted.cx - u;
      const double dv = fitted.fy * cloud.y(u, v) / z + fitted.cy - v;
      worst = std::max({worst, std::fabs(du), std::fabs(dv)});
    }
  }
  if (max_error != nullptr) *max_error = worst;
  if (!(worst <= tolerance)) return false;
  camera = fitted;
  return true;
}

DepthImage cloud_to_depth(const OrganizedCloud& cloud, double depth_scale) {
  require_consistent(cloud, "cloud_to_depth");
  if (!(depth_scale > 0) || !std::isfinite(depth_scale)) {
    throw std::invalid_argument(
        "cloud_to_depth: depth_scale [m per unit] must be finite and > 0, got " +
        rangeseg::detail::number_text(depth_scale));
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
