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
  const int w = (cloud.width() + factor - 1) / factor;
  const int h = (cloud.height() + factor - 1) / factor;
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

void to_sensor_frame(OrganizedCloud& cloud, const std::array<double, 7>& pose) {
  require_consistent(cloud, "to_sensor_frame");
  const bool finite =
      std::all_of(pose.begin(), pose.end(), [](double v) { return std::isfinite(v); });
  Eigen::Quaterniond q(pose[3], pose[4], pose[5], pose[6]);
  if (!finite || !(q.norm() >= 1e-6)) {
    std::string values;
    for (const double v : pose) {
      if (!values.empty()) values += ' ';
      values += std::to_string(v);
    }
    throw std::invalid_argument("to_sensor_frame: pose (tx ty tz qw qx qy qz) = " + values +
                                " needs finite values and a quaternion of norm >= 1e-6");
  }
  const Eigen::Matrix3d to_sensor = q.normalized().toRotationMatrix().transpose();
  const Eigen::Vector3d origin(pose[0], pose[1], pose[2]);
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if (!cloud.valid(u, v)) continue;
      const Eigen::Vector3d p =
          to_sensor * (Eigen::Vector3d(cloud.x(u, v), cloud.y(u, v), cloud.z(u, v)) - origin);
      cloud.x(u, v) = static_cast<float>(p.x());
      cloud.y(u, v) = static_cast<float>(p.y());
      cloud.z(u, v) = static_cast<float>(p.z());
    }
  }
}

}  // namespace rangeseg
