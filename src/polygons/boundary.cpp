// Plane polygons: boundary edges of every segment's faces, loop tracing, projection onto the
// plane, simplification with a simplicity check, convex hulls.
//
// Boundary edges are found in one pass over the cells: per cell a byte tells which of its four
// sides (and its diagonal) are covered by a face of the cell's segment, and a side is a boundary
// edge when exactly one of the two cells sharing it covers it. Faces of different segments
// never share an edge (every corner of a face carries the face's label), so one outgoing-edge
// mask per vertex serves all segments at once. The masks, the "remaining" copy and the
// revisit positions are kept all-zero between frames, so no full-image clear is needed.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "polygons/internal.hpp"
#include "rangeseg/polygons.hpp"

namespace rangeseg {

using polygons_detail::CheckEdge;

namespace {

// Per-cell coverage bits: sides (top a-b, bottom c-d, left a-c, right b-d) covered by a face of
// the cell's segment, and a diagonal covered by exactly one of the two triangles, with the
// direction in which that triangle traverses it.
constexpr std::uint8_t kT = 1, kB = 2, kL = 4, kR = 8;
constexpr std::uint8_t kDiagAD = 16, kDiagDA = 32, kDiagCB = 64, kDiagBC = 128;

constexpr std::uint8_t side_bits(int f) {
  if (f & face_bits::quad) return kT | kB | kL | kR;
  const bool t0 = f & face_bits::tri0, t1 = f & face_bits::tri1;
  int m = 0;
  if (!(f & face_bits::diag_bc)) {  // tri0 (a,d,b), tri1 (a,c,d)
    if (t0) m |= kT | kR;
    if (t1) m |= kL | kB;
    if (t0 && !t1) m |= kDiagAD;
    if (t1 && !t0) m |= kDiagDA;
  } else {  // tri0 (a,c,b), tri1 (b,c,d)
    if (t0) m |= kT | kL;
    if (t1) m |= kB | kR;
    if (t0 && !t1) m |= kDiagCB;
    if (t1 && !t0) m |= kDiagBC;
  }
  return static_cast<std::uint8_t>(m);
}
constexpr std::array<std::uint8_t, 16> make_side_table() {
  std::array<std::uint8_t, 16> t{};
  for (int f = 0; f < 16; ++f) t[f] = side_bits(f);
  return t;
}
constexpr std::array<std::uint8_t, 16> kSides = make_side_table();

// Cells per block of the uniform-label fast path of the cell pass (stride 1).
constexpr int kBlock = 8;

// Outgoing boundary edges of a vertex from the coverage bits of its four cells: c00 up-left
// (vertex is its d), c01 up-right (its c), c10 down-left (its b), c11 down-right (its a).
inline std::uint8_t vertex_mask(unsigned c00, unsigned c01, unsigned c10, unsigned c11) {
  unsigned m = 0;
  m |= ((c01 & kB) && !(c11 & kT)) ? 1u : 0u;   // right: bottom side of c01
  m |= (c11 & kDiagAD) ? 2u : 0u;               // down-right: a -> d of c11
  m |= ((c11 & kL) && !(c10 & kR)) ? 4u : 0u;   // down: left side of c11
  m |= (c10 & kDiagBC) ? 8u : 0u;               // down-left: b -> c of c10
  m |= ((c10 & kT) && !(c00 & kB)) ? 16u : 0u;  // left: top side of c10
  m |= (c00 & kDiagDA) ? 32u : 0u;              // up-left: d -> a of c00
  m |= ((c00 & kR) && !(c01 & kL)) ? 64u : 0u;  // up: right side of c00
  m |= (c01 & kDiagCB) ? 128u : 0u;             // up-right: c -> b of c01
  return static_cast<std::uint8_t>(m);
}

using Vec = std::array<double, 3>;
double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec cross3(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec normalized(const Vec& a) {
  const double n = std::sqrt(dot(a, a));
  return {a[0] / n, a[1] / n, a[2] / n};
}

PlaneFrame make_frame(const Segment& seg) {
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

struct RawLoop {
  int label;
  int first;  // into raw_idx
  int count;
  double area_px;  // area in the image, counter-clockwise on the image positive [pixel^2]
  int seg;         // index into out.segments
  int parent;      // holes: raw loop index of the enclosing outer loop
  int u_min, u_max, v_min, v_max;  // bounding box of the vertices [pixel]
};

// Even-odd test of image point (px, py) against a raw loop (its vertices' pixel coordinates):
// whether px < the x of the crossing of edge j-i with the line y = py, multiplied out by
// (yj - yi) so that the loop has no division and no branch. Coordinates are integers and
// half-integers, so both products are exact and the decisions equal the divided form's.
bool inside_px(const std::array<std::int32_t, 2>* uv, int n, double px, double py) {
  unsigned crossings = 0;
  for (int i = 0, j = n - 1; i < n; j = i++) {
    const double xi = uv[i][0], yi = uv[i][1], xj = uv[j][0], yj = uv[j][1];
    const double d = yj - yi;
    const double a = (px - xi) * d, b = (xj - xi) * (py - yi);
    const bool straddles = (yi > py) != (yj > py);
    const bool left = (d > 0 && a < b) || (d < 0 && a > b);
    crossings += static_cast<unsigned>(straddles & left);
  }
  return (crossings & 1u) != 0;
}

// The points xy[0..n) (x, y interleaved) that may be convex hull vertices, into `out`: all but
// those strictly inside the polygon of the extreme points in 8 directions (Akl-Toussaint), which
// are interior to the hull by a margin far above rounding, so the hull is unchanged. Boundary
// loops have most of their vertices inside, and the sort before the hull is the costly part.
void hull_candidates(const double* xy, int n, std::vector<int>& out) {
  out.clear();
  // Extreme points in the directions 0, 45, ..., 315 degrees, in counter-clockwise order.
  std::array<int, 8> ext{};
  std::array<double, 8> best{};
  best.fill(-std::numeric_limits<double>::infinity());
  double extent = 0;
  for (int i = 0; i < n; ++i) {
    const double x = xy[2 * i], y = xy[2 * i + 1];
    const double d[8] = {x, x + y, y, y - x, -x, -x - y, -y, x - y};
    for (int k = 0; k < 8; ++k) {
      if (d[k] > best[k]) {
        best[k] = d[k];
        ext[k] = i;
      }
    }
    extent = std::max({extent, std::abs(x), std::abs(y)});
  }
  // A point is dropped when it is to the left of every (non-degenerate) octagon edge by more
  // than eps (cross products are in m^2; rounding is ~1e-16 (1 + extent)^2).
  const double eps = 1e-9 * (1 + extent) * (1 + extent);
  std::array<double, 8> ax{}, ay{}, ex{}, ey{};
  int edges = 0;
  for (int k = 0; k < 8 && n > 0; ++k) {
    const int a = ext[k], b = ext[(k + 1) & 7];
    if (a == b) continue;
    ax[edges] = xy[2 * a];
    ay[edges] = xy[2 * a + 1];
    ex[edges] = xy[2 * b] - ax[edges];
    ey[edges] = xy[2 * b + 1] - ay[edges];
    ++edges;
  }
  for (int i = 0; i < n; ++i) {
    bool inside = edges >= 3;
    for (int e = 0; e < edges && inside; ++e) {
      inside = ex[e] * (xy[2 * i + 1] - ay[e]) - ey[e] * (xy[2 * i] - ax[e]) > eps;
    }
    if (!inside) out.push_back(i);
  }
}

}  // namespace

struct PolygonExtractor::Scratch {
  BytePlane orig, rem;
  Plane<std::int32_t> pos;
  bool dirty = false;
  std::vector<std::uint8_t> prev_sides, cur_sides;
  std::vector<std::int32_t> starts, walk, stack;
  std::vector<RawLoop> raw;
  std::vector<std::int32_t> raw_idx;
  std::vector<std::array<std::int32_t, 2>> raw_uv;  // (u, v) of each raw_idx entry
  std::vector<std::uint8_t> enabled;
  std::vector<int> seg_of_label;
  std::vector<int> bucket_start, bucket_loops;  // raw loops grouped by segment
  std::vector<int> kept;                        // raw loops of one segment in output order
  std::vector<int> xy_first;                    // per kept loop: offset into xy (in points)
  std::vector<double> xy;                       // projected plane points of the kept loops
  std::vector<double> tolerance;
  std::vector<int> keep, keep_first;
  std::vector<std::array<int, 2>> dp_stack;
  std::vector<CheckEdge> edges;
  std::vector<std::uint8_t> bad;
  std::vector<int> hull_order, hull_idx;
  std::vector<double> hull_xy;
  std::vector<std::int32_t> hull_pix;
};

PolygonExtractor::PolygonExtractor() : scratch_(std::make_unique<Scratch>()) {}
PolygonExtractor::~PolygonExtractor() = default;
PolygonExtractor::PolygonExtractor(PolygonExtractor&&) noexcept = default;
PolygonExtractor& PolygonExtractor::operator=(PolygonExtractor&&) noexcept = default;

void PolygonExtractor::extract(const OrganizedCloud& cloud, const Mesh& mesh,
                               const Segmentation& segmentation, const PolygonSettings& settings,
                               PolygonSet& out) {
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
  if (!(settings.simplify_tolerance >= 0) || !std::isfinite(settings.simplify_tolerance) ||
      !(settings.simplify_tolerance_pixels >= 0) ||
      !std::isfinite(settings.simplify_tolerance_pixels) || !(settings.min_loop_pixels >= 0) ||
      !std::isfinite(settings.viewpoint[0]) || !std::isfinite(settings.viewpoint[1]) ||
      !std::isfinite(settings.viewpoint[2])) {
    throw std::invalid_argument(
        "PolygonExtractor::extract: tolerances and min_loop_pixels must be finite and >= 0, "
        "viewpoint finite; got simplify_tolerance " +
        std::to_string(settings.simplify_tolerance) + ", simplify_tolerance_pixels " +
        std::to_string(settings.simplify_tolerance_pixels) + ", min_loop_pixels " +
        std::to_string(settings.min_loop_pixels));
  }

  Scratch& sc = *scratch_;
  out.width = width;
  out.height = height;
  out.segments.clear();
  out.loops.clear();
  out.points3d.clear();
  out.points2d.clear();
  out.pixels.clear();
  out.hull_points3d.clear();
  out.hull_points2d.clear();
  out.hull_pixels.clear();
  if (width == 0 || height == 0) return;

  // --- which segments ---
  const std::size_t n_labels = segmentation.segments.size() + 1;
  sc.enabled.assign(n_labels, 0);
  sc.seg_of_label.assign(n_labels, -1);
  for (const Segment& seg : segmentation.segments) {
    if (seg.label < 1 || static_cast<std::size_t>(seg.label) >= n_labels) continue;
    if (settings.planes_only && seg.model != SegmentModel::plane) continue;
    if (seg.pixel_count < settings.min_segment_pixels) continue;
    if (!std::isfinite(seg.offset) || !std::isfinite(seg.normal[0]) ||
        !std::isfinite(seg.normal[1]) || !std::isfinite(seg.normal[2]))
      continue;
    sc.enabled[seg.label] = 1;
  }
  for (std::size_t l = 1; l < n_labels; ++l) {
    if (!sc.enabled[l]) continue;
    sc.seg_of_label[l] = static_cast<int>(out.segments.size());
    SegmentPolygons sp;
    sp.label = static_cast<int>(l);
    out.segments.push_back(sp);
  }
  const std::uint8_t* en = sc.enabled.data();
  const auto enabled = [en, n_labels](std::int32_t l) {
    return static_cast<std::size_t>(static_cast<std::uint32_t>(l)) < n_labels && en[l];
  };

  // --- per-vertex outgoing boundary edges ---
  if (sc.orig.width() != width || sc.orig.height() != height || sc.dirty) {
    sc.orig.resize(width, height, 0);
    sc.rem.resize(width, height, 0);
    sc.pos.resize(width, height, 0);
  }
  sc.dirty = true;  // until the planes are all-zero again
  const std::ptrdiff_t stride = sc.orig.stride();
  if (sc.rem.stride() != stride || sc.pos.stride() != stride) {
    throw std::logic_error("PolygonExtractor: plane strides differ");
  }
  sc.prev_sides.assign(static_cast<std::size_t>(width), 0);
  sc.cur_sides.assign(static_cast<std::size_t>(width), 0);
  sc.starts.clear();
  std::uint8_t* orig = sc.orig.row(0);
  const int last_u = (width - 1) / s * s;
  for (int v = 0; v < height; v += s) {
    std::uint8_t* cur = sc.cur_sides.data();
    const std::uint8_t* prev = sc.prev_sides.data();
    if (v + s < height) {
      const std::int32_t* l0 = segmentation.labels.row(v);
      const std::int32_t* l1 = segmentation.labels.row(v + s);
      const std::uint8_t* f = mesh.faces.row(v);
      for (int u = 0; u + s < width; u += s) {
        if (s == 1 && u + kBlock < width) {
          // Most cells lie inside one segment (or outside all): kBlock cells whose kBlock + 1
          // corner columns in both rows carry one label take their faces' sides or nothing,
          // decided once for the block instead of per cell with branches on the labels.
          const std::int32_t label = l0[u];
          unsigned differ = 0;
          for (int i = 0; i <= kBlock; ++i) {
            differ |=
                static_cast<unsigned>(l0[u + i] ^ label) | static_cast<unsigned>(l1[u + i] ^ label);
          }
          if (differ == 0) {
            if (enabled(label)) {
              for (int i = 0; i < kBlock; ++i) cur[u + i] = kSides[f[u + i] & 15u];
            } else {
              std::memset(cur + u, 0, kBlock);
            }
            u += kBlock - 1;
            continue;
          }
        }
        const unsigned fb = f[u] & 15u;
        if (fb == 0) {
          cur[u] = 0;
          continue;
        }
        const std::int32_t la = l0[u], lb = l0[u + s], lc = l1[u], ld = l1[u + s];
        unsigned fe;
        if (la == lb && la == lc && la == ld) {
          fe = enabled(la) ? fb : 0u;
        } else if (fb & face_bits::quad) {
          fe = 0;
        } else {
          bool t0, t1;
          if (fb & face_bits::diag_bc) {
            t0 = la == lc && la == lb && enabled(la);
            t1 = lb == lc && lb == ld && enabled(lb);
          } else {
            t0 = la == ld && la == lb && enabled(la);
            t1 = la == lc && la == ld && enabled(la);
          }
          fe = (fb & face_bits::diag_bc) | (t0 ? (fb & face_bits::tri0) : 0u) |
               (t1 ? (fb & face_bits::tri1) : 0u);
        }
        cur[u] = kSides[fe];
      }
      cur[last_u] = 0;
    } else {
      for (int u = 0; u < width; u += s) cur[u] = 0;
    }
    std::uint8_t* mrow = orig + v * stride;
    for (int u = 0; u < width; u += s) {
      if (s == 1 && u >= 1 && u + 8 < width) {
        // Interior runs: 9 cells above and below all fully covered (or all empty) give no
        // boundary at the 8 vertices between them.
        std::uint64_t a, b, a1, b1;
        std::memcpy(&a, prev + u - 1, 8);
        std::memcpy(&b, cur + u - 1, 8);
        std::memcpy(&a1, prev + u, 8);
        std::memcpy(&b1, cur + u, 8);
        constexpr std::uint64_t kFull = 0x0F0F0F0F0F0F0F0Full;
        if ((a == kFull && b == kFull && a1 == kFull && b1 == kFull) ||
            (a == 0 && b == 0 && a1 == 0 && b1 == 0)) {
          u += 7;
          continue;
        }
      }
      const unsigned c11 = cur[u], c01 = prev[u];
      const unsigned c10 = u >= s ? cur[u - s] : 0u, c00 = u >= s ? prev[u - s] : 0u;
      if ((c00 | c01 | c10 | c11) == 0) continue;
      const std::uint8_t m = vertex_mask(c00, c01, c10, c11);
      if (m != 0) {
        mrow[u] = m;
        sc.starts.push_back(static_cast<std::int32_t>(v * stride + u));
      }
    }
    std::swap(sc.prev_sides, sc.cur_sides);
  }

  // --- loops ---
  sc.raw.clear();
  sc.raw_idx.clear();
  sc.raw_uv.clear();
  polygons_detail::trace_loops(orig, sc.rem.row(0), sc.pos.row(0), stride, s, sc.starts, sc.walk,
                               sc.stack, [&](const std::int32_t* idx, int n) {
                                 // Pixel coordinates once per vertex (one 32-bit division; the
                                 // index fits).
                                 const std::int32_t row_len = static_cast<std::int32_t>(stride);
                                 const std::size_t first = sc.raw_uv.size();
                                 int u_min = width, u_max = -1, v_min = height, v_max = -1;
                                 for (int i = 0; i < n; ++i) {
                                   const std::int32_t v = idx[i] / row_len,
                                                      u = idx[i] - v * row_len;
                                   sc.raw_uv.push_back({u, v});
                                   u_min = std::min(u_min, u);
                                   u_max = std::max(u_max, u);
                                   v_min = std::min(v_min, v);
                                   v_max = std::max(v_max, v);
                                 }
                                 const std::array<std::int32_t, 2>* uv = sc.raw_uv.data() + first;
                                 const int label = segmentation.labels.row(uv[0][1])[uv[0][0]];
                                 // Shoelace on the image (y down): counter-clockwise on the image
                                 // is negative there.
                                 std::int64_t twice = 0;
                                 for (int i = 0, j = n - 1; i < n; j = i++) {
                                   twice += static_cast<std::int64_t>(uv[j][0]) * uv[i][1] -
                                            static_cast<std::int64_t>(uv[i][0]) * uv[j][1];
                                 }
                                 RawLoop r{label,
                                           static_cast<int>(sc.raw_idx.size()),
                                           n,
                                           -0.5 * static_cast<double>(twice),
                                           sc.seg_of_label[static_cast<std::size_t>(label)],
                                           -1,
                                           u_min,
                                           u_max,
                                           v_min,
                                           v_max};
                                 sc.raw.push_back(r);
                                 sc.raw_idx.insert(sc.raw_idx.end(), idx, idx + n);
                               });
  for (std::int32_t p : sc.starts) orig[p] = 0;
  sc.dirty = false;

  // --- group raw loops by segment (counting sort keeps the tracing order) ---
  const std::size_t n_segs = out.segments.size();
  sc.bucket_start.assign(n_segs + 1, 0);
  for (const RawLoop& r : sc.raw) ++sc.bucket_start[static_cast<std::size_t>(r.seg) + 1];
  for (std::size_t i = 0; i < n_segs; ++i) sc.bucket_start[i + 1] += sc.bucket_start[i];
  sc.bucket_loops.resize(sc.raw.size());
  {
    sc.kept.assign(sc.bucket_start.begin(), sc.bucket_start.end() - 1);  // fill cursors
    for (std::size_t i = 0; i < sc.raw.size(); ++i) {
      sc.bucket_loops[static_cast<std::size_t>(
          sc.kept[static_cast<std::size_t>(sc.raw[i].seg)]++)] = static_cast<int>(i);
    }
  }

  const Vec vp{settings.viewpoint[0], settings.viewpoint[1], settings.viewpoint[2]};
  for (std::size_t si = 0; si < n_segs; ++si) {
    SegmentPolygons& sp = out.segments[si];
    const Segment& seg = segmentation.segments[static_cast<std::size_t>(sp.label - 1)];
    sp.frame = make_frame(seg);
    sp.first_loop = static_cast<int>(out.loops.size());
    sp.hull_first = static_cast<int>(out.hull_points2d.size());
    const int b0 = sc.bucket_start[si], b1 = sc.bucket_start[si + 1];
    if (b0 == b1) continue;

    // Outer loops (positive) by area descending, each followed by its holes.
    int largest = -1;
    for (int b = b0; b < b1; ++b) {
      const RawLoop& r = sc.raw[static_cast<std::size_t>(sc.bucket_loops[b])];
      if (r.area_px > 0 &&
          (largest < 0 || r.area_px > sc.raw[static_cast<std::size_t>(largest)].area_px))
        largest = sc.bucket_loops[b];
    }
    if (largest < 0) continue;
    sc.kept.clear();
    for (int b = b0; b < b1; ++b) {
      const int li = sc.bucket_loops[b];
      const RawLoop& r = sc.raw[static_cast<std::size_t>(li)];
      if (r.area_px > 0 && (li == largest || r.area_px >= settings.min_loop_pixels))
        sc.kept.push_back(li);
    }
    std::sort(sc.kept.begin(), sc.kept.end(), [&](int a, int b) {
      const double aa = sc.raw[static_cast<std::size_t>(a)].area_px,
                   ab = sc.raw[static_cast<std::size_t>(b)].area_px;
      return aa != ab ? aa > ab : a < b;
    });
    const std::size_t n_outer = sc.kept.size();
    for (int b = b0; b < b1; ++b) {
      const int li = sc.bucket_loops[b];
      RawLoop& r = sc.raw[static_cast<std::size_t>(li)];
      if (r.area_px >= 0 || -r.area_px < settings.min_loop_pixels) continue;
      r.parent = -1;
      if (n_outer == 1) {
        r.parent = sc.kept[0];
      } else {
        // Midpoint of the hole's first edge: never on another loop's edge (edges are unique).
        const std::array<std::int32_t, 2>* uv = sc.raw_uv.data() + r.first;
        const double px = 0.5 * static_cast<double>(uv[0][0] + uv[1][0]);
        const double py = 0.5 * static_cast<double>(uv[0][1] + uv[1][1]);
        for (std::size_t k = n_outer; k-- > 0;) {  // smallest enclosing outer loop
          const RawLoop& o = sc.raw[static_cast<std::size_t>(sc.kept[k])];
          if (px < o.u_min || px > o.u_max || py < o.v_min || py > o.v_max) continue;
          if (inside_px(sc.raw_uv.data() + o.first, o.count, px, py)) {
            r.parent = sc.kept[k];
            break;
          }
        }
      }
      if (r.parent >= 0) sc.kept.push_back(li);
    }
    // Output order: each outer loop followed by its holes, in tracing order (loop index as the
    // tie-break: std::sort, unlike std::stable_sort, never allocates).
    std::sort(sc.kept.begin() + static_cast<std::ptrdiff_t>(n_outer), sc.kept.end(),
              [&](int a, int b) {
                const auto rank = [&](int li) {
                  const int parent = sc.raw[static_cast<std::size_t>(li)].parent;
                  return std::find(sc.kept.begin(),
                                   sc.kept.begin() + static_cast<std::ptrdiff_t>(n_outer), parent) -
                         sc.kept.begin();
                };
                const auto ra = rank(a), rb = rank(b);
                return ra != rb ? ra < rb : a < b;
              });

    // Project every kept loop onto the plane.
    const PlaneFrame& fr = sp.frame;
    const double nvp = dot(fr.normal, vp) + fr.offset;
    sc.xy_first.clear();
    sc.xy.clear();
    for (int li : sc.kept) {
      const RawLoop& r = sc.raw[static_cast<std::size_t>(li)];
      sc.xy_first.push_back(static_cast<int>(sc.xy.size() / 2));
      for (int i = 0; i < r.count; ++i) {
        const auto [u, v] = sc.raw_uv[static_cast<std::size_t>(r.first + i)];
        const Vec p{cloud.x.row(v)[u], cloud.y.row(v)[u], cloud.z.row(v)[u]};
        const Vec dir{p[0] - vp[0], p[1] - vp[1], p[2] - vp[2]};
        const double denom = dot(fr.normal, dir);
        Vec q;
        if (denom < -1e-6 * std::sqrt(dot(dir, dir)) && nvp > 0) {
          const double t = -nvp / denom;
          q = {vp[0] + t * dir[0], vp[1] + t * dir[1], vp[2] + t * dir[2]};
        } else {
          const double dist = dot(fr.normal, p) + fr.offset;
          q = {p[0] - dist * fr.normal[0], p[1] - dist * fr.normal[1], p[2] - dist * fr.normal[2]};
        }
        const Vec rel{q[0] - fr.origin[0], q[1] - fr.origin[1], q[2] - fr.origin[2]};
        sc.xy.push_back(dot(rel, fr.e1));
        sc.xy.push_back(dot(rel, fr.e2));
      }
    }
    sc.xy_first.push_back(static_cast<int>(sc.xy.size() / 2));

    // Simplify; loops that cross another loop (or themselves) get half the tolerance, and after a
    // few halvings stay unsimplified (the mesh boundary is simple).
    const std::size_t nk = sc.kept.size();
    sc.tolerance.resize(nk);
    for (std::size_t k = 0; k < nk; ++k) {
      const int n = sc.xy_first[k + 1] - sc.xy_first[k];
      double area, perim;
      polygons_detail::area_perimeter(sc.xy.data() + 2 * sc.xy_first[k], n, area, perim);
      sc.tolerance[k] =
          std::max(settings.simplify_tolerance, settings.simplify_tolerance_pixels * perim / n);
    }
    for (int attempt = 0;; ++attempt) {
      sc.keep.clear();
      sc.keep_first.clear();
      for (std::size_t k = 0; k < nk; ++k) {
        sc.keep_first.push_back(static_cast<int>(sc.keep.size()));
        const int n = sc.xy_first[k + 1] - sc.xy_first[k];
        polygons_detail::simplify_closed(sc.xy.data() + 2 * sc.xy_first[k], n, sc.tolerance[k],
                                         sc.keep, sc.dp_stack);
      }
      sc.keep_first.push_back(static_cast<int>(sc.keep.size()));
      bool any_simplified = false;
      for (std::size_t k = 0; k < nk; ++k) any_simplified |= sc.tolerance[k] > 0;
      if (!any_simplified) break;
      sc.edges.clear();
      for (std::size_t k = 0; k < nk; ++k) {
        const RawLoop& r = sc.raw[static_cast<std::size_t>(sc.kept[k])];
        const int kb = sc.keep_first[k], ke = sc.keep_first[k + 1];
        const double* base = sc.xy.data() + 2 * sc.xy_first[k];
        for (int i = kb, j = ke - 1; i < ke; j = i++) {
          const int a = sc.keep[static_cast<std::size_t>(j)],
                    b = sc.keep[static_cast<std::size_t>(i)];
          sc.edges.push_back({base[2 * a], base[2 * a + 1], base[2 * b], base[2 * b + 1],
                              sc.raw_idx[static_cast<std::size_t>(r.first + a)],
                              sc.raw_idx[static_cast<std::size_t>(r.first + b)],
                              static_cast<int>(k)});
        }
      }
      sc.bad.assign(nk, 0);
      if (!polygons_detail::mark_crossings(sc.edges, sc.bad)) break;
      for (std::size_t k = 0; k < nk; ++k) {
        if (sc.bad[k]) sc.tolerance[k] = attempt >= 4 ? 0.0 : 0.5 * sc.tolerance[k];
      }
      if (attempt >= 5) break;  // every offender is unsimplified now
    }

    // Write the loops.
    for (std::size_t k = 0; k < nk; ++k) {
      const RawLoop& r = sc.raw[static_cast<std::size_t>(sc.kept[k])];
      const double* base = sc.xy.data() + 2 * sc.xy_first[k];
      PolygonLoop lp;
      lp.segment = static_cast<int>(si);
      lp.label = sp.label;
      lp.is_hole = r.area_px < 0;
      if (lp.is_hole) {
        const auto it = std::find(sc.kept.begin(), sc.kept.end(), r.parent);
        lp.parent = sp.first_loop + static_cast<int>(it - sc.kept.begin());
      }
      lp.raw_count = r.count;
      lp.tolerance = sc.tolerance[k];
      double a, p;
      polygons_detail::area_perimeter(base, r.count, a, p);
      lp.raw_area = std::abs(a);
      lp.raw_perimeter = p;
      lp.first = static_cast<int>(out.points2d.size());
      const int kb = sc.keep_first[k], ke = sc.keep_first[k + 1];
      lp.count = ke - kb;
      sc.hull_xy.clear();
      for (int i = kb; i < ke; ++i) {
        const int vi = sc.keep[static_cast<std::size_t>(i)];
        const double x = base[2 * vi], y = base[2 * vi + 1];
        sc.hull_xy.push_back(x);
        sc.hull_xy.push_back(y);
        out.points2d.push_back({static_cast<float>(x), static_cast<float>(y)});
        out.points3d.push_back({static_cast<float>(fr.origin[0] + x * fr.e1[0] + y * fr.e2[0]),
                                static_cast<float>(fr.origin[1] + x * fr.e1[1] + y * fr.e2[1]),
                                static_cast<float>(fr.origin[2] + x * fr.e1[2] + y * fr.e2[2])});
        const auto [pu, pv] = sc.raw_uv[static_cast<std::size_t>(r.first + vi)];
        out.pixels.push_back({static_cast<float>(pu), static_cast<float>(pv)});
      }
      polygons_detail::area_perimeter(sc.hull_xy.data(), lp.count, a, p);
      lp.area = std::abs(a);
      lp.perimeter = p;
      sp.area += lp.is_hole ? -lp.area : lp.area;
      sp.raw_area += lp.is_hole ? -lp.raw_area : lp.raw_area;
      sp.perimeter += lp.perimeter;
      out.loops.push_back(lp);
    }
    sp.loop_count = static_cast<int>(nk);

    // Convex hull of the outer loops' mesh boundary vertices.
    if (settings.convex_hull) {
      const double* xy = sc.xy.data();
      hull_candidates(xy, sc.xy_first[n_outer], sc.hull_order);
      const int n_pts = static_cast<int>(sc.hull_order.size());
      // (x, y), then the vertex index: equal points keep a deterministic order.
      std::sort(sc.hull_order.begin(), sc.hull_order.end(), [xy](int a, int b) {
        if (xy[2 * a] != xy[2 * b]) return xy[2 * a] < xy[2 * b];
        if (xy[2 * a + 1] != xy[2 * b + 1]) return xy[2 * a + 1] < xy[2 * b + 1];
        return a < b;
      });
      sc.hull_xy.resize(2 * static_cast<std::size_t>(n_pts));
      for (int i = 0; i < n_pts; ++i) {
        const int o = sc.hull_order[static_cast<std::size_t>(i)];
        sc.hull_xy[2 * static_cast<std::size_t>(i)] = xy[2 * o];
        sc.hull_xy[2 * static_cast<std::size_t>(i) + 1] = xy[2 * o + 1];
      }
      polygons_detail::monotone_chain_sorted(sc.hull_xy.data(), n_pts, sc.hull_idx);
      // Vertex o of the concatenated outer loops -> its mesh vertex, for the pixel.
      for (int hi : sc.hull_idx) {
        const int o = sc.hull_order[static_cast<std::size_t>(hi)];
        std::size_t k = 0;
        while (sc.xy_first[k + 1] <= o) ++k;
        const RawLoop& r = sc.raw[static_cast<std::size_t>(sc.kept[k])];
        const auto [pu, pv] = sc.raw_uv[static_cast<std::size_t>(r.first + o - sc.xy_first[k])];
        const double x = xy[2 * o], y = xy[2 * o + 1];
        out.hull_points2d.push_back({static_cast<float>(x), static_cast<float>(y)});
        out.hull_points3d.push_back(
            {static_cast<float>(fr.origin[0] + x * fr.e1[0] + y * fr.e2[0]),
             static_cast<float>(fr.origin[1] + x * fr.e1[1] + y * fr.e2[1]),
             static_cast<float>(fr.origin[2] + x * fr.e1[2] + y * fr.e2[2])});
        out.hull_pixels.push_back({static_cast<float>(pu), static_cast<float>(pv)});
      }
      sp.hull_count = static_cast<int>(sc.hull_idx.size());
      double a = 0, p = 0;
      sc.hull_xy.clear();
      for (int hi : sc.hull_idx) {
        const int o = sc.hull_order[static_cast<std::size_t>(hi)];
        sc.hull_xy.push_back(xy[2 * o]);
        sc.hull_xy.push_back(xy[2 * o + 1]);
      }
      if (sp.hull_count >= 3)
        polygons_detail::area_perimeter(sc.hull_xy.data(), sp.hull_count, a, p);
      sp.hull_area = std::abs(a);
      sp.hull_perimeter = p;
    }
  }
}

PolygonSet extract_polygons(const OrganizedCloud& cloud, const Mesh& mesh,
                            const Segmentation& segmentation, const PolygonSettings& settings) {
  PolygonExtractor extractor;
  PolygonSet out;
  extractor.extract(cloud, mesh, segmentation, settings, out);
  return out;
}

void loop_pixels(const PolygonSet& polygons, int loop, std::vector<std::array<float, 2>>& out) {
  if (loop < 0 || static_cast<std::size_t>(loop) >= polygons.loops.size()) {
    throw std::invalid_argument("loop_pixels: loop " + std::to_string(loop) + " out of range [0, " +
                                std::to_string(polygons.loops.size()) + ")");
  }
  const PolygonLoop& lp = polygons.loops[static_cast<std::size_t>(loop)];
  out.assign(polygons.pixels.begin() + lp.first, polygons.pixels.begin() + lp.first + lp.count);
}

void hull_pixels(const PolygonSet& polygons, int segment, std::vector<std::array<float, 2>>& out) {
  if (segment < 0 || static_cast<std::size_t>(segment) >= polygons.segments.size()) {
    throw std::invalid_argument("hull_pixels: segment " + std::to_string(segment) +
                                " out of range [0, " + std::to_string(polygons.segments.size()) +
                                ")");
  }
  const SegmentPolygons& sp = polygons.segments[static_cast<std::size_t>(segment)];
  out.assign(polygons.hull_pixels.begin() + sp.hull_first,
             polygons.hull_pixels.begin() + sp.hull_first + sp.hull_count);
}

}  // namespace rangeseg
