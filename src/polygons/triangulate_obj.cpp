// Triangulation of polygons with holes (hole bridging + ear clipping) and the OBJ writer.
//
// Polygons here are the simplified loops: tens of vertices, so the O(n^2) bridging and ear
// clipping are cheap and simple to get right.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "rangeseg/io/file.hpp"
#include "rangeseg/polygons.hpp"

namespace rangeseg {
namespace {

using P2 = std::array<float, 2>;

double orient(const P2& a, const P2& b, const P2& c) {
  return (static_cast<double>(b[0]) - a[0]) * (static_cast<double>(c[1]) - a[1]) -
         (static_cast<double>(b[1]) - a[1]) * (static_cast<double>(c[0]) - a[0]);
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

// Ear clipping of a weakly simple CCW polygon (bridges repeat vertices).
void ear_clip(std::vector<int> poly, const std::vector<P2>& pts,
              std::vector<std::array<int, 3>>& tris) {
  auto pt = [&](int i) -> const P2& { return pts[static_cast<std::size_t>(i)]; };
  while (poly.size() > 3) {
    const std::size_t n = poly.size();
    std::size_t ear = n;
    for (std::size_t i = 0; i < n && ear == n; ++i) {
      const int a = poly[(i + n - 1) % n], b = poly[i], c = poly[(i + 1) % n];
      if (orient(pt(a), pt(b), pt(c)) <= 0) continue;
      bool empty = true;
      for (std::size_t k = 0; k < n && empty; ++k) {
        const int q = poly[k];
        if (q == a || q == b || q == c) continue;
        const P2& p = pt(q);
        if (p == pt(a) || p == pt(b) || p == pt(c)) continue;
        empty = !(orient(pt(a), pt(b), p) >= 0 && orient(pt(b), pt(c), p) >= 0 &&
                  orient(pt(c), pt(a), p) >= 0);
      }
      if (empty) ear = i;
    }
    if (ear == n) {
      // Numerically degenerate remainder: clip the most convex vertex to terminate.
      double best = -INFINITY;
      for (std::size_t i = 0; i < n; ++i) {
        const double o = orient(pt(poly[(i + n - 1) % n]), pt(poly[i]), pt(poly[(i + 1) % n]));
        if (o > best) {
          best = o;
          ear = i;
        }
      }
      if (best <= 0) {
        poly.erase(poly.begin() + static_cast<std::ptrdiff_t>(ear));
        continue;
      }
    }
    tris.push_back({poly[(ear + n - 1) % n], poly[ear], poly[(ear + 1) % n]});
    poly.erase(poly.begin() + static_cast<std::ptrdiff_t>(ear));
  }
  if (poly.size() == 3 && orient(pt(poly[0]), pt(poly[1]), pt(poly[2])) > 0) {
    tris.push_back({poly[0], poly[1], poly[2]});
  }
}

}  // namespace

void triangulate_polygons(const PolygonSet& polygons, std::vector<std::array<int, 3>>& triangles) {
  triangles.clear();
  const std::vector<P2>& pts = polygons.points2d;
  std::vector<int> poly, holes;
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
    for (std::size_t hi = 0; hi < holes.size(); ++hi) {
      const PolygonLoop& hl = polygons.loops[static_cast<std::size_t>(holes[hi])];
      const int m = max_x_vertex(holes[hi]);
      const P2& pm = pts[static_cast<std::size_t>(m)];
      std::size_t best = poly.size();
      double best_d = INFINITY;
      for (std::size_t j = 0; j < poly.size(); ++j) {
        const P2& pp = pts[static_cast<std::size_t>(poly[j])];
        const double d =
            std::hypot(static_cast<double>(pp[0]) - pm[0], static_cast<double>(pp[1]) - pm[1]);
        if (d >= best_d || !in_wedge(poly, j, pts, pm)) continue;
        bool clear = true;
        for (std::size_t e = 0; e < poly.size() && clear; ++e) {
          clear = !segments_cross(pm, pp, pts[static_cast<std::size_t>(poly[e])],
                                  pts[static_cast<std::size_t>(poly[(e + 1) % poly.size()])]);
        }
        for (std::size_t oh = hi; oh < holes.size() && clear; ++oh) {
          const PolygonLoop& o = polygons.loops[static_cast<std::size_t>(holes[oh])];
          for (int e = 0; e < o.count && clear; ++e) {
            const auto first = static_cast<std::size_t>(o.first);
            clear = !segments_cross(pm, pp, pts[first + static_cast<std::size_t>(e)],
                                    pts[first + static_cast<std::size_t>((e + 1) % o.count)]);
          }
        }
        if (clear) {
          best = j;
          best_d = d;
        }
      }
      if (best == poly.size()) continue;  // no visible vertex (degenerate input): skip the hole
      std::vector<int> bridge;
      const int mo = m - hl.first;
      for (int k = 0; k <= hl.count; ++k) bridge.push_back(hl.first + (mo + k) % hl.count);
      bridge.push_back(poly[best]);
      poly.insert(poly.begin() + static_cast<std::ptrdiff_t>(best) + 1, bridge.begin(),
                  bridge.end());
    }
    ear_clip(poly, pts, triangles);
  }
}

std::string polygons_to_obj(const PolygonSet& polygons) {
  std::vector<std::array<int, 3>> tris;
  triangulate_polygons(polygons, tris);
  std::string text =
      "# rangeseg plane polygons: simplified segment outlines, metres, camera frame\n";
  char line[128];
  std::size_t t = 0;
  for (std::size_t si = 0; si < polygons.segments.size(); ++si) {
    const SegmentPolygons& sp = polygons.segments[si];
    if (sp.loop_count == 0) continue;
    std::snprintf(line, sizeof line, "o segment_%d\n", sp.label);
    text += line;
    const PolygonLoop& first = polygons.loops[static_cast<std::size_t>(sp.first_loop)];
    const PolygonLoop& last =
        polygons.loops[static_cast<std::size_t>(sp.first_loop + sp.loop_count - 1)];
    for (int i = first.first; i < last.first + last.count; ++i) {
      const auto& p = polygons.points3d[static_cast<std::size_t>(i)];
      std::snprintf(line, sizeof line, "v %.6g %.6g %.6g\n", p[0], p[1], p[2]);
      text += line;
    }
    for (; t < tris.size() && tris[t][0] < last.first + last.count; ++t) {
      std::snprintf(line, sizeof line, "f %d %d %d\n", tris[t][0] + 1, tris[t][1] + 1,
                    tris[t][2] + 1);
      text += line;
    }
  }
  return text;
}

void write_polygons_obj(const std::string& path, const PolygonSet& polygons) {
  io::write_file_atomic(path, polygons_to_obj(polygons));
}

}  // namespace rangeseg
