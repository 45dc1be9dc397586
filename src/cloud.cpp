#include "rangeseg/cloud.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "rangeseg/sensor.hpp"

namespace rangeseg {

void OrganizedCloud::resize(int width, int height) {
  constexpr float nan = std::numeric_limits<float>::quiet_NaN();
  const bool had_intensity = has_intensity(), had_rgb = has_rgb(), had_label = has_label();
  x.resize(width, height, nan);
  y.resize(width, height, nan);
  z.resize(width, height, nan);
  if (had_intensity) add_intensity();
  if (had_rgb) add_rgb();
  if (had_label) add_label();
}

void OrganizedCloud::add_rgb() {
  r.resize(width(), height(), 0);
  g.resize(width(), height(), 0);
  b.resize(width(), height(), 0);
}

std::size_t OrganizedCloud::count_valid() const { return cloud_stats(*this).valid; }

CloudStats cloud_stats(const OrganizedCloud& cloud) {
  require_consistent(cloud, "cloud_stats");
  CloudStats s;
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  // Squared ranges in double (no overflow for finite floats); one root each at the end.
  double near = std::numeric_limits<double>::infinity(), far = 0;
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if (!cloud.valid(u, v)) continue;
      ++s.valid;
      const double x = cloud.x(u, v), y = cloud.y(u, v), z = cloud.z(u, v);
      lo = std::min(lo, cloud.z(u, v));
      hi = std::max(hi, cloud.z(u, v));
      near = std::min(near, x * x + y * y + z * z);
      far = std::max(far, x * x + y * y + z * z);
    }
  }
  if (s.valid > 0) {
    s.min_z = lo;
    s.max_z = hi;
    s.min_range = static_cast<float>(std::sqrt(near));
    s.max_range = static_cast<float>(std::sqrt(far));
  }
  return s;
}

namespace {

/// Where a cloud's valid points lie: their largest coordinate and bounding-box diagonal [m], and
/// the median of their distances from the origin [m] over at most ~4096 of them (0 points: all
/// zero, `median_range` NaN).
struct PointSpread {
  double largest = 0, extent = 0, median_range = std::numeric_limits<double>::quiet_NaN();
};

PointSpread point_spread(const OrganizedCloud& cloud) {
  std::vector<float> range;
  PointSpread spread;
  std::array<double, 3> low{INFINITY, INFINITY, INFINITY}, high{-INFINITY, -INFINITY, -INFINITY};
  const std::size_t step = std::max<std::size_t>(1, cloud.size() / 4096);
  std::size_t index = 0;
  for (int v = 0; v < cloud.height(); ++v) {
    const float *x = cloud.x.row(v), *y = cloud.y.row(v), *z = cloud.z.row(v);
    for (int u = 0; u < cloud.width(); ++u, ++index) {
      if (!std::isfinite(x[u]) || !std::isfinite(y[u]) || !std::isfinite(z[u])) continue;
      const std::array<double, 3> p{x[u], y[u], z[u]};
      for (std::size_t a = 0; a < 3; ++a) {
        spread.largest = std::max(spread.largest, std::fabs(p[a]));
        low[a] = std::min(low[a], p[a]);
        high[a] = std::max(high[a], p[a]);
      }
      if (index % step == 0) range.push_back(static_cast<float>(std::hypot(p[0], p[1], p[2])));
    }
  }
  if (range.empty()) return spread;
  spread.extent = std::hypot(high[0] - low[0], high[1] - low[1], high[2] - low[2]);
  const auto middle = range.begin() + static_cast<std::ptrdiff_t>(range.size() / 2);
  std::nth_element(range.begin(), middle, range.end());
  spread.median_range = *middle;
  return spread;
}

}  // namespace

std::string cloud_scale_problem(const OrganizedCloud& cloud) {
  // Coordinates from which float keeps no millimetre [m] (its steps there are 1-2 mm), and
  // median distances from the sensor beyond any range sensor's, or below any's [m].
  constexpr double kFarCoordinate = 8192, kFarMedian = 500, kNearMedian = 0.01;
  // A cloud this much smaller than its distance from the origin lies far from it, whatever its
  // unit (a room in millimetres is about as wide as it is far from its camera).
  constexpr double kFarFromOrigin = 0.1;
  require_consistent(cloud, "cloud_scale_problem");
  const PointSpread spread = point_spread(cloud);
  if (!std::isfinite(spread.median_range)) return {};
  char text[320];
  if (spread.largest >= kFarCoordinate && spread.extent < 0.1 * spread.largest) {
    std::snprintf(
        text, sizeof text,
        "coordinates up to %.6g m, where float points lie %.3g m apart: move the origin "
        "near the sensor (e.g. subtract a UTM offset)",
        spread.largest,
        static_cast<double>(std::nextafter(static_cast<float>(spread.largest), INFINITY)) -
            spread.largest);
    return text;
  }
  const double median = spread.median_range;
  if (median > kFarMedian && spread.extent < kFarFromOrigin * median) {
    std::snprintf(text, sizeof text,
                  "the points lie %.4g m from the origin and span %.3g m: rangeseg takes the "
                  "sensor to be at the origin; points in a map's or another frame need the "
                  "sensor's pose applied, or the origin moved near the sensor",
                  median, spread.extent);
    return text;
  }
  if (median > kFarMedian) {
    std::snprintf(text, sizeof text,
                  "the points' median distance from the sensor is %.4g m: rangeseg reads metres "
                  "(a cloud in millimetres: scale it by 0.001)",
                  median);
    return text;
  }
  if (median < kNearMedian) {
    std::snprintf(text, sizeof text,
                  "the points' median distance from the sensor is %.4g m: rangeseg reads metres "
                  "(are they in another unit, or not in the sensor's frame?)",
                  median);
    return text;
  }
  return {};
}

std::string noise_scale_problem(const OrganizedCloud& cloud, const SensorNoise& noise) {
  // The segmentation's distance tests take about 3 sigma; beyond a tenth of the scene, they
  // join surfaces that lie apart in it (a room's floor and table top).
  constexpr double kSigmasOfTests = 3, kPartOfScene = 0.1;
  require_consistent(cloud, "noise_scale_problem");
  const PointSpread spread = point_spread(cloud);
  if (!std::isfinite(spread.median_range) || spread.extent <= 0) return {};
  const double sigma = noise.sigma(spread.median_range);
  if (!(kSigmasOfTests * sigma > kPartOfScene * spread.extent)) return {};
  char text[640];
  std::snprintf(text, sizeof text,
                "at the points' median distance from the origin (%.4g m) the noise model's sigma "
                "is %.3g m, over a thirtieth of their extent (%.3g m), so its tests cannot tell "
                "their surfaces apart; rangeseg takes the sensor to be at the origin: points "
                "beyond its range, or in a map's or another frame (merged scans), need the "
                "sensor's pose applied or the origin moved near it, or a noise model of their "
                "own (a map: a constant sigma, b = 0)",
                spread.median_range, sigma, spread.extent);
  return text;
}

bool surrounds_its_sensor(const OrganizedCloud& cloud) {
  require_consistent(cloud, "surrounds_its_sensor");
  constexpr std::size_t kFewestPoints = 100;  // that can tell a scan all round its sensor
  double sum[3] = {0, 0, 0};
  std::size_t n = 0;
  for (int v = 0; v < cloud.height(); ++v) {
    const float *x = cloud.x.row(v), *y = cloud.y.row(v), *z = cloud.z.row(v);
    for (int u = 0; u < cloud.width(); ++u) {
      const double px = x[u], py = y[u], pz = z[u];
      const double r = std::sqrt(px * px + py * py + pz * pz);
      if (!(r > 0) || !std::isfinite(r)) continue;
      sum[0] += px / r;
      sum[1] += py / r;
      sum[2] += pz / r;
      ++n;
    }
  }
  return n >= kFewestPoints && std::hypot(sum[0], sum[1], sum[2]) < 0.5 * static_cast<double>(n);
}

void require_organized(const OrganizedCloud& cloud, const char* what) {
  if (!cloud.is_organized()) {
    throw std::invalid_argument(
        std::string(what) + ": needs an organized cloud (height >= 2), got " +
        std::to_string(cloud.width()) + "x" + std::to_string(cloud.height()));
  }
  require_consistent(cloud, what);
}

void require_consistent(const OrganizedCloud& cloud, const char* what) {
  // Every function indexes each plane with the cloud's size.
  const auto require_size = [&](int width, int height, const char* plane, bool optional) {
    if ((optional && (width == 0 || height == 0)) ||
        (width == cloud.width() && height == cloud.height())) {
      return;
    }
    throw std::invalid_argument(std::string(what) + ": the cloud's " + plane + " plane is " +
                                std::to_string(width) + "x" + std::to_string(height) +
                                ", its z plane " + std::to_string(cloud.width()) + "x" +
                                std::to_string(cloud.height()));
  };
  require_size(cloud.x.width(), cloud.x.height(), "x", false);
  require_size(cloud.y.width(), cloud.y.height(), "y", false);
  require_size(cloud.intensity.width(), cloud.intensity.height(), "intensity", true);
  require_size(cloud.label.width(), cloud.label.height(), "label", true);
  // r, g and b come together: present (the cloud's size) or all empty.
  const int colours = int{!cloud.r.empty()} + int{!cloud.g.empty()} + int{!cloud.b.empty()};
  if (colours != 0 && colours != 3) {
    throw std::invalid_argument(std::string(what) + ": the cloud has " + std::to_string(colours) +
                                " of the r, g, b planes; they come together");
  }
  require_size(cloud.r.width(), cloud.r.height(), "r", true);
  require_size(cloud.g.width(), cloud.g.height(), "g", true);
  require_size(cloud.b.width(), cloud.b.height(), "b", true);
}

}  // namespace rangeseg
