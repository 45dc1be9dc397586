// Closed-loop Douglas-Peucker, the simplicity check after simplification, loop measures.
#include <algorithm>
#include <cmath>

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
      dist2_point_segment(e.x1, e.y1, f.x0, f.y0, f.x1, f.y1) <= eps2)
    return true;
  const double o1 = cross(e.x0, e.y0, e.x1, e.y1, f.x0, f.y0);
  const double o2 = cross(e.x0, e.y0, e.x1, e.y1, f.x1, f.y1);
  const double o3 = cross(f.x0, f.y0, f.x1, f.y1, e.x0, e.y0);
  const double o4 = cross(f.x0, f.y0, f.x1, f.y1, e.x1, e.y1);
  if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0)))
    return true;
  if (o1 == 0 && on_segment(e.x0, e.y0, e.x1, e.y1, f.x0, f.y0)) return true;
  if (o2 == 0 && on_segment(e.x0, e.y0, e.x1, e.y1, f.x1, f.y1)) return true;
  if (o3 == 0 && on_segment(f.x0, f.y0, f.x1, f.y1, e.x0, e.y0)) return true;
  if (o4 == 0 && on_segment(f.x0, f.y0, f.x1, f.y1, e.x1, e.y1)) return true;
  return false;
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
    const double dx = xy[2 * i] - xy[0], dy = xy[2 * i + 1] - xy[1];
    const double d2 = dx * dx + dy * dy;
    if (d2 > best) {
      best = d2;
      far = i;
    }
  }
  const double tol2 = tolerance * tolerance;
  keep.push_back(0);
  keep.push_back(far);
  stack.clear();
  stack.push_back({0, far});
  stack.push_back({far, n});  // index n is vertex 0 again
  while (!stack.empty()) {
    const auto [lo, hi] = stack.back();
    stack.pop_back();
    if (hi - lo < 2) continue;
    const double* a = xy + 2 * lo;
    const double* b = xy + 2 * (hi % n);
    int worst = -1;
    double worst_d2 = tol2;
    for (int i = lo + 1; i < hi; ++i) {
      const double d2 = dist2_segment(xy + 2 * i, a, b);
      if (d2 > worst_d2) {
        worst_d2 = d2;
        worst = i;
      }
    }
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
      const double d2 = dist2_segment(xy + 2 * i, xy, xy + 2 * far);
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
    if (dist2_segment(xy, xy + 2 * prev, xy + 2 * next) <= tol2) {
      // Every dropped vertex between prev and next must stay within tolerance too.
      bool fine = true;
      for (int i = prev + 1; i < n + next && fine; ++i) {
        fine = dist2_segment(xy + 2 * (i % n), xy + 2 * prev, xy + 2 * next) <= tol2;
      }
      if (fine) keep.erase(keep.begin() + static_cast<std::ptrdiff_t>(base));
    }
  }
}

bool mark_crossings(std::vector<CheckEdge>& edges, std::vector<std::uint8_t>& bad) {
  for (CheckEdge& e : edges) {
    if (e.x0 > e.x1) {
      std::swap(e.x0, e.x1);
      std::swap(e.y0, e.y1);
      std::swap(e.id0, e.id1);
    }
  }
  std::sort(edges.begin(), edges.end(),
            [](const CheckEdge& a, const CheckEdge& b) { return a.x0 < b.x0; });
  bool any = false;
  const std::size_t n = edges.size();
  for (std::size_t i = 0; i < n; ++i) {
    const CheckEdge& e = edges[i];
    const double margin = 1e-5 * (1.0 + std::abs(e.x1) + std::abs(e.y0) + std::abs(e.y1));
    const double ylo = std::min(e.y0, e.y1) - margin, yhi = std::max(e.y0, e.y1) + margin;
    for (std::size_t j = i + 1; j < n && edges[j].x0 <= e.x1 + margin; ++j) {
      const CheckEdge& f = edges[j];
      if (std::max(f.y0, f.y1) < ylo || std::min(f.y0, f.y1) > yhi) continue;
      if (e.id0 == f.id0 || e.id0 == f.id1 || e.id1 == f.id0 || e.id1 == f.id1) continue;
      const double scale =
          1.0 + std::max({std::abs(e.x0), std::abs(e.y0), std::abs(e.x1), std::abs(e.y1)});
      if (segments_touch(e, f, 1e-6 * scale)) {
        bad[e.loop] = 1;
        bad[f.loop] = 1;
        any = true;
      }
    }
  }
  return any;
}

void area_perimeter(const double* xy, int n, double& area, double& perimeter) {
  double a = 0, p = 0;
  for (int i = 0, j = n - 1; i < n; j = i++) {
    a += xy[2 * j] * xy[2 * i + 1] - xy[2 * i] * xy[2 * j + 1];
    const double dx = xy[2 * i] - xy[2 * j], dy = xy[2 * i + 1] - xy[2 * j + 1];
    p += std::sqrt(dx * dx + dy * dy);
  }
  area = 0.5 * a;
  perimeter = p;
}

void monotone_chain_sorted(const double* xy, int n, std::vector<int>& hull) {
  hull.clear();
  if (n <= 0) return;
  auto turn = [&](int o, int a, int b) {
    return cross(xy[2 * o], xy[2 * o + 1], xy[2 * a], xy[2 * a + 1], xy[2 * b], xy[2 * b + 1]);
  };
  hull.resize(2 * static_cast<std::size_t>(n) + 1);
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
