// The smooth-surface region model (local surface continuity): no global model.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "segmentation/region_growing.hpp"

namespace rangeseg::seg {
namespace {

/// A neighbour joins when its normal is within an angle of the normal of the point it is reached
/// from (not the region's) and its curvature is below a bound, so a region follows any surface
/// that bends slowly enough and stops at creases and depth edges (where the mesh has no edge).
class SmoothModel {
 public:
  explicit SmoothModel(const SegmentationSettings& s)
      : cos_max_angle_(static_cast<float>(std::cos(s.max_smooth_angle))),
        max_curvature_(static_cast<float>(s.max_curvature)) {}

  void init(const Frame& f, std::int32_t seed) {
    stats_.clear();
    add(f, seed);
  }

  bool accepts(const Frame& f, std::int32_t p, std::int32_t q) const {
    const float dot = f.nx[p] * f.nx[q] + f.ny[p] * f.ny[q] + f.nz[p] * f.nz[q];
    return dot >= cos_max_angle_ && f.curvature[q] <= max_curvature_;  // false for NaN
  }

  void add(const Frame& f, std::int32_t q) { stats_.add(f.x[q], f.y[q], f.z[q]); }

  const detail::PlaneStats& stats() const { return stats_; }

 private:
  float cos_max_angle_, max_curvature_;
  detail::PlaneStats stats_;
};

static_assert(RegionGrowingModel<SmoothModel>);

}  // namespace

void grow_smooth(const Frame& frame, const SegmentationSettings& settings,
                 Segmenter::Scratch& scratch) {
  SmoothModel model(settings);
  grow_regions(frame, model, scratch);
}

// The plane model leaves a curved surface unlabelled where its facets stay below
// min_region_size (a sphere or a thin cylinder far away, or one without noise, where the normal
// test allows only a few degrees of bend per facet). Such leftovers are grown again by surface
// continuity; regions large enough become segments, for the primitive pass to classify.
void grow_smooth_leftovers(const Frame& f, const SegmentationSettings& settings,
                           Segmenter::Scratch& s, Segmentation& out) {
  SegmentationSettings smooth = settings;
  smooth.model = RegionModel::smooth;
  collect_seeds(f, smooth, s);
  SmoothModel model(smooth);
  std::int32_t* const queue = s.queue.data();
  auto label = static_cast<std::int32_t>(out.segments.size());
  constexpr std::int32_t kTooSmall = -1;  // blocks growth like a label; cleared below
  std::size_t rejected = 0;
  for (const std::int32_t seed : s.seeds) {
    if (f.labels[seed] != 0) continue;
    f.labels[seed] = label + 1;
    model.init(f, seed);
    queue[0] = seed;
    const std::int32_t tail = grow_pixels(f, model, label + 1, queue, 0, 1, s.queue.size());
    if (model.stats().count < settings.min_region_size) {
      for (std::int32_t j = 0; j < tail; ++j) f.labels[queue[j]] = kTooSmall;
      rejected += static_cast<std::size_t>(tail);
      continue;
    }
    ++label;
    Segment segment;
    segment.label = label;
    segment.model = RegionModel::automatic;
    set_plane_fields(model.stats(), segment);
    out.segments.push_back(segment);
  }
  if (rejected == 0) return;
  for (int v = 0; v < f.height; v += f.pixel_stride) {
    std::int32_t* const row = f.labels + static_cast<std::ptrdiff_t>(v) * f.stride;
    for (int u = 0; u < f.width; u += f.pixel_stride) row[u] = std::max(row[u], 0);
  }
}

}  // namespace rangeseg::seg
