// Convex hull of 2D points and the grid concave hull of point sets without a mesh.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "polygons/internal.hpp"
#include "rangeseg/polygons.hpp"

namespace rangeseg {

void convex_hull(const std::vector<std::array<float, 2>>& points,
                 std::vector<std::array<float, 2>>& hull) {
  std::vector<std::array<float, 2>> sorted;
  sorted.reserve(points.size());
  for (const auto& p : points) {
    if (std::isfinite(p[0]) && std::isfinite(p[1])) sorted.push_back(p);
  }
  std::sort(sorted.begin(), sorted.end());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  hull.clear();
  if (sorted.size() < 3) {
    hull = sorted;
    return;
  }
  std::vector<double> xy(2 * sorted.size());
  for (std::size_t i = 0; i < sorted.size(); ++i) {
    xy[2 * i] = sorted[i][0];
    xy[2 * i + 1] = sorted[i][1];
  }
  std::vector<int> idx;
  polygons_detail::monotone_chain_sorted(xy.data(), static_cast<int>(sorted.size()), idx);
  for (int i : idx) hull.push_back(sorted[static_cast<std::size_t>(i)]);
}

void concave_hull(const std::vector<std::array<float, 2>>& points, double alpha, Polygons2D& out) {
  if (!(alpha > 0) || !std::isfinite(alpha)) {
    throw std::invalid_argument("concave_hull: alpha must be finite and > 0 [m], got " +
                                std::to_string(alpha));
  }
  out.points.clear();
  out.first.clear();
  out.count.clear();
  out.is_hole.clear();
  double minx = INFINITY, miny = INFINITY, maxx = -INFINITY, maxy = -INFINITY;
  std::size_t n_finite = 0;
  for (const auto& p : points) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1])) continue;
    minx = std::min(minx, static_cast<double>(p[0]));
    maxx = std::max(maxx, static_cast<double>(p[0]));
    miny = std::min(miny, static_cast<double>(p[1]));
    maxy = std::max(maxy, static_cast<double>(p[1]));
    ++n_finite;
  }
  if (n_finite == 0) return;
  const double h = alpha / 2;
  constexpr int kMargin = 2;  // room for the dilation
  const double cols_d = std::floor((maxx - minx) / h) + 1 + 2 * kMargin;
  const double rows_d = std::floor((maxy - miny) / h) + 1 + 2 * kMargin;
  if (cols_d * rows_d > static_cast<double>(1 << 26)) {
    throw std::invalid_argument("concave_hull: alpha " + std::to_string(alpha) +
                                " m is too small for the extent " + std::to_string(maxx - minx) +
                                " x " + std::to_string(maxy - miny) + " m (grid over 2^26 cells)");
  }
  const int cols = static_cast<int>(cols_d), rows = static_cast<int>(rows_d);
  const double x0 = minx - kMargin * h, y0 = miny - kMargin * h;
  std::vector<std::uint8_t> occ(static_cast<std::size_t>(cols) * rows, 0), tmp(occ.size(), 0);
  for (const auto& p : points) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1])) continue;
    const int i = std::clamp(static_cast<int>((p[0] - x0) / h), 0, cols - 1);
    const int j = std::clamp(static_cast<int>((p[1] - y0) / h), 0, rows - 1);
    occ[static_cast<std::size_t>(j) * cols + i] = 1;
  }
  // Closing with a 3x3 square: dilate into tmp, erode back into occ.
  for (int j = 1; j + 1 < rows; ++j) {
    for (int i = 1; i + 1 < cols; ++i) {
      std::uint8_t any = 0;
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di)
          any |= occ[static_cast<std::size_t>(j + dj) * cols + i + di];
      tmp[static_cast<std::size_t>(j) * cols + i] = any;
    }
  }
  for (int j = 1; j + 1 < rows; ++j) {
    for (int i = 1; i + 1 < cols; ++i) {
      std::uint8_t all = 1;
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di)
          all &= tmp[static_cast<std::size_t>(j + dj) * cols + i + di];
      occ[static_cast<std::size_t>(j) * cols + i] =
          static_cast<std::uint8_t>(occ[static_cast<std::size_t>(j) * cols + i] | all);
    }
  }
  // Corner lattice (cols + 1) x (rows + 1); cell (i, j) is a quad with corners (i, j)..(i+1, j+1).
  const int vw = cols + 1, vh = rows + 1;
  const std::ptrdiff_t stride = vw;
  std::vector<std::uint8_t> mask(static_cast<std::size_t>(vw) * vh, 0), rem(mask.size(), 0);
  std::vector<std::int32_t> pos(mask.size(), 0), starts, walk, stack;
  const auto cell = [&](int i, int j) -> bool {
    return i >= 0 && j >= 0 && i < cols && j < rows && occ[static_cast<std::size_t>(j) * cols + i];
  };
  for (int j = 0; j < vh; ++j) {
    for (int i = 0; i < vw; ++i) {
      const bool c00 = cell(i - 1, j - 1), c01 = cell(i, j - 1), c10 = cell(i - 1, j),
                 c11 = cell(i, j);
      const unsigned m = ((c01 && !c11) ? 1u : 0u) | ((c11 && !c10) ? 4u : 0u) |
                         ((c10 && !c00) ? 16u : 0u) | ((c00 && !c01) ? 64u : 0u);
      if (m) {
        mask[static_cast<std::size_t>(j) * vw + i] = static_cast<std::uint8_t>(m);
        starts.push_back(j * vw + i);
      }
    }
  }
  std::vector<double> xy;
  std::vector<int> loop_first;
  polygons_detail::trace_loops(mask.data(), rem.data(), pos.data(), stride, 1, starts, walk, stack,
                               [&](const std::int32_t* idx, int n) {
                                 loop_first.push_back(static_cast<int>(xy.size() / 2));
                                 // The tracer's orientation is for y down; reverse for y up.
                                 for (int k = n - 1; k >= 0; --k) {
                                   xy.push_back(x0 + (idx[k] % vw) * h);
                                   xy.push_back(y0 + (idx[k] / vw) * h);
                                 }
                               });
  loop_first.push_back(static_cast<int>(xy.size() / 2));
  const std::size_t n_loops = loop_first.size() - 1;
  std::vector<double> tol(n_loops, alpha / 4);
  std::vector<int> keep, keep_first;
  std::vector<std::array<int, 2>> dp_stack;
  std::vector<polygons_detail::CheckEdge> edges;
  std::vector<std::uint8_t> bad;
  for (int attempt = 0;; ++attempt) {
    keep.clear();
    keep_first.clear();
    for (std::size_t k = 0; k < n_loops; ++k) {
      keep_first.push_back(static_cast<int>(keep.size()));
      polygons_detail::simplify_closed(xy.data() + 2 * loop_first[k],
                                       loop_first[k + 1] - loop_first[k], tol[k], keep, dp_stack);
    }
    keep_first.push_back(static_cast<int>(keep.size()));
    edges.clear();
    for (std::size_t k = 0; k < n_loops; ++k) {
      const double* base = xy.data() + 2 * loop_first[k];
      for (int i = keep_first[k], j = keep_first[k + 1] - 1; i < keep_first[k + 1]; j = i++) {
        const int a = keep[static_cast<std::size_t>(j)], b = keep[static_cast<std::size_t>(i)];
        edges.push_back({base[2 * a], base[2 * a + 1], base[2 * b], base[2 * b + 1],
                         loop_first[k] + a, loop_first[k] + b, static_cast<int>(k)});
      }
    }
    // Corner ids are per loop; loops touching at a lattice corner share coordinates, so identify
    // ends by their lattice position instead.
    for (auto& e : edges) {
      e.id0 = std::llround((e.x0 - x0) / h) * (vh + 1) + std::llround((e.y0 - y0) / h);
      e.id1 = std::llround((e.x1 - x0) / h) * (vh + 1) + std::llround((e.y1 - y0) / h);
    }
    bad.assign(n_loops, 0);
    if (!polygons_detail::mark_crossings(edges, bad) || attempt >= 5) break;
    for (std::size_t k = 0; k < n_loops; ++k) {
      if (bad[k]) tol[k] = attempt >= 4 ? 0.0 : 0.5 * tol[k];
    }
  }
  for (std::size_t k = 0; k < n_loops; ++k) {
    const double* base = xy.data() + 2 * loop_first[k];
    out.first.push_back(static_cast<int>(out.points.size()));
    double area2 = 0;
    const int kb = keep_first[k], ke = keep_first[k + 1];
    for (int i = kb, j = ke - 1; i < ke; j = i++) {
      const int a = keep[static_cast<std::size_t>(j)], b = keep[static_cast<std::size_t>(i)];
      area2 += base[2 * a] * base[2 * b + 1] - base[2 * b] * base[2 * a + 1];
      out.points.push_back({static_cast<float>(base[2 * b]), static_cast<float>(base[2 * b + 1])});
    }
    out.count.push_back(ke - kb);
    out.is_hole.push_back(area2 < 0 ? 1 : 0);
  }
}

}  // namespace rangeseg
