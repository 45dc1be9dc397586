// Internal: the region growing over k-nearest-neighbour rings that segment() (planes, smooth
// surfaces) and the auto model's leftovers (primitives.cpp) share.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "detail/plane_stats.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/unorganized.hpp"
#include "segmentation/internal.hpp"
#include "unorganized/internal.hpp"

namespace rangeseg::unorganized {

/// The packed inputs of one call in ring order: points, normals, curvature, sigma(r), and the
/// cosine of the plane model's normal-angle bound at each point.
struct Points {
  std::vector<float>&xyz, &n, &curvature, &sigma, &cos_angle;

  Points(RingBuffers::Impl& b, const OrganizedCloud& cloud, const PointRings& rings,
         const NormalMap& normals, const SegmentationSettings& s)
      : xyz(b.seg_xyz), n(b.seg_n), curvature(b.curvature), sigma(b.sigma), cos_angle(b.cos_angle) {
    const SensorNoise& noise = s.noise;
    unorganized::pack_points(cloud, xyz);
    const std::size_t count = cloud.size();
    n.resize(3 * count);
    curvature.resize(count);
    sigma.resize(count);
    for (std::size_t i = 0; i < count; ++i) {
      n[3 * i] = at(normals.nx, i);
      n[3 * i + 1] = at(normals.ny, i);
      n[3 * i + 2] = at(normals.nz, i);
      curvature[i] = at(normals.curvature, i);
      const float* p = &xyz[3 * i];
      sigma[i] = static_cast<float>(
          noise.sigma(std::sqrt(double{p[0]} * p[0] + double{p[1]} * p[1] + double{p[2]} * p[2])));
    }
    cos_angle.resize(count);
    for (std::size_t i = 0; i < count; ++i) {
      cos_angle[i] = static_cast<float>(std::cos(normal_angle_bound(rings, i, s)));
    }
  }
  /// The plane model's angle bound at point i [rad]: max_normal_angle, or normal_noise_sigmas
  /// times the RMS angle of the normals of the point and its ring about their mean when that is
  /// wider (the spread the test will meet there: from the resultant length R of the unit
  /// normals, mean theta^2 ~ 2 (1 - R), as 1 - cos theta ~ theta^2 / 2). Far from a depth camera
  /// the noise exceeds the points' spacing, and on a surface seen at grazing incidence the ring
  /// is nearly a line, so the normals scatter; the distance test then does the work, as on the
  /// grid (whose cells measure the same spread).
  double normal_angle_bound(const PointRings& rings, std::size_t i,
                            const SegmentationSettings& s) const {
    if (rings.count[i] == 0 || s.normal_noise_sigmas <= 0 || !has_normal(i)) {
      return s.max_normal_angle;
    }
    const double spread = std::sqrt(std::max(0.0, 2.0 * (1.0 - resultant(rings, i))));
    return std::min(std::numbers::pi, std::max(s.max_normal_angle, s.normal_noise_sigmas * spread));
  }
  /// The mean resultant length of the unit normals of point i (which has one) and its ring.
  double resultant(const PointRings& rings, std::size_t i) const {
    double sum[3] = {n[3 * i], n[3 * i + 1], n[3 * i + 2]};
    double count = 1;
    for (const std::int32_t jj : rings.ring(i)) {
      const auto j = static_cast<std::size_t>(jj);
      if (!has_normal(j)) continue;
      for (int c = 0; c < 3; ++c) sum[c] += n[3 * j + c];
      count += 1;
    }
    return std::sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]) / count;
  }
  const float* point(std::size_t i) const { return &xyz[3 * i]; }
  const float* normal(std::size_t i) const { return &n[3 * i]; }
  bool has_normal(std::size_t i) const { return std::isfinite(n[3 * i]); }
};

/// Local surface continuity: the neighbour's normal is within max_smooth_angle of the current
/// point's and its curvature at most max_curvature.
class SmoothRegion {
 public:
  SmoothRegion(const Points& pts, const SegmentationSettings& s)
      : pts_(pts),
        cos_angle_(static_cast<float>(std::cos(s.max_smooth_angle))),
        max_curvature_(static_cast<float>(s.max_curvature)) {}
  void init(std::size_t /*seed*/) {}
  bool accepts(std::size_t from, std::size_t q) const {
    const float* a = pts_.normal(from);
    const float* b = pts_.normal(q);
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] >= cos_angle_ &&
           pts_.curvature[q] <= max_curvature_;
  }
  void add(std::size_t /*q*/) {}

 private:
  const Points& pts_;
  float cos_angle_, max_curvature_;
};

/// Every neighbour with a normal: the connected patches of the points left unlabelled.
struct ConnectedRegion {
  static void init(std::size_t /*seed*/) {}
  static bool accepts(std::size_t /*from*/, std::size_t /*q*/) { return true; }
  static void add(std::size_t /*q*/) {}
};

/// Region growing from the seeds in their order; raw labels after `label` in `labels`; returns
/// the last one.
template <class Model>
std::int32_t grow(const PointRings& rings, const Points& pts,
                  const std::vector<std::int32_t>& seeds, Model& model,
                  std::vector<std::int32_t>& labels, std::vector<std::int32_t>& queue,
                  std::int32_t label = 0) {
  for (const std::int32_t seed : seeds) {
    if (labels[static_cast<std::size_t>(seed)] != 0) continue;
    ++label;
    labels[static_cast<std::size_t>(seed)] = label;
    model.init(static_cast<std::size_t>(seed));
    queue.assign(1, seed);
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const auto p = static_cast<std::size_t>(queue[head]);
      for (const std::int32_t qq : rings.ring(p)) {
        const auto q = static_cast<std::size_t>(qq);
        if (labels[q] != 0 || !pts.has_normal(q) || !model.accepts(p, q)) continue;
        labels[q] = label;
        model.add(q);
        queue.push_back(qq);
      }
    }
  }
  return label;
}

/// Point statistics per raw label 0..count into `stats` (index 0 unused).
void label_stats(const Points& pts, const std::vector<std::int32_t>& labels, std::int32_t count,
                 std::vector<detail::PlaneStats>& stats);

/// Seeds of the given model in ascending curvature (ties in point order), into b.seeds: the
/// unlabelled points with a normal and curvature at most max_seed_curvature (and, unless for
/// planes, max_curvature).
void collect_seeds(const PointRings& rings, const Points& pts, const SegmentationSettings& s,
                   bool planes, const std::vector<std::int32_t>& labels, RingBuffers::Impl& b);

/// The grid's search for planes seen at grazing incidence (seg::find_grazing_planes) among the
/// points no segment took, over their nearest neighbours by viewing direction (`footprint`: the
/// rings' angular point spacing, ring_footprint): each plane found becomes a raw label appended
/// to `stats`, flagged in b.grazing (sized to `stats`).
void find_grazing_planes(const PointRings& rings, const Points& pts, const SegmentationSettings& s,
                         double footprint, std::vector<std::int32_t>& labels,
                         std::vector<detail::PlaneStats>& stats, RingBuffers::Impl& b);

/// The area of segment `s` that point i stands for [m^2]: point_area, or on a plane found seen
/// at grazing incidence (Segment::grazing), whose rings hold only each point's scan line,
/// (h r)^2 / sin(angle between the ray and the plane), with h = `spacing` the scan's angular
/// spacing [rad] and r the range (the angle at least 2 deg).
double sample_area(const OrganizedCloud& cloud, const PointRings& rings, std::size_t i,
                   const Segment& s, double spacing);

/// A frame of the grid's segmentation passes over the rings (seg::Frame::ring_neighbours): one
/// row of the points and the given packed normals, copied to planes in `planar`, and `labels`
/// (one per point).
seg::Frame ring_frame(const PointRings& rings, const Points& pts, const std::vector<float>& normals,
                      std::int32_t* labels, std::vector<float>& planar);

/// RegionModel::automatic after the leftovers are grown (grow_leftovers): the grid's primitive
/// pass over the rings. out.labels holds 1..out.segments.size(); segments 1..tentative_from are
/// plane segments or smooth leftovers, the rest tentative patches. Areas are summed again over
/// the final labels.
void fit_ring_primitives(const OrganizedCloud& cloud, const PointRings& rings, const Points& pts,
                         const SegmentationSettings& settings, std::int32_t tentative_from,
                         RingBuffers::Impl& b, Segmentation& out);

/// The auto model's leftovers, as on the grid (grow_smooth_leftovers): the points that no
/// plane segment took are grown again by surface continuity (regions below min_region_size
/// released at once), then what is still unlabelled by connectivity alone, into tentative
/// patches. Raw labels after `raw`, which is updated; returns the last label of the smooth
/// regions (those after it are tentative).
std::int32_t grow_leftovers(const PointRings& rings, const Points& pts,
                            const SegmentationSettings& s, std::vector<std::int32_t>& labels,
                            RingBuffers::Impl& b, std::int32_t& raw);

}  // namespace rangeseg::unorganized
