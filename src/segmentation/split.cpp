// Splitting of plane segments that one plane does not explain: the inverse of merging, for
// regions that crept over a crease or a step during growing, which no test of single points can
// stop where two faces meet within the noise.
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "detail/headroom.hpp"
#include "segmentation/internal.hpp"

namespace rangeseg::seg {
namespace {

using detail::PlaneFit;
using detail::PlaneStats;

/// At most this many points of a part take part in its two-plane fit (an even subsample); the
/// final assignment visits every point.
constexpr std::size_t kMaxFitSamples = 512;
constexpr int kMaxIterations = 12;
/// Fraction of the mesh edges inside a region that the two planes of a split must leave on one
/// side (see Splitter::coherent): 0.95-1 where box fronts meet (0.84-0.87 with one smoothing
/// pass), 0.68 for a far wall's disparity terraces.
constexpr double kMinCoherence = 0.8;
/// The iterations stop when at most 1 / kSettled of the samples change planes.
constexpr std::size_t kSettled = 200;

/// Whether point (x, y, z) is closer to plane b than to plane a. The two-plane fit compares
/// distances only: normals merely choose a starting partition, because smoothing bends them
/// towards each other near a crease, and a normal term would pull the parts' border away from it.
inline bool closer_to(const PlaneFit& a, const PlaneFit& b, double x, double y, double z) {
  return std::fabs(b.distance(x, y, z)) < std::fabs(a.distance(x, y, z));
}

/// The unit eigenvector of the largest eigenvalue of a symmetric 3x3 matrix.
Eigen::Vector3d principal_axis(const Eigen::Matrix3d& m) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(m);
  return solver.eigenvectors().col(2);
}

using Part = SplitPart;

/// At most this many parts per region.
constexpr std::size_t kMaxParts = 4;

class Splitter {
 public:
  Splitter(const Frame& f, const SegmentationSettings& settings, Segmenter::Scratch& s)
      : f_(f), settings_(settings), s_(s), min_size_(settings.min_region_size) {}

  /// Whether a part's RMS residual is more than split_residual_factor times `reference` (the
  /// lower tercile of the frame's other segments' RMS / sigma(z)) times sigma(z) at its
  /// centroid, and it is large enough for two segments.
  bool flagged(const PlaneStats& stats, const PlaneFit& fit, double reference) const {
    if (!fit.ok || stats.count < 2 * min_size_) return false;
    return fit.rms >
           settings_.split_residual_factor * reference * settings_.noise.sigma(depth(fit.centroid));
  }

  /// Splits region `label` (its points pixels[0, count), all labelled `label`) into up to
  /// kMaxParts planes while a part is flagged, then merges the adjacent parts that merging
  /// would join. Parts after the first get new raw labels.
  void split_region(std::int32_t label, std::int32_t* pixels, std::size_t count, double reference) {
    measured_ = with_measured_noise(settings_, reference);
    parts_.clear();
    parts_.push_back({.label = label,
                      .begin = 0,
                      .end = count,
                      .stats = s_.regions[label],
                      .fit = s_.fits[label]});
    while (parts_.size() < kMaxParts) {
      Part* worst = nullptr;
      double worst_ratio = 0;
      for (Part& p : parts_) {
        if (!p.splittable || !flagged(p.stats, p.fit, reference)) continue;
        const double ratio = p.fit.rms / settings_.noise.sigma(depth(p.fit.centroid));
        if (ratio > worst_ratio) {
          worst_ratio = ratio;
          worst = &p;
        }
      }
      if (worst == nullptr) break;
      Part second;
      if (split_in_two(*worst, pixels, second)) {
        parts_.push_back(second);
      } else {
        worst->splittable = false;
      }
    }
    if (parts_.size() == 1) return;
    merge_parts(pixels, count);
    for (const Part& p : parts_) {
      s_.regions[p.label] = p.stats;
      s_.fits[p.label] = p.fit;
    }
  }

 private:
  /// Two-plane k-means over part `p`'s points from three starting partitions (by the normals'
  /// main direction of spread: a crease; by the side of the part's plane: a step between
  /// parallel faces; by the points' main axis: faces side by side), the cheapest result kept;
  /// then each of the two keeps its largest mesh-connected piece. On success the second part
  /// (a new raw label) is `second`, the points of both are contiguous in `pixels`.
  bool split_in_two(Part& p, std::int32_t* pixels, Part& second) {
    const std::size_t count = p.end - p.begin;
    std::int32_t* const points = pixels + p.begin;
    const std::size_t step = (count + kMaxFitSamples - 1) / kMaxFitSamples;
    auto& samples = s_.split_samples;
    samples.clear();
    for (std::size_t j = 0; j < count; j += step) samples.push_back(points[j]);
    // The samples' coordinates and weights 1 / sigma(z)^2, contiguous for the iterations.
    auto& xyzw = s_.split_xyzw;
    detail::resize_with_headroom(xyzw, 4 * samples.size());
    for (std::size_t j = 0; j < samples.size(); ++j) {
      const std::int32_t i = samples[j];
      const double sigma = settings_.noise.sigma(depth({f_.x[i], f_.y[i], f_.z[i]}));
      xyzw[4 * j] = f_.x[i];
      xyzw[4 * j + 1] = f_.y[i];
      xyzw[4 * j + 2] = f_.z[i];
      xyzw[4 * j + 3] = 1.0 / (sigma * sigma);
    }

    Eigen::Vector3d mean_n = Eigen::Vector3d::Zero();
    for (const std::int32_t i : samples) {
      const Eigen::Vector3d n(f_.nx[i], f_.ny[i], f_.nz[i]);
      if (n.allFinite()) mean_n += n;
    }
    mean_n.normalize();
    Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
    for (const std::int32_t i : samples) {
      const Eigen::Vector3d d = Eigen::Vector3d(f_.nx[i], f_.ny[i], f_.nz[i]) - mean_n;
      if (d.allFinite()) spread += d * d.transpose();
    }
    const Eigen::Vector3d normal_axis = principal_axis(spread);
    const Eigen::Vector3d point_axis = principal_axis(p.stats.covariance());
    const auto centroid = p.stats.mean();

    double best_cost = INFINITY;
    std::array<PlaneFit, 2> best{};
    for (int start = 0; start < 3; ++start) {
      auto& side = s_.split_side;
      side.assign(samples.size(), 0);
      for (std::size_t j = 0; j < samples.size(); ++j) {
        const std::int32_t i = samples[j];
        double along = 0;
        if (start == 0) {
          along = (Eigen::Vector3d(f_.nx[i], f_.ny[i], f_.nz[i]) - mean_n).dot(normal_axis);
        } else if (start == 1) {
          along = p.fit.distance(f_.x[i], f_.y[i], f_.z[i]);
        } else {
          along = (f_.x[i] - centroid[0]) * point_axis(0) +
                  (f_.y[i] - centroid[1]) * point_axis(1) + (f_.z[i] - centroid[2]) * point_axis(2);
        }
        side[j] = along > 0 ? 1 : 0;
      }
      std::array<PlaneFit, 2> fits{};
      const double total = two_means(fits);
      if (total < best_cost) {
        best_cost = total;
        best = fits;
      }
    }
    if (!(best_cost < INFINITY)) return false;
    if (!coherent(best, p.label) || rejoined_on_samples(best, step)) return false;

    const auto other = static_cast<std::int32_t>(s_.regions.size());
    for (std::size_t j = 0; j < count; ++j) {
      const std::int32_t i = points[j];
      f_.labels[i] = closer_to(best[0], best[1], f_.x[i], f_.y[i], f_.z[i]) ? other : p.label;
    }
    keep_largest_piece(points, count, other, p.label);
    keep_largest_piece(points, count, p.label, other);

    std::array<PlaneStats, 2> stats;
    for (std::size_t j = 0; j < count; ++j) {
      const std::int32_t i = points[j];
      stats[f_.labels[i] == other ? 1 : 0].add(f_.x[i], f_.y[i], f_.z[i]);
    }
    const std::array<PlaneFit, 2> fits{stats[0].fit(), stats[1].fit()};
    if (stats[0].count < min_size_ || stats[1].count < min_size_ || !fits[0].ok || !fits[1].ok) {
      for (std::size_t j = 0; j < count; ++j) f_.labels[points[j]] = p.label;
      return false;
    }
    const std::size_t first = static_cast<std::size_t>(
        std::partition(points, points + count,
                       [&](std::int32_t i) { return f_.labels[i] == p.label; }) -
        points);
    s_.regions.push_back(stats[1]);
    const std::uint8_t grazing = s_.grazing_region[static_cast<std::size_t>(p.label)];
    s_.grazing_region.push_back(grazing);
    s_.fits.push_back(fits[1]);
    s_.parent.push_back(other);
    s_.remap.push_back(other);
    second = {
        .label = other, .begin = p.begin + first, .end = p.end, .stats = stats[1], .fit = fits[1]};
    p.end = p.begin + first;
    p.stats = stats[0];
    p.fit = fits[0];
    return true;
  }

  /// Whether the two planes cut the region into spatially coherent parts: of the mesh edges
  /// from the samples to points of the region, at least kMinCoherence join points closer to the
  /// same plane. Two faces meet along a border; two planes that take alternate disparity
  /// terraces of one far wall (which fits them better than one plane) interleave.
  bool coherent(const std::array<PlaneFit, 2>& fits, std::int32_t label) const {
    std::size_t same = 0, edges = 0;
    for (const std::int32_t i : s_.split_samples) {
      const bool side = closer_to(fits[0], fits[1], f_.x[i], f_.y[i], f_.z[i]);
      for_each_neighbour(f_, i, 0xFFu, [&](std::ptrdiff_t q) {
        if (f_.labels[q] != label) return;
        ++edges;
        same += closer_to(fits[0], fits[1], f_.x[q], f_.y[q], f_.z[q]) == side ? 1 : 0;
      });
    }
    return static_cast<double>(same) >= kMinCoherence * static_cast<double>(edges);
  }

  /// Whether the two planes' sample parts, their sums scaled to the whole part (every `step`-th
  /// point was sampled), are planes that merge_parts joins again: then the split is given up
  /// before every point is assigned and flood-filled (a far wall of 10^5 points whose residual
  /// is a candidate's but is one plane costs tens of milliseconds otherwise).
  bool rejoined_on_samples(const std::array<PlaneFit, 2>& fits, std::size_t step) const {
    const auto& xyzw = s_.split_xyzw;
    std::array<PlaneStats, 2> stats;
    for (std::size_t j = 0; 4 * j < xyzw.size(); ++j) {
      const double x = xyzw[4 * j], y = xyzw[4 * j + 1], z = xyzw[4 * j + 2];
      stats[closer_to(fits[0], fits[1], x, y, z) ? 1 : 0].add(x, y, z);
    }
    std::array<PlaneFit, 2> part_fits;
    const auto scale = static_cast<double>(step);
    for (int k = 0; k < 2; ++k) {
      PlaneStats& s = stats[k];
      s.count *= static_cast<std::int64_t>(step);
      for (double* sum : {&s.sx, &s.sy, &s.sz, &s.sxx, &s.sxy, &s.sxz, &s.syy, &s.syz, &s.szz}) {
        *sum *= scale;
      }
      part_fits[k] = s.fit();
      if (!part_fits[k].ok) return false;
    }
    return planes_merge(stats[0], part_fits[0], stats[1], part_fits[1], measured_, nullptr, nullptr,
                        by_range());
  }

  /// k-means with two planes over the samples (split_xyzw) from the partition split_side: the
  /// samples' summed squared distances in units of sigma(z) (infinite when a part empties or is
  /// collinear), the planes in `fits`.
  double two_means(std::array<PlaneFit, 2>& fits) {
    const auto& xyzw = s_.split_xyzw;
    auto& side = s_.split_side;
    const std::size_t n = side.size();
    double total = INFINITY;
    for (int iteration = 0; iteration < kMaxIterations; ++iteration) {
      std::array<PlaneStats, 2> stats;
      for (std::size_t j = 0; j < n; ++j) {
        stats[side[j]].add(xyzw[4 * j], xyzw[4 * j + 1], xyzw[4 * j + 2]);
      }
      for (int k = 0; k < 2; ++k) {
        fits[k] = stats[k].fit();
        if (!fits[k].ok) return INFINITY;
      }
      std::size_t changed = 0;
      total = 0;
      for (std::size_t j = 0; j < n; ++j) {
        const double x = xyzw[4 * j], y = xyzw[4 * j + 1], z = xyzw[4 * j + 2];
        const double d0 = fits[0].distance(x, y, z), d1 = fits[1].distance(x, y, z);
        const std::uint8_t best = std::fabs(d1) < std::fabs(d0) ? 1 : 0;
        total += xyzw[4 * j + 3] * std::min(d0 * d0, d1 * d1);
        changed += best != side[j] ? 1 : 0;
        side[j] = best;
      }
      // Settled: a few samples flipping between the planes at their intersection change
      // neither fit noticeably.
      if (changed * kSettled <= n) break;
    }
    return total;
  }

  /// Among `points` labelled `label`, those outside the largest mesh-connected piece of them
  /// get `other`. (Called for one label, then the other: the first's stray pieces join the
  /// second before its own pieces are found.)
  void keep_largest_piece(const std::int32_t* points, std::size_t count, std::int32_t label,
                          std::int32_t other) {
    auto& pieces = s_.split_pieces;
    auto& piece_start = s_.split_piece_start;
    pieces.clear();
    piece_start.clear();
    std::size_t largest = 0, largest_size = 0;
    for (std::size_t j = 0; j < count; ++j) {
      const std::int32_t seed = points[j];
      if (f_.labels[seed] != label || s_.queued[seed] != 0) continue;
      const std::size_t start = pieces.size();
      piece_start.push_back(start);
      s_.queued[seed] = 1;
      pieces.push_back(seed);
      for (std::size_t head = start; head < pieces.size(); ++head) {
        const std::int32_t q = pieces[head];
        for_each_neighbour(f_, q, 0xFFu, [&](std::ptrdiff_t r) {
          if (f_.labels[r] == label && s_.queued[r] == 0) {
            s_.queued[r] = 1;
            pieces.push_back(static_cast<std::int32_t>(r));
          }
        });
      }
      if (pieces.size() - start > largest_size) {
        largest_size = pieces.size() - start;
        largest = piece_start.size() - 1;
      }
    }
    piece_start.push_back(pieces.size());
    for (std::size_t piece = 0; piece + 1 < piece_start.size(); ++piece) {
      for (std::size_t j = piece_start[piece]; j < piece_start[piece + 1]; ++j) {
        s_.queued[pieces[j]] = 0;
        if (piece != largest) f_.labels[pieces[j]] = other;
      }
    }
  }

  /// Adjacent parts that post-processing's merge tests would join at the noise level of the
  /// frame's good planes (`measured_`) are joined again, the pair whose union fits best first;
  /// a part that disappears leaves its raw label unused.
  void merge_parts(const std::int32_t* pixels, std::size_t count) {
    const std::size_t n = parts_.size();
    const auto index_of = [&](std::int32_t l) {
      for (std::size_t a = 0; a < n; ++a) {
        if (parts_[a].label == l) return static_cast<int>(a);
      }
      return -1;
    };
    // adjacent[a] bit b: parts a and b share a mesh edge.
    std::array<unsigned, kMaxParts> adjacent{};
    for (std::size_t j = 0; j < count; ++j) {
      const std::int32_t i = pixels[j];
      const int a = index_of(f_.labels[i]);
      for_each_neighbour(f_, i, 0xFFu, [&](std::ptrdiff_t q) {
        const int b = index_of(f_.labels[q]);
        if (b >= 0 && b != a) adjacent[a] |= 1u << b;
      });
    }
    // into[a]: the part that part a was merged into (itself while it stands).
    std::array<std::size_t, kMaxParts> into{};
    for (std::size_t a = 0; a < n; ++a) into[a] = a;
    for (;;) {
      std::size_t best_a = n, best_b = n;
      PlaneStats best_stats;
      PlaneFit best_fit;
      for (std::size_t a = 0; a < n; ++a) {
        for (std::size_t b = a + 1; b < n; ++b) {
          if (into[a] != a || into[b] != b || (adjacent[a] >> b & 1u) == 0) continue;
          PlaneStats merged;
          PlaneFit merged_fit;
          if (!planes_merge(parts_[a].stats, parts_[a].fit, parts_[b].stats, parts_[b].fit,
                            measured_, &merged, &merged_fit, by_range())) {
            continue;
          }
          if (best_a == n || merged_fit.rms < best_fit.rms) {
            best_a = a;
            best_b = b;
            best_stats = merged;
            best_fit = merged_fit;
          }
        }
      }
      if (best_a == n) break;
      parts_[best_a].stats = best_stats;
      parts_[best_a].fit = best_fit;
      for (std::size_t a = 0; a < n; ++a) {
        if (into[a] == best_b) into[a] = best_a;
        if ((adjacent[a] >> best_b & 1u) != 0) adjacent[a] |= 1u << best_a;
      }
      adjacent[best_a] |= adjacent[best_b];
      adjacent[best_a] &= ~(1u << best_a);
    }
    // Part 0 (the region's own label) always stands: a part merges only into one before it.
    for (std::size_t j = 0; j < count; ++j) {
      const std::int32_t i = pixels[j];
      f_.labels[i] = parts_[into[static_cast<std::size_t>(index_of(f_.labels[i]))]].label;
    }
    std::size_t kept = 0;
    for (std::size_t a = 0; a < n; ++a) {
      if (into[a] == a) {
        parts_[kept++] = parts_[a];
        continue;
      }
      s_.regions[parts_[a].label] = PlaneStats{};
      s_.fits[parts_[a].label] = PlaneFit{};
      s_.remap[parts_[a].label] = 0;
    }
    parts_.resize(kept);
  }

  bool by_range() const { return f_.ring_neighbours != nullptr; }
  double depth(const std::array<double, 3>& p) const { return noise_depth(p, by_range()); }

  const Frame& f_;
  const SegmentationSettings& settings_;
  Segmenter::Scratch& s_;
  std::int64_t min_size_;
  SegmentationSettings measured_;  ///< the merge tests' settings at the region's noise level
  std::vector<Part>& parts_ = s_.split_parts;
};

}  // namespace

void split_unexplained_planes(const Frame& f, const SegmentationSettings& settings,
                              Segmenter::Scratch& s, std::span<const double> references) {
  if (!(settings.split_residual_factor > 0)) return;
  const auto region_count = static_cast<std::int32_t>(s.regions.size());
  const auto min_size = static_cast<std::int64_t>(settings.min_region_size);
  const auto is_segment = [&](std::int32_t r) {
    return s.remap[r] == r && find_root(s.parent, r) == r && s.fits[r].ok &&
           s.regions[r].count >= min_size;
  };
  const bool by_range = f.ring_neighbours != nullptr;
  const auto ratio_of = [&](std::int32_t r) {
    return s.fits[r].rms / settings.noise.sigma(noise_depth(s.fits[r].centroid, by_range));
  };
  // What the frame's good planes achieve: RMS residual / sigma(z) of its segments, sorted; a
  // segment is compared with the lower tercile of the others (the median rises with the
  // facets of curved objects, which a plane does not explain either). Not needed when the
  // caller gives each region its own reference.
  auto& ratios = s.quantile_values;
  ratios.clear();
  if (references.empty()) {
    for (std::int32_t r = 1; r < region_count; ++r) {
      if (is_segment(r)) ratios.push_back(ratio_of(r));
    }
    if (ratios.size() < 2) return;
    std::sort(ratios.begin(), ratios.end());
  }
  const auto others_tercile = [&](double ratio) {
    const auto rank = static_cast<std::size_t>(
        std::lower_bound(ratios.begin(), ratios.end(), ratio) - ratios.begin());
    const std::size_t tercile = (ratios.size() - 1) / 3;
    return tercile < rank ? ratios[tercile] : ratios[tercile + 1];
  };
  Splitter splitter(f, settings, s);

  // The candidates, and their points gathered from the label plane (each labelled with its
  // root, which the other raw labels of a merged region map to anyway).
  auto& slot = s.split_slot;
  slot.assign(static_cast<std::size_t>(region_count), -1);
  auto& candidates = s.split_candidates;
  auto& reference = s.split_reference;
  candidates.clear();
  reference.clear();
  for (std::int32_t r = 1; r < region_count; ++r) {
    if (!is_segment(r)) continue;
    const double others = references.empty() ? others_tercile(ratio_of(r)) : references[r];
    if (!splitter.flagged(s.regions[r], s.fits[r], others)) continue;
    slot[r] = static_cast<std::int32_t>(candidates.size());
    candidates.push_back(r);
    reference.push_back(others);
  }
  if (candidates.empty()) return;
  auto& start = s.split_start;
  start.assign(candidates.size() + 1, 0);
  for (std::size_t c = 0; c < candidates.size(); ++c) {
    start[c + 1] = start[c] + static_cast<std::size_t>(s.regions[candidates[c]].count);
  }
  auto& pixels = s.split_pixels;
  detail::resize_with_headroom(pixels, start.back());
  auto& fill = s.split_fill;
  fill.assign(start.begin(), start.end() - 1);
  // Every raw label to its root's candidate (labels after small-region removal are kept ones or
  // 0, and 0 is no candidate).
  for (std::int32_t r = 1; r < region_count; ++r) {
    if (s.remap[r] == r) slot[r] = slot[find_root(s.parent, r)];
  }
  const int step = f.pixel_stride;
  for (int v = 0; v < f.height; v += step) {
    std::int32_t* const row = f.labels + static_cast<std::ptrdiff_t>(v) * f.stride;
    for (int u = 0; u < f.width; u += step) {
      const std::int32_t c = slot[row[u]];
      if (c < 0) continue;
      // A region's labelled pixels are its point count (`cell_vertex_valid` keeps the coarse
      // level so); the guard keeps a broken count from writing into the next candidate's slots.
      assert(fill[c] < start[c + 1]);
      if (fill[c] == start[c + 1]) continue;
      row[u] = candidates[c];
      pixels[fill[c]++] = static_cast<std::int32_t>(row - f.labels + u);
    }
  }
  const std::size_t frame_pixels = static_cast<std::size_t>(f.stride) * f.height;
  if (s.queued.size() != frame_pixels) s.queued.assign(frame_pixels, 0);
  for (std::size_t c = 0; c < candidates.size(); ++c) {
    splitter.split_region(candidates[c], pixels.data() + start[c], fill[c] - start[c],
                          reference[c]);
  }
}

}  // namespace rangeseg::seg
