// Shared internals of the plane polygons: loop tracing on a grid of directed boundary edges,
// closed-loop simplification, simplicity checks and 2D hulls.
#pragma once

#include <array>
#include <cassert>
#include <cstddef>
#include <cstdint>
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

/// Traces the closed loops of directed boundary edges. `orig` holds per vertex (index
/// v * stride + u) the mask of outgoing boundary edges (kNeighbourDu/Dv directions, lattice step
/// s); `rem` and `pos` must be all zero on entry and are all zero on return. `starts` lists
/// every vertex with a non-zero mask, in any deterministic order. Each cycle of the
/// wedge pairing is cut at repeated vertices into simple loops; `emit(const int32_t* idx, int n)`
/// receives each loop (n >= 3 vertex indices, region on the left).
template <class Emit>
void trace_loops(const std::uint8_t* orig, std::uint8_t* rem, std::int32_t* pos,
                 std::ptrdiff_t stride, int s, const std::vector<std::int32_t>& starts,
                 std::vector<std::int32_t>& walk, std::vector<std::int32_t>& stack, Emit&& emit) {
  std::array<std::ptrdiff_t, 8> offset{};
  for (int k = 0; k < 8; ++k) offset[k] = s * (kNeighbourDv[k] * stride + kNeighbourDu[k]);
  for (std::int32_t p : starts) rem[p] = orig[p];
  const std::size_t max_walk = starts.size() * 8 + 8;
  for (std::int32_t p : starts) {
    while (rem[p] != 0) {
      const int k0 = __builtin_ctz(rem[p]);
      walk.clear();
      std::int32_t cur = p;
      int k = k0;
      bool ok = true;
      do {
        if (k == 255 || !(rem[cur] & (1u << k)) || walk.size() > max_walk) {
          ok = false;  // inconsistent boundary (cannot happen for faces on a grid); drop
          break;
        }
        walk.push_back(cur);
        rem[cur] = static_cast<std::uint8_t>(rem[cur] & ~(1u << k));
        const std::int32_t q = static_cast<std::int32_t>(cur + offset[k]);
        k = kNextDir.next[orig[q]][k];
        cur = q;
      } while (!(cur == p && k == k0));
      if (!ok) continue;
      // Cut the cyclic walk at repeated vertices into simple loops.
      stack.clear();
      const std::size_t n = walk.size();
      for (std::size_t i = 0; i <= n; ++i) {
        const std::int32_t v = walk[i < n ? i : 0];
        if (pos[v] != 0) {
          const std::size_t j = static_cast<std::size_t>(pos[v] - 1);
          if (stack.size() - j >= 3) emit(stack.data() + j, static_cast<int>(stack.size() - j));
          for (std::size_t t = j; t < stack.size(); ++t) pos[stack[t]] = 0;
          stack.resize(j);
          if (i == n) break;
        }
        stack.push_back(v);
        pos[v] = static_cast<std::int32_t>(stack.size());
      }
      for (std::int32_t v : stack) pos[v] = 0;  // only after an inconsistent walk
    }
  }
}

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

/// Andrew's monotone chain on points sorted by (x, y) ascending: writes hull indices,
/// counter-clockwise, into `hull`. Points with equal coordinates may repeat.
void monotone_chain_sorted(const double* xy, int n, std::vector<int>& hull);

}  // namespace rangeseg::polygons_detail
