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

/// Mesh connectivity alone: every neighbour with a normal joins.
class ConnectedModel {
 public:
  void init(const Frame& f, std::int32_t seed) {
    stats_.clear();
    add(f, seed);
  }
  bool accepts(const Frame& f, std::int32_t /*from*/, std::int32_t q) const {
    return f.nz[q] == f.nz[q];
  }
  void add(const Frame& f, std::int32_t q) { stats_.add(f.x[q], f.y[q], f.z[q]); }
  const detail::PlaneStats& stats() const { return stats_; }

 private:
  detail::PlaneStats stats_;
};

static_assert(RegionGrowingModel<ConnectedModel>);

}  // namespace

void grow_smooth(const Frame& frame, const SegmentationSettings& settings,
                 Segmenter::Scratch& scratch) {
  SmoothModel model(settings);
  grow_regions(frame, model, scratch);
}

namespace {

/// Grows a region of `model` from every free pixel `seed_ok` accepts, in `seeds` order; regions
/// whose statistics `keep` accepts are appended to `out` as segments, the others are marked with
/// -1 (which blocks growth like a label) and listed in s.marked, until clear_marks.
template <class Model, class Seeds, class SeedOk, class Keep>
void grow_leftover_regions(const Frame& f, Model& model, const Seeds& seeds, SeedOk&& seed_ok,
                           Keep&& keep, Segmenter::Scratch& s, Segmentation& out) {
  std::int32_t* const queue = s.queue.data();
  auto label = static_cast<std::int32_t>(out.segments.size());
  seeds([&](std::int32_t seed) {
    if (f.labels[seed] != 0 || !seed_ok(seed)) return;
    f.labels[seed] = label + 1;
    model.init(f, seed);
    queue[0] = seed;
    const std::int32_t tail = grow_pixels(f, model, label + 1, queue, 0, 1, s.queue.size());
    if (!keep(model.stats())) {
      for (std::int32_t j = 0; j < tail; ++j) f.labels[queue[j]] = -1;
      s.marked.insert(s.marked.end(), queue, queue + tail);
      return;
    }
    ++label;
    Segment segment;
    segment.label = label;
    segment.model = RegionModel::automatic;
    set_plane_fields(model.stats(), segment);
    out.segments.push_back(segment);
  });
}

void clear_marks(const Frame& f, Segmenter::Scratch& s) {
  for (const std::int32_t q : s.marked) f.labels[q] = 0;
  s.marked.clear();
}

}  // namespace

// The plane model leaves a curved surface unlabelled where its facets stay below
// min_region_size (a sphere or a thin cylinder far away, or one without noise, where the normal
// test allows only a few degrees of bend per facet). Such leftovers are grown again by surface
// continuity; regions large enough become segments, for the primitive pass to classify.
// Far from a noisy sensor even that fails: the 1-ring normals of a small curved object scatter
// more than max_smooth_angle. What is left of it is a mesh-connected patch of unlabelled points;
// such patches become tentative segments, which the primitive pass keeps only if a curved surface
// explains them.
std::int32_t grow_smooth_leftovers(const Frame& f, const SegmentationSettings& settings,
                                   Segmenter::Scratch& s, Segmentation& out) {
  SegmentationSettings smooth = settings;
  smooth.model = RegionModel::smooth;
  collect_seeds(f, smooth, s);
  SmoothModel model(smooth);
  s.marked.clear();
  const auto seed_list = [&](auto&& visit) {
    for (const std::int32_t seed : s.seeds) visit(seed);
  };
  const auto large = [&](const detail::PlaneStats& st) {
    return st.count >= settings.min_region_size;
  };
  grow_leftover_regions(
      f, model, seed_list, [](std::int32_t) { return true; }, large, s, out);
  clear_marks(f, s);

  const auto tentative_from = static_cast<std::int32_t>(out.segments.size());
  ConnectedModel connected;
  const auto every_free_pixel = [&](auto&& visit) {
    for (int v = 0; v < f.height; v += f.pixel_stride) {
      const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(v) * f.stride;
      for (int u = 0; u < f.width; u += f.pixel_stride) {
        if (f.labels[row + u] == 0) visit(static_cast<std::int32_t>(row + u));
      }
    }
  };
  grow_leftover_regions(
      f, connected, every_free_pixel, [&](std::int32_t q) { return f.nz[q] == f.nz[q]; }, large, s,
      out);
  clear_marks(f, s);
  return tentative_from;
}

}  // namespace rangeseg::seg
