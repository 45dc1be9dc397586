#include "rangeseg/cloud.hpp"

#include <algorithm>
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
  CloudStats s;
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if (!cloud.valid(u, v)) continue;
      ++s.valid;
      lo = std::min(lo, cloud.z(u, v));
      hi = std::max(hi, cloud.z(u, v));
    }
  }
  if (s.valid > 0) {
    s.min_z = lo;
    s.max_z = hi;
  }
  return s;
}

void require_organized(const OrganizedCloud& cloud, const char* what) {
  if (!cloud.is_organized()) {
    throw std::invalid_argument(
        std::string(what) + ": needs an organized cloud (height >= 2), got " +
        std::to_string(cloud.width()) + "x" + std::to_string(cloud.height()));
  }
}

}  // namespace rangeseg
