// Convex hull of 2D points and the grid concave hull of point sets without a mesh.
// The AVX2 kernels here must repeat the scalar code's IEEE operations exactly, so the
// compiler may not fuse multiply-adds (the AVX2 target includes FMA).
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "detail/headroom.hpp"
#include "detail/number_text.hpp"
#include "detail/simd.hpp"
#include "polygons/internal.hpp"
#include "rangeseg/polygons.hpp"

namespace rangeseg {
namespace polygons_detail {
namespace {

// Extreme points of xy[0..n) in kDirs directions evenly spaced counter-clockwise from +x (the
// first one on ties), and the largest |coordinate|. The directions of multiples of 45 degrees
// use the exact sums x + y etc.; the ones between them (kDirs 16) unit vectors.
template <int kDirs>
struct Extremes {
  std::array<int, kDirs> index{};
  std::array<double, kDirs> value{};
  double extent = 0;
  Extremes() { value.fill(-std::numeric_limits<double>::infinity()); }
};

constexpr double kCos22 = 0.92387953251128674, kSin22 = 0.38268343236508978;

template <int kDirs>
void extremes_scalar(const double* xy, int begin, int end, Extremes<kDirs>& e) {
  static_assert(kDirs == 8 || kDirs == 16);
  constexpr int kStep = kDirs / 8;
  for (int i = begin; i < end; ++i) {
    const double* pt = xy_point(xy, i);
    const double x = pt[0], y = pt[1];
    double d[kDirs];
    const double d45[8] = {x, x + y, y, y - x, -x, -x - y, -y, x - y};
    for (int k = 0; k < 8; ++k) d[k * kStep] = d45[k];
    if constexpr (kDirs == 16) {
      const double a = kCos22 * x, b = kSin22 * y, c = kSin22 * x, f = kCos22 * y;
      d[1] = a + b;
      d[3] = c + f;
      d[5] = f - c;
      d[7] = b - a;
      d[9] = -a - b;
      d[11] = -c - f;
      d[13] = c - f;
      d[15] = a - b;
    }
    for (int k = 0; k < kDirs; ++k) {
      if (d[k] > e.value[k]) {
        e.value[k] = d[k];
        e.index[k] = i;
      }
    }
    e.extent = std::max({e.extent, std::abs(x), std::abs(y)});
  }
}

// The polygon of the extreme points: edges (origin a, direction e), degenerate ones skipped.
template <int kDirs>
struct Polygon {
  std::array<double, kDirs> ax{}, ay{}, ex{}, ey{};
  int edges = 0;
  double eps = 0;
};

template <int kDirs>
Polygon<kDirs> make_polygon(const double* xy, int n, const Extremes<kDirs>& e) {
  Polygon<kDirs> o;
  // A point is dropped when it is to the left of every (non-degenerate) polygon edge by more
  // than eps (cross products are in m^2; rounding is ~1e-16 (1 + extent)^2).
  o.eps = 1e-9 * (1 + e.extent) * (1 + e.extent);
  for (int k = 0; k < kDirs && n > 0; ++k) {
    const int a = e.index[k], b = e.index[(k + 1) % kDirs];
    if (a == b) continue;
    const double *pa = xy_point(xy, a), *pb = xy_point(xy, b);
    o.ax[o.edges] = pa[0];
    o.ay[o.edges] = pa[1];
    o.ex[o.edges] = pb[0] - o.ax[o.edges];
    o.ey[o.edges] = pb[1] - o.ay[o.edges];
    ++o.edges;
  }
  return o;
}

template <int kDirs>
void outside_scalar(const double* xy, int begin, int end, const Polygon<kDirs>& o,
                    std::vector<int>& out) {
  for (int i = begin; i < end; ++i) {
    const double* pt = xy_point(xy, i);
    bool inside = o.edges >= 3;
    for (int e = 0; e < o.edges && inside; ++e) {
      inside = o.ex[e] * (pt[1] - o.ay[e]) - o.ey[e] * (pt[0] - o.ax[e]) > o.eps;
    }
    if (!inside) out.push_back(i);
  }
}

#if RANGESEG_SIMD_X86
// Points p[0..4) (x, y interleaved) as x and y vectors in point order.
RANGESEG_SIMD_AVX2_TARGET inline __attribute__((always_inline)) void load_xy(const double* p,
                                                                             __m256d& x,
                                                                             __m256d& y) {
  const __m256d p01 = _mm256_loadu_pd(p), p23 = _mm256_loadu_pd(p + 4);
  x = _mm256_permute4x64_pd(_mm256_unpacklo_pd(p01, p23), 0xD8);
  y = _mm256_permute4x64_pd(_mm256_unpackhi_pd(p01, p23), 0xD8);
}

// Four points per step with the scalar code's operations per point: each lane keeps its first
// maximum per direction; the lanes are merged by value, then smallest index, which is the first
// maximum of the sequential scan.
RANGESEG_SIMD_AVX2_TARGET void hull_candidates_avx2(const double* xy, int n,
                                                    std::vector<int>& out) {
  constexpr int kDirs = 16;
  Extremes<kDirs> e;
  const int n4 = n / 4 * 4;
  const __m256d sign = _mm256_set1_pd(-0.0);
  __m256d best[kDirs], best_index[kDirs];
  for (int k = 0; k < kDirs; ++k) {
    best[k] = _mm256_set1_pd(-std::numeric_limits<double>::infinity());
    best_index[k] = _mm256_set1_pd(-1.0);
  }
  const __m256d cos22 = _mm256_set1_pd(kCos22), sin22 = _mm256_set1_pd(kSin22);
  __m256d extent = _mm256_setzero_pd();
  __m256d index = _mm256_setr_pd(0, 1, 2, 3);
  const __m256d four = _mm256_set1_pd(4.0);
  for (int i = 0; i < n4; i += 4) {
    __m256d x, y;
    load_xy(xy_point(xy, i), x, y);
    const __m256d nx = _mm256_xor_pd(x, sign), ny = _mm256_xor_pd(y, sign);
    const __m256d a = _mm256_mul_pd(cos22, x), b = _mm256_mul_pd(sin22, y);
    const __m256d c = _mm256_mul_pd(sin22, x), f = _mm256_mul_pd(cos22, y);
    const __m256d na = _mm256_xor_pd(a, sign), nc = _mm256_xor_pd(c, sign);
    const __m256d d[kDirs] = {x,  _mm256_add_pd(a, b),  _mm256_add_pd(x, y),  _mm256_add_pd(c, f),
                              y,  _mm256_sub_pd(f, c),  _mm256_sub_pd(y, x),  _mm256_sub_pd(b, a),
                              nx, _mm256_sub_pd(na, b), _mm256_sub_pd(nx, y), _mm256_sub_pd(nc, f),
                              ny, _mm256_sub_pd(c, f),  _mm256_sub_pd(x, y),  _mm256_sub_pd(a, b)};
    for (int k = 0; k < kDirs; ++k) {
      const __m256d gt = _mm256_cmp_pd(d[k], best[k], _CMP_GT_OQ);
      best[k] = _mm256_blendv_pd(best[k], d[k], gt);
      best_index[k] = _mm256_blendv_pd(best_index[k], index, gt);
    }
    extent =
        _mm256_max_pd(extent, _mm256_max_pd(_mm256_andnot_pd(sign, x), _mm256_andnot_pd(sign, y)));
    index = _mm256_add_pd(index, four);
  }
  alignas(32) double lane_value[4], lane_index[4];
  for (int k = 0; k < kDirs; ++k) {
    _mm256_store_pd(lane_value, best[k]);
    _mm256_store_pd(lane_index, best_index[k]);
    for (int l = 0; l < 4; ++l) {
      if (lane_index[l] < 0) continue;
      const int at = static_cast<int>(lane_index[l]);
      if (lane_value[l] > e.value[k] || (lane_value[l] == e.value[k] && at < e.index[k])) {
        e.value[k] = lane_value[l];
        e.index[k] = at;
      }
    }
  }
  _mm256_store_pd(lane_value, extent);
  e.extent = std::max({lane_value[0], lane_value[1], lane_value[2], lane_value[3]});
  extremes_scalar(xy, n4, n, e);

  const Polygon<kDirs> o = make_polygon(xy, n, e);
  out.clear();
  if (o.edges < 3) {
    for (int i = 0; i < n; ++i) out.push_back(i);
    return;
  }
  const __m256d eps = _mm256_set1_pd(o.eps);
  for (int i = 0; i < n4; i += 4) {
    __m256d x, y;
    load_xy(xy_point(xy, i), x, y);
    __m256d inside = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    for (int k = 0; k < o.edges; ++k) {
      const __m256d cross = _mm256_sub_pd(
          _mm256_mul_pd(_mm256_set1_pd(o.ex[k]), _mm256_sub_pd(y, _mm256_set1_pd(o.ay[k]))),
          _mm256_mul_pd(_mm256_set1_pd(o.ey[k]), _mm256_sub_pd(x, _mm256_set1_pd(o.ax[k]))));
      inside = _mm256_and_pd(inside, _mm256_cmp_pd(cross, eps, _CMP_GT_OQ));
    }
    unsigned outside = ~static_cast<unsigned>(_mm256_movemask_pd(inside)) & 15u;
    while (outside != 0) {
      out.push_back(i + __builtin_ctz(outside));
      outside &= outside - 1;
    }
  }
  outside_scalar(xy, n4, n, o, out);
}
#endif

}  // namespace

void hull_candidates(const double* xy, int n, std::vector<int>& out) {
#if RANGESEG_SIMD_X86
  if (detail::simd::chosen_isa() >= detail::simd::Isa::avx2) {
    hull_candidates_avx2(xy, n, out);
    return;
  }
#endif
  out.clear();
  Extremes<8> e;
  extremes_scalar(xy, 0, n, e);
  outside_scalar(xy, 0, n, make_polygon(xy, n, e), out);
}

}  // namespace polygons_detail

using polygons_detail::xy_point;

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

void polygons_detail::outline_raster(std::vector<std::uint8_t>& occ, int cols, int rows, double x0,
                                     double y0, double h, double tolerance, RasterOutline& out) {
  assert(occ.size() == static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows));
  Polygons2D& loops = out.loops;
  loops.points.clear();
  loops.first.clear();
  loops.count.clear();
  loops.is_hole.clear();
  out.raw_area.clear();
  out.raw_perimeter.clear();
  out.raw_count.clear();
  out.tolerance.clear();
  // Closing with a 3x3 square: dilate into tmp, erode back into occ.
  std::vector<std::uint8_t>& tmp = out.tmp;
  detail::assign_with_headroom(tmp, occ.size(), 0);
  for (int j = 1; j + 1 < rows; ++j) {
    for (int i = 1; i + 1 < cols; ++i) {
      std::uint8_t any = 0;
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          any |= occ[static_cast<std::size_t>(j + dj) * cols + i + di];
        }
      }
      tmp[static_cast<std::size_t>(j) * cols + i] = any;
    }
  }
  for (int j = 1; j + 1 < rows; ++j) {
    for (int i = 1; i + 1 < cols; ++i) {
      std::uint8_t all = 1;
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          all &= tmp[static_cast<std::size_t>(j + dj) * cols + i + di];
        }
      }
      occ[static_cast<std::size_t>(j) * cols + i] =
          static_cast<std::uint8_t>(occ[static_cast<std::size_t>(j) * cols + i] | all);
    }
  }
  // Corner lattice (cols + 1) x (rows + 1); cell (i, j) is a quad with corners (i, j)..(i+1, j+1).
  const int vw = cols + 1, vh = rows + 1;
  const std::ptrdiff_t stride = vw;
  // mask and pos are zero wherever they were used (trace_loops clears what it sets).
  std::vector<std::uint16_t>& mask = out.mask;
  std::vector<std::int32_t>& pos = out.pos;
  std::vector<std::int32_t>& starts = out.starts;
  const std::size_t corners = static_cast<std::size_t>(vw) * static_cast<std::size_t>(vh);
  if (mask.size() < corners) {
    mask.resize(corners, 0);
    pos.resize(corners, 0);
  }
  starts.clear();
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
        mask[static_cast<std::size_t>(j) * vw + i] = static_cast<std::uint16_t>(m * 257u);
        starts.push_back(j * vw + i);
      }
    }
  }
  std::vector<double>& xy = out.xy;
  std::vector<int>& loop_first = out.loop_first;
  xy.clear();
  loop_first.clear();
  trace_loops(mask.data(), pos.data(), stride, 1, starts, out.steps, out.walk, out.stack,
              [&](const std::int32_t* idx, int n) {
                loop_first.push_back(static_cast<int>(xy.size() / 2));
                // The tracer's orientation is for y down; reverse for y up.
                for (int k = n - 1; k >= 0; --k) {
                  const auto [row, column] = std::div(idx[k], vw);
                  xy.push_back(x0 + column * h);
                  xy.push_back(y0 + row * h);
                }
              });
  loop_first.push_back(static_cast<int>(xy.size() / 2));
  for (const std::int32_t p : starts) mask[static_cast<std::size_t>(p)] = 0;
  const std::size_t n_loops = loop_first.size() - 1;
  for (std::size_t k = 0; k < n_loops; ++k) {
    double area = 0, perimeter = 0;
    area_perimeter(xy_point(xy.data(), loop_first[k]), loop_first[k + 1] - loop_first[k], area,
                   perimeter);
    out.raw_area.push_back(std::abs(area));
    out.raw_perimeter.push_back(perimeter);
    out.raw_count.push_back(loop_first[k + 1] - loop_first[k]);
  }
  std::vector<double>& tol = out.tolerance;
  detail::assign_with_headroom(tol, n_loops, tolerance);
  std::vector<int>& keep = out.keep;
  std::vector<int>& keep_first = out.keep_first;
  std::vector<std::array<int, 2>>& dp_stack = out.dp_stack;
  std::vector<CheckEdge>& edges = out.edges;
  std::vector<std::uint8_t>& bad = out.bad;
  for (int attempt = 0;; ++attempt) {
    keep.clear();
    keep_first.clear();
    for (std::size_t k = 0; k < n_loops; ++k) {
      keep_first.push_back(static_cast<int>(keep.size()));
      simplify_closed(xy_point(xy.data(), loop_first[k]), loop_first[k + 1] - loop_first[k], tol[k],
                      keep, dp_stack);
    }
    keep_first.push_back(static_cast<int>(keep.size()));
    edges.clear();
    for (std::size_t k = 0; k < n_loops; ++k) {
      const double* base = xy_point(xy.data(), loop_first[k]);
      for (int i = keep_first[k], j = keep_first[k + 1] - 1; i < keep_first[k + 1]; j = i++) {
        const int a = keep[static_cast<std::size_t>(j)], b = keep[static_cast<std::size_t>(i)];
        const double *pa = xy_point(base, a), *pb = xy_point(base, b);
        edges.push_back({pa[0], pa[1], pb[0], pb[1], loop_first[k] + a, loop_first[k] + b,
                         static_cast<int>(k)});
      }
    }
    // Corner ids are per loop; loops touching at a lattice corner share coordinates, so identify
    // ends by their lattice position instead.
    for (auto& e : edges) {
      e.id0 = std::llround((e.x0 - x0) / h) * (vh + 1) + std::llround((e.y0 - y0) / h);
      e.id1 = std::llround((e.x1 - x0) / h) * (vh + 1) + std::llround((e.y1 - y0) / h);
    }
    detail::assign_with_headroom(bad, n_loops, 0);
    if (!mark_crossings(edges, bad, out.crossing) || attempt >= 5) break;
    for (std::size_t k = 0; k < n_loops; ++k) {
      if (bad[k]) tol[k] = attempt >= 4 ? 0.0 : 0.5 * tol[k];
    }
  }
  for (std::size_t k = 0; k < n_loops; ++k) {
    const double* base = xy_point(xy.data(), loop_first[k]);
    loops.first.push_back(static_cast<int>(loops.points.size()));
    double area2 = 0;
    const int kb = keep_first[k], ke = keep_first[k + 1];
    for (int i = kb, j = ke - 1; i < ke; j = i++) {
      const int a = keep[static_cast<std::size_t>(j)], b = keep[static_cast<std::size_t>(i)];
      const double *pa = xy_point(base, a), *pb = xy_point(base, b);
      area2 += pa[0] * pb[1] - pb[0] * pa[1];
      loops.points.push_back({static_cast<float>(pb[0]), static_cast<float>(pb[1])});
    }
    loops.count.push_back(ke - kb);
    loops.is_hole.push_back(area2 < 0 ? 1 : 0);
  }
}

void concave_hull(const std::vector<std::array<float, 2>>& points, double alpha, Polygons2D& out) {
  if (!(alpha > 0) || !std::isfinite(alpha)) {
    throw std::invalid_argument("concave_hull: alpha must be finite and > 0 [m], got " +
                                rangeseg::detail::number_text(alpha));
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
    throw std::invalid_argument(
        "concave_hull: alpha " + rangeseg::detail::number_text(alpha) +
        " m is too small for the extent " + rangeseg::detail::number_text(maxx - minx) + " x " +
        rangeseg::detail::number_text(maxy - miny) + " m (grid over 2^26 cells)");
  }
  const int cols = static_cast<int>(cols_d), rows = static_cast<int>(rows_d);
  const double x0 = minx - kMargin * h, y0 = miny - kMargin * h;
  std::vector<std::uint8_t> occ(static_cast<std::size_t>(cols) * rows, 0);
  for (const auto& p : points) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1])) continue;
    const int i = std::clamp(static_cast<int>((p[0] - x0) / h), 0, cols - 1);
    const int j = std::clamp(static_cast<int>((p[1] - y0) / h), 0, rows - 1);
    occ[static_cast<std::size_t>(j) * cols + i] = 1;
  }
  polygons_detail::RasterOutline outline;
  polygons_detail::outline_raster(occ, cols, rows, x0, y0, h, alpha / 4, outline);
  out = std::move(outline.loops);
}

}  // namespace rangeseg
