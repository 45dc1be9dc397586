// Internal: points of a cloud picked by index into one row, every plane the cloud has (the
// valid or shuffled points of cloud_ops.cpp, the spatial order of unorganized clouds), and the
// optional planes copied from cloud to cloud.
#pragma once

#include <cstddef>
#include <span>

#include "rangeseg/cloud.hpp"

namespace rangeseg::detail {

/// out = in[points[t]] for t in [0, points.size()), as one row; points index the cloud as
/// v * width + u. An empty `in` (an absent optional plane) empties `out`. `out` keeps its
/// buffer when it has the size already.
template <class T, class Index>
void gather_plane(const Plane<T>& in, std::span<const Index> points, Plane<T>& out) {
  if (in.empty()) {
    out.clear();
    return;
  }
  const auto n = static_cast<int>(points.size());
  if (out.width() != n || out.height() != 1) out.resize(n, 1);
  const auto width = static_cast<std::size_t>(in.width());
  T* dst = out.row(0);
  if (in.height() == 1) {
    const T* src = in.row(0);
    for (std::size_t t = 0; t < points.size(); ++t) dst[t] = src[points[t]];
    return;
  }
  for (std::size_t t = 0; t < points.size(); ++t) {
    const auto i = static_cast<std::size_t>(points[t]);
    dst[t] = in.row(static_cast<int>(i / width))[i % width];
  }
}

/// The points `points` of `cloud` as a cloud of one row: x, y, z and the optional planes the
/// cloud has. The caller checks that their count fits an int.
template <class Index>
void gather_points(const OrganizedCloud& cloud, std::span<const Index> points,
                   OrganizedCloud& out) {
  gather_plane(cloud.x, points, out.x);
  gather_plane(cloud.y, points, out.y);
  gather_plane(cloud.z, points, out.z);
  gather_plane(cloud.intensity, points, out.intensity);
  gather_plane(cloud.r, points, out.r);
  gather_plane(cloud.g, points, out.g);
  gather_plane(cloud.b, points, out.b);
  gather_plane(cloud.label, points, out.label);
}

/// The planes a stage passes through unchanged (intensity, colour, label) from `from` to `to`
/// (the filter's output, the pipeline's per-point results).
inline void copy_optional_planes(const OrganizedCloud& from, OrganizedCloud& to) {
  to.intensity = from.intensity;
  to.r = from.r;
  to.g = from.g;
  to.b = from.b;
  to.label = from.label;
}

}  // namespace rangeseg::detail
