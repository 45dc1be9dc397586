// Helpers of the polygon tests: the exact properties every PolygonSet must have, and the
// comparison of two sets field by field.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "rangeseg/polygons.hpp"

namespace rangeseg::test {

using P2 = std::array<float, 2>;

inline double shoelace(const std::vector<P2>& p) {
  double a = 0;
  for (std::size_t i = 0, j = p.size() - 1; i < p.size(); j = i++) {
    a += static_cast<double>(p[j][0]) * p[i][1] - static_cast<double>(p[i][0]) * p[j][1];
  }
  return 0.5 * a;
}

inline std::vector<P2> loop2d(const PolygonSet& ps, const PolygonLoop& lp) {
  return {ps.points2d.begin() + lp.first, ps.points2d.begin() + lp.first + lp.count};
}

inline bool point_in(const std::vector<P2>& poly, double x, double y) {
  bool in = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    if ((poly[i][1] > y) != (poly[j][1] > y) &&
        x < (poly[j][0] - poly[i][0]) * (y - poly[i][1]) / (poly[j][1] - poly[i][1]) + poly[i][0]) {
      in = !in;
    }
  }
  return in;
}

inline double orient(const P2& a, const P2& b, const P2& c) {
  return (static_cast<double>(b[0]) - a[0]) * (static_cast<double>(c[1]) - a[1]) -
         (static_cast<double>(b[1]) - a[1]) * (static_cast<double>(c[0]) - a[0]);
}
inline bool cross_or_touch(const P2& a, const P2& b, const P2& c, const P2& d) {
  const double o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a),
               o4 = orient(c, d, b);
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  const auto on = [](const P2& p, const P2& q, const P2& r) {
    return std::min(p[0], q[0]) <= r[0] && r[0] <= std::max(p[0], q[0]) &&
           std::min(p[1], q[1]) <= r[1] && r[1] <= std::max(p[1], q[1]);
  };
  return (o1 == 0 && on(a, b, c)) || (o2 == 0 && on(a, b, d)) || (o3 == 0 && on(c, d, a)) ||
         (o4 == 0 && on(c, d, b));
}

/// Slow exact checks of one polygon set: loops closed (>= 3 vertices, no repeated vertex),
/// simple and mutually non-crossing (edges meet only in shared vertices), outer loops CCW and
/// holes CW, holes inside their parent, areas consistent.
inline void check_properties(const PolygonSet& ps) {
  for (const SegmentPolygons& sp : ps.segments) {
    if (sp.loop_count == 0) continue;
    struct E {
      P2 a, b;
    };
    std::vector<E> edges;
    double area = 0;
    for (int li = sp.first_loop; li < sp.first_loop + sp.loop_count; ++li) {
      const PolygonLoop& lp = ps.loops[li];
      ASSERT_GE(lp.count, 3);
      ASSERT_EQ(lp.label, sp.label);
      const std::vector<P2> pts = loop2d(ps, lp);
      std::vector<P2> sorted = pts;
      std::sort(sorted.begin(), sorted.end());
      EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end())
          << "loop " << li << " repeats a vertex";
      const double a = shoelace(pts);
      EXPECT_EQ(a < 0, lp.is_hole) << "loop " << li << " area " << a;
      EXPECT_NEAR(std::abs(a), lp.area, 1e-6 + 1e-4 * lp.area);
      area += a;
      for (std::size_t i = 0, j = pts.size() - 1; i < pts.size(); j = i++) {
        edges.push_back({pts[j], pts[i]});
      }
      if (lp.is_hole) {
        ASSERT_GE(lp.parent, sp.first_loop);
        const std::vector<P2> outer = loop2d(ps, ps.loops[lp.parent]);
        EXPECT_FALSE(ps.loops[lp.parent].is_hole);
        int outside = 0;
        for (std::size_t i = 0, j = pts.size() - 1; i < pts.size(); j = i++) {
          const double mx = 0.5 * (pts[i][0] + pts[j][0]), my = 0.5 * (pts[i][1] + pts[j][1]);
          outside += !point_in(outer, mx, my);
        }
        EXPECT_EQ(outside, 0) << "hole " << li << " leaves its outer loop";
      }
    }
    EXPECT_NEAR(area, sp.area, 1e-6 + 1e-4 * std::abs(sp.area));
    // Exact pairwise test, pruned by a sweep over x (edges sorted by their smaller x).
    for (E& e : edges) {
      if (e.b < e.a) std::swap(e.a, e.b);
    }
    std::sort(edges.begin(), edges.end(), [](const E& x, const E& y) { return x.a[0] < y.a[0]; });
    for (std::size_t i = 0; i < edges.size(); ++i) {
      for (std::size_t j = i + 1; j < edges.size() && edges[j].a[0] <= edges[i].b[0]; ++j) {
        const E& e = edges[i];
        const E& f = edges[j];
        if (e.a == f.a || e.a == f.b || e.b == f.a || e.b == f.b) continue;
        ASSERT_FALSE(cross_or_touch(e.a, e.b, f.a, f.b))
            << "segment " << sp.label << ": edges (" << e.a[0] << "," << e.a[1] << ")-(" << e.b[0]
            << "," << e.b[1] << ") and (" << f.a[0] << "," << f.a[1] << ")-(" << f.b[0] << ","
            << f.b[1] << ") cross";
      }
    }
  }
}

/// Every field of two polygon sets, bit for bit.
inline void expect_identical_polygons(const PolygonSet& a, const PolygonSet& b,
                                      const std::string& what) {
  SCOPED_TRACE(what);
  const auto segment_fields = [](const SegmentPolygons& x) {
    return std::tuple(x.label, x.first_loop, x.loop_count, x.hull_first, x.hull_count, x.area,
                      x.raw_area, x.perimeter, x.hull_area, x.hull_perimeter);
  };
  const auto loop_fields = [](const PolygonLoop& x) {
    return std::tuple(x.segment, x.label, x.is_hole, x.parent, x.first, x.count, x.raw_count,
                      x.area, x.raw_area, x.perimeter, x.tolerance);
  };
  ASSERT_EQ(a.segments.size(), b.segments.size());
  for (std::size_t i = 0; i < a.segments.size(); ++i) {
    EXPECT_EQ(segment_fields(a.segments[i]), segment_fields(b.segments[i])) << "segment " << i;
  }
  ASSERT_EQ(a.loops.size(), b.loops.size());
  for (std::size_t i = 0; i < a.loops.size(); ++i) {
    EXPECT_EQ(loop_fields(a.loops[i]), loop_fields(b.loops[i])) << "loop " << i;
  }
  EXPECT_EQ(a.points3d, b.points3d);
  EXPECT_EQ(a.points2d, b.points2d);
  EXPECT_EQ(a.pixels, b.pixels);
  EXPECT_EQ(a.hull_points3d, b.hull_points3d);
  EXPECT_EQ(a.hull_points2d, b.hull_points2d);
  EXPECT_EQ(a.hull_pixels, b.hull_pixels);
}

}  // namespace rangeseg::test
