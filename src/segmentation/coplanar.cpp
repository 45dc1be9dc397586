#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <numbers>
#include <numeric>
#include <vector>

#include "rangeseg/segmentation.hpp"

namespace rangeseg {

namespace {

double dot(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

double norm(const std::array<double, 3>& a) { return std::sqrt(dot(a, a)); }

/// The standard error of a plane segment's normal [rad], its points spread as a disc of its area.
double normal_stderr(const Segment& s, double sigma) {
  const double spread2 = s.area_m2 / (4.0 * std::numbers::pi);  // a disc's in-plane variance
  const double residual = std::max(s.rms_residual, sigma);
  const double n = static_cast<double>(s.pixel_count);
  if (!(spread2 > 0.0) || !(n > 0.0)) return std::numbers::pi;
  return residual / std::sqrt(n * spread2);
}

}  // namespace

std::vector<int> coplanar_groups(const Segmentation& segmentation,
                                 const SegmentationSettings& settings) {
  validate(settings);
  const std::vector<Segment>& segments = segmentation.segments;
  const std::size_t n = segments.size();
  std::vector<double> sigma(n, 0.0), stderr_normal(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    sigma[i] = settings.noise.sigma(norm(segments[i].centroid));
    stderr_normal[i] = normal_stderr(segments[i], sigma[i]);
  }
  const double k = settings.merge_distance_sigmas;
  const auto same_plane = [&](std::size_t a, std::size_t b) {
    const Segment& sa = segments[a];
    const Segment& sb = segments[b];
    const double angle = std::acos(std::min(1.0, std::fabs(dot(sa.normal, sb.normal))));
    if (angle > settings.merge_angle + k * std::hypot(stderr_normal[a], stderr_normal[b])) {
      return false;
    }
    const std::array<double, 3> d{sa.centroid[0] - sb.centroid[0], sa.centroid[1] - sb.centroid[1],
                                  sa.centroid[2] - sb.centroid[2]};
    const double lever2 = dot(d, d);
    const auto on_plane = [&](std::size_t point_of, std::size_t plane_of) {
      const Segment& p = segments[point_of];
      const Segment& q = segments[plane_of];
      const double distance = dot(q.normal, p.centroid) + q.offset;
      // The noise, or the larger scatter of a plane fit that also sees the sensor's systematic
      // bending of large planes, on both sides; and the plane's tilt error over the lever.
      const double own = std::max(sigma[point_of], p.rms_residual);
      const double tol2 = k * k *
                          (own * own + q.rms_residual * q.rms_residual +
                           lever2 * stderr_normal[plane_of] * stderr_normal[plane_of]);
      return distance * distance <= tol2;
    };
    return on_plane(a, b) && on_plane(b, a);
  };
  // Union-find; the root is the smallest index, the largest segment (segments are by size).
  std::vector<std::size_t> parent(n);
  std::iota(parent.begin(), parent.end(), std::size_t{0});
  const auto find = [&](std::size_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (std::size_t a = 0; a < n; ++a) {
    if (!is_plane(segments[a])) continue;
    for (std::size_t b = a + 1; b < n; ++b) {
      if (!is_plane(segments[b]) || !same_plane(a, b)) continue;
      const std::size_t ra = find(a), rb = find(b);
      if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
    }
  }
  std::vector<int> groups(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (is_plane(segments[i])) groups[i] = segments[find(i)].label;
  }
  return groups;
}

}  // namespace rangeseg
