// The spatial order of an unorganized cloud's points (Morton codes), and the moves into it and
// back.

#include "unorganized/order.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>

#include "detail/gather_points.hpp"
#include "detail/radix_sort.hpp"
#include "unorganized/internal.hpp"

namespace rangeseg::unorganized {
namespace {

constexpr int kBitsPerAxis = 21;  // 3 x 21 = 63 bits of a 64-bit key
constexpr double kCells = (1u << kBitsPerAxis) - 1;

/// The low 21 bits of v spread to every third bit (bit j to bit 3 j).
std::uint64_t spread_bits(std::uint32_t v) {
  std::uint64_t x = v & ((1u << kBitsPerAxis) - 1);
  x = (x | x << 32) & 0x001F00000000FFFFull;
  x = (x | x << 16) & 0x001F0000FF0000FFull;
  x = (x | x << 8) & 0x100F00F00F00F00Full;
  x = (x | x << 4) & 0x10C30C30C30C30C3ull;
  x = (x | x << 2) & 0x1249249249249249ull;
  return x;
}

/// The cell of `value` on an axis from `low` with `scale` cells per unit. In double: the extent
/// of finite floats can exceed the float range (-3e38 to 3e38), and NaN would not convert.
std::uint32_t cell(float value, double low, double scale) {
  const double c = (double{value} - low) * scale;
  return c > 0 ? static_cast<std::uint32_t>(std::min(c, kCells)) : 0u;
}

template <class T>
void plane_to_input_order(Plane<T>& plane, const SpatialOrder& o, std::vector<T>& scratch) {
  const std::size_t n = o.order.size();
  if (n == 0) return;
  assert(plane.height() == 1 && static_cast<std::size_t>(plane.width()) == n);
  if (scratch.size() < n) scratch.resize(n);
  std::copy(plane.row(0), plane.row(0) + n, scratch.data());
  if (o.total != n) plane.resize(static_cast<int>(o.total), 1);
  T* row = plane.row(0);
  for (std::size_t t = 0; t < n; ++t) row[o.order[t]] = scratch[t];
  for (std::size_t c = 0; c < o.copies.size(); ++c) row[o.copies[c]] = row[o.copied[c]];
}

/// Point i = v * width + u of `cloud`.
std::array<float, 3> point_at(const OrganizedCloud& cloud, std::int32_t i) {
  const int w = cloud.width(), u = i % w, v = i / w;
  return {cloud.x.row(v)[u], cloud.y.row(v)[u], cloud.z.row(v)[u]};
}

bool same_point(const OrganizedCloud& cloud, std::int32_t a, std::int32_t b) {
  return point_at(cloud, a) == point_at(cloud, b);
}

/// Runs of equal keys longer than this are searched for copies by sorting, not pair by pair
/// (many points on one viewing ray share a key by direction).
constexpr std::size_t kLongRun = 32;

/// The copies in the long run o.order[run, end) (by position, then input index, so that the
/// first of equal points is the original), appended to o.copies / o.copied; `scratch` holds
/// the sorted run.
void copies_in_long_run(const OrganizedCloud& cloud, SpatialOrder& o, std::size_t run,
                        std::size_t end, std::vector<std::int32_t>& scratch) {
  scratch.assign(o.order.begin() + static_cast<std::ptrdiff_t>(run),
                 o.order.begin() + static_cast<std::ptrdiff_t>(end));
  std::sort(scratch.begin(), scratch.end(), [&](std::int32_t a, std::int32_t b) {
    const auto pa = point_at(cloud, a), pb = point_at(cloud, b);
    return pa != pb ? pa < pb : a < b;
  });
  std::size_t original = 0;
  for (std::size_t j = 1; j < scratch.size(); ++j) {
    if (!same_point(cloud, scratch[j], scratch[original])) {
      original = j;
      continue;
    }
    o.copies.push_back(scratch[j]);
    o.copied.push_back(scratch[original]);
  }
}

/// Moves the valid points in o.order[0, valid) that equal an earlier one of the same key (copies
/// share their key) to o.copies; returns how many stay.
std::size_t take_out_copies(const OrganizedCloud& cloud, SpatialOrder& o, std::size_t valid) {
  o.copies.clear();
  o.copied.clear();
  std::size_t kept = 0;
  for (std::size_t run = 0; run < valid;) {
    std::size_t end = run + 1;
    while (end < valid && o.keys[end] == o.keys[run]) ++end;
    if (end - run > kLongRun) {
      const std::size_t before = o.copies.size();
      copies_in_long_run(cloud, o, run, end, o.order_tmp);
      // The run's copies, by input index, to leave them out of the run in its order.
      std::vector<std::int32_t>& gone = o.order_tmp;
      gone.assign(o.copies.begin() + static_cast<std::ptrdiff_t>(before), o.copies.end());
      std::sort(gone.begin(), gone.end());
      for (std::size_t t = run; t < end; ++t) {
        if (!std::binary_search(gone.begin(), gone.end(), o.order[t])) o.order[kept++] = o.order[t];
      }
      run = end;
      continue;
    }
    const std::size_t first = kept;
    for (std::size_t t = run; t < end; ++t) {
      const std::int32_t i = o.order[t];
      std::size_t s = first;
      while (s < kept && !same_point(cloud, o.order[s], i)) ++s;
      if (s < kept) {
        o.copies.push_back(i);
        o.copied.push_back(o.order[s]);
      } else {
        o.order[kept++] = i;
      }
    }
    run = end;
  }
  return kept;
}

}  // namespace

void spatial_order(const OrganizedCloud& cloud, const RingSettings& settings, SpatialOrder& o) {
  const std::size_t n = cloud.size();
  const int w = cloud.width();
  o.order.clear();
  o.coords.clear();
  o.order.reserve(n);
  o.coords.reserve(3 * n);
  float low[3] = {std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
                  std::numeric_limits<float>::max()};
  float high[3] = {-low[0], -low[1], -low[2]};
  for (int v = 0; v < cloud.height(); ++v) {
    const float* x = cloud.x.row(v);
    const float* y = cloud.y.row(v);
    const float* z = cloud.z.row(v);
    for (int u = 0; u < w; ++u) {
      if (!std::isfinite(x[u]) || !std::isfinite(y[u]) || !std::isfinite(z[u])) continue;
      float c[3] = {x[u], y[u], z[u]};
      if (settings.by_direction) direction_from(settings.viewpoint, c, c);
      for (int a = 0; a < 3; ++a) {
        low[a] = std::min(low[a], c[a]);
        high[a] = std::max(high[a], c[a]);
        o.coords.push_back(c[a]);
      }
      o.order.push_back(static_cast<std::int32_t>(static_cast<std::size_t>(v) * w + u));
    }
  }
  const std::size_t valid = o.order.size();
  double scale[3];
  for (int a = 0; a < 3; ++a) {
    const double extent = double{high[a]} - low[a];
    scale[a] = extent > 0 ? kCells / extent : 0.0;
  }
  o.keys.resize(valid);
  for (std::size_t t = 0; t < valid; ++t) {
    const float* c = o.coords.data() + 3 * t;
    o.keys[t] = spread_bits(cell(c[0], low[0], scale[0])) |
                spread_bits(cell(c[1], low[1], scale[1])) << 1 |
                spread_bits(cell(c[2], low[2], scale[2])) << 2;
  }
  detail::radix_sort_by_key(o.order, o.keys, o.order_tmp, o.keys_tmp);
  o.total = n;
  o.order.resize(take_out_copies(cloud, o, valid));
  for (int v = 0; v < cloud.height(); ++v) {
    const float* x = cloud.x.row(v);
    const float* y = cloud.y.row(v);
    const float* z = cloud.z.row(v);
    for (int u = 0; u < w; ++u) {
      if (!std::isfinite(x[u]) || !std::isfinite(y[u]) || !std::isfinite(z[u])) {
        o.order.push_back(static_cast<std::int32_t>(static_cast<std::size_t>(v) * w + u));
      }
    }
  }
}

void gather(const OrganizedCloud& cloud, const std::vector<std::int32_t>& order,
            OrganizedCloud& out) {
  detail::gather_points(cloud, std::span<const std::int32_t>(order), out);
}

void rings_to_input_order(const PointRings& ordered, const SpatialOrder& o, PointRings& out) {
  const std::vector<std::int32_t>& order = o.order;
  const std::size_t n = ordered.size();
  assert(order.size() == n);
  const auto k = static_cast<std::size_t>(ordered.k);
  out.k = ordered.k;
  out.by_direction = ordered.by_direction;
  out.viewpoint = ordered.viewpoint;
  out.neighbours.resize(o.total * k);
  out.count.resize(o.total);
  for (std::size_t t = 0; t < n; ++t) {
    const auto i = static_cast<std::size_t>(order[t]);
    const std::uint8_t count = ordered.count[t];
    out.count[i] = count;
    const std::int32_t* from = ordered.neighbours.data() + t * k;
    std::int32_t* to = out.neighbours.data() + i * k;
    std::size_t j = 0;
    for (; j < count; ++j) to[j] = order[static_cast<std::size_t>(from[j])];
    for (; j < k; ++j) to[j] = -1;
  }
  for (std::size_t c = 0; c < o.copies.size(); ++c) {
    const auto i = static_cast<std::size_t>(o.copies[c]);
    const auto from = static_cast<std::size_t>(o.copied[c]);
    out.count[i] = out.count[from];
    std::copy_n(out.neighbours.data() + from * k, k, out.neighbours.data() + i * k);
  }
}

void to_input_order(FloatPlane& plane, const SpatialOrder& o, std::vector<float>& scratch) {
  plane_to_input_order(plane, o, scratch);
}

void to_input_order(LabelImage& plane, const SpatialOrder& o, std::vector<std::int32_t>& scratch) {
  plane_to_input_order(plane, o, scratch);
}

void to_input_order(NormalMap& normals, SpatialOrder& o) {
  for (FloatPlane* p : {&normals.nx, &normals.ny, &normals.nz, &normals.curvature}) {
    if (!p->empty()) to_input_order(*p, o, o.floats);
  }
}

}  // namespace rangeseg::unorganized
