// Plane polygons: boundary edges of every segment's faces, loop tracing, projection onto the
// plane, simplification with a simplicity check, convex hulls.
//
// Boundary edges are found in one pass over the cells (boundary_masks.cpp): one outgoing-edge
// mask per vertex serves all segments at once. The masks, the "remaining" copy and the
// revisit positions are kept all-zero between frames, so no full-image clear is needed.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>

#include "detail/bad_setting.hpp"
#include "detail/headroom.hpp"
#include "detail/segment_labels.hpp"
#include "detail/simd.hpp"
#include "polygons/internal.hpp"
#include "rangeseg/polygons.hpp"
#include "rangeseg/thread_pool.hpp"

namespace rangeseg {

using polygons_detail::CheckEdge;
using polygons_detail::xy_point;

namespace {

using polygons_detail::dot;
using polygons_detail::Projection;
using polygons_detail::Vec;

Vec cross3(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec normalized(const Vec& a) {
  const double n = std::sqrt(dot(a, a));
  return {a[0] / n, a[1] / n, a[2] / n};
}

}  // namespace

PlaneFrame polygons_detail::plane_frame(const Segment& seg) {
  PlaneFrame fr;
  Vec n = seg.normal;
  const double len = std::sqrt(dot(n, n));
  n = len > 0 ? Vec{n[0] / len, n[1] / len, n[2] / len} : Vec{0, 0, -1};
  fr.normal = n;
  fr.offset = seg.offset;
  const double dist = dot(n, seg.centroid) + seg.offset;
  fr.origin = {seg.centroid[0] - dist * n[0], seg.centroid[1] - dist * n[1],
               seg.centroid[2] - dist * n[2]};
  const Vec ex{1.0 - n[0] * n[0], -n[0] * n[1], -n[0] * n[2]};  // x - (x.n) n
  if (dot(ex, ex) > 0.01) {
    fr.e1 = normalized(ex);
    fr.e2 = cross3(n, fr.e1);
  } else {
    const Vec up{n[1] * n[0], -1.0 + n[1] * n[1], n[1] * n[2]};  // -(y - (y.n) n)
    fr.e2 = normalized(up);
    fr.e1 = cross3(fr.e2, n);
  }
  return fr;
}

namespace {

struct RawLoop {
  int label;
  int first;  // into raw_idx
  int count;
  double area_px;  // area in the image, counter-clockwise on the image positive [pixel^2]
  int seg;         // index into out.segments
  int parent;      // holes: raw loop index of the enclosing outer loop
  int u_min, u_max, v_min, v_max;  // bounding box of the vertices [pixel]
};

// Vertices at (u, v) = uv[first, n) into xy (x, y interleaved), from `first` on.
void project_scalar(const OrganizedCloud& cloud, const std::array<std::int32_t, 2>* uv, int first,
                    int n, const Projection& pr, double* xy) {
  for (int i = first; i < n; ++i) {
    // The points are scattered over cloud planes that earlier stages have mostly evicted
    // from the caches: fetch a few vertices ahead.
    constexpr int kAhead = 16;
    if (i + kAhead < n) {
      const auto [pu, pv] = uv[i + kAhead];
      __builtin_prefetch(cloud.x.row(pv) + pu);
      __builtin_prefetch(cloud.y.row(pv) + pu);
      __builtin_prefetch(cloud.z.row(pv) + pu);
    }
    const auto [u, v] = uv[i];
    polygons_detail::project_point(pr, {cloud.x.row(v)[u], cloud.y.row(v)[u], cloud.z.row(v)[u]},
                                   xy_point(xy, i));
  }
}

#if RANGESEG_SIMD_X86
// project_scalar four vertices at a time (scalar loads of the cloud values: gathers were
// slower here), both projections computed and blended. Every lane does the scalar code's IEEE
// operations in the same order (the target has no FMA, so nothing is contracted), so the results
// are bit-identical.
/// a0 b0 + a1 b1 + a2 b2 per lane, in dot()'s order.
__attribute__((target("avx2"), always_inline)) inline __m256d dot3(__m256d a0, __m256d a1,
                                                                   __m256d a2, __m256d b0,
                                                                   __m256d b1, __m256d b2) {
  return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(a0, b0), _mm256_mul_pd(a1, b1)),
                       _mm256_mul_pd(a2, b2));
}

__attribute__((target("avx2"))) void project_avx2(const OrganizedCloud& cloud,
                                                  const std::array<std::int32_t, 2>* uv, int n,
                                                  const Projection& pr, double* xy) {
  const PlaneFrame& fr = pr.fr;
  const std::ptrdiff_t stride = cloud.x.stride();
  const float* px = cloud.x.row(0);
  const float* py = cloud.y.row(0);
  const float* pz = cloud.z.row(0);
  const __m256d vp0 = _mm256_set1_pd(pr.vp[0]), vp1 = _mm256_set1_pd(pr.vp[1]),
                vp2 = _mm256_set1_pd(pr.vp[2]);
  const __m256d n0 = _mm256_set1_pd(fr.normal[0]), n1 = _mm256_set1_pd(fr.normal[1]),
                n2 = _mm256_set1_pd(fr.normal[2]);
  const __m256d o0 = _mm256_set1_pd(fr.origin[0]), o1 = _mm256_set1_pd(fr.origin[1]),
                o2 = _mm256_set1_pd(fr.origin[2]);
  const __m256d e10 = _mm256_set1_pd(fr.e1[0]), e11 = _mm256_set1_pd(fr.e1[1]),
                e12 = _mm256_set1_pd(fr.e1[2]);
  const __m256d e20 = _mm256_set1_pd(fr.e2[0]), e21 = _mm256_set1_pd(fr.e2[1]),
                e22 = _mm256_set1_pd(fr.e2[2]);
  const __m256d offset = _mm256_set1_pd(fr.offset), neg_nvp = _mm256_set1_pd(-pr.nvp),
                zero = _mm256_setzero_pd();
  const __m256d two_sine2 =
                    _mm256_set1_pd(2 * polygons_detail::kMinRaySine * polygons_detail::kMinRaySine),
                minus_sine = _mm256_set1_pd(-polygons_detail::kMinRaySine);
  const __m256d front = pr.nvp > 0 ? _mm256_castsi256_pd(_mm256_set1_epi64x(-1)) : zero;
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    constexpr int kAhead = 16;
    if (i + kAhead + 4 <= n) {
      for (int a = 0; a < 4; a += 2) {  // two of the next four: a cache line holds several
        const auto [pu, pv] = uv[i + kAhead + a];
        __builtin_prefetch(px + pv * stride + pu);
        __builtin_prefetch(py + pv * stride + pu);
        __builtin_prefetch(pz + pv * stride + pu);
      }
    }
    // Four scalar loads per plane: faster than gathers here.
    std::ptrdiff_t at[4];
    for (int a = 0; a < 4; ++a) at[a] = uv[i + a][1] * stride + uv[i + a][0];
    const __m256d p0 = _mm256_cvtps_pd(_mm_setr_ps(px[at[0]], px[at[1]], px[at[2]], px[at[3]]));
    const __m256d p1 = _mm256_cvtps_pd(_mm_setr_ps(py[at[0]], py[at[1]], py[at[2]], py[at[3]]));
    const __m256d p2 = _mm256_cvtps_pd(_mm_setr_ps(pz[at[0]], pz[at[1]], pz[at[2]], pz[at[3]]));
    const __m256d d0 = _mm256_sub_pd(p0, vp0), d1 = _mm256_sub_pd(p1, vp1),
                  d2 = _mm256_sub_pd(p2, vp2);
    const __m256d denom = dot3(n0, n1, n2, d0, d1, d2);
    const __m256d dir2 = dot3(d0, d1, d2, d0, d1, d2);
    const __m256d steep =
        _mm256_cmp_pd(_mm256_mul_pd(denom, denom), _mm256_mul_pd(two_sine2, dir2), _CMP_GT_OQ);
    const __m256d near =
        _mm256_cmp_pd(denom, _mm256_mul_pd(minus_sine, _mm256_sqrt_pd(dir2)), _CMP_LT_OQ);
    const __m256d ray = _mm256_and_pd(_mm256_and_pd(front, _mm256_cmp_pd(denom, zero, _CMP_LT_OQ)),
                                      _mm256_or_pd(steep, near));
    const __m256d t = _mm256_div_pd(neg_nvp, denom);
    const __m256d dist = _mm256_add_pd(dot3(n0, n1, n2, p0, p1, p2), offset);
    const __m256d q0 = _mm256_blendv_pd(_mm256_sub_pd(p0, _mm256_mul_pd(dist, n0)),
                                        _mm256_add_pd(vp0, _mm256_mul_pd(t, d0)), ray);
    const __m256d q1 = _mm256_blendv_pd(_mm256_sub_pd(p1, _mm256_mul_pd(dist, n1)),
                                        _mm256_add_pd(vp1, _mm256_mul_pd(t, d1)), ray);
    const __m256d q2 = _mm256_blendv_pd(_mm256_sub_pd(p2, _mm256_mul_pd(dist, n2)),
                                        _mm256_add_pd(vp2, _mm256_mul_pd(t, d2)), ray);
    const __m256d r0 = _mm256_sub_pd(q0, o0), r1 = _mm256_sub_pd(q1, o1),
                  r2 = _mm256_sub_pd(q2, o2);
    const __m256d x = dot3(r0, r1, r2, e10, e11, e12);
    const __m256d y = dot3(r0, r1, r2, e20, e21, e22);
    // Interleave: (x0, y0, x1, y1), (x2, y2, x3, y3).
    const __m256d lo = _mm256_unpacklo_pd(x, y), hi = _mm256_unpackhi_pd(x, y);
    double* dst = xy_point(xy, i);
    _mm256_storeu_pd(dst, _mm256_permute2f128_pd(lo, hi, 0x20));
    _mm256_storeu_pd(dst + 4, _mm256_permute2f128_pd(lo, hi, 0x31));
  }
  project_scalar(cloud, uv, i, n, pr, xy);
}
#endif

// Projects the loop vertices uv[0, n) onto the plane: (x, y) interleaved into xy[0, 2n).
void project(const OrganizedCloud& cloud, const std::array<std::int32_t, 2>* uv, int n,
             const Projection& pr, double* xy) {
#if RANGESEG_SIMD_X86
  if (detail::simd::chosen_isa() >= detail::simd::Isa::avx2 &&
      cloud.y.stride() == cloud.x.stride() && cloud.z.stride() == cloud.x.stride() &&
      cloud.x.stride() * static_cast<std::ptrdiff_t>(cloud.height()) <=
          std::numeric_limits<std::int32_t>::max()) {
    project_avx2(cloud, uv, n, pr, xy);
    return;
  }
#endif
  project_scalar(cloud, uv, 0, n, pr, xy);
}

}  // namespace

namespace {

// Buffers of one worker's segments: each segment's kept loops, their projection,
// simplification and hull. Workers share the raw loops (each writes only its own segments'
// entries of raw[].parent and outer_rank).
struct SegmentWork {
  std::vector<int> kept;        // raw loops of one segment in output order
  std::vector<int> hole_count;  // per outer loop rank: holes (prefix sums: fill cursors)
  // Holes whose parent is searched: raw loop, doubled query point, grouped by its row.
  std::vector<int> queries, query_x2, query_y2, row_start, row_queries, touched;
  std::vector<std::uint8_t> parity;
  std::vector<int> xy_first;  // per kept loop: offset into xy (in points)
  std::vector<double> xy;     // projected plane points of the kept loops
  std::vector<double> tolerance, raw_area, raw_perimeter;  // per kept loop
  std::vector<int> keep, keep_first, keep_next, keep_first_next;
  std::vector<std::array<int, 2>> dp_stack;
  std::vector<CheckEdge> edges;
  std::vector<std::uint8_t> bad;
  polygons_detail::CrossingScratch crossing;
  std::vector<std::uint8_t> changed;  ///< loops simplified again in this attempt
  std::vector<int> hull_order, hull_idx;
  polygons_detail::PointSortScratch hull_sort;
  std::vector<double> hull_xy;
  PolygonSet part;  // the loops and hulls of a worker after the first, appended to the output
};

}  // namespace

struct PolygonExtractor::Scratch {
  Plane<std::uint16_t> edge_masks;  // outgoing boundary edges: mask | remaining << 8
  Plane<std::int32_t> pos;
  bool dirty = false;
  polygons_detail::TraceSteps trace_steps;
  std::vector<std::int32_t> starts, walk, stack;
  std::vector<std::vector<std::int32_t>> band_starts;            // with threads: per row band
  std::vector<polygons_detail::BoundaryMaskScratch> band_masks;  // per row band
  std::vector<RawLoop> raw;
  std::vector<std::int32_t> raw_idx;
  std::vector<std::array<std::int32_t, 2>> raw_uv;  // (u, v) of each raw_idx entry
  std::vector<std::uint8_t> enabled;
  std::vector<int> seg_of_label;
  std::vector<int> bucket_start, bucket_loops;  // raw loops grouped by segment
  std::vector<int> fill;                        // cursors of the grouping
  std::vector<int> outer_rank;           // per raw outer loop: its index in its segment's `kept`
  std::vector<std::size_t> group_first;  // per worker: its first segment (then the end)
  std::vector<SegmentWork> work;         // per worker
};

namespace {

// Parents of the holes sc.queries (raw loops, parent -1) among the outer loops sc.kept[0,
// n_outer): the smallest outer loop (the last in `kept`) whose even-odd test counts an odd
// number of its edges crossing the ray from the hole's query point to the left (+x is right).
// A crossing is decided as in the divided form x_query < x of the edge at y_query, multiplied
// out by (yj - yi) so that it has no division; coordinates are integers and half-integers, so
// the products are exact. Instead of testing every hole against every outer loop, the query
// points are grouped by row and each loop's edges visit only the holes of the rows they cross:
// grid loops' edges span at most pixel_stride rows. The result equals the pairwise test.
void find_parents(std::vector<RawLoop>& raw, const std::vector<std::array<std::int32_t, 2>>& raw_uv,
                  SegmentWork& sc, std::size_t n_outer) {
  const std::size_t nq = sc.queries.size();
  detail::resize_with_headroom(sc.query_x2, nq);
  detail::resize_with_headroom(sc.query_y2, nq);
  int y2_min = std::numeric_limits<int>::max(), y2_max = std::numeric_limits<int>::min();
  for (std::size_t q = 0; q < nq; ++q) {
    const RawLoop& r = raw[static_cast<std::size_t>(sc.queries[q])];
    const std::array<std::int32_t, 2>* uv = raw_uv.data() + r.first;
    sc.query_x2[q] = uv[0][0] + uv[1][0];
    sc.query_y2[q] = uv[0][1] + uv[1][1];
    y2_min = std::min(y2_min, sc.query_y2[q]);
    y2_max = std::max(y2_max, sc.query_y2[q]);
  }
  const std::size_t rows = static_cast<std::size_t>(y2_max - y2_min) + 1;
  detail::assign_with_headroom(sc.row_start, rows + 1, 0);
  for (std::size_t q = 0; q < nq; ++q) {
    ++sc.row_start[static_cast<std::size_t>(sc.query_y2[q] - y2_min) + 1];
  }
  for (std::size_t i = 0; i < rows; ++i) sc.row_start[i + 1] += sc.row_start[i];
  detail::resize_with_headroom(sc.row_queries, nq);
  sc.touched.assign(sc.row_start.begin(), sc.row_start.end() - 1);  // fill cursors
  for (std::size_t q = 0; q < nq; ++q) {
    sc.row_queries[static_cast<std::size_t>(
        sc.touched[static_cast<std::size_t>(sc.query_y2[q] - y2_min)]++)] = static_cast<int>(q);
  }
  detail::assign_with_headroom(sc.parity, nq, 0);
  for (std::size_t k = n_outer; k-- > 0;) {
    const int outer = sc.kept[k];
    const RawLoop& o = raw[static_cast<std::size_t>(outer)];
    if (2 * o.v_max < y2_min || 2 * o.v_min > y2_max) continue;
    const std::array<std::int32_t, 2>* uv = raw_uv.data() + o.first;
    sc.touched.clear();
    for (int i = 0, j = o.count - 1; i < o.count; j = i++) {
      const int yi_int = uv[i][1], yj_int = uv[j][1];
      if (yi_int == yj_int) continue;
      // The edge straddles y_query (one end above, one at or below) for 2 lo <= y2 < 2 hi.
      const int lo = std::max(2 * std::min(yi_int, yj_int), y2_min);
      const int hi = std::min(2 * std::max(yi_int, yj_int) - 1, y2_max);
      for (int y2 = lo; y2 <= hi; ++y2) {
        const int row = y2 - y2_min;
        for (int t = sc.row_start[static_cast<std::size_t>(row)];
             t < sc.row_start[static_cast<std::size_t>(row) + 1]; ++t) {
          const int q = sc.row_queries[static_cast<std::size_t>(t)];
          if (raw[static_cast<std::size_t>(sc.queries[static_cast<std::size_t>(q)])].parent >= 0) {
            continue;
          }
          const double px = 0.5 * static_cast<double>(sc.query_x2[static_cast<std::size_t>(q)]);
          const double py = 0.5 * static_cast<double>(y2);
          const double xi = uv[i][0], yi = yi_int, xj = uv[j][0], yj = yj_int;
          const double d = yj - yi;
          const double a = (px - xi) * d, b = (xj - xi) * (py - yi);
          if ((d > 0 && a < b) || (d < 0 && a > b)) {
            sc.parity[static_cast<std::size_t>(q)] ^= 1u;
            sc.touched.push_back(q);
          }
        }
      }
    }
    for (const int q : sc.touched) {
      if (!sc.parity[static_cast<std::size_t>(q)]) continue;
      sc.parity[static_cast<std::size_t>(q)] = 0;
      raw[static_cast<std::size_t>(sc.queries[static_cast<std::size_t>(q)])].parent = outer;
    }
  }
}

// The loops of segment si (simplified, projected onto its plane) and its convex hull, appended
// to dst; sp = out_segments[si] takes their offsets in dst and their areas.
void outline_segment(const OrganizedCloud& cloud, const Segmentation& segmentation,
                     const PolygonSettings& settings, const Vec& vp, PolygonExtractor::Scratch& sc,
                     SegmentWork& w, std::size_t si, std::vector<SegmentPolygons>& out_segments,
                     PolygonSet& dst) {
  SegmentPolygons& sp = out_segments[si];
  const Segment& seg = segmentation.segments[static_cast<std::size_t>(sp.label - 1)];
  sp.frame = polygons_detail::plane_frame(seg);
  sp.first_loop = static_cast<int>(dst.loops.size());
  sp.hull_first = static_cast<int>(dst.hull_points2d.size());
  const int b0 = sc.bucket_start[si], b1 = sc.bucket_start[si + 1];
  if (b0 == b1) return;

  // Outer loops (positive) by area descending, then the holes grouped by parent.
  int largest = -1;
  for (int b = b0; b < b1; ++b) {
    const RawLoop& r = sc.raw[static_cast<std::size_t>(sc.bucket_loops[b])];
    if (r.area_px > 0 &&
        (largest < 0 || r.area_px > sc.raw[static_cast<std::size_t>(largest)].area_px)) {
      largest = sc.bucket_loops[b];
    }
  }
  if (largest < 0) return;
  w.kept.clear();
  for (int b = b0; b < b1; ++b) {
    const int li = sc.bucket_loops[b];
    const RawLoop& r = sc.raw[static_cast<std::size_t>(li)];
    if (r.area_px > 0 && (li == largest || r.area_px >= settings.min_loop_pixels)) {
      w.kept.push_back(li);
    }
  }
  std::sort(w.kept.begin(), w.kept.end(), [&](int a, int b) {
    const double aa = sc.raw[static_cast<std::size_t>(a)].area_px,
                 ab = sc.raw[static_cast<std::size_t>(b)].area_px;
    return aa != ab ? aa > ab : a < b;
  });
  const std::size_t n_outer = w.kept.size();
  for (std::size_t k = 0; k < n_outer; ++k) {
    sc.outer_rank[static_cast<std::size_t>(w.kept[k])] = static_cast<int>(k);
  }
  // Holes: the parent is the smallest outer loop containing the midpoint of the hole's first
  // edge (never on another loop's edge: edges are unique).
  w.queries.clear();
  for (int b = b0; b < b1; ++b) {
    const int li = sc.bucket_loops[b];
    RawLoop& r = sc.raw[static_cast<std::size_t>(li)];
    if (r.area_px >= 0 || -r.area_px < settings.min_loop_pixels) continue;
    r.parent = n_outer == 1 ? w.kept[0] : -1;
    if (n_outer > 1) w.queries.push_back(li);
  }
  if (!w.queries.empty()) find_parents(sc.raw, sc.raw_uv, w, n_outer);
  // Output order: the holes of each outer loop in turn, in tracing order (a counting sort by
  // the parent's rank keeps the order of the bucket, which is the tracing order).
  detail::assign_with_headroom(w.hole_count, n_outer + 1, 0);
  for (int b = b0; b < b1; ++b) {
    const RawLoop& r = sc.raw[static_cast<std::size_t>(sc.bucket_loops[b])];
    if (r.area_px >= 0 || -r.area_px < settings.min_loop_pixels || r.parent < 0) continue;
    ++w.hole_count[static_cast<std::size_t>(sc.outer_rank[static_cast<std::size_t>(r.parent)]) + 1];
  }
  for (std::size_t k = 0; k < n_outer; ++k) w.hole_count[k + 1] += w.hole_count[k];
  detail::resize_with_headroom(w.kept, n_outer + static_cast<std::size_t>(w.hole_count[n_outer]));
  for (int b = b0; b < b1; ++b) {
    const int li = sc.bucket_loops[b];
    const RawLoop& r = sc.raw[static_cast<std::size_t>(li)];
    if (r.area_px >= 0 || -r.area_px < settings.min_loop_pixels || r.parent < 0) continue;
    const int rank = sc.outer_rank[static_cast<std::size_t>(r.parent)];
    w.kept[n_outer + static_cast<std::size_t>(w.hole_count[static_cast<std::size_t>(rank)]++)] = li;
  }

  // Project every kept loop onto the plane.
  const PlaneFrame& fr = sp.frame;
  const Projection pr = polygons_detail::make_projection(fr, vp);
  w.xy_first.clear();
  std::size_t n_points = 0;
  for (int li : w.kept) {
    w.xy_first.push_back(static_cast<int>(n_points));
    n_points += static_cast<std::size_t>(sc.raw[static_cast<std::size_t>(li)].count);
  }
  w.xy_first.push_back(static_cast<int>(n_points));
  detail::resize_with_headroom(w.xy, 2 * n_points);
  for (std::size_t k = 0; k < w.kept.size(); ++k) {
    const RawLoop& r = sc.raw[static_cast<std::size_t>(w.kept[k])];
    project(cloud, sc.raw_uv.data() + r.first, r.count, pr, xy_point(w.xy.data(), w.xy_first[k]));
  }

  // Simplify; loops that cross another loop (or themselves) get half the tolerance, and after a
  // few halvings stay unsimplified (the mesh boundary is simple).
  const std::size_t nk = w.kept.size();
  detail::resize_with_headroom(w.tolerance, nk);
  detail::resize_with_headroom(w.raw_area, nk);
  detail::resize_with_headroom(w.raw_perimeter, nk);
  for (std::size_t k = 0; k < nk; ++k) {
    const int n = w.xy_first[k + 1] - w.xy_first[k];
    polygons_detail::area_perimeter(xy_point(w.xy.data(), w.xy_first[k]), n, w.raw_area[k],
                                    w.raw_perimeter[k]);
    const double inradius = w.raw_perimeter[k] > 0 ? 2 * w.raw_area[k] / w.raw_perimeter[k] : 0;
    w.tolerance[k] = std::max(
        std::min(settings.simplify_tolerance, settings.simplify_inradius_fraction * inradius),
        settings.simplify_tolerance_pixels * w.raw_perimeter[k] / n);
  }
  for (int attempt = 0;; ++attempt) {
    // Only loops whose tolerance changed are simplified again.
    w.keep_next.clear();
    w.keep_first_next.clear();
    for (std::size_t k = 0; k < nk; ++k) {
      w.keep_first_next.push_back(static_cast<int>(w.keep_next.size()));
      if (attempt > 0 && !w.bad[k]) {
        detail::append_with_headroom(w.keep_next, w.keep.begin() + w.keep_first[k],
                                     w.keep.begin() + w.keep_first[k + 1]);
        continue;
      }
      const int n = w.xy_first[k + 1] - w.xy_first[k];
      polygons_detail::simplify_closed(xy_point(w.xy.data(), w.xy_first[k]), n, w.tolerance[k],
                                       w.keep_next, w.dp_stack);
    }
    w.keep_first_next.push_back(static_cast<int>(w.keep_next.size()));
    std::swap(w.keep, w.keep_next);
    std::swap(w.keep_first, w.keep_first_next);
    polygons_detail::share_capacity(w.keep, w.keep_next);
    polygons_detail::share_capacity(w.keep_first, w.keep_first_next);
    bool any_simplified = false;
    for (std::size_t k = 0; k < nk; ++k) any_simplified |= w.tolerance[k] > 0;
    if (!any_simplified) break;
    w.edges.clear();
    for (std::size_t k = 0; k < nk; ++k) {
      const RawLoop& r = sc.raw[static_cast<std::size_t>(w.kept[k])];
      const int kb = w.keep_first[k], ke = w.keep_first[k + 1];
      const double* base = xy_point(w.xy.data(), w.xy_first[k]);
      for (int i = kb, j = ke - 1; i < ke; j = i++) {
        const int a = w.keep[static_cast<std::size_t>(j)], b = w.keep[static_cast<std::size_t>(i)];
        const double *pa = xy_point(base, a), *pb = xy_point(base, b);
        w.edges.push_back(
            {pa[0], pa[1], pb[0], pb[1],
             sc.raw_idx[static_cast<std::size_t>(r.first) + static_cast<std::size_t>(a)],
             sc.raw_idx[static_cast<std::size_t>(r.first) + static_cast<std::size_t>(b)],
             static_cast<int>(k)});
      }
    }
    // After the first check only pairs with a loop simplified again can newly touch: a pair of
    // unchanged loops that touched marked both, and they changed, unless already unsimplified.
    w.changed.assign(w.bad.begin(), w.bad.end());
    detail::assign_with_headroom(w.bad, nk, 0);
    if (!polygons_detail::mark_crossings(w.edges, w.bad, w.crossing,
                                         attempt > 0 ? w.changed.data() : nullptr)) {
      break;
    }
    for (std::size_t k = 0; k < nk; ++k) {
      if (!w.bad[k]) continue;
      const double tolerance = attempt >= 4 ? 0.0 : 0.5 * w.tolerance[k];
      w.bad[k] = tolerance != w.tolerance[k];  // from here on: "simplify again"
      w.tolerance[k] = tolerance;
    }
    if (attempt >= 5) break;  // every offender is unsimplified now
  }

  // Write the loops.
  for (std::size_t k = 0; k < nk; ++k) {
    const RawLoop& r = sc.raw[static_cast<std::size_t>(w.kept[k])];
    const double* base = xy_point(w.xy.data(), w.xy_first[k]);
    PolygonLoop lp;
    lp.segment = static_cast<int>(si);
    lp.label = sp.label;
    lp.is_hole = r.area_px < 0;
    if (lp.is_hole) lp.parent = sp.first_loop + sc.outer_rank[static_cast<std::size_t>(r.parent)];
    lp.raw_count = r.count;
    lp.tolerance = w.tolerance[k];
    lp.raw_area = std::abs(w.raw_area[k]);
    lp.raw_perimeter = w.raw_perimeter[k];
    double a, p;
    lp.first = static_cast<int>(dst.points2d.size());
    const int kb = w.keep_first[k], ke = w.keep_first[k + 1];
    lp.count = ke - kb;
    w.hull_xy.clear();
    for (int i = kb; i < ke; ++i) {
      const int vi = w.keep[static_cast<std::size_t>(i)];
      const double* pt = xy_point(base, vi);
      const double x = pt[0], y = pt[1];
      w.hull_xy.push_back(x);
      w.hull_xy.push_back(y);
      dst.points2d.push_back({static_cast<float>(x), static_cast<float>(y)});
      dst.points3d.push_back({static_cast<float>(fr.origin[0] + x * fr.e1[0] + y * fr.e2[0]),
                              static_cast<float>(fr.origin[1] + x * fr.e1[1] + y * fr.e2[1]),
                              static_cast<float>(fr.origin[2] + x * fr.e1[2] + y * fr.e2[2])});
      const auto [pu, pv] =
          sc.raw_uv[static_cast<std::size_t>(r.first) + static_cast<std::size_t>(vi)];
      dst.pixels.push_back({static_cast<float>(pu), static_cast<float>(pv)});
    }
    polygons_detail::area_perimeter(w.hull_xy.data(), lp.count, a, p);
    lp.area = std::abs(a);
    lp.perimeter = p;
    sp.area += lp.is_hole ? -lp.area : lp.area;
    sp.raw_area += lp.is_hole ? -lp.raw_area : lp.raw_area;
    sp.perimeter += lp.perimeter;
    dst.loops.push_back(lp);
  }
  sp.loop_count = static_cast<int>(nk);
  // Holes lie inside their outer loops, so this is never below 0 but for a plane seen edge-on
  // (through the viewpoint), whose outline projects onto it as a sliver of overlapping loops.
  sp.area = std::max(0.0, sp.area);

  // Convex hull of the outer loops' mesh boundary vertices.
  if (settings.convex_hull) {
    const double* xy = w.xy.data();
    polygons_detail::hull_candidates(xy, w.xy_first[n_outer], w.hull_order);
    const int n_pts = static_cast<int>(w.hull_order.size());
    polygons_detail::sort_points_xy(xy, w.hull_order, w.hull_sort);
    detail::resize_with_headroom(w.hull_xy, 2 * static_cast<std::size_t>(n_pts));
    for (int i = 0; i < n_pts; ++i) {
      const int o = w.hull_order[static_cast<std::size_t>(i)];
      const double* pt = xy_point(xy, o);
      w.hull_xy[2 * static_cast<std::size_t>(i)] = pt[0];
      w.hull_xy[2 * static_cast<std::size_t>(i) + 1] = pt[1];
    }
    polygons_detail::monotone_chain_sorted(w.hull_xy.data(), n_pts, w.hull_idx);
    // Vertex o of the concatenated outer loops -> its mesh vertex, for the pixel.
    for (int hi : w.hull_idx) {
      const int o = w.hull_order[static_cast<std::size_t>(hi)];
      std::size_t k = 0;
      while (w.xy_first[k + 1] <= o) ++k;
      const RawLoop& r = sc.raw[static_cast<std::size_t>(w.kept[k])];
      const auto [pu, pv] = sc.raw_uv[static_cast<std::size_t>(r.first + o - w.xy_first[k])];
      const double* pt = xy_point(xy, o);
      const double x = pt[0], y = pt[1];
      dst.hull_points2d.push_back({static_cast<float>(x), static_cast<float>(y)});
      dst.hull_points3d.push_back({static_cast<float>(fr.origin[0] + x * fr.e1[0] + y * fr.e2[0]),
                                   static_cast<float>(fr.origin[1] + x * fr.e1[1] + y * fr.e2[1]),
                                   static_cast<float>(fr.origin[2] + x * fr.e1[2] + y * fr.e2[2])});
      dst.hull_pixels.push_back({static_cast<float>(pu), static_cast<float>(pv)});
    }
    sp.hull_count = static_cast<int>(w.hull_idx.size());
    double a = 0, p = 0;
    w.hull_xy.clear();
    for (int hi : w.hull_idx) {
      const int o = w.hull_order[static_cast<std::size_t>(hi)];
      const double* pt = xy_point(xy, o);
      w.hull_xy.push_back(pt[0]);
      w.hull_xy.push_back(pt[1]);
    }
    if (sp.hull_count >= 3) {
      polygons_detail::area_perimeter(w.hull_xy.data(), sp.hull_count, a, p);
    }
    sp.hull_area = std::abs(a);
    sp.hull_perimeter = p;
  }
}

// Worker g > 0 wrote its segments' loops and hulls into its own set, with offsets into it.
void append_part(PolygonSet& part, std::size_t seg_begin, std::size_t seg_end, PolygonSet& out) {
  const int loops = static_cast<int>(out.loops.size());
  const int points = static_cast<int>(out.points2d.size());
  const int hull_points = static_cast<int>(out.hull_points2d.size());
  for (std::size_t si = seg_begin; si < seg_end; ++si) {
    out.segments[si].first_loop += loops;
    out.segments[si].hull_first += hull_points;
  }
  for (PolygonLoop& lp : part.loops) {
    lp.first += points;
    if (lp.is_hole) lp.parent += loops;
  }
  const auto append = [](auto& to, const auto& from) {
    detail::append_with_headroom(to, from.begin(), from.end());
  };
  append(out.loops, part.loops);
  append(out.points2d, part.points2d);
  append(out.points3d, part.points3d);
  append(out.pixels, part.pixels);
  append(out.hull_points2d, part.hull_points2d);
  append(out.hull_points3d, part.hull_points3d);
  append(out.hull_pixels, part.hull_pixels);
}

}  // namespace

PolygonExtractor::PolygonExtractor() : scratch_(std::make_unique<Scratch>()) {}
PolygonExtractor::~PolygonExtractor() = default;
PolygonExtractor::PolygonExtractor(PolygonExtractor&&) noexcept = default;
PolygonExtractor& PolygonExtractor::operator=(PolygonExtractor&&) noexcept = default;

void PolygonExtractor::extract(const OrganizedCloud& cloud, const Mesh& mesh,
                               const Segmentation& segmentation, const PolygonSettings& settings,
                               PolygonSet& out) {
  extract_grid(cloud, mesh, segmentation, settings, out, nullptr);
}

void PolygonExtractor::extract(const OrganizedCloud& cloud, const Mesh& mesh,
                               const Segmentation& segmentation, const PolygonSettings& settings,
                               PolygonSet& out, ThreadPool& pool) {
  extract_grid(cloud, mesh, segmentation, settings, out, pool.threads() > 1 ? &pool : nullptr);
}

void PolygonExtractor::extract_grid(const OrganizedCloud& cloud, const Mesh& mesh,
                                    const Segmentation& segmentation,
                                    const PolygonSettings& settings, PolygonSet& out,
                                    ThreadPool* pool) {
  const int width = cloud.width(), height = cloud.height(), s = mesh.pixel_stride;
  if (mesh.width() != width || mesh.height() != height || mesh.faces.width() != width ||
      mesh.faces.height() != height || segmentation.labels.width() != width ||
      segmentation.labels.height() != height || cloud.x.width() != width ||
      cloud.y.width() != width || cloud.x.height() != height || cloud.y.height() != height) {
    throw std::invalid_argument("PolygonExtractor::extract: sizes differ: cloud " +
                                std::to_string(width) + "x" + std::to_string(height) + ", mesh " +
                                std::to_string(mesh.width()) + "x" + std::to_string(mesh.height()) +
                                ", labels " + std::to_string(segmentation.labels.width()) + "x" +
                                std::to_string(segmentation.labels.height()));
  }
  if (s < 1) {
    throw std::invalid_argument("PolygonExtractor::extract: mesh pixel_stride must be >= 1, got " +
                                std::to_string(s));
  }
  // A label that names no segment would cut a hole in its neighbour's polygon.
  detail::require_labels_name_segments(segmentation, "PolygonExtractor::extract");
  validate(settings);

  if (!scratch_) scratch_ = std::make_unique<Scratch>();  // moved from
  Scratch& sc = *scratch_;
  out.clear();
  out.width = width;
  out.height = height;
  if (width == 0 || height == 0) return;

  // --- which segments ---
  const std::size_t n_labels = segmentation.segments.size() + 1;
  detail::assign_with_headroom(sc.enabled, n_labels, 0);
  detail::assign_with_headroom(sc.seg_of_label, n_labels, -1);
  for (const Segment& seg : segmentation.segments) {
    if (seg.label < 1 || static_cast<std::size_t>(seg.label) >= n_labels) continue;
    if (settings.planes_only && !is_plane(seg)) continue;
    if (seg.pixel_count < settings.min_segment_pixels) continue;
    if (!std::isfinite(seg.offset) || !std::isfinite(seg.normal[0]) ||
        !std::isfinite(seg.normal[1]) || !std::isfinite(seg.normal[2])) {
      continue;
    }
    sc.enabled[seg.label] = 1;
  }
  for (std::size_t l = 1; l < n_labels; ++l) {
    if (!sc.enabled[l]) continue;
    sc.seg_of_label[l] = static_cast<int>(out.segments.size());
    SegmentPolygons sp;
    sp.label = static_cast<int>(l);
    out.segments.push_back(sp);
  }
  // --- per-vertex outgoing boundary edges ---
  if (sc.edge_masks.width() != width || sc.edge_masks.height() != height || sc.dirty) {
    sc.edge_masks.resize(width, height, 0);
    sc.pos.resize(width, height, 0);
  }
  sc.dirty = true;  // until the planes are all-zero again
  const std::ptrdiff_t stride = sc.edge_masks.stride();
  if (sc.pos.stride() != stride) {
    throw std::logic_error("PolygonExtractor: plane strides differ");
  }
  std::uint16_t* edge_masks = sc.edge_masks.row(0);
  const auto find_boundary = [&](int v_begin, int v_end, std::vector<std::int32_t>& starts,
                                 polygons_detail::BoundaryMaskScratch& masks) {
    polygons_detail::find_boundary_vertices(segmentation.labels.view(), mesh.faces.view(), s,
                                            sc.enabled.data(), n_labels, edge_masks, stride,
                                            v_begin, v_end, starts, masks);
  };
  const auto bands = static_cast<std::size_t>(pool != nullptr ? pool->threads() : 1);
  if (sc.band_masks.size() < bands) {
    sc.band_starts.resize(bands);
    sc.band_masks.resize(bands);
  }
  if (pool == nullptr) {
    find_boundary(0, height, sc.starts, sc.band_masks[0]);
  } else {
    pool->for_each_band(height, s, [&](int band, int v_begin, int v_end) {
      const auto b = static_cast<std::size_t>(band);
      find_boundary(v_begin, v_end, sc.band_starts[b], sc.band_masks[b]);
    });
    sc.starts.clear();
    for (std::size_t b = 0; b < bands; ++b) {
      detail::append_with_headroom(sc.starts, sc.band_starts[b].begin(), sc.band_starts[b].end());
    }
  }

  // --- loops ---
  const std::int32_t row_len = static_cast<std::int32_t>(stride);
  const double inv_row_len = 1.0 / static_cast<double>(row_len);
  sc.raw.clear();
  sc.raw_idx.clear();
  sc.raw_uv.clear();
  polygons_detail::trace_loops(
      edge_masks, sc.pos.row(0), stride, s, sc.starts, sc.trace_steps, sc.walk, sc.stack,
      [&](const std::int32_t* idx, int n) {
        const std::size_t first = sc.raw_uv.size();
        detail::resize_with_headroom(sc.raw_uv, first + static_cast<std::size_t>(n));
        sc.raw_idx.insert(sc.raw_idx.end(), idx, idx + n);
        std::array<std::int32_t, 2>* uv = sc.raw_uv.data() + first;
        // One pass: pixel coordinates, bounding box and the shoelace sum (image, y down:
        // counter-clockwise on the image is negative there). v = idx / stride, from
        // (idx + 0.5) / stride, which is at least 0.5 / stride away from an integer, far above
        // the rounding of the product.
        const auto to_uv = [&](std::int32_t i) -> std::array<std::int32_t, 2> {
          const auto v = static_cast<std::int32_t>((static_cast<double>(i) + 0.5) * inv_row_len);
          return {i - v * row_len, v};
        };
        const std::array<std::int32_t, 2> last = to_uv(idx[n - 1]);
        std::int32_t pu = last[0], pv = last[1];
        int u_min = width, u_max = -1, v_min = height, v_max = -1;
        std::int64_t twice = 0;
        for (int i = 0; i < n; ++i) {
          const auto [u, v] = to_uv(idx[i]);
          uv[i] = {u, v};
          u_min = std::min(u_min, u);
          u_max = std::max(u_max, u);
          v_min = std::min(v_min, v);
          v_max = std::max(v_max, v);
          twice += static_cast<std::int64_t>(pu) * v - static_cast<std::int64_t>(u) * pv;
          pu = u;
          pv = v;
        }
        const int label = segmentation.labels.row(uv[0][1])[uv[0][0]];
        sc.raw.push_back({label, static_cast<int>(first), n, -0.5 * static_cast<double>(twice),
                          sc.seg_of_label[static_cast<std::size_t>(label)], -1, u_min, u_max, v_min,
                          v_max});
      });
  for (std::int32_t p : sc.starts) edge_masks[p] = 0;
  sc.dirty = false;

  // --- group raw loops by segment (counting sort keeps the tracing order) ---
  const std::size_t n_segs = out.segments.size();
  detail::resize_with_headroom(sc.outer_rank, sc.raw.size());
  detail::assign_with_headroom(sc.bucket_start, n_segs + 1, 0);
  for (const RawLoop& r : sc.raw) ++sc.bucket_start[static_cast<std::size_t>(r.seg) + 1];
  for (std::size_t i = 0; i < n_segs; ++i) sc.bucket_start[i + 1] += sc.bucket_start[i];
  detail::resize_with_headroom(sc.bucket_loops, sc.raw.size());
  {
    sc.fill.assign(sc.bucket_start.begin(), sc.bucket_start.end() - 1);
    for (std::size_t i = 0; i < sc.raw.size(); ++i) {
      sc.bucket_loops[static_cast<std::size_t>(
          sc.fill[static_cast<std::size_t>(sc.raw[i].seg)]++)] = static_cast<int>(i);
    }
  }

  // Workers take consecutive segments with about equal numbers of loop vertices, which the
  // work after the tracing is about proportional to.
  const Vec vp{settings.viewpoint[0], settings.viewpoint[1], settings.viewpoint[2]};
  const std::size_t workers =
      pool != nullptr && n_segs > 1 ? static_cast<std::size_t>(pool->threads()) : 1;
  if (sc.work.size() < workers) sc.work.resize(workers);
  sc.group_first.assign(workers + 1, n_segs);
  sc.group_first[0] = 0;
  std::size_t vertices = 0, g = 1;
  for (std::size_t si = 0; si < n_segs && g < workers; ++si) {
    for (int b = sc.bucket_start[si]; b < sc.bucket_start[si + 1]; ++b) {
      vertices +=
          static_cast<std::size_t>(sc.raw[static_cast<std::size_t>(sc.bucket_loops[b])].count);
    }
    while (g < workers && vertices * workers >= sc.raw_idx.size() * g) sc.group_first[g++] = si + 1;
  }
  const auto outline_group = [&](std::size_t group) {
    PolygonSet& dst = group == 0 ? out : sc.work[group].part;
    if (group > 0) dst.clear();
    for (std::size_t si = sc.group_first[group]; si < sc.group_first[group + 1]; ++si) {
      outline_segment(cloud, segmentation, settings, vp, sc, sc.work[group], si, out.segments, dst);
    }
  };
  if (workers == 1) {
    outline_group(0);
    return;
  }
  pool->for_each_band(static_cast<int>(workers), 1, [&](int, int group_begin, int group_end) {
    for (int group = group_begin; group < group_end; ++group) {
      outline_group(static_cast<std::size_t>(group));
    }
  });
  for (std::size_t group = 1; group < workers; ++group) {
    append_part(sc.work[group].part, sc.group_first[group], sc.group_first[group + 1], out);
  }
}

PolygonSet extract_polygons(const OrganizedCloud& cloud, const Mesh& mesh,
                            const Segmentation& segmentation, const PolygonSettings& settings) {
  PolygonExtractor extractor;
  PolygonSet out;
  extractor.extract(cloud, mesh, segmentation, settings, out);
  return out;
}

void validate(const PolygonSettings& settings) {
  // Runs every frame: a message is made only on failure (no allocation otherwise).
  constexpr std::string_view owner = "PolygonSettings";
  const auto finite_nonnegative = [&](double value, std::string_view field) {
    if (!std::isfinite(value) || !(value >= 0)) {
      detail::throw_bad_setting(owner, field, value, "finite and >= 0");
    }
  };
  finite_nonnegative(settings.simplify_tolerance, "simplify_tolerance");
  finite_nonnegative(settings.simplify_tolerance_pixels, "simplify_tolerance_pixels");
  finite_nonnegative(settings.simplify_inradius_fraction, "simplify_inradius_fraction");
  finite_nonnegative(settings.min_loop_pixels, "min_loop_pixels");
  if (settings.min_segment_pixels < 0) {
    detail::throw_bad_setting(owner, "min_segment_pixels", settings.min_segment_pixels, ">= 0");
  }
  for (std::size_t k = 0; k < 3; ++k) {
    if (!std::isfinite(settings.viewpoint[k])) {
      detail::throw_bad_setting(owner, "viewpoint[" + std::to_string(k) + "]",
                                settings.viewpoint[k], "finite [m]");
    }
  }
}

void loop_pixels(const PolygonSet& polygons, int loop, std::vector<std::array<float, 2>>& out) {
  if (loop < 0 || static_cast<std::size_t>(loop) >= polygons.loops.size()) {
    throw std::invalid_argument("loop_pixels: loop " + std::to_string(loop) + " out of range [0, " +
                                std::to_string(polygons.loops.size()) + ")");
  }
  const PolygonLoop& lp = polygons.loops[static_cast<std::size_t>(loop)];
  if (polygons.pixels.size() < static_cast<std::size_t>(lp.first) + lp.count) {
    out.clear();  // no image (an unorganized cloud)
    return;
  }
  out.assign(polygons.pixels.begin() + lp.first, polygons.pixels.begin() + lp.first + lp.count);
}

void hull_pixels(const PolygonSet& polygons, int segment, std::vector<std::array<float, 2>>& out) {
  if (segment < 0 || static_cast<std::size_t>(segment) >= polygons.segments.size()) {
    throw std::invalid_argument("hull_pixels: segment " + std::to_string(segment) +
                                " out of range [0, " + std::to_string(polygons.segments.size()) +
                                ")");
  }
  const SegmentPolygons& sp = polygons.segments[static_cast<std::size_t>(segment)];
  if (polygons.hull_pixels.size() < static_cast<std::size_t>(sp.hull_first) + sp.hull_count) {
    out.clear();  // no image (an unorganized cloud)
    return;
  }
  out.assign(polygons.hull_pixels.begin() + sp.hull_first,
             polygons.hull_pixels.begin() + sp.hull_first + sp.hull_count);
}

}  // namespace rangeseg
