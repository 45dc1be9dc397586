// The smooth-surface region model (local surface continuity): no global model.
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

}  // namespace rangeseg::seg
