// The seam of a grid whose columns go once round the sensor (a spinning lidar's organized scan):
// its first and last columns are neighbours that the mesh, a grid, does not join.
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "segmentation/internal.hpp"

namespace rangeseg::seg {

namespace {

bool valid(const Frame& f, std::ptrdiff_t i) {
  return std::isfinite(f.x[i]) && std::isfinite(f.y[i]) && std::isfinite(f.z[i]);
}

double distance(const Frame& f, std::ptrdiff_t a, std::ptrdiff_t b) {
  const double dx = double{f.x[a]} - f.x[b], dy = double{f.y[a]} - f.y[b],
               dz = double{f.z[a]} - f.z[b];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

/// The angle between the rays from the origin to points a and b [rad]; 0 when one is the origin.
double ray_angle(const Frame& f, std::ptrdiff_t a, std::ptrdiff_t b) {
  const double ax = f.x[a], ay = f.y[a], az = f.z[a], bx = f.x[b], by = f.y[b], bz = f.z[b];
  // atan2 of |a x b| and a . b: accurate for the small angles between neighbouring columns.
  const double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
  return std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), ax * bx + ay * by + az * bz);
}

}  // namespace

bool columns_wrap(const Frame& f) {
  const int step = f.pixel_stride;
  const int last = last_lattice_column(f);
  if (f.ring_neighbours != nullptr || last < 2 * step) return false;
  int rows = 0, wrapping = 0;
  // Up to 64 rows tell: a camera's frame pays a few microseconds.
  const int lattice_rows = (f.height + step - 1) / step;
  const int row_step = step * std::max(1, lattice_rows / 64);
  for (int v = 0; v < f.height; v += row_step) {
    const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(v) * f.stride;
    const std::ptrdiff_t a = row + last, b = row, a_in = a - step, b_in = b + step;
    if (!valid(f, a) || !valid(f, b) || !valid(f, a_in) || !valid(f, b_in)) continue;
    const double beside = std::max(ray_angle(f, a, a_in), ray_angle(f, b, b_in));
    const double seam = ray_angle(f, a, b);
    if (!(beside > 0) || !std::isfinite(seam)) continue;
    ++rows;
    wrapping += seam <= 2.5 * beside ? 1 : 0;  // a column missing at the seam too
  }
  return rows > 0 && 2 * wrapping > rows;
}

bool column_seam_linked(const Frame& f, std::ptrdiff_t last, std::ptrdiff_t first) {
  if (!valid(f, last) || !valid(f, first)) return false;
  const int step = f.pixel_stride;
  double beside = 0;
  if (valid(f, last - step)) beside = distance(f, last, last - step);
  if (valid(f, first + step)) beside = std::max(beside, distance(f, first, first + step));
  return beside > 0 && distance(f, last, first) <= 3 * beside;
}

}  // namespace rangeseg::seg
