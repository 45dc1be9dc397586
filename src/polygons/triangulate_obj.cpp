// Triangulation of polygons with holes (hole bridging + ear clipping) and the OBJ writer.
//
// Polygons are the simplified loops: mostly tens of vertices, but a surface seen through much
// clutter can have thousands of holes, so neither step may scan the whole polygon per vertex.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rangeseg/io/file.hpp"
#include "rangeseg/polygons.hpp"

namespace rangeseg {
namespace {

// Double: vertices where loops touch are moved by a thousandth of an edge.
using P2 = std::array<double, 2>;

double orient(const P2& a, const P2& b, const P2& c) {
  return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

// Proper crossing or touching of segments a-b and c-d, ignoring shared end points.
bool segments_cross(const P2& a, const P2& b, const P2& c, const P2& d) {
  if (a == c || a == d || b == c || b == d) return false;
  const double o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a),
               o4 = orient(c, d, b);
  if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0))) {
    return true;
  }
  const auto on = [](const P2& p, const P2& q, const P2& r) {
    return std::min(p[0], q[0]) <= r[0] && r[0] <= std::max(p[0], q[0]) &&
           std::min(p[1], q[1]) <= r[1] && r[1] <= std::max(p[1], q[1]);
  };
  return (o1 == 0 && on(a, b, c)) || (o2 == 0 && on(a, b, d)) || (o3 == 0 && on(c, d, a)) ||
         (o4 == 0 && on(c, d, b));
}

// Whether direction p -> m leaves vertex poly[j] into the polygon's interior (CCW polygon).
bool in_wedge(const std::vector<int>& poly, std::size_t j, const std::vector<P2>& pts,
              const P2& m) {
  const std::size_t n = poly.size();
  const P2& prev = pts[static_cast<std::size_t>(poly[(j + n - 1) % n])];
  const P2& p = pts[static_cast<std::size_t>(poly[j])];
  const P2& next = pts[static_cast<std::size_t>(poly[(j + 1) % n])];
  const bool left_prev = orient(prev, p, m) > 0, left_next = orient(p, next, m) > 0;
  return orient(prev, p, next) >= 0 ? (left_prev && left_next) : (left_prev || left_next);
}

/// Items bucketed by a uniform grid over their points' bounding box, with about one item per
/// cell; an item is in every cell its own bounding box overlaps. Built from
/// for_each_box(fn(lo, hi, item)), which must visit the items in the same order each call.
class BucketGrid {
 public:
  template <class ForEachBox>
  BucketGrid(std::size_t items, ForEachBox&& for_each_box) {
    bool first = true;
    for_each_box([&](const P2& lo, const P2& hi, std::size_t) {
      for (int k = 0; k < 2; ++k) {
        lo_[k] = first ? lo[k] : std::min(lo_[k], lo[k]);
        hi_[k] = first ? hi[k] : std::max(hi_[k], hi[k]);
      }
      first = false;
    });
    const double w = std::max(hi_[0] - lo_[0], 1e-12);
    const double h = std::max(hi_[1] - lo_[1], 1e-12);
    const double cell =
        std::sqrt(w * h / static_cast<double>(std::max<std::size_t>(items, 1))) + 1e-12;
    cols_ = static_cast<int>(std::clamp(std::ceil(w / cell), 1.0, 4096.0));
    rows_ = static_cast<int>(std::clamp(std::ceil(h / cell), 1.0, 4096.0));
    sx_ = cols_ / w;
    sy_ = rows_ / h;
    start_.assign(static_cast<std::size_t>(cols_) * rows_ + 1, 0);
    for_each_box([&](const P2& lo, const P2& hi, std::size_t) {
      for_each_cell(lo, hi, [&](std::size_t c) { ++start_[c + 1]; });
    });
    for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    items_.resize(start_.back());
    std::vector<std::size_t> fill(start_.begin(), start_.end() - 1);
    for_each_box([&](const P2& lo, const P2& hi, std::size_t item) {
      for_each_cell(lo, hi, [&](std::size_t c) { items_[fill[c]++] = item; });
    });
  }

  /// Calls fn(item) for every item in a cell the box [lo, hi] overlaps (an item may come more
  /// than once), until fn returns false; returns whether it never did.
  template <class F>
  bool all_in_box(const P2& lo, const P2& hi, F&& fn) const {
    const int c0 = column(lo[0]), c1 = column(hi[0]), r0 = row(lo[1]), r1 = row(hi[1]);
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) {
        const std::size_t cell = static_cast<std::size_t>(r) * cols_ + c;
        for (std::size_t k = start_[cell]; k < start_[cell + 1]; ++k) {
          if (!fn(items_[k])) return false;
        }
      }
    }
    return true;
  }

 private:
  template <class F>
  void for_each_cell(const P2& lo, const P2& hi, F&& fn) const {
    const int c0 = column(lo[0]), c1 = column(hi[0]), r0 = row(lo[1]), r1 = row(hi[1]);
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) fn(static_cast<std::size_t>(r) * cols_ + c);
    }
  }
  int column(double x) const {
    return static_cast<int>(std::clamp((x - lo_[0]) * sx_, 0.0, cols_ - 1.0));
  }
  int row(double y) const {
    return static_cast<int>(std::clamp((y - lo_[1]) * sy_, 0.0, rows_ - 1.0));
  }

  P2 lo_{}, hi_{};
  int cols_ = 1, rows_ = 1;
  double sx_ = 1, sy_ = 1;
  std::vector<std::size_t> start_, items_;
};

/// The vertices of a polygon (positions j in `poly`) bucketed, so that the vertices inside a
/// small triangle are found without visiting all of them.
BucketGrid vertex_grid(const std::vector<int>& poly, const std::vector<P2>& pts) {
  return BucketGrid(poly.size(), [&](auto&& fn) {
    for (std::size_t j = 0; j < poly.size(); ++j) {
      const P2& p = pts[static_cast<std::size_t>(poly[j])];
      fn(p, p, j);
    }
  });
}

/// An edge of an outline or a hole, with the loop it belongs to.
struct Edge {
  int a, b;   ///< point indices
  int group;  ///< which loop: edges of a group can be switched off together
};

/// The edges bucketed, so that a bridge is tested for crossings only against the edges near it.
BucketGrid edge_grid(const std::vector<Edge>& edges, const std::vector<P2>& pts) {
  return BucketGrid(edges.size(), [&](auto&& fn) {
    for (std::size_t e = 0; e < edges.size(); ++e) {
      const P2& a = pts[static_cast<std::size_t>(edges[e].a)];
      const P2& b = pts[static_cast<std::size_t>(edges[e].b)];
      fn(P2{std::min(a[0], b[0]), std::min(a[1], b[1])},
         P2{std::max(a[0], b[0]), std::max(a[1], b[1])}, e);
    }
  });
}

/// Whether segment p-q crosses or touches (segments_cross) an edge of a group not switched off.
bool crosses_an_edge(const P2& p, const P2& q, const BucketGrid& grid,
                     const std::vector<Edge>& edges, const std::vector<P2>& pts,
                     const std::vector<std::uint8_t>& group_off) {
  const P2 lo{std::min(p[0], q[0]), std::min(p[1], q[1])};
  const P2 hi{std::max(p[0], q[0]), std::max(p[1], q[1])};
  return !grid.all_in_box(lo, hi, [&](std::size_t k) {
    const Edge& e = edges[k];
    return group_off[static_cast<std::size_t>(e.group)] != 0 ||
           !segments_cross(p, q, pts[static_cast<std::size_t>(e.a)],
                           pts[static_cast<std::size_t>(e.b)]);
  });
}

// Ear clipping of a weakly simple CCW polygon (bridges repeat vertices): the vertices are a
// linked ring; the walk clips every ear it meets and goes on from the next vertex, and a
// candidate ear is tested only against the remaining vertices the grid puts near it. O(n) ear
// tests on typical outlines instead of the O(n^2) of rescanning from the start, which took
// minutes on outlines with thousands of holes.
void ear_clip(const std::vector<int>& poly, const std::vector<P2>& pts,
              std::vector<std::array<int, 3>>& tris) {
  const std::size_t n = poly.size();
  if (n < 3) return;
  auto pt = [&](std::size_t j) -> const P2& { return pts[static_cast<std::size_t>(poly[j])]; };
  std::vector<std::size_t> prev(n), next(n);
  std::vector<std::uint8_t> alive(n, 1);
  for (std::size_t j = 0; j < n; ++j) {
    prev[j] = (j + n - 1) % n;
    next[j] = (j + 1) % n;
  }
  const BucketGrid grid = vertex_grid(poly, pts);
  const auto is_ear = [&](std::size_t j) {
    const std::size_t ja = prev[j], jc = next[j];
    const P2 &a = pt(ja), &b = pt(j), &c = pt(jc);
    if (orient(a, b, c) <= 0) return false;
    const P2 lo{std::min({a[0], b[0], c[0]}), std::min({a[1], b[1], c[1]})};
    const P2 hi{std::max({a[0], b[0], c[0]}), std::max({a[1], b[1], c[1]})};
    const int ia = poly[ja], ib = poly[j], ic = poly[jc];
    return grid.all_in_box(lo, hi, [&](std::size_t k) {
      if (!alive[k]) return true;
      const int q = poly[k];
      if (q == ia || q == ib || q == ic) return true;
      const P2& p = pt(k);
      if (p == a || p == b || p == c) return true;
      return !(orient(a, b, p) >= 0 && orient(b, c, p) >= 0 && orient(c, a, p) >= 0);
    });
  };
  const auto remove = [&](std::size_t j) {
    alive[j] = 0;
    next[prev[j]] = next[j];
    prev[next[j]] = prev[j];
  };
  std::size_t left = n, j = 0, unclipped = 0;  // vertices visited since the last clip
  while (left > 3) {
    if (is_ear(j)) {
      tris.push_back({poly[prev[j]], poly[j], poly[next[j]]});
      const std::size_t after = next[j];
      remove(j);
      --left;
      // The previous vertex may have become an ear: step back to it.
      j = prev[after];
      unclipped = 0;
      continue;
    }
    j = next[j];
    if (++unclipped <= left) continue;
    // A whole turn without an ear (numerically degenerate remainder): clip the most convex
    // vertex, or drop a flat one, to terminate.
    double best = -INFINITY;
    std::size_t ear = j;
    for (std::size_t k = j, t = 0; t < left; k = next[k], ++t) {
      const double o = orient(pt(prev[k]), pt(k), pt(next[k]));
      if (o > best) {
        best = o;
        ear = k;
      }
    }
    if (best > 0) tris.push_back({poly[prev[ear]], poly[ear], poly[next[ear]]});
    j = next[ear];
    remove(ear);
    --left;
    unclipped = 0;
  }
  if (orient(pt(prev[j]), pt(j), pt(next[j])) > 0) {
    tris.push_back({poly[prev[j]], poly[j], poly[next[j]]});
  }
}

/// Unit vector from p into the region a loop encloses (the solid for a counter-clockwise outer
/// loop, the hole for a clockwise one) at vertex p with neighbours u (before) and w (after):
/// the bisector of the enclosed angle.
P2 into_enclosed(const P2& u, const P2& p, const P2& w, bool counter_clockwise) {
  const auto unit = [](double x, double y) {
    const double n = std::hypot(x, y);
    return n > 0 ? P2{x / n, y / n} : P2{0, 0};
  };
  const P2 a = unit(u[0] - p[0], u[1] - p[1]), b = unit(w[0] - p[0], w[1] - p[1]);
  P2 d = unit(a[0] + b[0], a[1] + b[1]);
  const double turn = orient(u, p, w);
  if (d == P2{0, 0}) {
    // Straight through p: the normal on the enclosed side (left of u -> w when CCW).
    d = counter_clockwise ? P2{-b[1], b[0]} : P2{b[1], -b[0]};
  } else if ((turn > 0) != counter_clockwise) {
    d = {-d[0], -d[1]};  // a reflex corner of the enclosed region
  }
  return d;
}

/// Where loops of one segment touch (a vertex of one at the position of a vertex of another,
/// or a loop through one point twice), moves the touching vertices a little into the region
/// their loop encloses, so that every outline with its holes is a simple polygon: ear clipping
/// is exact only for those (touching loops made it emit overlapping triangles). A hole's vertex
/// moves into the hole; a vertex of an outer loop moves into its solid only when another outer
/// vertex is there too (a hole's hole-side wedge lies inside the outline's solid-side wedge, so
/// moving the outline's vertex could cross the hole). The move is a thousandth of the shorter
/// adjacent edge: the triangles keep the original vertex indices.
void separate_touching_vertices(const PolygonSet& polygons, std::vector<P2>& pts) {
  std::vector<int> loop_of(pts.size(), -1);
  for (std::size_t l = 0; l < polygons.loops.size(); ++l) {
    const PolygonLoop& loop = polygons.loops[l];
    for (int i = loop.first; i < loop.first + loop.count; ++i) {
      loop_of[static_cast<std::size_t>(i)] = static_cast<int>(l);
    }
  }
  std::vector<int> order;
  order.reserve(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (loop_of[i] >= 0) order.push_back(static_cast<int>(i));
  }
  const std::vector<P2> original = pts;
  const auto at = [&](int i) -> const P2& { return original[static_cast<std::size_t>(i)]; };
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return at(a) != at(b) ? at(a) < at(b) : a < b; });
  for (std::size_t g = 0; g < order.size();) {
    std::size_t end = g + 1;
    while (end < order.size() && at(order[end]) == at(order[g])) ++end;
    if (end - g > 1) {
      int outer = 0;
      for (std::size_t k = g; k < end; ++k) {
        outer += !polygons.loops[static_cast<std::size_t>(loop_of[order[k]])].is_hole;
      }
      for (std::size_t k = g; k < end; ++k) {
        const auto i = static_cast<std::size_t>(order[k]);
        const PolygonLoop& loop = polygons.loops[static_cast<std::size_t>(loop_of[i])];
        if (!loop.is_hole && outer < 2) continue;
        const int j = static_cast<int>(i) - loop.first;
        const int before = loop.first + (j + loop.count - 1) % loop.count;
        const int after = loop.first + (j + 1) % loop.count;
        const P2& u = original[static_cast<std::size_t>(before)];
        const P2& w = original[static_cast<std::size_t>(after)];
        const P2& p = original[i];
        const double step = 1e-3 * std::min(std::hypot(u[0] - p[0], u[1] - p[1]),
                                            std::hypot(w[0] - p[0], w[1] - p[1]));
        const P2 d = into_enclosed(u, p, w, !loop.is_hole);
        pts[i] = {p[0] + step * d[0], p[1] + step * d[1]};
      }
    }
    g = end;
  }
}

/// The track id of the segment labelled `label` (segments[label - 1]), 0 when untracked or
/// there is no such segment.
std::uint32_t track_of(const Segmentation* segmentation, int label) {
  if (segmentation == nullptr || label < 1 ||
      static_cast<std::size_t>(label) > segmentation->segments.size()) {
    return 0;
  }
  return segmentation->segments[static_cast<std::size_t>(label - 1)].track_id;
}

}  // namespace

void triangulate_polygons(const PolygonSet& polygons, std::vector<std::array<int, 3>>& triangles) {
  triangles.clear();
  std::vector<P2> pts(polygons.points2d.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    pts[i] = {polygons.points2d[i][0], polygons.points2d[i][1]};
  }
  separate_touching_vertices(polygons, pts);
  std::vector<int> poly, holes;
  std::vector<std::pair<double, std::size_t>> candidates;  // (squared distance, index in poly)
  std::vector<Edge> edges;
  std::vector<std::uint8_t> group_off;       // per edge group: a hole left unbridged
  std::vector<std::pair<int, int>> bridges;  // point indices
  std::optional<BucketGrid> grid;
  for (std::size_t li = 0; li < polygons.loops.size(); ++li) {
    const PolygonLoop& outer = polygons.loops[li];
    if (outer.is_hole) continue;
    poly.clear();
    for (int i = 0; i < outer.count; ++i) poly.push_back(outer.first + i);
    holes.clear();
    for (std::size_t h = li + 1; h < polygons.loops.size(); ++h) {
      const PolygonLoop& hl = polygons.loops[h];
      if (hl.segment != outer.segment) break;
      if (hl.is_hole && hl.parent == static_cast<int>(li)) holes.push_back(static_cast<int>(h));
    }
    // Bridge holes from the one reaching farthest in +x (its bridge cannot be blocked by others).
    const auto max_x_vertex = [&](int h) {
      const PolygonLoop& hl = polygons.loops[static_cast<std::size_t>(h)];
      int best = hl.first;
      for (int i = hl.first; i < hl.first + hl.count; ++i) {
        if (pts[static_cast<std::size_t>(i)][0] > pts[static_cast<std::size_t>(best)][0]) best = i;
      }
      return best;
    };
    std::sort(holes.begin(), holes.end(), [&](int a, int b) {
      return pts[static_cast<std::size_t>(max_x_vertex(a))][0] >
             pts[static_cast<std::size_t>(max_x_vertex(b))][0];
    });
    if (!holes.empty()) {
      // Group 0: the outline; group 1 + h: hole holes[h].
      edges.clear();
      const auto add_loop = [&](const PolygonLoop& l, int group) {
        for (int e = 0; e < l.count; ++e) {
          edges.push_back({l.first + e, l.first + (e + 1) % l.count, group});
        }
      };
      add_loop(outer, 0);
      for (std::size_t h = 0; h < holes.size(); ++h) {
        add_loop(polygons.loops[static_cast<std::size_t>(holes[h])], 1 + static_cast<int>(h));
      }
      group_off.assign(holes.size() + 1, 0);
      bridges.clear();
      grid.emplace(edge_grid(edges, pts));
    }
    for (std::size_t hi = 0; hi < holes.size(); ++hi) {
      const PolygonLoop& hl = polygons.loops[static_cast<std::size_t>(holes[hi])];
      const int m = max_x_vertex(holes[hi]);
      const P2& pm = pts[static_cast<std::size_t>(m)];
      // The bridge goes to the nearest vertex (first in polygon order among equals) that sees
      // pm, i.e. crosses no edge of the outline, of a hole bridged or still to bridge, or an
      // earlier bridge. Candidates are tried nearest first, usually only the nearest.
      const auto sees = [&](std::size_t j) {
        const P2& pp = pts[static_cast<std::size_t>(poly[j])];
        if (!in_wedge(poly, j, pts, pm) || crosses_an_edge(pm, pp, *grid, edges, pts, group_off)) {
          return false;
        }
        return std::none_of(bridges.begin(), bridges.end(), [&](const std::pair<int, int>& b) {
          return segments_cross(pm, pp, pts[static_cast<std::size_t>(b.first)],
                                pts[static_cast<std::size_t>(b.second)]);
        });
      };
      const auto distance2 = [&](std::size_t j) {
        const P2& pp = pts[static_cast<std::size_t>(poly[j])];
        const double dx = pp[0] - pm[0], dy = pp[1] - pm[1];
        return dx * dx + dy * dy;
      };
      double nearest_distance = INFINITY;
      std::size_t nearest = 0;
      for (std::size_t j = 0; j < poly.size(); ++j) {
        const double d = distance2(j);
        if (d < nearest_distance) nearest_distance = d, nearest = j;
      }
      std::size_t best = poly.size();
      if (sees(nearest)) {
        best = nearest;
      } else {
        // A min-heap: building it is O(n), and only the few nearest are popped.
        candidates.clear();
        for (std::size_t j = 0; j < poly.size(); ++j) candidates.push_back({distance2(j), j});
        std::make_heap(candidates.begin(), candidates.end(), std::greater<>{});
        while (!candidates.empty()) {
          std::pop_heap(candidates.begin(), candidates.end(), std::greater<>{});
          const std::size_t j = candidates.back().second;
          candidates.pop_back();
          if (sees(j)) {
            best = j;
            break;
          }
        }
      }
      if (best == poly.size()) {  // no visible vertex (degenerate input): skip the hole
        group_off[hi + 1] = 1;
        continue;
      }
      bridges.emplace_back(m, poly[best]);
      std::vector<int> bridge;
      const int mo = m - hl.first;
      for (int k = 0; k <= hl.count; ++k) bridge.push_back(hl.first + (mo + k) % hl.count);
      bridge.push_back(poly[best]);
      poly.insert(poly.begin() + static_cast<std::ptrdiff_t>(best) + 1, bridge.begin(),
                  bridge.end());
    }
    ear_clip(poly, pts, triangles);
  }
  // Slivers at moved vertices can be flat or flipped in the original coordinates (of negligible
  // area; a viewer would show them as back faces).
  const auto original = [&](int i) {
    const auto& p = polygons.points2d[static_cast<std::size_t>(i)];
    return P2{p[0], p[1]};
  };
  std::erase_if(triangles, [&](const std::array<int, 3>& t) {
    return !(orient(original(t[0]), original(t[1]), original(t[2])) > 0);
  });
}

std::string polygons_to_obj(const PolygonSet& polygons, const Segmentation* segmentation) {
  std::vector<std::array<int, 3>> tris;
  triangulate_polygons(polygons, tris);
  std::string text =
      "# rangeseg plane polygons: simplified segment outlines, metres, camera frame\n";
  char line[128];
  std::size_t t = 0;
  for (std::size_t si = 0; si < polygons.segments.size(); ++si) {
    const SegmentPolygons& sp = polygons.segments[si];
    if (sp.loop_count == 0) continue;
    const std::uint32_t track = track_of(segmentation, sp.label);
    if (track != 0) {
      std::snprintf(line, sizeof line, "o segment_%d_track_%u\n", sp.label, track);
    } else {
      std::snprintf(line, sizeof line, "o segment_%d\n", sp.label);
    }
    text += line;
    const PolygonLoop& first = polygons.loops[static_cast<std::size_t>(sp.first_loop)];
    const PolygonLoop& last =
        polygons.loops[static_cast<std::size_t>(sp.first_loop + sp.loop_count - 1)];
    for (int i = first.first; i < last.first + last.count; ++i) {
      // Shortest round trip of each float, whatever the C locale: with 6 digits (5 um at a few
      // metres) some of the sliver triangles of long, straight outlines turned over.
      char* end = line;
      *end++ = 'v';
      for (const float c : polygons.points3d[static_cast<std::size_t>(i)]) {
        *end++ = ' ';
        end = std::to_chars(end, line + sizeof line, c).ptr;
      }
      *end++ = '\n';
      text.append(line, end);
    }
    for (; t < tris.size() && tris[t][0] < last.first + last.count; ++t) {
      std::snprintf(line, sizeof line, "f %d %d %d\n", tris[t][0] + 1, tris[t][1] + 1,
                    tris[t][2] + 1);
      text += line;
    }
  }
  return text;
}

void write_polygons_obj(const std::string& path, const PolygonSet& polygons,
                        const Segmentation* segmentation) {
  io::write_file_atomic(path, polygons_to_obj(polygons, segmentation));
}

}  // namespace rangeseg
