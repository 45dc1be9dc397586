// Shared internals of the plane polygons: loop tracing on a grid of directed boundary edges,
// closed-loop simplification, simplicity checks and 2D hulls.
#pragma once

#include <array>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "rangeseg/mesh.hpp"

namespace rangeseg::polygons_detail {

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

/// Traces the closed loops of directed boundary edges. `edges` holds per vertex (index
/// v * stride + u) the mask of outgoing boundary edges (kNeighbourDu/Dv directions, lattice step
/// s) in its low byte and the edges not traced yet in its high byte: both equal on entry, the
/// high byte zero on return (orig and remaining share a cache line). `pos` must be all zero on
/// entry and is all zero on return. `starts` lists every vertex with a non-zero mask, in any
/// deterministic order. Each cycle of the wedge pairing is cut at repeated vertices into simple
/// loops; `emit(const int32_t* idx, int n)` receives each loop (n >= 3 vertex indices, region
/// on the left).
template <class Emit>
void trace_loops(std::uint16_t* edges, std::int32_t* pos, std::ptrdiff_t stride, int s,
                 const std::vector<std::int32_t>& starts, std::vector<std::int32_t>& walk,
                 std::vector<std::int32_t>& stack, Emit&& emit) {
  std::array<std::ptrdiff_t, 8> offset{};
  for (int k = 0; k < 8; ++k) offset[k] = s * (kNeighbourDv[k] * stride + kNeighbourDu[k]);
  const auto rem = [edges](std::int32_t p) -> unsigned { return edges[p] >> 8; };
  const std::size_t max_walk = starts.size() * 8 + 8;
  // Only a vertex with several outgoing edges can recur in a walk; walk entries of such
  // vertices carry this flag, and only they use `pos` (a mostly cold full-image plane).
  constexpr std::int32_t kTracked = std::numeric_limits<std::int32_t>::min();
  constexpr std::int32_t kIndex = std::numeric_limits<std::int32_t>::max();
  for (std::int32_t p : starts) {
    while (rem(p) != 0) {
      const int k0 = __builtin_ctz(rem(p));
      walk.clear();
      std::int32_t cur = p;
      unsigned mask = edges[p] & 0xFFu;
      bool several = false;
      int k = k0;
      bool ok = true;
      do {
        if (k == 255 || !(rem(cur) & (1u << k)) || walk.size() > max_walk) {
          ok = false;  // inconsistent boundary (cannot happen for faces on a grid); drop
          break;
        }
        const bool branches = (mask & (mask - 1)) != 0;
        several |= branches;
        walk.push_back(branches ? (cur | kTracked) : cur);
        edges[cur] = static_cast<std::uint16_t>(edges[cur] & ~(0x100u << k));
        const std::int32_t q = static_cast<std::int32_t>(cur + offset[k]);
        mask = edges[q] & 0xFFu;
        k = kNextDir.next[mask][k];
        cur = q;
      } while (!(cur == p && k == k0));
      if (!ok) continue;
      const std::size_t n = walk.size();
      if (!several) {  // no vertex recurs: one simple loop
        if (n >= 3) emit(walk.data(), static_cast<int>(n));
        continue;
      }
      // Cut the cyclic walk at repeated vertices into simple loops.
      walk[0] |= kTracked;  // the walk's end is checked against its start
      stack.clear();
      for (std::size_t i = 0; i <= n; ++i) {
        const std::int32_t w = walk[i < n ? i : 0];
        if (w >= 0) {
          stack.push_back(w);
          continue;
        }
        const std::int32_t v = w & kIndex;
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
        stack.push_back(w);
        pos[v] = static_cast<std::int32_t>(stack.size());
      }
      for (std::int32_t w : stack) {  // only after an inconsistent walk
        if (w < 0) pos[w & kIndex] = 0;
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
/// their indices into `starts`, in increasing index order. Pixel_stride 1 runs a vector kernel
/// when the CPU has AVX2 (and detail::simd::isa_limit allows it) and labels fit in 16 bits;
/// results are identical to the scalar path.
void find_boundary_vertices(View<const std::int32_t> labels, View<const std::uint8_t> faces, int s,
                            const std::uint8_t* enabled, std::size_t n_labels, std::uint16_t* edges,
                            std::ptrdiff_t stride, std::vector<std::int32_t>& starts,
                            BoundaryMaskScratch& scratch);

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
/// Marks in `bad` (indexed by CheckEdge::loop, sized by the caller) every loop one of whose
/// edges crosses or touches another edge (of any loop) not sharing an end id. Sorts `edges`.
/// Returns whether any was found.
bool mark_crossings(std::vector<CheckEdge>& edges, std::vector<std::uint8_t>& bad);

/// Signed area (counter-clockwise positive) and perimeter of a closed 2D loop.
void area_perimeter(const double* xy, int n, double& area, double& perimeter);

/// The points xy[0..n) (x, y interleaved) that may be convex hull vertices, into `out` in
/// increasing order: all but those strictly inside the polygon of the extreme points in 8
/// directions (Akl-Toussaint), which are interior to the hull by a margin far above rounding, so
/// the hull is unchanged. Boundary loops have most of their vertices inside, and the sort before
/// the hull is the costly part. Uses AVX2 when available (identical results).
void hull_candidates(const double* xy, int n, std::vector<int>& out);

/// Andrew's monotone chain on points sorted by (x, y) ascending: writes hull indices,
/// counter-clockwise, into `hull`. Points with equal coordinates may repeat.
void monotone_chain_sorted(const double* xy, int n, std::vector<int>& hull);

}  // namespace rangeseg::polygons_detail
