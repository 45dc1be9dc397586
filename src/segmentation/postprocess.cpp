// Post-processing of the grown regions: least-squares refit, merging of adjacent coplanar
// segments, removal of small segments, compaction (re-assignment of boundary points:
// reassign.cpp).
// Contraction into fused multiply-adds is off in this file, so that the vectorised face areas
// equal the scalar ones on every CPU.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <utility>

#include <Eigen/Eigenvalues>

#include "detail/headroom.hpp"
#include "detail/simd.hpp"
#include "detail/sort_distinct.hpp"
#include "segmentation/internal.hpp"

namespace rangeseg::seg {
namespace {

/// The faces of a run of cells that all carry one label (see accumulate_areas), summed in any
/// order. Their twice-areas are non-negative floats, so each is an integer multiple of the unit in
/// the last place of the smallest positive one, w = 2^(e - 24) with 2^(e-1) <= smallest; while
/// the total stays below 2^53 w every partial sum is exact in double, whatever the order, and
/// equals the scalar running sum bit for bit. Runs beyond that bound (a face far smaller than
/// the rest of a large run) mark the result inexact, and the caller recomputes in scalar order.
struct AreaRun {
  std::int32_t label = 0;
  double sum = 0;                     ///< twice the area of the faces added so far
  float smallest = __builtin_inff();  ///< smallest positive twice-area added
  bool inexact = false;

  void add(float twice_area) {
    sum += twice_area;
    if (twice_area > 0 && twice_area < smallest) smallest = twice_area;
  }
  void flush(double* area, std::int32_t next_label) {
    if (smallest < __builtin_inff()) {
      int e = 0;
      std::frexp(smallest, &e);
      // Half the bound, for the rounding of `sum` itself if it were inexact.
      if (!(sum < std::ldexp(1.0, e + 28))) inexact = true;
    }
    area[label] += 0.5 * sum;
    label = next_label;
    sum = 0;
    smallest = __builtin_inff();
  }
};

struct ScalarPoint {
  float x, y, z;
  static ScalarPoint at(const float* x, const float* y, const float* z, int u) {
    return {x[u], y[u], z[u]};
  }
};

/// |(p1 - p0) x (p3 - p2)|: twice the area of the triangle a-b-c as (a, b, a, c), or of the quad
/// a-b-d-c as its diagonals (a, d, b, c). Float is plenty for one face (sub-millimetre edges at
/// 6 m keep ~1e-4 relative precision); sums are kept in double.
inline float cross_norm_points(const ScalarPoint& p0, const ScalarPoint& p1, const ScalarPoint& p2,
                               const ScalarPoint& p3) {
  const float ux = p1.x - p0.x, uy = p1.y - p0.y, uz = p1.z - p0.z;
  const float vx = p3.x - p2.x, vy = p3.y - p2.y, vz = p3.z - p2.z;
  const float cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
  return std::sqrt(cx * cx + cy * cy + cz * cz);
}

/// Twice the area of the faces of cell a-b-c-d (a, b top; c, d bottom), as accumulate_areas.
inline float scalar_cell_twice_area(std::uint8_t bits, const ScalarPoint& a, const ScalarPoint& b,
                                    const ScalarPoint& c, const ScalarPoint& d) {
  float twice_area = 0;
  if (bits & face_bits::quad) {
    twice_area = cross_norm_points(a, d, b, c);
  } else if (bits & face_bits::diag_bc) {
    if (bits & face_bits::tri0) twice_area += cross_norm_points(a, c, a, b);
    if (bits & face_bits::tri1) twice_area += cross_norm_points(b, c, b, d);
  } else {
    if (bits & face_bits::tri0) twice_area += cross_norm_points(a, d, a, b);
    if (bits & face_bits::tri1) twice_area += cross_norm_points(a, c, a, d);
  }
  return twice_area;
}

/// A cell with corners of different labels: each face's area split among its corners.
inline void credit_cell(std::uint8_t bits, const ScalarPoint& a, const ScalarPoint& b,
                        const ScalarPoint& c, const ScalarPoint& d, std::int32_t la,
                        std::int32_t lb, std::int32_t lc, std::int32_t ld, double* area) {
  const auto credit = [&](float twice_area, std::int32_t l0, std::int32_t l1, std::int32_t l2,
                          std::int32_t l3) {
    const double share = 0.5 * twice_area / (l3 < 0 ? 3 : 4);
    area[l0] += share;
    area[l1] += share;
    area[l2] += share;
    if (l3 >= 0) area[l3] += share;
  };
  if (bits & face_bits::quad) {
    credit(cross_norm_points(a, d, b, c), la, lc, ld, lb);
  } else if (bits & face_bits::diag_bc) {
    if (bits & face_bits::tri0) credit(cross_norm_points(a, c, a, b), la, lc, lb, -1);
    if (bits & face_bits::tri1) credit(cross_norm_points(b, c, b, d), lb, lc, ld, -1);
  } else {
    if (bits & face_bits::tri0) credit(cross_norm_points(a, d, a, b), la, ld, lb, -1);
    if (bits & face_bits::tri1) credit(cross_norm_points(a, c, a, d), la, lc, ld, -1);
  }
}

/// One cell of row_areas (see accumulate_areas): `vector_area` is its twice-area when
/// `have_vector_area`, else it is computed here. Out of line, to keep the vector loop's
/// registers free.
[[gnu::noinline]] void area_cell(const float* x0, const float* y0, const float* z0, const float* x1,
                                 const float* y1, const float* z1, const std::uint8_t* faces,
                                 const std::int32_t* l0, const std::int32_t* l1, int u,
                                 float vector_area, bool have_vector_area, AreaRun& run,
                                 double* area) {
  const std::uint8_t bits = faces[u];
  if (bits == 0) return;
  const std::int32_t la = l0[u], lb = l0[u + 1], lc = l1[u], ld = l1[u + 1];
  if ((la | lb | lc | ld) == 0) return;
  const auto point = [](const float* x, const float* y, const float* z, int at) {
    return ScalarPoint::at(x, y, z, at);
  };
  if (la == lb && la == lc && la == ld) {
    const float twice_area =
        have_vector_area
            ? vector_area
            : scalar_cell_twice_area(bits, point(x0, y0, z0, u), point(x0, y0, z0, u + 1),
                                     point(x1, y1, z1, u), point(x1, y1, z1, u + 1));
    if (la != run.label) run.flush(area, la);
    run.add(twice_area);
    return;
  }
  credit_cell(bits, point(x0, y0, z0, u), point(x0, y0, z0, u + 1), point(x1, y1, z1, u),
              point(x1, y1, z1, u + 1), la, lb, lc, ld, area);
}

/// Bit k set when lane k of a comparison result (all ones or zero per lane) is set.
#if RANGESEG_SIMD_X86
RANGESEG_SIMD_INLINE unsigned lane_bits(detail::simd::i32x4 m) {
  return static_cast<unsigned>(_mm_movemask_ps((__m128)m));
}
RANGESEG_SIMD_AVX2_TARGET RANGESEG_SIMD_INLINE unsigned lane_bits(detail::simd::i32x8 m) {
  return static_cast<unsigned>(_mm256_movemask_ps((__m256)m));
}
RANGESEG_SIMD_AVX512_TARGET RANGESEG_SIMD_INLINE unsigned lane_bits(detail::simd::i32x16 m) {
  return _mm512_movepi32_mask((__m512i)m);
}
#else
template <class Mask>
RANGESEG_SIMD_INLINE unsigned lane_bits(Mask m) {
  unsigned bits = 0;
  for (int k = 0; k < static_cast<int>(sizeof(Mask) / sizeof(std::int32_t)); ++k) {
    if (m[k] != 0) bits |= 1u << k;
  }
  return bits;
}
#endif

#define RANGESEG_SIMD_KERNEL_FILE "segmentation/area_simd_kernels.hpp"
#include "detail/simd_instances.hpp"
#undef RANGESEG_SIMD_KERNEL_FILE

using CellAreasFn = int (*)(const float*, const float*, const float*, const float*, const float*,
                            const float*, const std::uint8_t*, int, float*);
#define RANGESEG_AREA_KERNEL(ns) &ns::cell_twice_areas
const CellAreasFn& cell_areas_kernel() { RANGESEG_SIMD_PICK(CellAreasFn, RANGESEG_AREA_KERNEL); }
#undef RANGESEG_AREA_KERNEL
using RowAreasFn = void (*)(const float*, const float*, const float*, const float*, const float*,
                            const float*, const std::uint8_t*, const std::int32_t*,
                            const std::int32_t*, int, AreaRun&, double*);
#define RANGESEG_ROW_AREAS_KERNEL(ns) &ns::row_areas
const RowAreasFn& row_areas_kernel() { RANGESEG_SIMD_PICK(RowAreasFn, RANGESEG_ROW_AREAS_KERNEL); }
#undef RANGESEG_ROW_AREAS_KERNEL
using AdjacencyPixelsFn = int (*)(const std::int32_t*, const std::int32_t*, int, int, std::int32_t*,
                                  int&);
#define RANGESEG_ADJACENCY_KERNEL(ns) &ns::adjacency_pixels
const AdjacencyPixelsFn& adjacency_pixels_kernel() {
  RANGESEG_SIMD_PICK(AdjacencyPixelsFn, RANGESEG_ADJACENCY_KERNEL);
}
#undef RANGESEG_ADJACENCY_KERNEL
using BorderPixelsFn = int (*)(const std::int32_t*, const std::int32_t*, const std::int32_t*, int,
                               int, std::int32_t*, int&);
#define RANGESEG_BORDER_KERNEL(ns) &ns::unlabelled_border_pixels
const BorderPixelsFn& border_pixels_kernel() {
  RANGESEG_SIMD_PICK(BorderPixelsFn, RANGESEG_BORDER_KERNEL);
}
#undef RANGESEG_BORDER_KERNEL
using RemapLabelsFn = void (*)(std::int32_t*, const std::int32_t*, int);
#define RANGESEG_REMAP_KERNEL(ns) &ns::remap_labels
const RemapLabelsFn& remap_labels_kernel() {
  RANGESEG_SIMD_PICK(RemapLabelsFn, RANGESEG_REMAP_KERNEL);
}
#undef RANGESEG_REMAP_KERNEL

using detail::PlaneFit;
using detail::PlaneStats;

/// Regions smaller than this take no part in merging: their normals are not worth testing, and
/// they are dissolved later and re-assigned point by point [pixels] (a 3x3 patch).
constexpr std::int64_t kMinFitPixels = 9;

double dot(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/// Two fitted planes describe the same surface when their normals agree within the merge angle
/// plus the statistical uncertainty of both normals, and each centroid lies on the other plane
/// within the sensor noise plus the error that the other normal's uncertainty causes over the
/// distance between the centroids.
bool same_plane(const PlaneFit& a, const PlaneFit& b, const SegmentationSettings& s,
                bool by_range = false) {
  const double k = s.merge_distance_sigmas;
  const double cos_angle = std::min(1.0, std::fabs(dot(a.normal, b.normal)));
  const double angle = std::acos(cos_angle);
  if (angle > s.merge_angle + k * std::hypot(a.normal_stderr, b.normal_stderr)) return false;
  const double dx = a.centroid[0] - b.centroid[0], dy = a.centroid[1] - b.centroid[1],
               dz = a.centroid[2] - b.centroid[2];
  const double lever2 = dx * dx + dy * dy + dz * dz;
  const auto on_plane = [&](const PlaneFit& point_of, const PlaneFit& plane) {
    const double sigma = s.noise.sigma(noise_depth(point_of.centroid, by_range));
    const double tol2 =
        k * k * (sigma * sigma + lever2 * plane.normal_stderr * plane.normal_stderr);
    const double d =
        plane.distance(point_of.centroid[0], point_of.centroid[1], point_of.centroid[2]);
    return d * d <= tol2;
  };
  return on_plane(a, b) && on_plane(b, a);
}

/// Standard error of a segment's normal direction [rad] with its residual floored at the sensor
/// noise: sqrt(max(rms^2, sigma^2) / (count lambda_1)), lambda_1 the covariance eigenvalue of the
/// segment's narrower in-plane extent. A fit's own residual can be far below the noise (a strip
/// of one quantisation terrace has rms 0 and a normal along the view ray), but its points do
/// not pin the surface's orientation better than the sensor noise across its width allows.
double floored_normal_stderr(const PlaneStats& stats, const PlaneFit& fit, double sigma) {
  const Eigen::Matrix3d cov = stats.covariance();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(cov, Eigen::EigenvaluesOnly);
  const double lambda1 = solver.eigenvalues()(1);
  if (!(lambda1 > 0)) return 3.14159265358979323846;
  const double residual2 = std::max(fit.rms * fit.rms, sigma * sigma);
  return std::sqrt(residual2 / (static_cast<double>(stats.count) * lambda1));
}

/// The residual a merge may reach: 1.5 times the larger of the parts' residuals, plus half the
/// sensor noise sigma(z) when the parts' normals do not tell them apart (their angle within
/// merge_angle plus merge_distance_sigmas floored standard errors of the smaller part's
/// normal). The slack is for what the parts' own fits cannot see, the staircase of
/// range-quantisation terraces and the calibration's bending, which tilt thin or noisy parts;
/// two compact, well-fitted parts whose normals differ beyond their uncertainty are two surfaces
/// when one plane fits their union much worse than each fits itself (box fronts a few degrees
/// apart: parts 4 mm, union 12 mm, sigma 14 mm at 3 m).
bool merged_residual_ok(const PlaneFit& merged, const PlaneStats& sa, const PlaneFit& a,
                        const PlaneStats& sb, const PlaneFit& b, const SegmentationSettings& s,
                        bool by_range) {
  const double sigma = s.noise.sigma(noise_depth(merged.centroid, by_range));
  const double pooled = std::max(a.rms, b.rms);
  if (!(merged.rms <= 1.5 * pooled + 0.5 * sigma)) return false;
  if (merged.rms <= 1.5 * pooled) return true;
  const double angle = std::acos(std::min(1.0, std::fabs(dot(a.normal, b.normal))));
  const bool a_smaller = sa.count < sb.count;
  const PlaneFit& small_fit = a_smaller ? a : b;
  const double small_sigma = s.noise.sigma(noise_depth(small_fit.centroid, by_range));
  return angle <=
         s.merge_angle + s.merge_distance_sigmas *
                             floored_normal_stderr(a_smaller ? sa : sb, small_fit, small_sigma);
}

/// The F-test view of a merge: two segments are one plane when a single plane explains the
/// union of their points as well as the sensor noise allows, i.e. the merged fit's RMS residual
/// is within the noise sigma(z) at its centroid (the residual of a correct plane fit is ~sigma)
/// and not much above the pooled RMS of the two separate fits. Two planes meeting at an angle
/// phi over a region of extent L leave a residual ~ L phi / sqrt(12), far above the noise for
/// any crease worth a segment boundary. This also joins the strips that range quantisation
/// terraces cut a grazing surface into, whose own fits are tilted by the staircase.
bool fits_as_one(const PlaneFit& merged, const PlaneStats& sa, const PlaneFit& a,
                 const PlaneStats& sb, const PlaneFit& b, const SegmentationSettings& s,
                 bool by_range = false) {
  if (std::fabs(dot(a.normal, b.normal)) < std::cos(s.merge_rms_max_angle)) return false;
  const double sigma = s.noise.sigma(noise_depth(merged.centroid, by_range));
  if (!(merged.rms <= s.merge_rms_sigmas * sigma)) return false;
  return merged_residual_ok(merged, sa, a, sb, b, s, by_range);
}

/// The scanner's view of a merge: two adjacent segments are one surface when the points of each
/// lie on the plane fitted to their union, in RMS, within merge_distance_sigmas times the noise
/// of that surface. The noise is sigma(z), or the pooled RMS residual of the two fits when that
/// is larger: a plane fit over a large area also sees the scanner's systematic distortion (the
/// calibration bends a real plane by a fraction of a millimetre over the field of view), which
/// splits a large plane into pieces whose own fits are tilted slightly against each other,
/// whereas the points of a different surface lie ~ extent * angle off the merged plane. The
/// normals must agree within merge_rms_max_angle plus merge_distance_sigmas standard errors of
/// the smaller part's normal (floored at the noise), so a thin strip (e.g. one range-quantisation
/// terrace, whose own fit faces the sensor) can join while a compact patch of another
/// orientation cannot, and the merged residual must stay within the bound of `fits_as_one`
/// relative to the parts. Cheap tests first; the eigen-solve only for strips at a large angle.
bool lies_on_merged_plane(const PlaneFit& merged, const PlaneStats& sa, const PlaneFit& a,
                          const PlaneStats& sb, const PlaneFit& b, const SegmentationSettings& s,
                          bool by_range = false) {
  const double k = s.merge_distance_sigmas;
  const double sigma = s.noise.sigma(noise_depth(merged.centroid, by_range));
  if (!merged_residual_ok(merged, sa, a, sb, b, s, by_range)) return false;
  const double na = static_cast<double>(sa.count), nb = static_cast<double>(sb.count);
  const double pooled2 = (na * a.rms * a.rms + nb * b.rms * b.rms) / (na + nb);
  const double bound2 = k * k * std::max(sigma * sigma, pooled2);
  for (const PlaneStats* part : {&sa, &sb}) {
    const double d = part->rms_distance(merged.normal, merged.offset);
    if (!(d * d <= bound2)) return false;
  }
  const double angle = std::acos(std::min(1.0, std::fabs(dot(a.normal, b.normal))));
  if (angle <= s.merge_rms_max_angle) return true;
  const bool a_smaller = sa.count < sb.count;
  const PlaneFit& small_fit = a_smaller ? a : b;
  const double small_sigma = s.noise.sigma(noise_depth(small_fit.centroid, by_range));
  return angle <= s.merge_rms_max_angle +
                      k * floored_normal_stderr(a_smaller ? sa : sb, small_fit, small_sigma);
}

/// Flag of a label pair whose regions meet only across a cut of the mesh (adjacent_pairs).
constexpr std::uint64_t kAcrossCut = std::uint64_t{1} << 63;

/// The label pairs (smaller << 32 | larger) of lattice neighbours in rows [v_begin, v_end) whose
/// regions are both large enough to fit, appended to `pairs` (with repeats); pairs that meet
/// where the mesh has no edge carry kAcrossCut. The pixels that start a pair over a mesh edge
/// go to `border` (for refine_plane_boundaries). `row_pixels`: one row.
void adjacent_pairs(const Frame& f, const std::vector<PlaneStats>& regions, int v_begin, int v_end,
                    std::int32_t* row_pixels, std::vector<std::uint64_t>& pairs,
                    std::vector<std::int32_t>& border) {
  std::uint64_t last = 0;
  const int step = f.pixel_stride;
  const std::ptrdiff_t right = f.neighbour_offset[0], down = f.neighbour_offset[2];
  // Directions 0..3 (right, down-right, down, down-left) visit every undirected edge once.
  // The forward lattice neighbours inside the image of a pixel in column u of an inner row.
  const auto inside = [&](int u, bool inner_row) {
    const bool has_right = u + step < f.width, has_left = u >= step;
    return (has_right ? 1u : 0u) |
           (inner_row ? (has_right ? 2u : 0u) | 4u | (has_left ? 8u : 0u) : 0u);
  };
  const auto visit = [&](std::ptrdiff_t i, std::int32_t a, unsigned mask) {
    if (a == 0 || regions[a].count < kMinFitPixels) return;
    const unsigned edges = f.edges[i];
    bool on_border = false;
    while (mask != 0) {
      const int k = std::countr_zero(mask);
      mask &= mask - 1;
      const std::int32_t b = f.labels[i + f.neighbour_offset[k]];
      if (b == 0 || b == a || regions[b].count < kMinFitPixels) continue;
      const bool edge = (edges >> k & 1u) != 0;
      on_border = on_border || edge;
      const std::uint64_t key = (static_cast<std::uint64_t>(std::min(a, b)) << 32) |
                                static_cast<std::uint32_t>(std::max(a, b)) |
                                (edge ? 0 : kAcrossCut);
      if (key != last) pairs.push_back(key);
      last = key;
    }
    if (on_border) border.push_back(static_cast<std::int32_t>(i));
  };
  // Inside a segment (nearly every pixel) all forward neighbours share the label.
  const auto interior = [&](std::ptrdiff_t i, std::int32_t a) {
    return f.labels[i + right] == a && f.labels[i + down] == a && f.labels[i + down - right] == a &&
           f.labels[i + down + right] == a;
  };
  // At stride 1 the inner pixels of inner rows are screened a vector at a time.
  const bool screen = step == 1 && f.width > 2;
  const AdjacencyPixelsFn adjacency_pixels = adjacency_pixels_kernel();
  for (int v = v_begin; v < v_end; v += step) {
    const std::ptrdiff_t row = v * f.stride;
    const bool inner_row = v + step < f.height;
    int u = 0;
    if (inner_row && screen) {
      visit(row, f.labels[row], inside(0, true));
      int found = 0;
      u = adjacency_pixels(f.labels + row, f.labels + row + f.stride, 1, f.width - 1, row_pixels,
                           found);
      for (int j = 0; j < found; ++j) {
        const int column = row_pixels[j];
        visit(row + column, f.labels[row + column], 0x0Fu);  // inner columns of an inner row
      }
    }
    for (; u < f.width; u += step) {
      const std::ptrdiff_t i = row + u;
      const std::int32_t a = f.labels[i];
      if (inner_row && u >= step && u + step < f.width && interior(i, a)) continue;
      visit(i, a, inside(u, inner_row));
    }
  }
}

/// The label pairs of adjacent_pairs across the column seam of a frame whose columns wrap: the
/// pixels of the last and the first lattice column of each row; kAcrossCut where the seam is
/// a step (column_seam_linked).
void column_seam_pairs(const Frame& f, const std::vector<PlaneStats>& regions,
                       std::vector<std::uint64_t>& pairs) {
  const int last = last_lattice_column(f);
  for (int v = 0; v < f.height; v += f.pixel_stride) {
    const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(v) * f.stride;
    const std::int32_t a = f.labels[row + last], b = f.labels[row];
    if (a == 0 || b == 0 || a == b || regions[a].count < kMinFitPixels ||
        regions[b].count < kMinFitPixels) {
      continue;
    }
    const bool edge = column_seam_linked(f, row + last, row);
    pairs.push_back((static_cast<std::uint64_t>(std::min(a, b)) << 32) |
                    static_cast<std::uint32_t>(std::max(a, b)) | (edge ? 0 : kAcrossCut));
  }
}

/// `settings` with its noise model scaled to what the frame's good planes show: the lower
/// tercile of RMS residual / sigma(z) over the fitted regions of at least min_region_size pixels
/// (with_measured_noise).
SegmentationSettings measured_noise(const SegmentationSettings& settings, Segmenter::Scratch& s) {
  auto& ratios = s.quantile_values;
  ratios.clear();
  for (std::size_t r = 1; r < s.regions.size(); ++r) {
    if (!s.fits[r].ok || s.regions[r].count < settings.min_region_size) continue;
    ratios.push_back(s.fits[r].rms / settings.noise.sigma(s.fits[r].centroid[2]));
  }
  if (ratios.empty()) return settings;
  const auto tercile = ratios.begin() + static_cast<std::ptrdiff_t>((ratios.size() - 1) / 3);
  std::nth_element(ratios.begin(), tercile, ratios.end());
  return with_measured_noise(settings, *tercile);
}

void merge_adjacent_planes(const Frame& f, const SegmentationSettings& settings,
                           Segmenter::Scratch& s) {
  // Row bands collect their pairs concurrently; sorting the union makes the list independent
  // of the bands.
  ensure_band_buffers(s, f.width);
  for_each_band(s, f.height, f.pixel_stride, [&](int band, int v_begin, int v_end) {
    auto& pairs = band == 0 ? s.adjacency : s.band_adjacency[static_cast<std::size_t>(band)];
    auto& border = s.band_border[static_cast<std::size_t>(band)];
    pairs.clear();
    border.clear();
    adjacent_pairs(f, s.regions, v_begin, v_end, row_pixels_of(s, band), pairs, border);
  });
  s.border_regions = s.regions.size();
  for (int band = 1; band < band_count(s); ++band) {
    const auto& pairs = s.band_adjacency[static_cast<std::size_t>(band)];
    detail::append_with_headroom(s.adjacency, pairs.begin(), pairs.end());
  }
  if (f.columns_wrap) column_seam_pairs(f, s.regions, s.adjacency);
  detail::sort_distinct(s.adjacency, s.adjacency_table);

  // Regions that meet only where the mesh is cut (a depth step, or a terrace crack of a surface
  // seen at grazing incidence) merge only when their planes agree at the noise level the frame's
  // good planes show (see measured_noise), not the sensor model's: a cut is evidence of a step.
  const SegmentationSettings across_cut = measured_noise(settings, s);
  for (const std::uint64_t key : s.adjacency) {
    std::int32_t a = find_root(s.parent, static_cast<std::int32_t>((key & ~kAcrossCut) >> 32));
    std::int32_t b = find_root(s.parent, static_cast<std::int32_t>(key & 0xFFFFFFFFu));
    if (a == b || !s.fits[a].ok || !s.fits[b].ok) continue;
    PlaneStats merged;
    PlaneFit merged_fit;
    if (!planes_merge(s.regions[a], s.fits[a], s.regions[b], s.fits[b],
                      (key & kAcrossCut) != 0 ? across_cut : settings, &merged, &merged_fit)) {
      continue;
    }
    if (s.regions[a].count < s.regions[b].count) std::swap(a, b);
    s.parent[b] = a;
    s.grazing_region[a] |= s.grazing_region[b];
    s.regions[a] = merged;
    s.fits[a] = merged_fit;
  }
}

/// Adds a third of every triangle's area (a quarter of every quad's) to each labelled corner.
/// Cells whose four corners share one label (nearly all) are summed in a running total that is
/// flushed when the label changes, so the per-label array is not hit four times per face.
/// The reference order of the sums: used at strides > 1 and when accumulate_areas_vector cannot
/// guarantee the same bits.
void accumulate_areas(const Frame& f, Segmenter::Scratch& s) {
  const std::uint8_t* const faces = f.faces;
  const int step = f.pixel_stride;
  const std::ptrdiff_t right = step, down = step * f.stride;
  double* const area = s.area.data();
  const std::int32_t* const labels = f.labels;
  std::int32_t run_label = 0;
  double run_area = 0;  // twice the area of the faces of the current run
  // At stride 1 the cells' areas come from a vector kernel, a row at a time (the last cells of
  // a row, fewer than a vector, below).
  const CellAreasFn cell_areas = cell_areas_kernel();
  s.cell_area.resize(static_cast<std::size_t>(std::max(f.width, 1)));
  float* const row_area = s.cell_area.data();
  for (int v = 0; v + step < f.height; v += step) {
    const std::ptrdiff_t row = v * f.stride;
    int vector_end = 0;  // cells [0, vector_end) of this row are in row_area
    if (step == 1 && f.width > 1) {
      vector_end = cell_areas(f.x + row, f.y + row, f.z + row, f.x + row + down, f.y + row + down,
                              f.z + row + down, faces + row, f.width - 1, row_area);
    }
    for (int u = 0; u + step < f.width; u += step) {
      const std::ptrdiff_t a = row + u, b = a + right, c = a + down, d = c + right;
      const std::uint8_t bits = faces[a];
      if (bits == 0) continue;
      const std::int32_t la = labels[a], lb = labels[b], lc = labels[c], ld = labels[d];
      if ((la | lb | lc | ld) == 0) continue;
      const auto point = [&](std::ptrdiff_t i) { return ScalarPoint{f.x[i], f.y[i], f.z[i]}; };
      // One label on all four corners (nearly every cell): add the cell's faces to the run.
      if (la == lb && la == lc && la == ld) {
        const float twice_area =
            u < vector_end ? row_area[u]
                           : scalar_cell_twice_area(bits, point(a), point(b), point(c), point(d));
        if (la != run_label) {
          area[run_label] += 0.5 * run_area;
          run_label = la;
          run_area = 0;
        }
        run_area += twice_area;
        continue;
      }
      credit_cell(bits, point(a), point(b), point(c), point(d), la, lb, lc, ld, area);
    }
  }
  area[run_label] += 0.5 * run_area;
  area[0] = 0;  // unlabelled corners collected here
}

/// accumulate_areas at stride 1, a vector of cells at a time; false (with `s.area` partly
/// filled) when a run's sum may differ from the scalar order (see AreaRun).
bool accumulate_areas_vector(const Frame& f, Segmenter::Scratch& s) {
  const RowAreasFn row_areas = row_areas_kernel();
  double* const area = s.area.data();
  const std::ptrdiff_t down = f.stride;
  AreaRun run;
  for (int v = 0; v + 1 < f.height; ++v) {
    const std::ptrdiff_t row = v * f.stride;
    row_areas(f.x + row, f.y + row, f.z + row, f.x + row + down, f.y + row + down, f.z + row + down,
              f.faces + row, f.labels + row, f.labels + row + down, f.width - 1, run, area);
  }
  run.flush(area, 0);
  area[0] = 0;  // unlabelled corners collected here
  return !run.inexact;
}

/// set_plane_fields with its plane fit `fit` (= stats.fit()) given.
void fill_plane_fields(const PlaneStats& stats, const PlaneFit& fit, Segment& seg) {
  seg.pixel_count = static_cast<int>(stats.count);
  seg.centroid = stats.mean();
  if (fit.ok) {
    seg.normal = fit.normal;
    seg.offset = fit.offset;
    seg.rms_residual = fit.rms;
  } else {
    const double dist = std::hypot(seg.centroid[0], seg.centroid[1], seg.centroid[2]);
    seg.normal = {-seg.centroid[0] / dist, -seg.centroid[1] / dist, -seg.centroid[2] / dist};
    seg.offset = dist;
    seg.rms_residual = stats.rms_distance(seg.normal, seg.offset);
  }
}

/// labels = remap[labels] over the whole label plane, in concurrent row bands.
void remap_all_labels(const Frame& f, Segmenter::Scratch& s, const std::int32_t* remap) {
  const RemapLabelsFn remap_labels = remap_labels_kernel();
  for_each_band(s, f.height, 1, [&](int, int v_begin, int v_end) {
    remap_labels(f.labels + static_cast<std::ptrdiff_t>(v_begin) * f.stride, remap,
                 static_cast<int>(static_cast<std::ptrdiff_t>(v_end - v_begin) * f.stride));
  });
}

}  // namespace

SegmentationSettings with_measured_noise(const SegmentationSettings& settings, double ratio) {
  SegmentationSettings measured = settings;
  const double scale = std::clamp(ratio, 0.05, 1.0);
  measured.noise.a *= scale;
  measured.noise.b *= scale;
  return measured;
}

double pixel_footprint(const Frame& f, Segmenter::Scratch& s, bool vertical) {
  auto& steps = s.quantile_values;
  steps.clear();
  const int step = f.pixel_stride;
  // Three rows (or columns) at a quarter, half and three quarters of the frame.
  const int lines = vertical ? f.width : f.height, length = vertical ? f.height : f.width;
  const std::ptrdiff_t along = vertical ? step * f.stride : step;
  for (int band = 1; band <= 3; ++band) {
    const int line = (lines * band / 4) / step * step;
    const std::ptrdiff_t first = vertical ? line : static_cast<std::ptrdiff_t>(line) * f.stride;
    for (int t = 0; t + step < length; t += step) {
      const std::ptrdiff_t i = first + (t / step) * along, j = i + along;
      // The range, not z: a scan around the sensor (a spinning lidar's) has points at every z.
      const double x = f.x[i], y = f.y[i], z = f.z[i];
      const double dx = f.x[j] - x, dy = f.y[j] - y, dz = f.z[j] - z;
      const double squared_range = x * x + y * y + z * z;
      const double squared_step = dx * dx + dy * dy + dz * dz;  // NaN, inf: no step
      if (!(squared_range > 0) || !std::isfinite(squared_range) || !std::isfinite(squared_step)) {
        continue;
      }
      steps.push_back(std::sqrt(squared_step / squared_range));
    }
  }
  if (steps.empty()) return 0;
  const auto middle = steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2);
  std::nth_element(steps.begin(), middle, steps.end());
  return *middle;
}

bool wide_enough(const PlaneStats& stats, int min_region_size, double footprint) {
  if (!(footprint > 0) || 2 * stats.count < min_region_size || stats.count < 3) return false;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(stats.covariance(), Eigen::EigenvaluesOnly);
  const double narrow = std::sqrt(12.0 * std::max(0.0, solver.eigenvalues()(1)));
  return narrow >= std::sqrt(2.0 * min_region_size) * footprint * noise_depth(stats.mean(), true);
}

bool planes_merge(const PlaneStats& sa, const PlaneFit& a, const PlaneStats& sb, const PlaneFit& b,
                  const SegmentationSettings& settings, PlaneStats* merged_out,
                  PlaneFit* merged_fit_out, bool by_range) {
  PlaneStats merged = sa;
  merged.merge(sb);
  const PlaneFit merged_fit = merged.fit();
  if (!merged_fit.ok) return false;
  if (!same_plane(a, b, settings, by_range) &&
      !fits_as_one(merged_fit, sa, a, sb, b, settings, by_range) &&
      !lies_on_merged_plane(merged_fit, sa, a, sb, b, settings, by_range)) {
    return false;
  }
  if (merged_out != nullptr) *merged_out = merged;
  if (merged_fit_out != nullptr) *merged_fit_out = merged_fit;
  return true;
}

namespace {

/// Union-find over raw labels in s.seam_parent: the regions below min_region_size on either
/// side of a growth band's seam that a mesh edge joins across it, or of the column seam of a
/// frame whose columns wrap (column_seam_linked), and whose planes merge (planes_merge); and
/// per root the pixels of its group in s.seam_count. A surface the seam
/// cuts into pieces, each below the minimum, would otherwise be removed before merging joins
/// them again, so whether it is kept would depend on where the seam runs. (A small piece
/// beside a large one goes, and boundary re-assignment gives its points to the large one.)
/// Returns false when there is neither seam.
bool group_seam_pieces(const Frame& f, const SegmentationSettings& settings,
                       Segmenter::Scratch& s) {
  std::size_t bands = s.growth_rows.size() < 2 ? 1 : s.growth_rows.size() - 1;
  if (bands >= 2 && s.growth_rows.back() != f.height) bands = 1;
  if (bands < 2 && !f.columns_wrap) return false;
  const auto region_count = static_cast<std::int32_t>(s.regions.size());
  detail::resize_with_headroom(s.seam_parent, static_cast<std::size_t>(region_count));
  std::iota(s.seam_parent.begin(), s.seam_parent.end(), 0);
  const auto small = [&](std::int32_t r) { return s.regions[r].count < settings.min_region_size; };
  const auto join = [&](std::int32_t a, std::int32_t c) {
    if (a <= 0 || c <= 0 || c == a || !small(a) || !small(c)) return;
    const std::int32_t ra = find_root(s.seam_parent, a), rc = find_root(s.seam_parent, c);
    if (ra == rc) return;
    const detail::PlaneFit fa = s.regions[a].fit(), fc = s.regions[c].fit();
    if (fa.ok && fc.ok && planes_merge(s.regions[a], fa, s.regions[c], fc, settings)) {
      s.seam_parent[std::max(ra, rc)] = std::min(ra, rc);
    }
  };
  const int step = f.pixel_stride;
  for (std::size_t b = 1; b < bands; ++b) {
    const int above = s.growth_rows[b] - step;  // the last lattice row of band b - 1
    if (above < 0) continue;
    for (int u = 0; u < f.width; u += step) {
      const std::ptrdiff_t i = static_cast<std::ptrdiff_t>(above) * f.stride + u;
      if (f.labels[i] <= 0) continue;
      for (int k = 0; k < 8; ++k) {
        if (kNeighbourDv[k] != 1 || ((f.edges[i] >> k) & 1u) == 0) continue;
        join(f.labels[i], f.labels[i + f.neighbour_offset[k]]);
      }
    }
  }
  if (f.columns_wrap) {
    const int last = last_lattice_column(f);
    for (int v = 0; v < f.height; v += step) {
      const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(v) * f.stride;
      if (f.labels[row + last] > 0 && f.labels[row] > 0 && column_seam_linked(f, row + last, row)) {
        join(f.labels[row + last], f.labels[row]);
      }
    }
  }
  detail::assign_with_headroom(s.seam_count, static_cast<std::size_t>(region_count), 0);
  for (std::int32_t r = 1; r < region_count; ++r) {
    s.seam_count[find_root(s.seam_parent, r)] += s.regions[r].count;
  }
  return true;
}

}  // namespace

void postprocess(const Frame& f, const SegmentationSettings& settings, Segmenter::Scratch& s,
                 Segmentation& out) {
  const auto region_count = static_cast<std::int32_t>(s.regions.size());  // incl. label 0
  const bool planes = settings.model == RegionModel::plane;

  detail::resize_with_headroom(s.parent, static_cast<std::size_t>(region_count));
  std::iota(s.parent.begin(), s.parent.end(), 0);
  detail::assign_with_headroom(s.fits, static_cast<std::size_t>(region_count), PlaneFit{});
  detail::assign_with_headroom(s.grazing_region, static_cast<std::size_t>(region_count), 0);
  // Small-region removal first: the points between two pieces of one surface (e.g. the steps of
  // a disparity-quantised wall) often form tiny regions of their own, which would keep the
  // pieces from being adjacent. Raw labels map to themselves or to 0.
  detail::assign_with_headroom(s.remap, static_cast<std::size_t>(region_count), 0);
  const double footprint = planes ? pixel_footprint(f, s) : 0;
  const bool seams = planes && settings.merge_planes && group_seam_pieces(f, settings, s);
  if (seams) detail::assign_with_headroom(s.seam_kept, static_cast<std::size_t>(region_count), 0);
  for (std::int32_t r = 1; r < region_count; ++r) {
    bool keep = s.regions[r].count >= settings.min_region_size ||
                wide_enough(s.regions[r], settings.min_region_size, footprint);
    if (!keep && seams && s.seam_count[find_root(s.seam_parent, r)] >= settings.min_region_size) {
      keep = true;
      s.seam_kept[r] = 1;
    }
    if (keep) {
      s.remap[r] = r;
      if (!s.fits[r].ok) s.fits[r] = s.regions[r].fit();
    }
  }
  remap_all_labels(f, s, s.remap.data());

  if (planes && settings.reassign_boundary) reassign_boundary(f, settings, s);
  if (planes) find_grazing_planes(f, settings, s, footprint);
  if (planes && settings.merge_planes) {
    // Re-assignment changed the statistics; without it the fits above are current.
    for (std::int32_t r = 1; r < region_count && settings.reassign_boundary; ++r) {
      if (s.remap[r] == r) s.fits[r] = s.regions[r].fit();
    }
    merge_adjacent_planes(f, settings, s);
    split_unexplained_planes(f, settings, s);
    if (settings.boundary_refine_sigmas > 0) refine_plane_boundaries(f, settings, s);
  }
  const auto region_total = static_cast<std::int32_t>(s.regions.size());  // with split parts
  // Surviving regions are the union-find roots among the kept ones; the labels go through the
  // composition root -> compact label in one pass below.
  for (std::int32_t r = 1; r < region_total; ++r) {
    s.remap[r] = s.remap[r] == r ? find_root(s.parent, r) : 0;
  }
  if (seams) {
    // Seam pieces that merging did not join into a region of min_region_size go, as they
    // would have without the seam: their root is marked in seam_kept (2), then unmapped.
    s.seam_kept.resize(static_cast<std::size_t>(region_total), 0);  // split parts
    for (std::int32_t r = 1; r < region_count; ++r) {
      const std::int32_t root = s.remap[r];
      if (s.seam_kept[r] == 1 && root > 0 && s.regions[root].count < settings.min_region_size) {
        s.seam_kept[root] = 2;
      }
    }
    for (std::int32_t r = 1; r < region_total; ++r) {
      const std::int32_t root = s.remap[r];
      if (root > 0 && s.seam_kept[root] == 2) s.remap[r] = 0;
    }
  }

  // Compact labels 1..N by size, descending (ties by raw label for determinism).
  s.order.clear();
  for (std::int32_t r = 1; r < region_total; ++r) {
    if (s.remap[r] == r) s.order.push_back(r);
  }
  detail::assign_with_headroom(s.compact, static_cast<std::size_t>(region_total), 0);
  std::sort(s.order.begin(), s.order.end(), [&](std::int32_t a, std::int32_t b) {
    const auto ca = s.regions[a].count, cb = s.regions[b].count;
    return ca != cb ? ca > cb : a < b;
  });
  for (std::size_t j = 0; j < s.order.size(); ++j) {
    s.compact[s.order[j]] = static_cast<std::int32_t>(j + 1);
  }
  for (std::int32_t r = 1; r < region_total; ++r) s.remap[r] = s.compact[s.remap[r]];
  remap_all_labels(f, s, s.remap.data());

  const std::size_t n = s.order.size();
  out.segments.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    // A Segmenter reuses `out` frame after frame: every field starts from its default, so that
    // no sphere or cylinder parameter of an earlier frame's segment stays on a plane.
    Segment& seg = out.segments[j];
    seg = Segment{};
    seg.label = static_cast<int>(j + 1);
    seg.model = settings.model;
    // After merging, the fit of every surviving region is that of its final statistics.
    if (planes && settings.merge_planes) {
      fill_plane_fields(s.regions[s.order[j]], s.fits[s.order[j]], seg);
    } else {
      fill_plane_fields(s.regions[s.order[j]], s.regions[s.order[j]].fit(), seg);
    }
    seg.grazing = s.grazing_region[s.order[j]] != 0;
  }
}

void segment_areas(const Frame& f, Segmenter::Scratch& s, std::vector<Segment>& segments) {
  const std::size_t n = segments.size();
  s.area.assign(n + 1, 0.0);
  if (f.pixel_stride != 1 || f.width < 2 || !accumulate_areas_vector(f, s)) {
    s.area.assign(n + 1, 0.0);
    accumulate_areas(f, s);
  }
  for (std::size_t j = 0; j < n; ++j) segments[j].area_m2 = s.area[j + 1];
}

void set_plane_fields(const PlaneStats& stats, Segment& seg) {
  fill_plane_fields(stats, stats.fit(), seg);
}

int adjacency_pixels(const std::int32_t* row, const std::int32_t* below, int begin, int end,
                     std::int32_t* out, int& found) {
  return adjacency_pixels_kernel()(row, below, begin, end, out, found);
}

void ensure_band_buffers(Segmenter::Scratch& s, int width) {
  const auto bands = static_cast<std::size_t>(band_count(s));
  s.row_pixels.resize(static_cast<std::size_t>(width));
  if (s.band_row_pixels.size() < bands) s.band_row_pixels.resize(bands);
  if (s.band_adjacency.size() < bands) s.band_adjacency.resize(bands);
  if (s.band_border.size() < bands) s.band_border.resize(bands);
  for (std::size_t b = 1; b < bands; ++b) {
    s.band_row_pixels[b].resize(static_cast<std::size_t>(width));
  }
  s.band_found.resize(2 * bands);
}

std::int32_t* row_pixels_of(Segmenter::Scratch& s, int band) {
  return band == 0 ? s.row_pixels.data() : s.band_row_pixels[static_cast<std::size_t>(band)].data();
}

int unlabelled_border_pixels(const std::int32_t* above, const std::int32_t* row,
                             const std::int32_t* below, int begin, int end, std::int32_t* out,
                             int& found) {
  return border_pixels_kernel()(above, row, below, begin, end, out, found);
}

}  // namespace rangeseg::seg
