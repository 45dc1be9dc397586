// Closed-loop Douglas-Peucker, the simplicity check after simplification, loop measures.
// The AVX2 kernels here must repeat the scalar code's IEEE operations exactly, so the
// compiler may not fuse multiply-adds (the AVX2 target includes FMA).
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif
#include <algorithm>
#include <cmath>

#include "detail/headroom.hpp"
#include "detail/radix_sort.hpp"
#include "detail/simd.hpp"
#include "polygons/internal.hpp"

namespace rangeseg::polygons_detail {
namespace {

// Squared distance of p from the segment a-b.
double dist2_segment(const double* p, const double* a, const double* b) {
  const double ex = b[0] - a[0], ey = b[1] - a[1];
  const double px = p[0] - a[0], py = p[1] - a[1];
  const double len2 = ex * ex + ey * ey;
  double t = len2 > 0 ? (px * ex + py * ey) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  const double dx = px - t * ex, dy = py - t * ey;
  return dx * dx + dy * dy;
}

double cross(double ax, double ay, double bx, double by, double cx, double cy) {
  return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
}

bool on_segment(double ax, double ay, double bx, double by, double px, double py) {
  return std::min(ax, bx) <= px && px <= std::max(ax, bx) && std::min(ay, by) <= py &&
         py <= std::max(ay, by);
}

// Squared distance of (px, py) from segment a-b.
double dist2_point_segment(double px, double py, double ax, double ay, double bx, double by) {
  const double p[2] = {px, py}, a[2] = {ax, ay}, b[2] = {bx, by};
  return dist2_segment(p, a, b);
}

// Crossing, touching, or an end point within `eps` of the other edge: output coordinates are
// rounded to float, so a vertex lying (almost) on another loop's edge must count as touching.
bool segments_touch(const CheckEdge& e, const CheckEdge& f, double eps) {
  const double eps2 = eps * eps;
  if (dist2_point_segment(f.x0, f.y0, e.x0, e.y0, e.x1, e.y1) <= eps2 ||
      dist2_point_segment(f.x1, f.y1, e.x0, e.y0, e.x1, e.y1) <= eps2 ||
      dist2_point_segment(e.x0, e.y0, f.x0, f.y0, f.x1, f.y1) <= eps2 ||
      dist2_point_segment(e.x1, e.y1, f.x0, f.y0, f.x1, f.y1) <= eps2) {
    return true;
  }
  const double o1 = cross(e.x0, e.y0, e.x1, e.y1, f.x0, f.y0);
  const double o2 = cross(e.x0, e.y0, e.x1, e.y1, f.x1, f.y1);
  const double o3 = cross(f.x0, f.y0, f.x1, f.y1, e.x0, e.y0);
  const double o4 = cross(f.x0, f.y0, f.x1, f.y1, e.x1, e.y1);
  if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0))) {
    return true;
  }
  if (o1 == 0 && on_segment(e.x0, e.y0, e.x1, e.y1, f.x0, f.y0)) return true;
  if (o2 == 0 && on_segment(e.x0, e.y0, e.x1, e.y1, f.x1, f.y1)) return true;
  if (o3 == 0 && on_segment(f.x0, f.y0, f.x1, f.y1, e.x0, e.y0)) return true;
  if (o4 == 0 && on_segment(f.x0, f.y0, f.x1, f.y1, e.x1, e.y1)) return true;
  return false;
}

// The vertex in (lo, hi) farthest from the chord a-b by dist2_segment, if that is more than
// `worst_d2` (the first such vertex on ties), else -1.
int farthest_from_chord_scalar(const double* xy, int lo, int hi, const double* a, const double* b,
                               double worst_d2) {
  int worst = -1;
  for (int i = lo + 1; i < hi; ++i) {
    const double d2 = dist2_segment(xy_point(xy, i), a, b);
    if (d2 > worst_d2) {
      worst_d2 = d2;
      worst = i;
    }
  }
  return worst;
}

#if RANGESEG_SIMD_X86
// The same four vertices at a time, with the same IEEE operations per vertex as
// dist2_segment (contraction is off in this file), so the distances are bit-identical.
// Each lane keeps its first maximum; the reduction takes the largest distance and, among equal
// ones, the smallest index: the first maximum of the sequential scan.
RANGESEG_SIMD_AVX2_TARGET int farthest_from_chord_avx2(const double* xy, int lo, int hi,
                                                       const double* a, const double* b,
                                                       double worst_d2) {
  const double ex = b[0] - a[0], ey = b[1] - a[1];
  const double len2 = ex * ex + ey * ey;
  if (!(len2 > 0) || hi - lo - 1 < 8) return farthest_from_chord_scalar(xy, lo, hi, a, b, worst_d2);
  const __m256d vex = _mm256_set1_pd(ex), vey = _mm256_set1_pd(ey), vlen2 = _mm256_set1_pd(len2);
  const __m256d ax = _mm256_set1_pd(a[0]), ay = _mm256_set1_pd(a[1]);
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
  __m256d best = _mm256_set1_pd(worst_d2);
  __m256d best_index = _mm256_set1_pd(-1.0);
  // unpacklo / unpackhi of two loads of two points each give lanes in vertex order 0, 2, 1, 3.
  __m256d index = _mm256_setr_pd(lo + 1, lo + 3, lo + 2, lo + 4);
  const __m256d four = _mm256_set1_pd(4.0);
  int i = lo + 1;
  for (; i + 4 <= hi; i += 4) {
    const double* pt = xy_point(xy, i);
    const __m256d p01 = _mm256_loadu_pd(pt), p23 = _mm256_loadu_pd(pt + 4);
    const __m256d px = _mm256_sub_pd(_mm256_unpacklo_pd(p01, p23), ax);
    const __m256d py = _mm256_sub_pd(_mm256_unpackhi_pd(p01, p23), ay);
    __m256d t = _mm256_div_pd(_mm256_add_pd(_mm256_mul_pd(px, vex), _mm256_mul_pd(py, vey)), vlen2);
    t = _mm256_blendv_pd(t, zero, _mm256_cmp_pd(t, zero, _CMP_LT_OQ));  // std::clamp(t, 0, 1)
    t = _mm256_blendv_pd(t, one, _mm256_cmp_pd(one, t, _CMP_LT_OQ));
    const __m256d dx = _mm256_sub_pd(px, _mm256_mul_pd(t, vex));
    const __m256d dy = _mm256_sub_pd(py, _mm256_mul_pd(t, vey));
    const __m256d d2 = _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy));
    const __m256d gt = _mm256_cmp_pd(d2, best, _CMP_GT_OQ);
    best = _mm256_blendv_pd(best, d2, gt);
    best_index = _mm256_blendv_pd(best_index, index, gt);
    index = _mm256_add_pd(index, four);
  }
  alignas(32) double lane_best[4], lane_index[4];
  _mm256_store_pd(lane_best, best);
  _mm256_store_pd(lane_index, best_index);
  int worst = -1;
  for (int k = 0; k < 4; ++k) {
    if (lane_index[k] < 0) continue;
    const int at = static_cast<int>(lane_index[k]);
    if (worst < 0 || lane_best[k] > worst_d2 || (lane_best[k] == worst_d2 && at < worst)) {
      worst_d2 = lane_best[k];
      worst = at;
    }
  }
  for (; i < hi; ++i) {
    const double d2 = dist2_segment(xy_point(xy, i), a, b);
    if (d2 > worst_d2) {
      worst_d2 = d2;
      worst = i;
    }
  }
  return worst;
}
#endif

using FarthestFn = int (*)(const double*, int, int, const double*, const double*, double);
FarthestFn farthest_from_chord() {
#if RANGESEG_SIMD_X86
  if (detail::simd::chosen_isa() >= detail::simd::Isa::avx2) return farthest_from_chord_avx2;
#endif
  return farthest_from_chord_scalar;
}

}  // namespace

void simplify_closed(const double* xy, int n, double tolerance, std::vector<int>& keep,
                     std::vector<std::array<int, 2>>& stack) {
  const std::size_t base = keep.size();
  if (n <= 3 || !(tolerance > 0)) {
    for (int i = 0; i < n; ++i) keep.push_back(i);
    return;
  }
  // Anchors: vertex 0 and the vertex farthest from it.
  int far = 1;
  double best = -1;
  for (int i = 1; i < n; ++i) {
    const double* pt = xy_point(xy, i);
    const double dx = pt[0] - xy[0], dy = pt[1] - xy[1];
    const double d2 = dx * dx + dy * dy;
    if (d2 > best) {
      best = d2;
      far = i;
    }
  }
  const double tol2 = tolerance * tolerance;
  const FarthestFn farthest = farthest_from_chord();
  keep.push_back(0);
  keep.push_back(far);
  stack.clear();
  stack.push_back({0, far});
  stack.push_back({far, n});  // index n is vertex 0 again
  while (!stack.empty()) {
    const auto [lo, hi] = stack.back();
    stack.pop_back();
    if (hi - lo < 2) continue;
    const int worst = farthest(xy, lo, hi, xy_point(xy, lo), xy_point(xy, hi % n), tol2);
    if (worst < 0) continue;
    keep.push_back(worst);
    stack.push_back({lo, worst});
    stack.push_back({worst, hi});
  }
  std::sort(keep.begin() + static_cast<std::ptrdiff_t>(base), keep.end());
  if (keep.size() - base < 3) {
    // Everything within tolerance of the chord 0-far: keep the farthest vertex off it.
    int extra = -1;
    double extra_d2 = -1;
    for (int i = 1; i < n; ++i) {
      if (i == far) continue;
      const double d2 = dist2_segment(xy_point(xy, i), xy, xy_point(xy, far));
      if (d2 > extra_d2) {
        extra_d2 = d2;
        extra = i;
      }
    }
    keep.push_back(extra);
    std::sort(keep.begin() + static_cast<std::ptrdiff_t>(base), keep.end());
    return;
  }
  // Vertex 0 was an anchor by position only: drop it when it lies on a straight stretch.
  if (keep.size() - base > 3) {
    const int prev = keep.back(), next = keep[base + 1];
    const double *p_prev = xy_point(xy, prev), *p_next = xy_point(xy, next);
    if (dist2_segment(xy, p_prev, p_next) <= tol2) {
      // Every dropped vertex between prev and next must stay within tolerance too.
      bool fine = true;
      for (int i = prev + 1; i < n + next && fine; ++i) {
        fine = dist2_segment(xy_point(xy, i % n), p_prev, p_next) <= tol2;
      }
      if (fine) keep.erase(keep.begin() + static_cast<std::ptrdiff_t>(base));
    }
  }
}

namespace {

/// The pair test of mark_crossings for edges[i] before edges[j] in x0 order: f starts within e's
/// x extent (plus margin) and their y ranges overlap, they share no end, and they touch.
bool pair_touches(const CheckEdge& e, const CheckEdge& f) {
  const double margin = 1e-5 * (1.0 + std::abs(e.x1) + std::abs(e.y0) + std::abs(e.y1));
  if (f.x0 > e.x1 + margin) return false;
  const double ylo = std::min(e.y0, e.y1) - margin, yhi = std::max(e.y0, e.y1) + margin;
  if (std::max(f.y0, f.y1) < ylo || std::min(f.y0, f.y1) > yhi) return false;
  if (e.id0 == f.id0 || e.id0 == f.id1 || e.id1 == f.id0 || e.id1 == f.id1) return false;
  const double scale =
      1.0 + std::max({std::abs(e.x0), std::abs(e.y0), std::abs(e.x1), std::abs(e.y1)});
  return segments_touch(e, f, 1e-6 * scale);
}

/// Sets of more edges than this go through the grid; fewer are swept in x order.
constexpr std::size_t kGridMinEdges = 128;

/// Both implementations start here: every edge left to right, sorted by x0 (stably, by a radix
/// sort of the x0 bits: a comparison sort of these 56-byte records was a third of the check).
void sort_edges(std::vector<CheckEdge>& edges, CrossingScratch& sc) {
  const std::size_t n = edges.size();
  detail::resize_with_headroom(sc.order, n);
  detail::resize_with_headroom(sc.keys, n);
  for (std::size_t i = 0; i < n; ++i) {
    CheckEdge& e = edges[i];
    if (e.x0 > e.x1) {
      std::swap(e.x0, e.x1);
      std::swap(e.y0, e.y1);
      std::swap(e.id0, e.id1);
    }
    sc.order[i] = static_cast<std::int32_t>(i);
    sc.keys[i] = detail::double_order_key(e.x0);
  }
  detail::radix_sort_by_key(sc.order, sc.keys, sc.order_tmp, sc.keys_tmp);
  detail::resize_with_headroom(sc.sorted, n);
  for (std::size_t i = 0; i < n; ++i) sc.sorted[i] = edges[static_cast<std::size_t>(sc.order[i])];
  edges.swap(sc.sorted);
  share_capacity(edges, sc.sorted);
}

/// Whether the pair must be tested: some loop of it changed since the last check (all when
/// `changed` is null).
inline bool pair_changed(const CheckEdge& e, const CheckEdge& f, const std::uint8_t* changed) {
  return changed == nullptr || changed[e.loop] != 0 || changed[f.loop] != 0;
}

void mark_pair(const CheckEdge& e, const CheckEdge& f, std::vector<std::uint8_t>& bad) {
  bad[e.loop] = 1;
  bad[f.loop] = 1;
}

bool sweep_sorted(const std::vector<CheckEdge>& edges, std::vector<std::uint8_t>& bad,
                  const std::uint8_t* changed) {
  bool any = false;
  const std::size_t n = edges.size();
  for (std::size_t i = 0; i < n; ++i) {
    const CheckEdge& e = edges[i];
    const double margin = 1e-5 * (1.0 + std::abs(e.x1) + std::abs(e.y0) + std::abs(e.y1));
    for (std::size_t j = i + 1; j < n && edges[j].x0 <= e.x1 + margin; ++j) {
      if (pair_changed(e, edges[j], changed) && pair_touches(e, edges[j])) {
        mark_pair(e, edges[j], bad);
        any = true;
      }
    }
  }
  return any;
}

}  // namespace

bool mark_crossings_sweep(std::vector<CheckEdge>& edges, std::vector<std::uint8_t>& bad,
                          CrossingScratch& scratch, const std::uint8_t* changed) {
  sort_edges(edges, scratch);
  return sweep_sorted(edges, bad, changed);
}

bool mark_crossings(std::vector<CheckEdge>& edges, std::vector<std::uint8_t>& bad,
                    CrossingScratch& scratch, const std::uint8_t* changed) {
  sort_edges(edges, scratch);
  const std::size_t n = edges.size();
  if (n <= kGridMinEdges) return sweep_sorted(edges, bad, changed);
  bool any = false;
  // A sweep in x alone meets every edge under a long one (the outline of a wall with many holes
  // is quadratic). The grid finds the same pairs: an edge is entered in every cell its widened box
  // covers, and a pair is tested once, in the first cell both cover, with the sweep's own test.
  CrossingScratch& grid = scratch;
  double x_lo = edges.front().x0, x_hi = x_lo, y_lo = edges.front().y0, y_hi = y_lo;
  for (const CheckEdge& e : edges) {
    const double margin = 1e-5 * (1.0 + std::abs(e.x1) + std::abs(e.y0) + std::abs(e.y1));
    x_hi = std::max(x_hi, e.x1 + margin);
    y_lo = std::min(y_lo, std::min(e.y0, e.y1) - margin);
    y_hi = std::max(y_hi, std::max(e.y0, e.y1) + margin);
  }
  const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))));
  const double to_x = side / std::max(x_hi - x_lo, 1e-300);
  const double to_y = side / std::max(y_hi - y_lo, 1e-300);
  const auto cell = [side](double t) {  // NaN and out-of-range values are clamped first
    return !(t > 0) ? 0 : t >= side - 1 ? side - 1 : static_cast<int>(t);
  };
  detail::resize_with_headroom(grid.cells, 4 * n);
  detail::assign_with_headroom(grid.start, static_cast<std::size_t>(side) * side + 1, 0);
  const auto cell_index = [side](int cx, int cy) {
    return static_cast<std::size_t>(cy) * static_cast<std::size_t>(side) +
           static_cast<std::size_t>(cx);
  };
  for (std::size_t i = 0; i < n; ++i) {
    const CheckEdge& e = edges[i];
    const double margin = 1e-5 * (1.0 + std::abs(e.x1) + std::abs(e.y0) + std::abs(e.y1));
    std::int32_t* const c = grid.cells.data() + 4 * i;
    c[0] = cell((e.x0 - x_lo) * to_x);
    c[1] = cell((e.x1 + margin - x_lo) * to_x);
    c[2] = cell((std::min(e.y0, e.y1) - margin - y_lo) * to_y);
    c[3] = cell((std::max(e.y0, e.y1) + margin - y_lo) * to_y);
    for (int cy = c[2]; cy <= c[3]; ++cy) {
      for (int cx = c[0]; cx <= c[1]; ++cx) ++grid.start[cell_index(cx, cy) + 1];
    }
  }
  for (std::size_t k = 1; k < grid.start.size(); ++k) grid.start[k] += grid.start[k - 1];
  detail::resize_with_headroom(grid.items, static_cast<std::size_t>(grid.start.back()));
  for (std::size_t i = 0; i < n; ++i) {
    const std::int32_t* const c = grid.cells.data() + 4 * i;
    for (int cy = c[2]; cy <= c[3]; ++cy) {
      for (int cx = c[0]; cx <= c[1]; ++cx) {
        grid.items[static_cast<std::size_t>(grid.start[cell_index(cx, cy)]++)] =
            static_cast<std::int32_t>(i);
      }
    }
  }
  // start[k] is now the end of cell k, i.e. start[k - 1] its beginning.
  for (int cy = 0; cy < side; ++cy) {
    for (int cx = 0; cx < side; ++cx) {
      const std::size_t k = cell_index(cx, cy);
      const std::int32_t begin = k == 0 ? 0 : grid.start[k - 1], end = grid.start[k];
      for (std::int32_t p = begin; p < end; ++p) {
        const std::int32_t i = grid.items[static_cast<std::size_t>(p)];
        const std::int32_t* const ci = grid.cells.data() + 4 * static_cast<std::size_t>(i);
        for (std::int32_t q = p + 1; q < end; ++q) {
          const std::int32_t j = grid.items[static_cast<std::size_t>(q)];
          const std::int32_t* const cj = grid.cells.data() + 4 * static_cast<std::size_t>(j);
          if (std::max(ci[0], cj[0]) != cx || std::max(ci[2], cj[2]) != cy) continue;
          const CheckEdge& e = edges[static_cast<std::size_t>(i)];
          const CheckEdge& f = edges[static_cast<std::size_t>(j)];
          if (pair_changed(e, f, changed) && pair_touches(e, f)) {
            mark_pair(e, f, bad);
            any = true;
          }
        }
      }
    }
  }
  return any;
}

void sort_points_xy(const double* xy, std::vector<int>& order, PointSortScratch& sc) {
  const std::size_t n = order.size();
  const auto less = [xy](int a, int b) {
    const double *pa = xy_point(xy, a), *pb = xy_point(xy, b);
    if (pa[0] != pb[0]) return pa[0] < pb[0];
    if (pa[1] != pb[1]) return pa[1] < pb[1];
    return a < b;
  };
  constexpr std::size_t kRadixMin = 256;
  if (n < kRadixMin) {
    std::sort(order.begin(), order.end(), less);
    return;
  }
  detail::resize_with_headroom(sc.keys, n);
  for (std::size_t i = 0; i < n; ++i) {
    sc.keys[i] = detail::double_order_key(xy_point(xy, order[i])[0]);
  }
  detail::radix_sort_by_key(order, sc.keys, sc.order_tmp, sc.keys_tmp);
  const std::uint64_t* const keys = sc.keys.data();
  for (std::size_t i = 0; i + 1 < n;) {  // runs of equal x: by (y, index)
    std::size_t j = i + 1;
    while (j < n && keys[j] == keys[i]) ++j;
    if (j - i > 1) {
      std::sort(order.begin() + static_cast<std::ptrdiff_t>(i),
                order.begin() + static_cast<std::ptrdiff_t>(j), less);
    }
    i = j;
  }
}

void area_perimeter(const double* xy, int n, double& area, double& perimeter) {
  double a = 0, p = 0;
  for (int i = 0, j = n - 1; i < n; j = i++) {
    const double *pi = xy_point(xy, i), *pj = xy_point(xy, j);
    a += pj[0] * pi[1] - pi[0] * pj[1];
    const double dx = pi[0] - pj[0], dy = pi[1] - pj[1];
    p += std::sqrt(dx * dx + dy * dy);
  }
  area = 0.5 * a;
  perimeter = p;
}

void monotone_chain_sorted(const double* xy, int n, std::vector<int>& hull) {
  hull.clear();
  if (n <= 0) return;
  auto turn = [&](int o, int a, int b) {
    const double *po = xy_point(xy, o), *pa = xy_point(xy, a), *pb = xy_point(xy, b);
    return cross(po[0], po[1], pa[0], pa[1], pb[0], pb[1]);
  };
  detail::resize_with_headroom(hull, 2 * static_cast<std::size_t>(n) + 1);
  std::size_t k = 0;
  for (int i = 0; i < n; ++i) {  // lower chain
    while (k >= 2 && turn(hull[k - 2], hull[k - 1], i) <= 0) --k;
    hull[k++] = i;
  }
  for (int i = n - 2, t = static_cast<int>(k) + 1; i >= 0; --i) {  // upper chain
    while (static_cast<int>(k) >= t && turn(hull[k - 2], hull[k - 1], i) <= 0) --k;
    hull[k++] = i;
  }
  hull.resize(k > 1 ? k - 1 : k);  // the last point repeats the first
}

}  // namespace rangeseg::polygons_detail
