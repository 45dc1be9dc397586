// Stage 5 over k-nearest-neighbour rings: plane polygons without a mesh, from the union of the
// points' footprints on the plane.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "polygons/internal.hpp"
#include "rangeseg/unorganized.hpp"
#include "unorganized/internal.hpp"

namespace rangeseg {
namespace {

using polygons_detail::Projection;
using polygons_detail::Vec;
using unorganized::at;

/// At most this many raster cells per segment: bounds the time and memory of one outline
/// whatever the spread of the point spacing.
constexpr double kMaxCells = 1 << 21;
constexpr double kMaxSide = 1 << 16;

/// The upper median of `values` (reordered; 0 when empty).
double median_of(std::vector<double>& values) {
  if (values.empty()) return 0;
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

/// A segment's points on its plane: coordinates, and the half-widths in x and y of each point's
/// footprint.
struct Footprints {
  std::vector<double> xy;      // x, y interleaved [m]
  std::vector<double> half;    // half-width x, y interleaved [m]
  std::vector<double> spread;  // scratch for quantiles
  double median_side = 0;      // median side of a footprint, sqrt(area) [m]
};

/// The footprint of a point is an ellipse of the shape of the covariance C of its ring's points
/// in the same segment (`count` of them), in the plane's coordinates, scaled to hold those
/// points at their density (area 4 pi sqrt(det C) / (count + 1), as `point_area`); points of
/// other segments would land anywhere when projected onto this plane. the bounding box of that
/// ellipse has half-widths c sqrt(C_xx) and c sqrt(C_yy) with c = 2 / sqrt(count + 1). On a square
/// grid of spacing h and k = 12 that is 0.60 h, so the boxes of neighbouring points overlap and the
/// union's border lies ~0.6 h outside the last points, as the pixel squares of a range image would
/// (0.5 h). The covariance is about the ring's mean, not about the point: a ring on a border is
/// one-sided and reaches twice as far inwards, and moments about the point would put the
/// border ~0.85 h out; about the mean, the spread across the border shrinks instead (0.4 h).
/// `local[i]` is the index of point i in `points` for the points of the segment, -1 for the
/// others (only those entries are set and read).
void footprints(const std::vector<float>& xyz, const PointRings& rings,
                const std::vector<std::int32_t>& points, std::vector<std::int32_t>& local,
                const Projection& pr, Footprints& f) {
  const std::size_t m = points.size();
  f.xy.resize(2 * m);
  f.half.resize(2 * m);
  f.spread.clear();
  for (std::size_t a = 0; a < m; ++a) {
    const float* p = &xyz[3 * static_cast<std::size_t>(points[a])];
    polygons_detail::project_point(pr, Vec{p[0], p[1], p[2]}, &f.xy[2 * a]);
  }
  for (std::size_t a = 0; a < m; ++a) {
    const auto ring = rings.ring(static_cast<std::size_t>(points[a]));
    double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    int count = 0;
    for (const std::int32_t j : ring) {
      const std::int32_t b = local[static_cast<std::size_t>(j)];
      if (b < 0) continue;
      ++count;
      const double* q = &f.xy[2 * static_cast<std::size_t>(b)];
      const double dx = q[0] - f.xy[2 * a], dy = q[1] - f.xy[2 * a + 1];
      sx += dx;
      sy += dy;
      sxx += dx * dx;
      syy += dy * dy;
      sxy += dx * dy;
    }
    if (count < 2 || !std::isfinite(sxx + syy + sxy)) {
      f.half[2 * a] = f.half[2 * a + 1] = NAN;  // filled in below
      continue;
    }
    const double c2 = 4.0 / (count + 1);
    sx /= count;
    sy /= count;
    sxx = sxx / count - sx * sx;
    syy = syy / count - sy * sy;
    sxy = sxy / count - sx * sy;
    f.half[2 * a] = std::sqrt(c2 * sxx);
    f.half[2 * a + 1] = std::sqrt(c2 * syy);
    const double det = std::max(0.0, sxx * syy - sxy * sxy);
    f.spread.push_back(std::sqrt(std::numbers::pi * c2 * std::sqrt(det)));
  }
  f.median_side = median_of(f.spread);
  // A point with fewer than two ring neighbours in its segment, or one whose ring reaches far (an
  // outlier), gets a footprint of the segment's typical size instead.
  const double fallback = 0.5 * f.median_side, cap = 4 * f.median_side;
  for (double& h : f.half) h = std::isfinite(h) ? std::min(h, cap) : fallback;
}

/// The footprints of the points of a plane seen at grazing incidence (Segment::grazing), where
/// the rings hold only each point's neighbours along its scan line (the veil test cut the
/// others), so the ring's covariance is degenerate: the patch of the plane that one sample of
/// the scan covers, half-widths h r / (2 s) along the ray's trace on the plane and h r / 2
/// across it (the patches of neighbouring samples meet; the raster's closing bridges what
/// rounding leaves between them), with r the range, s the sine of the ray's angle to the plane
/// (at least kMinGrazingSine) and h the angular spacing of the scan: the median over the
/// segment of the angle to the nearest ring neighbour in it.
void grazing_footprints(const std::vector<float>& xyz, const PointRings& rings,
                        const std::vector<std::int32_t>& points,
                        const std::vector<std::int32_t>& local, const Projection& pr,
                        Footprints& f) {
  const std::size_t m = points.size();
  f.xy.resize(2 * m);
  f.half.resize(2 * m);
  f.spread.clear();
  const Vec& vp = pr.vp;
  const Vec& n = pr.fr.normal;
  for (std::size_t a = 0; a < m; ++a) {
    const float* p = &xyz[3 * static_cast<std::size_t>(points[a])];
    polygons_detail::project_point(pr, Vec{p[0], p[1], p[2]}, &f.xy[2 * a]);
    double nearest = std::numeric_limits<double>::infinity();
    for (const std::int32_t j : rings.ring(static_cast<std::size_t>(points[a]))) {
      if (local[static_cast<std::size_t>(j)] < 0) continue;
      const float* q = &xyz[3 * static_cast<std::size_t>(j)];
      nearest = std::min(nearest, double{unorganized::squared_distance(p, q)});
    }
    const Vec rel{p[0] - vp[0], p[1] - vp[1], p[2] - vp[2]};
    const double r = std::sqrt(polygons_detail::dot(rel, rel));
    if (std::isfinite(nearest) && r > 0) f.spread.push_back(std::sqrt(nearest) / r);
  }
  const double spacing = median_of(f.spread);
  f.spread.clear();
  for (std::size_t a = 0; a < m; ++a) {
    const float* p = &xyz[3 * static_cast<std::size_t>(points[a])];
    Vec d{p[0] - vp[0], p[1] - vp[1], p[2] - vp[2]};  // the ray, unit below
    const double r = std::sqrt(polygons_detail::dot(d, d));
    for (double& c : d) c /= r;
    const double along = polygons_detail::dot(n, d);
    Vec u{d[0] - along * n[0], d[1] - along * n[1], d[2] - along * n[2]};  // the ray's trace
    const double length = std::sqrt(polygons_detail::dot(u, u));
    if (!(r > 0) || !(length > 0)) {
      f.half[2 * a] = f.half[2 * a + 1] = 0;
      continue;
    }
    for (double& c : u) c /= length;
    const Vec w{n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]};
    const double across = 0.5 * spacing * r;
    const double lengthwise = across / std::max(std::abs(along), unorganized::kMinGrazingSine);
    const double u1 = polygons_detail::dot(u, pr.fr.e1), u2 = polygons_detail::dot(u, pr.fr.e2);
    const double w1 = polygons_detail::dot(w, pr.fr.e1), w2 = polygons_detail::dot(w, pr.fr.e2);
    f.half[2 * a] = std::hypot(lengthwise * u1, across * w1);
    f.half[2 * a + 1] = std::hypot(lengthwise * u2, across * w2);
    f.spread.push_back(std::sqrt(std::numbers::pi * lengthwise * across));
  }
  f.median_side = median_of(f.spread);
}

/// Morphological closing of the cols x rows raster with a (2r + 1)^2 square: a dilation, then
/// an erosion, each as a sliding-window count along the rows and then the columns. Cells within
/// r of the raster's edge must be empty.
void close_square(std::vector<std::uint8_t>& occ, int cols, int rows, int r,
                  std::vector<std::uint8_t>& tmp) {
  if (r < 1) return;
  const auto at = [cols](int i, int j) {
    return static_cast<std::size_t>(j) * static_cast<std::size_t>(cols) +
           static_cast<std::size_t>(i);
  };
  // pass(src, dst, along_rows, need): dst = 1 where at least `need` of the 2r + 1 cells of the
  // window about it in src are set (need 1: dilation, need 2r + 1: erosion).
  const auto pass = [&](const std::vector<std::uint8_t>& src, std::vector<std::uint8_t>& dst,
                        bool along_rows, int need) {
    const int lines = along_rows ? rows : cols, length = along_rows ? cols : rows;
    for (int line = 0; line < lines; ++line) {
      const auto cell = [&](int k) { return along_rows ? at(k, line) : at(line, k); };
      int count = 0;
      for (int k = 0; k < std::min(r, length); ++k) count += src[cell(k)];
      for (int k = 0; k < length; ++k) {
        if (k + r < length) count += src[cell(k + r)];
        if (k - r - 1 >= 0) count -= src[cell(k - r - 1)];
        dst[cell(k)] = count >= need ? 1 : 0;
      }
    }
  };
  tmp.assign(occ.size(), 0);
  pass(occ, tmp, true, 1);
  pass(tmp, occ, false, 1);
  pass(occ, tmp, true, 2 * r + 1);
  pass(tmp, occ, false, 2 * r + 1);
}

/// Whether (x, y) lies inside the closed loop of `count` points from `first` (even-odd rule).
bool inside(const Polygons2D& loops, int loop, double x, double y) {
  const int first = loops.first[static_cast<std::size_t>(loop)];
  const int count = loops.count[static_cast<std::size_t>(loop)];
  bool in = false;
  for (int i = 0, j = count - 1; i < count; j = i++) {
    const auto& a = loops.points[static_cast<std::size_t>(first) + static_cast<std::size_t>(i)];
    const auto& b = loops.points[static_cast<std::size_t>(first) + static_cast<std::size_t>(j)];
    if ((a[1] > y) != (b[1] > y) && x < (b[0] - a[0]) * (y - a[1]) / (b[1] - a[1]) + a[0]) {
      in = !in;
    }
  }
  return in;
}

/// A point just left of the first edge of hole `loop`: in the region around the hole (holes run
/// clockwise, so the segment lies on their left), i.e. inside the hole's parent and in no
/// island of the hole.
std::array<double, 2> beside_hole(const Polygons2D& loops, int loop, double step) {
  const int first = loops.first[static_cast<std::size_t>(loop)];
  const auto& a = loops.points[static_cast<std::size_t>(first)];
  const auto& b = loops.points[static_cast<std::size_t>(first) + 1];
  const double dx = b[0] - a[0], dy = b[1] - a[1];
  const double len = std::max(std::hypot(dx, dy), 1e-30);
  return {0.5 * (a[0] + b[0]) - step * dy / len, 0.5 * (a[1] + b[1]) + step * dx / len};
}

void require_settings(const PolygonSettings& s) {
  const bool ok = s.simplify_tolerance >= 0 && std::isfinite(s.simplify_tolerance) &&
                  s.simplify_tolerance_pixels >= 0 && std::isfinite(s.simplify_tolerance_pixels) &&
                  s.simplify_inradius_fraction >= 0 &&
                  std::isfinite(s.simplify_inradius_fraction) && s.min_loop_pixels >= 0 &&
                  std::isfinite(s.min_loop_pixels) && std::isfinite(s.viewpoint[0]) &&
                  std::isfinite(s.viewpoint[1]) && std::isfinite(s.viewpoint[2]);
  if (!ok) {
    std::ostringstream msg;
    msg << "extract_polygons: tolerances and min_loop_pixels must be finite and >= 0, viewpoint "
           "finite; got simplify_tolerance "
        << s.simplify_tolerance << ", simplify_tolerance_pixels " << s.simplify_tolerance_pixels
        << ", simplify_inradius_fraction " << s.simplify_inradius_fraction << ", min_loop_pixels "
        << s.min_loop_pixels << ", viewpoint (" << s.viewpoint[0] << ", " << s.viewpoint[1] << ", "
        << s.viewpoint[2] << ")";
    throw std::invalid_argument(msg.str());
  }
}

}  // namespace

/// Buffers of the ring polygons, kept from frame to frame (they only grow).
struct PolygonExtractor::RingScratch {
  std::vector<std::int32_t> first, next, points, members, local;
  std::vector<float> xyz;
  std::vector<const Segment*> segment_of;
  Footprints f;
  std::vector<std::uint8_t> occ, scratch;
  polygons_detail::RasterOutline outline;
  std::vector<int> order;  // kept loops: outer by area descending, then holes by parent
  std::vector<int> parent;
  std::vector<std::pair<int, int>> holes;
  std::vector<double> hull_xy, sorted, hull;
  std::vector<int> hull_order, hull_idx;
  polygons_detail::PointSortScratch sort;

  /// Rasterises the footprints of the segment's points and traces their union's outline.
  /// Returns false when the segment has no extent.
  bool trace(double tolerance) {
    const std::size_t m = f.xy.size() / 2;
    double minx = INFINITY, miny = INFINITY, maxx = -INFINITY, maxy = -INFINITY;
    f.spread.clear();
    for (std::size_t a = 0; a < m; ++a) {
      const double x = f.xy[2 * a], y = f.xy[2 * a + 1], hx = f.half[2 * a], hy = f.half[2 * a + 1];
      minx = std::min(minx, x - hx);
      maxx = std::max(maxx, x + hx);
      miny = std::min(miny, y - hy);
      maxy = std::max(maxy, y + hy);
      f.spread.push_back(std::min(hx, hy));
    }
    if (!(maxx > minx) || !(maxy > miny) || !std::isfinite(maxx - minx + maxy - miny)) {
      return false;
    }
    // Cells of 1.5 median smaller half-widths: a typical box covers one or two cells along
    // each axis. (Where the points are denser, several share a cell; the outline's detail there
    // is below the simplification tolerance, 1.5 median footprints.) At most kMaxCells cells,
    // and at most kMaxSide along either axis (a long, thin segment).
    double h = 1.5 * median_of(f.spread);
    h = std::max({h, std::sqrt((maxx - minx) * (maxy - miny) / kMaxCells), (maxx - minx) / kMaxSide,
                  (maxy - miny) / kMaxSide});
    if (!(h > 0)) return false;
    // Gaps between the footprints (random points leave some a spacing wide) up to two median
    // footprints across are closed (at most 8 cells, for footprints far from square);
    // outline_raster needs two more empty rows and columns.
    const int close = static_cast<int>(std::min(8.0, std::round(f.median_side / h)));
    const int kMargin = 2 + close;
    const int cols = static_cast<int>(std::floor((maxx - minx) / h)) + 1 + 2 * kMargin;
    const int rows = static_cast<int>(std::floor((maxy - miny) / h)) + 1 + 2 * kMargin;
    const double x0 = minx - kMargin * h, y0 = miny - kMargin * h;
    occ.assign(static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows), 0);
    // A box covers the cells whose centre it holds, and the point's own cell.
    const auto span = [h](double centre, double half, double origin, int n, int& lo, int& hi) {
      const double c = (centre - origin) / h;
      const int own = static_cast<int>(std::floor(c));
      lo = std::clamp(std::min(own, static_cast<int>(std::ceil(c - half / h - 0.5))), 0, n - 1);
      hi = std::clamp(std::max(own, static_cast<int>(std::floor(c + half / h - 0.5))), 0, n - 1);
    };
    for (std::size_t a = 0; a < m; ++a) {
      int i0, i1, j0, j1;
      span(f.xy[2 * a], f.half[2 * a], x0, cols, i0, i1);
      span(f.xy[2 * a + 1], f.half[2 * a + 1], y0, rows, j0, j1);
      for (int j = j0; j <= j1; ++j) {
        std::fill_n(occ.begin() + static_cast<std::ptrdiff_t>(j) * cols + i0, i1 - i0 + 1, 1);
      }
    }
    close_square(occ, cols, rows, close, scratch);
    polygons_detail::outline_raster(occ, cols, rows, x0, y0, h, tolerance, outline);
    return true;
  }

  /// Chooses the loops to keep and their order, and each hole's parent (index into `order`).
  void arrange(double min_loop_area, double step) {
    const Polygons2D& loops = outline.loops;
    const int n = static_cast<int>(loops.first.size());
    order.clear();
    int largest = -1;
    for (int k = 0; k < n; ++k) {
      if (loops.is_hole[static_cast<std::size_t>(k)]) continue;
      if (largest < 0 || outline.raw_area[static_cast<std::size_t>(k)] >
                             outline.raw_area[static_cast<std::size_t>(largest)]) {
        largest = k;
      }
    }
    if (largest < 0) return;
    const auto area = [&](int k) { return outline.raw_area[static_cast<std::size_t>(k)]; };
    for (int k = 0; k < n; ++k) {
      if (!loops.is_hole[static_cast<std::size_t>(k)] &&
          (k == largest || area(k) >= min_loop_area)) {
        order.push_back(k);
      }
    }
    // std::sort with ties in loop order: stable_sort takes a temporary buffer per call.
    std::sort(order.begin(), order.end(),
              [&](int a, int b) { return area(a) > area(b) || (area(a) == area(b) && a < b); });
    const std::size_t n_outer = order.size();
    parent.assign(n_outer, -1);
    // A hole's parent is the smallest kept outer loop around it.
    holes.clear();  // (parent rank, loop)
    for (int k = 0; k < n; ++k) {
      if (!loops.is_hole[static_cast<std::size_t>(k)] || area(k) < min_loop_area) continue;
      const auto p = beside_hole(loops, k, step);
      int best = -1;
      for (std::size_t r = 0; r < n_outer; ++r) {
        if (!inside(loops, order[r], p[0], p[1])) continue;
        if (best < 0 || area(order[r]) < area(order[static_cast<std::size_t>(best)])) {
          best = static_cast<int>(r);
        }
      }
      if (best >= 0) holes.emplace_back(best, k);
    }
    std::sort(holes.begin(), holes.end());  // by parent, then loop: the order they were found
    for (const auto& [rank, k] : holes) {
      order.push_back(k);
      parent.push_back(rank);
    }
  }

  /// Writes the kept loops and the hull of segment `si`.
  void write(const PolygonSettings& settings, PolygonSet& out, int si, SegmentPolygons& sp) {
    const Polygons2D& loops = outline.loops;
    const PlaneFrame& fr = sp.frame;
    sp.first_loop = static_cast<int>(out.loops.size());
    sp.loop_count = static_cast<int>(order.size());
    hull_xy.clear();
    for (std::size_t r = 0; r < order.size(); ++r) {
      const auto k = static_cast<std::size_t>(order[r]);
      PolygonLoop lp;
      lp.segment = si;
      lp.label = sp.label;
      lp.is_hole = loops.is_hole[k] != 0;
      lp.parent = lp.is_hole ? sp.first_loop + parent[r] : -1;
      lp.first = static_cast<int>(out.points2d.size());
      lp.count = loops.count[k];
      lp.raw_area = outline.raw_area[k];
      lp.raw_perimeter = outline.raw_perimeter[k];
      lp.raw_count = outline.raw_count[k];
      lp.tolerance = outline.tolerance[k];
      const std::size_t first = static_cast<std::size_t>(loops.first[k]);
      double area2 = 0;
      for (int i = 0, j = lp.count - 1; i < lp.count; j = i++) {
        const auto& a = loops.points[first + static_cast<std::size_t>(i)];
        const auto& b = loops.points[first + static_cast<std::size_t>(j)];
        area2 += double{b[0]} * a[1] - double{a[0]} * b[1];
        lp.perimeter += std::hypot(double{a[0]} - b[0], double{a[1]} - b[1]);
        const double x = a[0], y = a[1];
        out.points2d.push_back(a);
        out.points3d.push_back({static_cast<float>(fr.origin[0] + x * fr.e1[0] + y * fr.e2[0]),
                                static_cast<float>(fr.origin[1] + x * fr.e1[1] + y * fr.e2[1]),
                                static_cast<float>(fr.origin[2] + x * fr.e1[2] + y * fr.e2[2])});
        if (!lp.is_hole) {
          hull_xy.push_back(x);
          hull_xy.push_back(y);
        }
      }
      lp.area = 0.5 * std::abs(area2);
      sp.area += lp.is_hole ? -lp.area : lp.area;
      sp.raw_area += lp.is_hole ? -lp.raw_area : lp.raw_area;
      sp.perimeter += lp.perimeter;
      out.loops.push_back(lp);
    }
    if (!settings.convex_hull || hull_xy.empty()) return;
    // The hull of the outer loops' vertices, so that it holds the polygon.
    const int n = static_cast<int>(hull_xy.size() / 2);
    polygons_detail::hull_candidates(hull_xy.data(), n, hull_order);
    polygons_detail::sort_points_xy(hull_xy.data(), hull_order, sort);
    sorted.resize(2 * hull_order.size());
    for (std::size_t i = 0; i < hull_order.size(); ++i) {
      sorted[2 * i] = hull_xy[2 * static_cast<std::size_t>(hull_order[i])];
      sorted[2 * i + 1] = hull_xy[2 * static_cast<std::size_t>(hull_order[i]) + 1];
    }
    polygons_detail::monotone_chain_sorted(sorted.data(), static_cast<int>(hull_order.size()),
                                           hull_idx);
    sp.hull_first = static_cast<int>(out.hull_points2d.size());
    sp.hull_count = static_cast<int>(hull_idx.size());
    for (const int i : hull_idx) {
      const double x = sorted[2 * static_cast<std::size_t>(i)];
      const double y = sorted[2 * static_cast<std::size_t>(i) + 1];
      out.hull_points2d.push_back({static_cast<float>(x), static_cast<float>(y)});
      out.hull_points3d.push_back({static_cast<float>(fr.origin[0] + x * fr.e1[0] + y * fr.e2[0]),
                                   static_cast<float>(fr.origin[1] + x * fr.e1[1] + y * fr.e2[1]),
                                   static_cast<float>(fr.origin[2] + x * fr.e1[2] + y * fr.e2[2])});
    }
    if (sp.hull_count >= 3) {
      hull.resize(2 * hull_idx.size());
      for (std::size_t i = 0; i < hull_idx.size(); ++i) {
        hull[2 * i] = sorted[2 * static_cast<std::size_t>(hull_idx[i])];
        hull[2 * i + 1] = sorted[2 * static_cast<std::size_t>(hull_idx[i]) + 1];
      }
      double a = 0, p = 0;
      polygons_detail::area_perimeter(hull.data(), sp.hull_count, a, p);
      sp.hull_area = std::abs(a);
      sp.hull_perimeter = p;
    }
  }
};

void PolygonExtractor::RingScratchDeleter::operator()(RingScratch* scratch) const {
  delete scratch;
}

void PolygonExtractor::extract(const OrganizedCloud& cloud, const PointRings& rings,
                               const Segmentation& segmentation, const PolygonSettings& settings,
                               PolygonSet& out) {
  unorganized::require_rings_match(cloud, rings, nullptr, "extract_polygons");
  if (segmentation.labels.width() != cloud.width() ||
      segmentation.labels.height() != cloud.height()) {
    std::ostringstream msg;
    msg << "extract_polygons: labels of " << segmentation.labels.width() << " x "
        << segmentation.labels.height() << " for a cloud of " << cloud.width() << " x "
        << cloud.height();
    throw std::invalid_argument(msg.str());
  }
  require_settings(settings);
  if (!ring_scratch_) ring_scratch_.reset(new RingScratch);
  RingScratch& sc = *ring_scratch_;
  out.clear();
  out.width = cloud.width();
  out.height = cloud.height();
  const std::size_t n = cloud.size(), n_labels = segmentation.segments.size() + 1;
  // The points of every label, grouped (a counting sort).
  sc.first.assign(n_labels + 1, 0);
  sc.points.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::int32_t l = at(segmentation.labels, i);
    if (l > 0 && static_cast<std::size_t>(l) < n_labels) {
      ++sc.first[static_cast<std::size_t>(l) + 1];
    }
  }
  for (std::size_t l = 0; l < n_labels; ++l) sc.first[l + 1] += sc.first[l];
  sc.next.assign(sc.first.begin(), sc.first.end() - 1);
  for (std::size_t i = 0; i < n; ++i) {
    const std::int32_t l = at(segmentation.labels, i);
    if (l > 0 && static_cast<std::size_t>(l) < n_labels) {
      sc.points[static_cast<std::size_t>(sc.next[static_cast<std::size_t>(l)]++)] =
          static_cast<std::int32_t>(i);
    }
  }
  unorganized::pack_points(cloud, sc.xyz);
  const Vec vp{settings.viewpoint[0], settings.viewpoint[1], settings.viewpoint[2]};
  sc.segment_of.assign(n_labels, nullptr);
  for (const Segment& seg : segmentation.segments) {
    if (seg.label >= 1 && static_cast<std::size_t>(seg.label) < n_labels) {
      sc.segment_of[static_cast<std::size_t>(seg.label)] = &seg;
    }
  }
  sc.local.assign(n, -1);
  for (std::size_t l = 1; l < n_labels; ++l) {  // by label ascending, as from the grid
    const Segment* seg = sc.segment_of[l];
    if (seg == nullptr) continue;
    if (settings.planes_only && !is_plane(*seg)) continue;
    if (seg->pixel_count < settings.min_segment_pixels) continue;
    if (!std::isfinite(seg->offset) || !std::isfinite(seg->normal[0]) ||
        !std::isfinite(seg->normal[1]) || !std::isfinite(seg->normal[2])) {
      continue;
    }
    sc.members.clear();
    for (std::int32_t a = sc.first[l]; a < sc.first[l + 1]; ++a) {
      const std::int32_t i = sc.points[static_cast<std::size_t>(a)];
      if (!std::isnan(sc.xyz[3 * static_cast<std::size_t>(i)])) sc.members.push_back(i);
    }
    SegmentPolygons& sp = out.segments.emplace_back();
    sp.label = seg->label;
    sp.frame = polygons_detail::plane_frame(*seg);
    sp.first_loop = static_cast<int>(out.loops.size());
    sp.hull_first = static_cast<int>(out.hull_points2d.size());
    if (sc.members.empty()) continue;
    const Projection pr = polygons_detail::make_projection(sp.frame, vp);
    for (std::size_t a = 0; a < sc.members.size(); ++a) {
      sc.local[static_cast<std::size_t>(sc.members[a])] = static_cast<std::int32_t>(a);
    }
    if (seg->grazing) {
      grazing_footprints(sc.xyz, rings, sc.members, sc.local, pr, sc.f);
    } else {
      footprints(sc.xyz, rings, sc.members, sc.local, pr, sc.f);
    }
    for (const std::int32_t i : sc.members) sc.local[static_cast<std::size_t>(i)] = -1;
    const double side = sc.f.median_side;
    // The segment's inradius, its area (footprints of about side^2 each) taken as a square's.
    const double inradius = 0.5 * side * std::sqrt(static_cast<double>(sc.members.size()));
    const double tolerance = std::max(
        std::min(settings.simplify_tolerance, settings.simplify_inradius_fraction * inradius),
        settings.simplify_tolerance_pixels * side);
    if (!sc.trace(tolerance)) continue;
    sc.arrange(settings.min_loop_pixels * side * side, 1e-3 * side);
    sc.write(settings, out, static_cast<int>(out.segments.size()) - 1, sp);
  }
}

void extract_polygons(const OrganizedCloud& cloud, const PointRings& rings,
                      const Segmentation& segmentation, const PolygonSettings& settings,
                      PolygonSet& out) {
  PolygonExtractor extractor;
  extractor.extract(cloud, rings, segmentation, settings, out);
}

}  // namespace rangeseg
