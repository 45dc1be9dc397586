// Plane segments of surfaces seen at grazing incidence, whose 1-ring normals scatter too far for
// region growing: the tops of boxes and tables a few degrees below the sensor's height.
#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "segmentation/internal.hpp"

namespace rangeseg::seg {
namespace {

using detail::PlaneFit;
using detail::PlaneStats;

/// Label of the points a component has visited, until the end of find_grazing_planes.
constexpr std::int32_t kVisited = -1;

/// The inlier bound of the robust fit shrinks over these rounds, in units of max_distance_sigmas
/// times the point's noise perpendicular to the plane (see try_plane): the first plane is fitted
/// to the whole component, which may include the rims of the surfaces around it.
constexpr std::array<double, 4> kRounds{4.0, 2.0, 1.0, 1.0};

/// |n . p| / |p|: the sine of the angle between the viewing ray through p and the plane.
double ray_sine(const PlaneFit& fit, double x, double y, double z) {
  const double length = std::sqrt(x * x + y * y + z * z);
  return std::abs(fit.normal[0] * x + fit.normal[1] * y + fit.normal[2] * z) / length;
}

class GrazingFinder {
 public:
  GrazingFinder(const Frame& f, const SegmentationSettings& settings, Segmenter::Scratch& s,
                double footprint)
      : f_(f),
        settings_(settings),
        s_(s),
        footprint_(footprint),
        sin_min_(std::sin(settings.grazing_min_angle)),
        sin_max_(std::sin(settings.grazing_max_angle)),
        inv_tan_min_(1.0 / std::tan(settings.grazing_min_angle)) {}

  void run() {
    auto& pixels = s_.grazing_pixels;
    pixels.clear();
    const int step = f_.pixel_stride;
    for (int v = 0; v < f_.height; v += step) {
      for (int u = next_candidate(v, 0, f_.width, step); u < f_.width;
           u = next_candidate(v, u + step, f_.width, step)) {
        const std::ptrdiff_t i = v * f_.stride + u;
        const std::size_t begin = pixels.size();
        collect_component(i);
        if (2 * static_cast<std::int64_t>(pixels.size() - begin) >= settings_.min_region_size) {
          try_plane(begin);
        }
      }
    }
    // Visited points that joined no plane are unlabelled again.
    for (const std::int32_t i : pixels) {
      if (f_.labels[i] == kVisited) f_.labels[i] = 0;
    }
  }

 private:
  bool candidate(std::ptrdiff_t i) const { return f_.labels[i] == 0 && f_.z[i] > 0; }

  /// The first column of [u, end), in steps of `step` from u, of an unlabelled valid point of
  /// row v (end if none).
  int next_candidate(int v, int u, int end, int step) const {
    const std::ptrdiff_t row = v * f_.stride;
#if defined(__SSE2__)
    if (step == 1) {
      // Candidate lanes of 4 columns from c: label 0 and depth > 0 (false for NaN).
      const auto lanes = [&](int c) {
        const __m128i labels =
            _mm_loadu_si128(reinterpret_cast<const __m128i*>(f_.labels + row + c));
        const __m128 valid = _mm_cmpgt_ps(_mm_loadu_ps(f_.z + row + c), _mm_setzero_ps());
        return _mm_and_si128(_mm_cmpeq_epi32(labels, _mm_setzero_si128()), _mm_castps_si128(valid));
      };
      for (; u + 16 <= end; u += 16) {
        const __m128i bytes = _mm_packs_epi16(_mm_packs_epi32(lanes(u), lanes(u + 4)),
                                              _mm_packs_epi32(lanes(u + 8), lanes(u + 12)));
        const int found = _mm_movemask_epi8(bytes);
        if (found != 0) return u + std::countr_zero(static_cast<unsigned>(found));
      }
    }
#endif
    while (u < end && !candidate(row + u)) u += step;
    return std::min(u, end);
  }

  /// Vertically or horizontally adjacent samples of one surface whose angle to the viewing rays
  /// is at least grazing_min_angle lie at most footprint z / tan(angle) apart in depth, plus the
  /// noise of both.
  bool linked(std::ptrdiff_t i, std::ptrdiff_t j) const {
    const double z = std::min(f_.z[i], f_.z[j]);
    const double bound = footprint_ * z * inv_tan_min_ + settings_.max_distance_sigmas *
                                                             std::numbers::sqrt2 *
                                                             settings_.noise.sigma(z);
    return std::abs(static_cast<double>(f_.z[i]) - f_.z[j]) <= bound;
  }

  /// The unlabelled valid pixels 4-connected to `start` over linked pairs, appended to
  /// grazing_pixels and labelled kVisited.
  void collect_component(std::ptrdiff_t start) {
    auto& pixels = s_.grazing_pixels;
    const auto visit = [&](std::ptrdiff_t j) {
      f_.labels[j] = kVisited;
      pixels.push_back(static_cast<std::int32_t>(j));
    };
    visit(start);
    const int step = f_.pixel_stride;
    const std::ptrdiff_t row_step = step * f_.stride;
    for (std::size_t k = pixels.size() - 1; k < pixels.size(); ++k) {
      const std::ptrdiff_t i = pixels[k];
      const auto v = static_cast<int>(i / f_.stride);
      const auto u = static_cast<int>(i - v * f_.stride);
      if (u + step < f_.width && candidate(i + step) && linked(i, i + step)) visit(i + step);
      if (u >= step && candidate(i - step) && linked(i, i - step)) visit(i - step);
      if (v + step < f_.height && candidate(i + row_step) && linked(i, i + row_step)) {
        visit(i + row_step);
      }
      if (v >= step && candidate(i - row_step) && linked(i, i - row_step)) visit(i - row_step);
    }
  }

  /// Fits a plane to the component grazing_pixels[begin, end) robustly; a grazing plane that
  /// explains enough of it becomes a new region. The noise of a point perpendicular to a
  /// grazing plane is sigma(z) along the ray times the sine of the ray's angle to the plane,
  /// floored at that of grazing_max_angle (a sensor also places a depth at a neighbouring pixel,
  /// which moves it across the plane).
  void try_plane(std::size_t begin) {
    const std::span<const std::int32_t> pixels(s_.grazing_pixels.data() + begin,
                                               s_.grazing_pixels.size() - begin);
    // Per point: x, y, z, sigma(z), 1 / |p|, contiguous for the rounds.
    auto& points = s_.grazing_points;
    if (points.size() < 5 * pixels.size()) points.resize(5 * pixels.size());  // never shrinks
    PlaneStats stats;
    for (std::size_t k = 0; k < pixels.size(); ++k) {
      const std::int32_t i = pixels[k];
      const double x = f_.x[i], y = f_.y[i], z = f_.z[i];
      double* const p = points.data() + 5 * k;
      p[0] = x;
      p[1] = y;
      p[2] = z;
      p[3] = settings_.noise.sigma(z);
      p[4] = 1.0 / std::sqrt(x * x + y * y + z * z);
      stats.add(x, y, z);
    }
    const auto within = [&](const PlaneFit& fit, const double* p, double sigmas) {
      const double d = fit.normal[0] * p[0] + fit.normal[1] * p[1] + fit.normal[2] * p[2];
      const double sine = std::max(std::abs(d) * p[4], sin_max_);
      return std::abs(d + fit.offset) <= sigmas * p[3] * sine;
    };
    PlaneFit fit = stats.fit();
    for (const double round : kRounds) {
      const double sigmas = round * settings_.max_distance_sigmas;
      if (!fit.ok) return;
      PlaneStats inliers;
      for (std::size_t k = 0; k < pixels.size(); ++k) {
        const double* const p = points.data() + 5 * k;
        if (within(fit, p, sigmas)) inliers.add(p[0], p[1], p[2]);
      }
      if (2 * inliers.count < settings_.min_region_size) return;
      const bool same = inliers.count == stats.count && round == kRounds.back();
      stats = inliers;
      fit = stats.fit();
      if (same) break;
    }
    if (!fit.ok) return;
    const auto& c = fit.centroid;
    const double sine = ray_sine(fit, c[0], c[1], c[2]);
    // Written to reject NaN too (a point at infinite depth).
    if (!(sine >= sin_min_ && sine <= sin_max_)) return;
    if (!(fit.rms <= settings_.noise.sigma(c[2]) * sin_max_)) return;
    if (stats.count < settings_.min_region_size &&
        !wide_enough(stats, settings_.min_region_size, footprint_)) {
      return;
    }
    const auto label = static_cast<std::int32_t>(s_.regions.size());
    PlaneStats kept;
    for (std::size_t k = 0; k < pixels.size(); ++k) {
      const double* const p = points.data() + 5 * k;
      if (within(fit, p, settings_.max_distance_sigmas)) {
        f_.labels[pixels[k]] = label;
        kept.add(p[0], p[1], p[2]);
      }
    }
    if (2 * kept.count < settings_.min_region_size) {  // the last refit moved the plane
      for (const std::int32_t i : pixels) {
        if (f_.labels[i] == label) f_.labels[i] = kVisited;
      }
      return;
    }
    s_.regions.push_back(kept);
    s_.grazing_region.push_back(1);
    s_.fits.push_back(kept.fit());
    s_.parent.push_back(label);
    s_.remap.push_back(label);
  }

  const Frame& f_;
  const SegmentationSettings& settings_;
  Segmenter::Scratch& s_;
  double footprint_;
  double sin_min_, sin_max_, inv_tan_min_;
};

}  // namespace

void find_grazing_planes(const Frame& f, const SegmentationSettings& settings,
                         Segmenter::Scratch& s, double footprint) {
  if (!(settings.grazing_min_angle > 0) || !(footprint > 0)) return;
  GrazingFinder(f, settings, s, footprint).run();
}

}  // namespace rangeseg::seg

namespace rangeseg::seg {

void close_grazing_faces(const std::int32_t* labels, std::ptrdiff_t stride, int width, int height,
                         int step, bool quads, const std::vector<Segment>& segments,
                         std::uint8_t* faces, std::uint8_t* edges) {
  const std::uint8_t all = quads ? face_bits::quad : face_bits::tri0 | face_bits::tri1;
  const std::ptrdiff_t down = step * stride;
  for (int v = 0; v + step < height; v += step) {
    for (int u = 0; u + step < width; u += step) {
      const std::ptrdiff_t i = v * stride + u;
      const std::int32_t label = labels[i];
      if (label == 0 || !segments[static_cast<std::size_t>(label - 1)].grazing ||
          labels[i + step] != label || labels[i + down] != label ||
          labels[i + down + step] != label || (faces[i] & all) == all) {
        continue;
      }
      faces[i] |= all;
      if (edges == nullptr) continue;
      // Direction bits (kNeighbourDu/Dv) of the cell's edges at its corners a b / c d.
      const bool diag_bc = !quads && (faces[i] & face_bits::diag_bc) != 0;
      const bool diag_ad = !quads && !diag_bc;
      edges[i] |= static_cast<std::uint8_t>(1u | 4u | (diag_ad ? 2u : 0u));
      edges[i + step] |= static_cast<std::uint8_t>(16u | 4u | (diag_bc ? 8u : 0u));
      edges[i + down] |= static_cast<std::uint8_t>(64u | 1u | (diag_bc ? 128u : 0u));
      edges[i + down + step] |= static_cast<std::uint8_t>(64u | 16u | (diag_ad ? 32u : 0u));
    }
  }
}

}  // namespace rangeseg::seg

namespace rangeseg {

void close_grazing_cells(const Segmentation& segmentation, Mesh& mesh) {
  const LabelImage& labels = segmentation.labels;
  if (labels.width() != mesh.width() || labels.height() != mesh.height()) {
    throw std::invalid_argument("close_grazing_cells: the label image is " +
                                std::to_string(labels.width()) + "x" +
                                std::to_string(labels.height()) + ", the mesh " +
                                std::to_string(mesh.width()) + "x" + std::to_string(mesh.height()));
  }
  if (std::none_of(segmentation.segments.begin(), segmentation.segments.end(),
                   [](const Segment& s) { return s.grazing; })) {
    return;
  }
  seg::require_labels_name_segments(segmentation, "close_grazing_cells");
  if (labels.stride() != mesh.faces.stride() || labels.stride() != mesh.edges.stride()) {
    throw std::invalid_argument(
        "close_grazing_cells: the label image and the mesh planes have "
        "different row strides");
  }
  seg::close_grazing_faces(labels.row(0), labels.stride(), labels.width(), labels.height(),
                           mesh.pixel_stride, mesh.type == MeshType::quad, segmentation.segments,
                           mesh.faces.row(0), mesh.edges.row(0));
}

}  // namespace rangeseg
