#include "rangeseg/cloud.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

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
