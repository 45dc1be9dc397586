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

#include "detail/segment_labels.hpp"
#include "segmentation/internal.hpp"

namespace rangeseg::seg {
namespace {

using detail::PlaneFit;
using detail::PlaneStats;

/// Label of the points a component has visited, until the end of find_grazing_planes.
constexpr std::int32_t kVisited = -1;

/// The inlier bound of the robust fit shrinks over these rounds, in units of max_distance_sigmas
/// times the point's noise perpendicular to the plane (see try_plane): the first plane may be
/// the least-squares plane of the whole component, which may include the rims of the surfaces
/// around it.
constexpr std::array<double, 4> kRounds{4.0, 2.0, 1.0, 1.0};

/// The first plane is chosen among the least-squares plane of the whole component and planes
/// through this many sampled triples of its points, half of them within kSampleReach places of
/// each other in the breadth-first order of the component (close on the lattice), half anywhere.
constexpr int kSamples = 24;
constexpr std::size_t kSampleReach = 48;
/// ... scored by the points within the first round's bound among at most this many of the
/// component's points, evenly spaced in its order.
constexpr std::size_t kScoredPoints = 128;

/// The width [lattice steps] of the points of `pixels` labelled `label` across their longer
/// axis in the image: sqrt(12 lambda) of the smaller eigenvalue of their positions' covariance.
double image_width(const Frame& f, std::span<const std::int32_t> pixels, std::int32_t label) {
  double n = 0, su = 0, sv = 0, suu = 0, svv = 0, suv = 0;
  for (const std::int32_t i : pixels) {
    if (f.labels[i] != label) continue;
    // Lattice row and column (integers: the lattice steps are whole pixels).
    const std::ptrdiff_t row = i / f.stride / f.pixel_stride;
    const std::ptrdiff_t column = i % f.stride / f.pixel_stride;
    const auto v = static_cast<double>(row), u = static_cast<double>(column);
    n += 1;
    su += u, sv += v, suu += u * u, svv += v * v, suv += u * v;
  }
  if (n == 0) return 0;
  const double cuu = suu / n - (su / n) * (su / n), cvv = svv / n - (sv / n) * (sv / n);
  const double cuv = suv / n - (su / n) * (sv / n);
  const double smaller = 0.5 * (cuu + cvv) - std::hypot(0.5 * (cuu - cvv), cuv);
  return std::sqrt(12.0 * std::max(0.0, smaller));
}

/// |n . p| / |p|: the sine of the angle between the viewing ray through p and the plane.
double ray_sine(const PlaneFit& fit, double x, double y, double z) {
  const double length = std::sqrt(x * x + y * y + z * z);
  return std::abs(fit.normal[0] * x + fit.normal[1] * y + fit.normal[2] * z) / length;
}

/// The parameters of the robust grazing-plane fit (fit_grazing_plane).
struct GrazingFit {
  const SegmentationSettings& settings;
  double footprint, sin_min, sin_max;
  bool by_range;
  const double* points;  // kGrazingPointSize per point
  std::size_t n;

  const double* point(std::size_t k) const { return points + kGrazingPointSize * k; }

  /// The noise of a point perpendicular to a grazing plane is sigma along the ray times the
  /// sine of the ray's angle to the plane, floored at that of grazing_max_angle (a sensor also
  /// places a depth at a neighbouring pixel, which moves it across the plane).
  bool within(const PlaneFit& fit, const double* p, double sigmas) const {
    return within_grazing_plane(fit, p, sigmas, sin_max);
  }

  /// The first plane of the robust fit (see kSamples): of the candidates whose angle to the
  /// ray at their reference point is in [grazing_min_angle, grazing_max_angle], the one with
  /// the most scored points within the first round's bound. A set that mixes a grazing surface
  /// with the rims or strips of others (whose least-squares plane is neither) starts from the
  /// grazing surface; one without any grazing candidate gets a plane that is not ok.
  PlaneFit first_plane(const PlaneStats& all) const {
    const std::size_t step = std::max<std::size_t>(1, n / kScoredPoints);
    const double sigmas = kRounds[0] * settings.max_distance_sigmas;
    PlaneFit best;
    std::size_t best_count = 0;
    const auto consider = [&](const PlaneFit& fit, const double* ref) {
      const double sine = ray_sine(fit, ref[0], ref[1], ref[2]);
      if (!(sine >= sin_min && sine <= sin_max)) return;
      std::size_t count = 0;
      for (std::size_t k = 0; k < n; k += step) count += within(fit, point(k), sigmas);
      if (count > best_count) best = fit, best_count = count;
    };
    const PlaneFit least_squares = all.fit();
    if (least_squares.ok) consider(least_squares, least_squares.centroid.data());
    // A fixed xorshift sequence per set: the result depends only on the input.
    std::uint32_t state = 0x9e3779b9u ^ static_cast<std::uint32_t>(n);
    const auto next = [&](std::size_t below) {
      state ^= state << 13, state ^= state >> 17, state ^= state << 5;
      return static_cast<std::size_t>(state % below);
    };
    const std::size_t reach = std::min(n - 1, kSampleReach);
    for (int t = 0; t < kSamples && n >= 3; ++t) {
      std::size_t i0 = 0, i1 = 0, i2 = 0;
      if (t % 2 == 0) {  // close together
        i0 = next(n - reach), i1 = i0 + 1 + next(reach), i2 = i0 + 1 + next(reach);
      } else {  // anywhere
        i0 = next(n), i1 = next(n), i2 = next(n);
      }
      if (i0 == i1 || i0 == i2 || i1 == i2) continue;
      const double* a = point(i0);
      const double* b = point(i1);
      const double* c = point(i2);
      const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
      const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      PlaneFit fit;
      fit.normal = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0]};
      const double length = std::hypot(fit.normal[0], fit.normal[1], fit.normal[2]);
      if (!(length > 0)) continue;
      for (double& e : fit.normal) e /= length;
      fit.offset = -(fit.normal[0] * a[0] + fit.normal[1] * a[1] + fit.normal[2] * a[2]);
      fit.ok = true;
      consider(fit, a);
    }
    return best;
  }

  PlaneFit run() const {
    PlaneStats stats;
    for (std::size_t k = 0; k < n; ++k) stats.add(point(k)[0], point(k)[1], point(k)[2]);
    PlaneFit fit = first_plane(stats);
    for (const double round : kRounds) {
      const double sigmas = round * settings.max_distance_sigmas;
      if (!fit.ok) return {};
      PlaneStats inliers;
      for (std::size_t k = 0; k < n; ++k) {
        const double* const p = point(k);
        if (within(fit, p, sigmas)) inliers.add(p[0], p[1], p[2]);
      }
      if (2 * inliers.count < settings.min_region_size) return {};
      const bool same = inliers.count == stats.count && round == kRounds.back();
      stats = inliers;
      fit = stats.fit();
      if (same) break;
    }
    if (!fit.ok) return {};
    const auto& c = fit.centroid;
    // The angle to the rays over the inliers, not at the centroid: the centroid of a floor all
    // round a spinning lidar lies at the sensor's foot, where the floor is seen head-on.
    double sine_sum = 0;
    std::size_t inliers = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const double* const p = point(k);
      if (!within(fit, p, settings.max_distance_sigmas)) continue;
      sine_sum +=
          std::abs(fit.normal[0] * p[0] + fit.normal[1] * p[1] + fit.normal[2] * p[2]) * p[4];
      ++inliers;
    }
    const double sine = sine_sum / static_cast<double>(inliers);
    // Written to reject NaN too (no inliers, a point at infinite depth).
    if (!(sine >= sin_min && sine <= sin_max)) return {};
    const double noise_depth = by_range ? std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) : c[2];
    if (!(fit.rms <= settings.noise.sigma(noise_depth) * sin_max)) return {};
    // A plane whose angle to the rays has sine `sine` is covered by 1 / sine times fewer points
    // than if it faced the sensor: min_region_size counts that frontal area (and the rounds
    // above ask for at least half as many points, as for any region).
    if (static_cast<double>(stats.count) < settings.min_region_size * sine &&
        !wide_enough(stats, settings.min_region_size, footprint)) {
      return {};
    }
    return fit;
  }
};

}  // namespace

bool within_grazing_plane(const PlaneFit& fit, const double* p, double sigmas, double sin_max) {
  const double d = fit.normal[0] * p[0] + fit.normal[1] * p[1] + fit.normal[2] * p[2];
  const double sine = std::max(std::abs(d) * p[4], sin_max);
  return std::abs(d + fit.offset) <= sigmas * p[3] * sine;
}

PlaneFit fit_grazing_plane(const double* points, std::size_t n,
                           const SegmentationSettings& settings, double footprint, bool by_range) {
  if (n == 0) return {};
  return GrazingFit{.settings = settings,
                    .footprint = footprint,
                    .sin_min = std::sin(settings.grazing_min_angle),
                    .sin_max = std::sin(settings.grazing_max_angle),
                    .by_range = by_range,
                    .points = points,
                    .n = n}
      .run();
}

namespace {

class GrazingFinder {
 public:
  GrazingFinder(const Frame& f, const SegmentationSettings& settings, Segmenter::Scratch& s,
                double footprint, double vertical_footprint)
      : f_(f),
        settings_(settings),
        s_(s),
        footprint_(footprint),
        vertical_footprint_(vertical_footprint),
        sin_max_(std::sin(settings.grazing_max_angle)),
        inv_tan_min_(1.0 / std::tan(settings.grazing_min_angle)) {}

  void run() {
    auto& pixels = s_.grazing_pixels;
    pixels.clear();
    const int step = f_.pixel_stride;
    for (int v = 0; v < f_.height; v += step) {
      for (int u = next_candidate(v, 0, f_.width, step); u < f_.width;
           u = next_candidate(v, u + step, f_.width, step)) {
        search_from(v * f_.stride + u);
      }
    }
    // Visited points that joined no plane are unlabelled again.
    for (const std::int32_t i : pixels) {
      if (f_.labels[i] == kVisited) f_.labels[i] = 0;
    }
  }

 private:
  // An infinite coordinate is no point, as NaN is, and a scanner's (0, 0, 0) none either. Any
  // z is: a spinning lidar's scan surrounds the sensor.
  bool candidate(std::ptrdiff_t i) const {
    return f_.labels[i] == 0 && std::isfinite(f_.z[i]) && std::isfinite(f_.x[i]) &&
           std::isfinite(f_.y[i]) && squared_range(i) > 0;
  }
  double squared_range(std::ptrdiff_t i) const {
    return static_cast<double>(f_.x[i]) * f_.x[i] + static_cast<double>(f_.y[i]) * f_.y[i] +
           static_cast<double>(f_.z[i]) * f_.z[i];
  }

  /// The component of `start` and, each time a plane is taken from one, the components of the
  /// rest of its points: a component may hold two grazing surfaces (a box's top and its side).
  void search_from(std::ptrdiff_t start) {
    auto& pixels = s_.grazing_pixels;
    auto& starts = s_.grazing_starts;
    starts.assign(1, static_cast<std::int32_t>(start));
    while (!starts.empty()) {
      const std::int32_t i = starts.back();
      starts.pop_back();
      if (!candidate(i)) continue;
      const std::size_t begin = pixels.size();
      collect_component(i);
      const auto size = static_cast<std::int64_t>(pixels.size() - begin);
      if (2 * size < settings_.min_region_size || !try_plane(begin)) continue;
      const std::size_t end = pixels.size();
      for (std::size_t k = begin; k < end; ++k) {
        if (f_.labels[pixels[k]] != kVisited) continue;
        f_.labels[pixels[k]] = 0;
        starts.push_back(pixels[k]);
      }
    }
  }

  /// The first column of [u, end), in steps of `step` from u, of an unlabelled valid point of
  /// row v (end if none).
  int next_candidate(int v, int u, int end, int step) const {
    const std::ptrdiff_t row = v * f_.stride;
#if defined(__SSE2__)
    if (step == 1) {
      // Lanes of 4 columns from c that may be candidates: label 0 and z not NaN.
      const auto lanes = [&](int c) {
        const __m128i labels =
            _mm_loadu_si128(reinterpret_cast<const __m128i*>(f_.labels + row + c));
        const __m128 z = _mm_loadu_ps(f_.z + row + c);
        const __m128 valid = _mm_cmpord_ps(z, z);
        return _mm_and_si128(_mm_cmpeq_epi32(labels, _mm_setzero_si128()), _mm_castps_si128(valid));
      };
      for (; u + 16 <= end; u += 16) {
        const __m128i bytes = _mm_packs_epi16(_mm_packs_epi32(lanes(u), lanes(u + 4)),
                                              _mm_packs_epi32(lanes(u + 8), lanes(u + 12)));
        for (int found = _mm_movemask_epi8(bytes); found != 0; found &= found - 1) {
          const int c = u + std::countr_zero(static_cast<unsigned>(found));
          if (candidate(row + c)) return c;
        }
      }
    }
#endif
    while (u < end && !candidate(row + u)) u += step;
    return std::min(u, end);
  }

  /// Vertically or horizontally adjacent samples of one surface whose angle to the viewing rays
  /// is at least grazing_min_angle lie at most footprint r / tan(angle) apart in range r, plus
  /// the noise of both (sigma at the depth z, as the growth's tests take it); the footprint of
  /// their direction on the lattice. `ri`: the range of i.
  bool linked(std::ptrdiff_t i, double ri, std::ptrdiff_t j, double footprint) const {
    const double rj = std::sqrt(squared_range(j));
    const double z = std::abs(f_.z[i]) < std::abs(f_.z[j]) ? f_.z[i] : f_.z[j];
    const double bound =
        footprint * std::min(ri, rj) * inv_tan_min_ +
        settings_.max_distance_sigmas * std::numbers::sqrt2 * settings_.noise.sigma(z);
    return std::abs(ri - rj) <= bound;
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
      const double across = footprint_, down = vertical_footprint_;
      const double r = std::sqrt(squared_range(i));
      if (u + step < f_.width && candidate(i + step) && linked(i, r, i + step, across)) {
        visit(i + step);
      }
      if (u >= step && candidate(i - step) && linked(i, r, i - step, across)) visit(i - step);
      if (v + step < f_.height && candidate(i + row_step) && linked(i, r, i + row_step, down)) {
        visit(i + row_step);
      }
      if (v >= step && candidate(i - row_step) && linked(i, r, i - row_step, down)) {
        visit(i - row_step);
      }
    }
  }

  /// Fits a plane to the component grazing_pixels[begin, end) robustly (fit_grazing_plane); a
  /// grazing plane that explains enough of it becomes a new region (returns whether one did).
  bool try_plane(std::size_t begin) {
    const std::span<const std::int32_t> pixels(s_.grazing_pixels.data() + begin,
                                               s_.grazing_pixels.size() - begin);
    auto& points = s_.grazing_points;
    if (points.size() < kGrazingPointSize * pixels.size()) {
      points.resize(kGrazingPointSize * pixels.size());  // never shrinks
    }
    for (std::size_t k = 0; k < pixels.size(); ++k) {
      const std::int32_t i = pixels[k];
      const double x = f_.x[i], y = f_.y[i], z = f_.z[i];
      double* const p = points.data() + kGrazingPointSize * k;
      p[0] = x;
      p[1] = y;
      p[2] = z;
      p[3] = settings_.noise.sigma(z);
      p[4] = 1.0 / std::sqrt(x * x + y * y + z * z);
    }
    const PlaneFit fit =
        fit_grazing_plane(points.data(), pixels.size(), settings_, footprint_, false);
    if (!fit.ok) return false;
    const auto label = static_cast<std::int32_t>(s_.regions.size());
    PlaneStats kept;
    for (std::size_t k = 0; k < pixels.size(); ++k) {
      const double* const p = points.data() + kGrazingPointSize * k;
      if (within_grazing_plane(fit, p, settings_.max_distance_sigmas, sin_max_)) {
        f_.labels[pixels[k]] = label;
        kept.add(p[0], p[1], p[2]);
      }
    }
    // 2 kept < min_region_size: the last refit moved the plane. Points on one row, column or
    // diagonal of the image (a scanner's last column) lie in one plane with the rays, and no
    // plane through them is better than another.
    if (2 * kept.count < settings_.min_region_size || narrow_strip(pixels, label, kept) ||
        image_width(f_, pixels, label) < 1.0) {
      for (const std::int32_t i : pixels) {
        if (f_.labels[i] == label) f_.labels[i] = kVisited;
      }
      return false;
    }
    s_.regions.push_back(kept);
    s_.grazing_region.push_back(1);
    s_.fits.push_back(kept.fit());
    s_.parent.push_back(label);
    s_.remap.push_back(label);
    return true;
  }

  /// Whether a plane that only its frontal area keeps (below min_region_size points and not
  /// wide_enough) is too narrow to tell from a plane through its points edge-on, their depth
  /// noise lying in it (a wall's points left along an occluding edge fit one): across a strip w
  /// wide that plane leaves a residual of about w / sqrt(12), within the fit's bound sigma(z)
  /// sin(grazing_max_angle) unless w exceeds sqrt(12) sigma(z) sin(grazing_max_angle).
  bool narrow_strip(std::span<const std::int32_t> pixels, std::int32_t label,
                    const PlaneStats& kept) const {
    if (kept.count >= settings_.min_region_size ||
        wide_enough(kept, settings_.min_region_size, footprint_)) {
      return false;
    }
    const double z = kept.sz / static_cast<double>(kept.count);
    const double width =
        image_width(f_, pixels, label) * footprint_ * noise_depth(kept.mean(), true);  // [m]
    return width <= std::sqrt(12.0) * settings_.noise.sigma(z) * sin_max_;
  }

  const Frame& f_;
  const SegmentationSettings& settings_;
  Segmenter::Scratch& s_;
  double footprint_, vertical_footprint_;
  double sin_max_, inv_tan_min_;
};

}  // namespace

void find_grazing_planes(const Frame& f, const SegmentationSettings& settings,
                         Segmenter::Scratch& s, double footprint) {
  if (!(settings.grazing_min_angle > 0) || !(footprint > 0)) return;
  const double vertical = pixel_footprint(f, s, true);
  GrazingFinder(f, settings, s, footprint, vertical > 0 ? vertical : footprint).run();
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
  detail::require_labels_name_segments(segmentation, "close_grazing_cells");
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
