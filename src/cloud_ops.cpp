#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <random>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "detail/gather_points.hpp"
#include "detail/number_text.hpp"
#include "detail/sensor_pose.hpp"
#include "rangeseg/cloud.hpp"

namespace rangeseg {
namespace {

template <class T>
void take_every(const Plane<T>& in, int factor, int out_width, int out_height, Plane<T>& out) {
  if (in.empty()) return;
  out.resize(out_width, out_height);
  for (int v = 0; v < out_height; ++v) {
    const T* src = in.row(v * factor);
    T* dst = out.row(v);
    for (int u = 0; u < out_width; ++u) dst[u] = src[static_cast<std::ptrdiff_t>(u) * factor];
  }
}

OrganizedCloud points_at(const OrganizedCloud& cloud, const std::vector<std::size_t>& pixels) {
  if (pixels.size() > static_cast<std::size_t>(std::numeric_limits<int>::max())) {
    throw std::invalid_argument("valid_points: " + std::to_string(pixels.size()) +
                                " points do not fit in one row");
  }
  OrganizedCloud out;
  detail::gather_points(cloud, std::span<const std::size_t>(pixels), out);
  return out;
}

std::vector<std::size_t> valid_pixels(const OrganizedCloud& cloud) {
  require_consistent(cloud, "valid_points");
  std::vector<std::size_t> pixels;
  pixels.reserve(cloud.size());
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if (cloud.valid(u, v)) pixels.push_back(static_cast<std::size_t>(v) * cloud.width() + u);
    }
  }
  return pixels;
}

}  // namespace

OrganizedCloud valid_points(const OrganizedCloud& cloud, std::vector<std::size_t>* pixels) {
  std::vector<std::size_t> p = valid_pixels(cloud);
  OrganizedCloud out = points_at(cloud, p);
  if (pixels != nullptr) *pixels = std::move(p);
  return out;
}

OrganizedCloud shuffled_valid_points(const OrganizedCloud& cloud, std::uint64_t seed,
                                     std::vector<std::size_t>* pixels) {
  std::vector<std::size_t> p = valid_pixels(cloud);
  std::shuffle(p.begin(), p.end(), std::mt19937_64(seed));
  OrganizedCloud out = points_at(cloud, p);
  if (pixels != nullptr) *pixels = std::move(p);
  return out;
}

OrganizedCloud downsample(const OrganizedCloud& cloud, int factor) {
  require_consistent(cloud, "downsample");
  if (factor < 1) {
    throw std::invalid_argument("downsample: factor must be >= 1, got " + std::to_string(factor));
  }
  // ceil(size / factor) without the overflow of size + factor - 1.
  const auto ceil_div = [factor](int size) { return size == 0 ? 0 : (size - 1) / factor + 1; };
  const int w = ceil_div(cloud.width()), h = ceil_div(cloud.height());
  OrganizedCloud out;
  take_every(cloud.x, factor, w, h, out.x);
  take_every(cloud.y, factor, w, h, out.y);
  take_every(cloud.z, factor, w, h, out.z);
  take_every(cloud.intensity, factor, w, h, out.intensity);
  take_every(cloud.r, factor, w, h, out.r);
  take_every(cloud.g, factor, w, h, out.g);
  take_every(cloud.b, factor, w, h, out.b);
  take_every(cloud.label, factor, w, h, out.label);
  return out;
}

void interleaved_to_cloud(const float* xyz, int width, int height, std::size_t point_stride,
                          OrganizedCloud& cloud) {
  constexpr std::size_t kPointBytes = 3 * sizeof(float);
  if (xyz == nullptr || width < 1 || height < 1 || point_stride < kPointBytes ||
      point_stride % alignof(float) != 0) {
    throw std::invalid_argument(
        "interleaved_to_cloud: needs points, width and height >= 1 and a point stride of at "
        "least 12 bytes, a multiple of 4; got " +
        std::string(xyz == nullptr ? "no points" : "points") + ", " + std::to_string(width) +
        " x " + std::to_string(height) + ", stride " + std::to_string(point_stride));
  }
  // Only the sizes change: a stream's cloud keeps its memory from frame to frame.
  for (FloatPlane* plane : {&cloud.x, &cloud.y, &cloud.z}) plane->resize(width, height, NAN);
  cloud.intensity.clear();
  for (BytePlane* plane : {&cloud.r, &cloud.g, &cloud.b}) plane->clear();
  cloud.label.clear();
  const std::size_t step = point_stride / sizeof(float);
  for (int v = 0; v < height; ++v) {
    const float* in = xyz + static_cast<std::size_t>(v) * static_cast<std::size_t>(width) * step;
    float* x = cloud.x.row(v);
    float* y = cloud.y.row(v);
    float* z = cloud.z.row(v);
    for (int u = 0; u < width; ++u, in += step) {
      // The sensor's own position is no measurement: every stage then sees the same invalid
      // pixel, and a camera's points, flattened, stay on its pixel grid.
      const bool valid = std::isfinite(in[0]) && std::isfinite(in[1]) && std::isfinite(in[2]) &&
                         (in[0] != 0.0f || in[1] != 0.0f || in[2] != 0.0f);
      x[u] = valid ? in[0] : NAN;
      y[u] = valid ? in[1] : NAN;
      z[u] = valid ? in[2] : NAN;
    }
  }
}

OrganizedCloud interleaved_to_cloud(const float* xyz, int width, int height,
                                    std::size_t point_stride) {
  OrganizedCloud cloud;
  interleaved_to_cloud(xyz, width, height, point_stride, cloud);
  return cloud;
}

namespace detail {

SensorPose sensor_pose(const std::array<double, 7>& pose, const char* what) {
  const bool finite =
      std::all_of(pose.begin(), pose.end(), [](double v) { return std::isfinite(v); });
  Eigen::Quaterniond q(pose[3], pose[4], pose[5], pose[6]);
  if (!finite || !(q.norm() >= 1e-6)) {
    std::string values;
    for (const double v : pose) {
      if (!values.empty()) values += ' ';
      values += rangeseg::detail::number_text(v);
    }
    throw std::invalid_argument(std::string(what) + ": pose (tx ty tz qw qx qy qz) = " + values +
                                " needs finite values and a quaternion of norm >= 1e-6");
  }
  return {q.normalized().toRotationMatrix().transpose(),
          Eigen::Vector3d(pose[0], pose[1], pose[2])};
}

}  // namespace detail

void to_sensor_frame(OrganizedCloud& cloud, const std::array<double, 7>& pose) {
  require_consistent(cloud, "to_sensor_frame");
  const detail::SensorPose motion = detail::sensor_pose(pose, "to_sensor_frame");
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if (!cloud.valid(u, v)) continue;
      const Eigen::Vector3d p =
          motion.apply(Eigen::Vector3d(cloud.x(u, v), cloud.y(u, v), cloud.z(u, v)));
      cloud.x(u, v) = static_cast<float>(p.x());
      cloud.y(u, v) = static_cast<float>(p.y());
      cloud.z(u, v) = static_cast<float>(p.z());
    }
  }
}

}  // namespace rangeseg
