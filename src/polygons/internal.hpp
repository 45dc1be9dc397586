// Shared internals of the plane polygons: loop tracing on a grid of directed boundary edges,
// closed-loop simplification, simplicity checks and 2D hulls.
#pragma once

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "rangeseg/mesh.hpp"
#include "rangeseg/polygons.hpp"
#include "rangeseg/segmentation.hpp"

namespace rangeseg::polygons_detail {

/// Gives two buffers that trade places (std::swap) the larger capacity of the two. Which one
/// ends a frame in which role depends on how often they traded, which differs from frame to
/// frame: unless both can take the largest set seen, a later frame allocates.
template <class T>
void share_capacity(std::vector<T>& a, std::vector<T>& b) {
  const std::size_t capacity = std::max(a.capacity(), b.capacity());
  a.reserve(capacity);
  b.reserve(capacity);
}

using Vec = std::array<double, 3>;
inline double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/// The plane frame of a segment (polygons.hpp, PlaneFrame): its plane, origin at the point of
/// the plane closest to its centroid.
PlaneFrame plane_frame(const Segment& segment);

/// The projection of points onto a segment's plane (see polygons.hpp): along the viewing ray
/// from `vp` when it meets the plane's front side, else orthogonally; then the plane frame.
struct Projection {
  PlaneFrame fr;
  Vec vp;
  double nvp;  ///< signed distance of the viewpoint from the plane
};

inline Projection make_projection(const PlaneFrame& fr, const Vec& vp) {
  return {fr, vp, dot(fr.normal, vp) + fr.offset};
}

/// Boundary points move onto their plane along their viewing ray (their noise lies along it)
/// unless the ray meets the plane at less than this sine (1 deg): the move along the ray is
/// 1 / sine times their distance from the plane, and a plane through the viewpoint (seen
/// edge-on) would collapse onto it. Those go perpendicular to the plane.
inline constexpr double kMinRaySine = 0.0175;

/// Plane coordinates (x, y) of camera-frame point p under `pr`.
inline void project_point(const Projection& pr, const Vec& p, double* xy) {
  const PlaneFrame& fr = pr.fr;
  const Vec& vp = pr.vp;
  const Vec dir{p[0] - vp[0], p[1] - vp[1], p[2] - vp[2]};
  const double denom = dot(fr.normal, dir);
  // Along the ray when it meets the plane's front side at more than kMinRaySine (nvp > 0,
  // denom < -kMinRaySine |dir|); the square root is needed only near that limit: denom^2 >
  // 2 kMinRaySine^2 |dir|^2 already implies it with a margin of sqrt(2) over the rounding of
  // either side.
  bool ray = false;
  if (pr.nvp > 0 && denom < 0) {
    const double dir2 = dot(dir, dir);
    ray = denom * denom > 2 * kMinRaySine * kMinRaySine * dir2 ||
          denom < -kMinRaySine * std::sqrt(dir2);
  }
  Vec q;
  if (ray) {
    const double t = -pr.nvp / denom;
    q = {vp[0] + t * dir[0], vp[1] + t * dir[1], vp[2] + t * dir[2]};
  } else {
    const double dist = dot(fr.normal, p) + fr.offset;
    q = {p[0] - dist * fr.normal[0], p[1] - dist * fr.normal[1], p[2] - dist * fr.normal[2]};
  }
  const Vec rel{q[0] - fr.origin[0], q[1] - fr.origin[1], q[2] - fr.origin[2]};
  xy[0] = dot(rel, fr.e1);
  xy[1] = dot(rel, fr.e2);
}

/// Point i of x, y interleaved coordinates: xy + 2 i, with the offset computed in
/// std::ptrdiff_t (an int product would overflow first).
inline const double* xy_point(const double* xy, std::ptrdiff_t i) { return xy + 2 * i; }
inline double* xy_point(double* xy, std::ptrdiff_t i) { return xy + 2 * i; }

/// kNextDir[mask][k_in]: the outgoing boundary edge at a vertex with outgoing-edge mask `mask`
/// after arriving along direction k_in: the first edge met rotating clockwise on the image
/// (increasing k) from the reversed incoming direction, i.e. the edge bounding the same wedge
/// of the region (region on the left of each directed edge). 255: none.
struct NextDirTable {
  std::array<std::array<std::uint8_t, 8>, 256> next{};
  constexpr NextDirTable() {
    for (int m = 0; m < 256; ++m) {
      for (int k = 0; k < 8; ++k) {
        std::uint8_t out = 255;
        const int r = (k + 4) & 7;
        for (int j = 1; j <= 8; ++j) {
          const int d = (r + j) & 7;
          if (m & (1 << d)) {
            out = static_cast<std::uint8_t>(d);
            break;
          }
        }
        next[m][k] = out;
      }
    }
  }
};
inline constexpr NextDirTable kNextDir{};

/// kNextDir combined with the lattice: entry[mask * 8 + k_in] = offset * 16 + k_out, where
/// k_out = kNextDir.next[mask][k_in] and offset is the index step along k_out (k_out = 8 and
/// offset 0 for none). One load per step of a walk instead of a direction and then an offset:
/// the walk is a chain of dependent loads, so its latency is the cost.
struct TraceSteps {
  std::array<std::int32_t, std::size_t{256} * 8> entry{};
  std::array<std::ptrdiff_t, 8> offset{};
  std::ptrdiff_t stride = -1;
  int s = -1;
  /// Rebuilds the table when the lattice (row stride, step s) differs from the last call.
  void prepare(std::ptrdiff_t new_stride, int new_s) {
    if (new_stride == stride && new_s == s) return;
    stride = new_stride;
    s = new_s;
    for (int k = 0; k < 8; ++k) offset[k] = s * (kNeighbourDv[k] * stride + kNeighbourDu[k]);
    for (int m = 0; m < 256; ++m) {
      for (int k = 0; k < 8; ++k) {
        const int d = kNextDir.next[m][k];
        entry[m * 8 + k] = d == 255 ? 8 : static_cast<std::int32_t>(offset[d] * 16 + d);
      }
    }
  }
};

/// Traces the closed loops of directed boundary edges. `edges` holds per vertex (index
/// v * stride + u) the mask of outgoing boundary edges (kNeighbourDu/Dv directions, lattice step
/// s) in its low byte and the edges not traced yet in its high byte: both equal on entry, the
/// high byte zero on return (orig and remaining share a cache line). `pos` must be all zero on
/// entry and is all zero on return. `starts` lists every vertex with a non-zero mask, in any
/// deterministic order. Each cycle of the wedge pairing is cut at repeated vertices into simple
/// loops; `emit(const int32_t* idx, int n)` receives each loop (n >= 3 vertex indices, region
/// on the left). `steps` is prepared here for (stride, s) (kept between calls).
template <class Emit>
void trace_loops(std::uint16_t* edges, std::int32_t* pos, std::ptrdiff_t stride, int s,
                 const std::vector<std::int32_t>& starts, TraceSteps& steps,
                 std::vector<std::int32_t>& walk, std::vector<std::int32_t>& stack, Emit&& emit) {
  steps.prepare(stride, s);
  const std::int32_t* entry = steps.entry.data();
  // A walk uses each directed edge at most once; its buffer is sized once (it only grows) and
  // written through a pointer.
  const std::size_t max_walk = starts.size() * 8 + 8;
  if (walk.size() < max_walk + 1) walk.resize(max_walk + 1);
  std::int32_t* const w = walk.data();
  // Only a vertex with several outgoing edges can recur in a walk; walk entries of such
  // vertices carry this flag, and only they use `pos` (a mostly cold full-image plane).
  constexpr std::int32_t kTracked = std::numeric_limits<std::int32_t>::min();
  constexpr std::int32_t kIndex = std::numeric_limits<std::int32_t>::max();
  for (std::int32_t p : starts) {
    while ((edges[p] >> 8) != 0) {
      // e: the current entry of `cur` (loaded when the walk arrived there; a walk never steps
      // in place, so nothing wrote it since), k: the edge leaving cur, off: its index step.
      unsigned e = edges[p];
      const int k0 = __builtin_ctz(e >> 8);
      int k = k0;
      std::ptrdiff_t off = steps.offset[k0];
      std::int32_t cur = p;
      std::size_t n = 0;
      bool several = false;
      bool ok = true;
      do {
        if (k > 7 || !((e >> 8) & (1u << k)) || n > max_walk) {
          ok = false;  // inconsistent boundary (cannot happen for faces on a grid); drop
          break;
        }
        const unsigned mask = e & 0xFFu;
        const bool branches = (mask & (mask - 1)) != 0;
        several |= branches;
        w[n++] = branches ? (cur | kTracked) : cur;
        edges[cur] = static_cast<std::uint16_t>(e & ~(0x100u << k));
        const std::int32_t q = static_cast<std::int32_t>(cur + off);
        e = edges[q];
        const std::int32_t step = entry[(e & 0xFFu) * 8 + static_cast<unsigned>(k)];
        k = step & 15;
        off = step >> 4;
        cur = q;
      } while (!(cur == p && k == k0));
      if (!ok) continue;
      if (!several) {  // no vertex recurs: one simple loop
        if (n >= 3) emit(w, static_cast<int>(n));
        continue;
      }
      // Cut the cyclic walk at repeated vertices into simple loops.
      w[0] |= kTracked;  // the walk's end is checked against its start
      stack.clear();
      for (std::size_t i = 0; i <= n; ++i) {
        const std::int32_t wi = w[i < n ? i : 0];
        if (wi >= 0) {
          stack.push_back(wi);
          continue;
        }
        const std::int32_t v = wi & kIndex;
        if (pos[v] != 0) {
          const std::size_t j = static_cast<std::size_t>(pos[v] - 1);
          for (std::size_t t = j; t < stack.size(); ++t) {
            if (stack[t] >= 0) continue;
            stack[t] &= kIndex;
            pos[stack[t]] = 0;
          }
          if (stack.size() - j >= 3) emit(stack.data() + j, static_cast<int>(stack.size() - j));
          stack.resize(j);
          if (i == n) break;
        }
        stack.push_back(wi);
        pos[v] = static_cast<std::int32_t>(stack.size());
      }
      for (std::int32_t wi : stack) {  // only after an inconsistent walk
        if (wi < 0) pos[wi & kIndex] = 0;
      }
    }
  }
}

/// Buffers of find_boundary_vertices, reused frame after frame.
struct BoundaryMaskScratch {
  std::vector<std::uint8_t> sides;      ///< two rows of per-cell coverage bits (with padding)
  std::vector<std::uint16_t> labels16;  ///< two label rows, 0 where not enabled (vector path)
  std::vector<std::int32_t> label_map;  ///< label -> label if enabled, else 0 (vector path)
};

/// The outgoing boundary-edge mask (kNeighbourDu/Dv directions, region on the left) of every
/// lattice vertex of the faces of enabled segments: a face belongs to segment L when all its
/// corners carry label L, and L is enabled when L < n_labels and enabled[L] != 0. Writes the
/// non-zero masks m as m * 257 (trace_loops' mask and remaining bytes) into `edges` (index
/// v * stride + u; all zero on entry, untouched elsewhere) and
/// their indices into `starts`, in increasing index order, for the vertex rows [v_begin, v_end)
/// (v_begin a multiple of s): row bands can run concurrently, each with its own `starts` and
/// scratch. Pixel_stride 1 runs a vector kernel when the CPU has AVX2 (and
/// detail::simd::isa_limit allows it) and labels fit in 16 bits; results are identical to the
/// scalar path.
void find_boundary_vertices(View<const std::int32_t> labels, View<const std::uint8_t> faces, int s,
                            const std::uint8_t* enabled, std::size_t n_labels, std::uint16_t* edges,
                            std::ptrdiff_t stride, int v_begin, int v_end,
                            std::vector<std::int32_t>& starts, BoundaryMaskScratch& scratch);

/// Douglas-Peucker on the closed loop xy[0..n) (x, y interleaved): appends the indices of the
/// kept vertices, in loop order, to `keep` (at least 3 when n >= 3). `stack` is scratch.
void simplify_closed(const double* xy, int n, double tolerance, std::vector<int>& keep,
                     std::vector<std::array<int, 2>>& stack);

/// An edge of a loop for the simplicity check: end points and the ids of the mesh vertices at
/// its ends (edges sharing an id touch legitimately, e.g. at a pinch vertex).
struct CheckEdge {
  double x0, y0, x1, y1;
  std::int64_t id0, id1;
  int loop;
};
/// Buffers of mark_crossings, reused call after call: the sort of the edges by x0, and the
/// buckets of a uniform grid over the edges' boxes (each widened by its margin).
struct CrossingScratch {
  std::vector<std::int32_t> order, order_tmp;
  std::vector<std::uint64_t> keys, keys_tmp;
  std::vector<CheckEdge> sorted;
  std::vector<std::int32_t> cells;  ///< per edge: first cell x, last x, first y, last y
  std::vector<std::int32_t> start;  ///< per grid cell: first entry in `items`, then one past
  std::vector<std::int32_t> items;  ///< edge indices grouped by cell, ascending in each
};
/// Marks in `bad` (indexed by CheckEdge::loop, sized by the caller) every loop one of whose
/// edges crosses or touches another edge (of any loop) not sharing an end id. Sorts `edges`.
/// Returns whether any was found. Given `changed` (per loop), only pairs with an edge of a
/// changed loop are tested: the others were, in an earlier check of the same loops.
/// Large sets are bucketed on a grid over the edges' boxes (the same pairs, each tested once).
bool mark_crossings(std::vector<CheckEdge>& edges, std::vector<std::uint8_t>& bad,
                    CrossingScratch& scratch, const std::uint8_t* changed = nullptr);
/// The same by a sweep in x alone (the reference; quadratic under long edges).
bool mark_crossings_sweep(std::vector<CheckEdge>& edges, std::vector<std::uint8_t>& bad,
                          CrossingScratch& scratch, const std::uint8_t* changed = nullptr);

/// Signed area (counter-clockwise positive) and perimeter of a closed 2D loop.
void area_perimeter(const double* xy, int n, double& area, double& perimeter);

/// The points xy[0..n) (x, y interleaved) that may be convex hull vertices, into `out` in
/// increasing order: all but those strictly inside the polygon of the extreme points in 8
/// directions (Akl-Toussaint), which are interior to the hull by a margin far above rounding, so
/// the hull is unchanged. Boundary loops have most of their vertices inside, and the sort before
/// the hull is the costly part. Uses AVX2 when available (identical results).
void hull_candidates(const double* xy, int n, std::vector<int>& out);

/// Buffers of sort_points_xy, reused.
struct PointSortScratch {
  std::vector<std::uint64_t> keys, keys_tmp;
  std::vector<int> order_tmp;
};
/// Sorts `order` (indices into xy, x and y interleaved; no NaN) by (x, y, index), a total order,
/// so the result is the one of any correct sort. Comparison sorts mispredict about every other
/// comparison on such keys; large sets take an LSD radix sort on the bits of x (11-bit digits on
/// which all keys agree are skipped, detail::radix_sort_by_key), then each run of equal x (rare)
/// is sorted by (y, index).
void sort_points_xy(const double* xy, std::vector<int>& order, PointSortScratch& scratch);

/// Andrew's monotone chain on points sorted by (x, y) ascending: writes hull indices,
/// counter-clockwise, into `hull`. Points with equal coordinates may repeat.
void monotone_chain_sorted(const double* xy, int n, std::vector<int>& hull);

/// The outline of a raster of occupied square cells: cell (i, j) of `cols` x `rows`, row-major in
/// `occ`, covers [x0 + i h, x0 + (i + 1) h) x [y0 + j h, y0 + (j + 1) h). The raster is first
/// closed with a 3x3 square (bridging gaps of one cell); the two outermost rows and columns must
/// be empty. The boundary loops of the occupied cells are traced and simplified (Douglas-Peucker
/// at `tolerance`, halved for loops that then cross or touch another, unsimplified after a few
/// halvings). `loops` gets them with outer loops counter-clockwise (y up) and holes clockwise;
/// per loop also the unsimplified area (unsigned), perimeter and vertex count and the tolerance
/// used.
struct RasterOutline {
  Polygons2D loops;
  std::vector<double> raw_area, raw_perimeter, tolerance;
  std::vector<int> raw_count;
  // Buffers reused call after call (`mask` and `pos` are all zero between calls).
  std::vector<std::uint8_t> tmp;
  std::vector<std::uint16_t> mask;
  std::vector<std::int32_t> pos, starts, walk, stack;
  std::vector<double> xy;
  std::vector<int> loop_first, keep, keep_first;
  std::vector<std::array<int, 2>> dp_stack;
  std::vector<CheckEdge> edges;
  std::vector<std::uint8_t> bad;
  CrossingScratch crossing;
  TraceSteps steps;
};
void outline_raster(std::vector<std::uint8_t>& occ, int cols, int rows, double x0, double y0,
                    double h, double tolerance, RasterOutline& out);

}  // namespace rangeseg::polygons_detail
