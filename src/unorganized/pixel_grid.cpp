// The pixel grid of a depth camera's valid points (rangeseg/pixel_grid.hpp).
#include "rangeseg/pixel_grid.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "detail/radix_sort.hpp"
#include "unorganized/internal.hpp"

namespace rangeseg {
namespace {

/// Sorted x / z values of one pixel column follow each other closely: they differ by float
/// rounding (~1e-7), or by the rounding of text with 6 significant digits (Open3D's and PCL's
/// ascii files: ~5e-6 over a column), and a column holds many points; the columns of a camera
/// with fx <= 50000 pixels are at least 2e-5 apart. A gap of more than this starts a column.
constexpr double kColumnGap = 1e-5;
/// How far from an integer pixel coordinate a point may lie [pixels].
constexpr double kPixelTolerance = 0.05;
constexpr int kMaxSide = 16384;
constexpr double kMaxPixelsPerPoint = 16;
constexpr double kMinNeighbours = 3;
constexpr std::size_t kMinPoints = 16;
constexpr std::size_t kFitSample = 32768;

float from_order_key(std::uint32_t key) {
  return std::bit_cast<float>((key & 0x80000000u) != 0 ? key & 0x7fffffffu : ~key);
}

/// t = t0 + index / f: one axis of the lattice.
struct Axis {
  double t0 = 0, f = 0;
  int size = 0;
};

/// The lattice of the values of one axis (x / z or y / z of the valid points) from their
/// sorted float keys: the clusters of equal values are the columns; consecutive columns are
/// numbered by their gap in units of the smallest gap, and the spacing is fitted to all of them
/// by least squares (a single gap's rounding would drift over hundreds of columns).
bool fit_axis(const std::vector<std::uint32_t>& sorted, std::vector<double>& columns, Axis& out) {
  columns.clear();
  double sum = 0, previous = from_order_key(sorted[0]);
  std::size_t count = 0;
  for (const std::uint32_t key : sorted) {
    const double t = from_order_key(key);
    if (t - previous > kColumnGap) {
      columns.push_back(sum / static_cast<double>(count));
      if (columns.size() > static_cast<std::size_t>(kMaxSide)) return false;
      sum = 0;
      count = 0;
    }
    previous = t;
    sum += t;
    ++count;
  }
  columns.push_back(sum / static_cast<double>(count));
  if (columns.size() < 2) return false;
  double gap = std::numeric_limits<double>::max();
  for (std::size_t j = 1; j < columns.size(); ++j) gap = std::min(gap, columns[j] - columns[j - 1]);
  // Index the columns by their gaps, then fit t = t0 + index * s.
  double index = 0, sk = 0, st = 0, skk = 0, skt = 0;
  const auto n = static_cast<double>(columns.size());
  for (std::size_t j = 0; j < columns.size(); ++j) {
    if (j > 0) {
      const double steps = (columns[j] - columns[j - 1]) / gap;
      const double whole = std::round(steps);
      if (std::fabs(steps - whole) > 0.25) return false;
      index += whole;
      if (index >= kMaxSide) return false;
    }
    sk += index;
    st += columns[j];
    skk += index * index;
    skt += index * columns[j];
  }
  const double s = (n * skt - sk * st) / (n * skk - sk * sk);
  if (!(s > 0)) return false;
  out.f = 1.0 / s;
  out.t0 = (st - s * sk) / n;
  out.size = static_cast<int>(index) + 1;
  return true;
}

/// The pixel index of value t on the axis, or -1 when it is not within the tolerance of one.
int pixel_on(const Axis& axis, double t) {
  const double u = (t - axis.t0) * axis.f;
  if (!(u > -0.5 && u < axis.size - 0.5)) return -1;
  // u > -0.5, so truncation rounds (std::round is a library call, 2 per point). It rounds
  // u = 0.5 - 2^-54 up, which fails the tolerance either way.
  const int whole = static_cast<int>(u + 0.5);  // NOLINT(bugprone-incorrect-roundings)
  return std::fabs(u - whole) <= kPixelTolerance ? whole : -1;
}

bool find(const OrganizedCloud& cloud, PixelGrid& grid, RingBuffers::Impl& b) {
  require_consistent(cloud, "find_pixel_grid");
  grid.width = grid.height = 0;
  grid.pixel.assign(cloud.size(), -1);
  // x / z and y / z of the valid points: in float, ~1e-7 off, 1e-4 pixel at fx = 1000.
  std::vector<std::int32_t>& items = b.grid_items;
  std::vector<float>& tu = b.grid_tu;
  std::vector<float>& tv = b.grid_tv;
  items.clear();
  tu.clear();
  tv.clear();
  const int w = cloud.width();
  for (int row = 0; row < cloud.height(); ++row) {
    const float* x = cloud.x.row(row);
    const float* y = cloud.y.row(row);
    const float* z = cloud.z.row(row);
    for (int col = 0; col < w; ++col) {
      if (!(std::isfinite(x[col]) && std::isfinite(y[col]) && std::isfinite(z[col]))) continue;
      if (!(z[col] > 0)) return false;
      items.push_back(row * w + col);
      tu.push_back(x[col] / z[col]);
      tv.push_back(y[col] / z[col]);
    }
  }
  const std::size_t points = items.size();
  if (points < kMinPoints) return false;
  Axis u_axis, v_axis;
  std::vector<std::int32_t>& tmp = b.grid_items_tmp;
  std::vector<std::uint32_t>& keys_tmp = b.grid_keys_tmp;
  // The lattices are fitted to a sample of ~32768 points (hundreds per column of a 640 x 480
  // frame, so adjacent columns are both in it); every point is checked against them below.
  const std::size_t step = std::max<std::size_t>(1, points / kFitSample);
  for (auto [values, axis] : {std::pair{&tu, &u_axis}, std::pair{&tv, &v_axis}}) {
    b.grid_sorted.clear();
    b.grid_sorted_keys.clear();
    for (std::size_t j = 0; j < points; j += step) {
      b.grid_sorted.push_back(items[j]);
      b.grid_sorted_keys.push_back(detail::float_order_key((*values)[j]));
    }
    detail::radix_sort_by_key(b.grid_sorted, b.grid_sorted_keys, tmp, keys_tmp);
    if (!fit_axis(b.grid_sorted_keys, b.grid_columns, *axis)) return false;
    // The sample may have missed the outermost columns: the lattice spans all the values.
    const auto [low, high] = std::minmax_element(values->begin(), values->end());
    axis->t0 += std::round((*low - axis->t0) * axis->f) / axis->f;
    const double size = std::round((*high - axis->t0) * axis->f) + 1;
    if (!(size >= 2 && size <= kMaxSide)) return false;
    axis->size = static_cast<int>(size);
  }
  const auto width = static_cast<std::size_t>(u_axis.size);
  const auto height = static_cast<std::size_t>(v_axis.size);
  if (static_cast<double>(width) * static_cast<double>(height) >
      kMaxPixelsPerPoint * static_cast<double>(points)) {
    return false;
  }
  std::vector<std::uint8_t>& taken = b.grid_taken;
  taken.assign(width * height, 0);
  for (std::size_t j = 0; j < points; ++j) {
    const int u = pixel_on(u_axis, tu[j]);
    const int v = pixel_on(v_axis, tv[j]);
    if (u < 0 || v < 0) return false;
    const std::size_t pixel = static_cast<std::size_t>(v) * width + static_cast<std::size_t>(u);
    if (taken[pixel] != 0) return false;
    taken[pixel] = 1;
    grid.pixel[static_cast<std::size_t>(items[j])] = static_cast<std::int32_t>(pixel);
  }
  // Dense enough for the mesh: on average at least 3 of a point's 4 pixel neighbours are points.
  // Each pair of 4-neighbours counts once per row (left-right) or column (up-down) pair, for
  // both of its points.
  std::size_t pairs = 0;
  for (std::size_t v = 0; v < height; ++v) {
    const std::uint8_t* row = taken.data() + v * width;
    for (std::size_t u = 0; u + 1 < width; ++u) pairs += row[u] & row[u + 1];
    if (v + 1 < height) {
      for (std::size_t u = 0; u < width; ++u) pairs += row[u] & row[u + width];
    }
  }
  const std::size_t neighbours = 2 * pairs;
  if (static_cast<double>(neighbours) < kMinNeighbours * static_cast<double>(points)) return false;
  grid.width = u_axis.size;
  grid.height = v_axis.size;
  grid.fx = u_axis.f;
  grid.fy = v_axis.f;
  grid.cx = -u_axis.t0 * u_axis.f;
  grid.cy = -v_axis.t0 * v_axis.f;
  return true;
}

}  // namespace

bool find_pixel_grid(const OrganizedCloud& cloud, PixelGrid& grid) {
  RingBuffers buffers;
  return find_pixel_grid(cloud, grid, buffers);
}

bool find_pixel_grid(const OrganizedCloud& cloud, PixelGrid& grid, RingBuffers& buffers) {
  if (find(cloud, grid, buffers.impl())) return true;
  grid.clear();
  return false;
}

void scatter_to_grid(const OrganizedCloud& cloud, const PixelGrid& grid, OrganizedCloud& out) {
  require_consistent(cloud, "scatter_to_grid");
  if (!grid.found() || grid.pixel.size() != cloud.size()) {
    throw std::invalid_argument(
        "scatter_to_grid: the grid (" + std::to_string(grid.width) + " x " +
        std::to_string(grid.height) + ", " + std::to_string(grid.pixel.size()) +
        " points) was not found for this cloud of " + std::to_string(cloud.size()) + " points");
  }
  constexpr float nan = std::numeric_limits<float>::quiet_NaN();
  const int w = grid.width, h = grid.height;
  out.x.resize(w, h, nan);
  out.y.resize(w, h, nan);
  out.z.resize(w, h, nan);
  const auto optional = [&](const auto& in, auto& plane) {
    if (in.empty()) {
      plane.clear();
    } else {
      plane.resize(w, h, {});
    }
  };
  optional(cloud.intensity, out.intensity);
  optional(cloud.r, out.r);
  optional(cloud.g, out.g);
  optional(cloud.b, out.b);
  optional(cloud.label, out.label);
  // Every plane of a width has the same row stride, the cloud's and the grid's.
  const std::ptrdiff_t stride = out.z.stride(), cloud_stride = cloud.z.stride();
  const auto width = static_cast<std::uint32_t>(w);
  const auto cloud_width = static_cast<std::size_t>(cloud.width());
  const bool one_row = cloud.height() == 1;
  for (std::size_t i = 0; i < grid.pixel.size(); ++i) {
    if (grid.pixel[i] < 0) continue;
    const std::ptrdiff_t to = unorganized::grid_offset(grid.pixel[i], width, stride);
    const std::ptrdiff_t from = one_row
                                    ? static_cast<std::ptrdiff_t>(i)
                                    : static_cast<std::ptrdiff_t>(i / cloud_width) * cloud_stride +
                                          static_cast<std::ptrdiff_t>(i % cloud_width);
    out.x.row(0)[to] = cloud.x.row(0)[from];
    out.y.row(0)[to] = cloud.y.row(0)[from];
    out.z.row(0)[to] = cloud.z.row(0)[from];
    if (!cloud.intensity.empty()) out.intensity.row(0)[to] = cloud.intensity.row(0)[from];
    if (!cloud.r.empty()) {
      out.r.row(0)[to] = cloud.r.row(0)[from];
      out.g.row(0)[to] = cloud.g.row(0)[from];
      out.b.row(0)[to] = cloud.b.row(0)[from];
    }
    if (!cloud.label.empty()) out.label.row(0)[to] = cloud.label.row(0)[from];
  }
}

}  // namespace rangeseg
