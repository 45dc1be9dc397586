// Internal: the region models of issue 6 (incremental planes, automatic primitive labelling).
#pragma once

#include <span>

#include "segmentation/internal.hpp"

namespace rangeseg::seg {

/// Grows regions with the incremental plane model (RegionModel::incremental_plane); same
/// contract as grow_planes.
void grow_incremental_planes(const Frame& frame, const SegmentationSettings& settings,
                             Segmenter::Scratch& scratch);

/// RegionModel::automatic, after plane growing and post-processing have produced `out` (and
/// compact labels in frame.labels): merges adjacent segments whose union a cylinder or sphere
/// explains within the noise, re-assigns unlabelled boundary points to curved segments, labels
/// every segment with its surface kind and parameters, and recompacts the labels (by size).
/// What fit_primitives needs from the earlier steps.
struct PrimitiveContext {
  /// Segments after the first `tentative_from` are tentative (grow_smooth_leftovers): dropped
  /// (unlabelled) unless they end in a curved group.
  std::int32_t tentative_from = 0;
  /// The frame's normal noise constant c, sigma_n(z) = c sigma(z) / z (0: not measured).
  double normal_noise_c = 0;
  /// Point statistics of segments 1, 2, ... as post-processing left them (may cover only the
  /// first segments); the others are summed from their pixels when needed.
  std::span<const detail::PlaneStats> segment_stats;
};
/// `frame` may be one of rings (Frame::ring_neighbours); its labels are 1..out.segments.size().
/// Segment fields read: normal, centroid, rms_residual, area_m2, grazing.
void fit_primitives(const Frame& frame, const SegmentationSettings& settings, Segmentation& out,
                    PrimitiveScratchPtr& scratch, const PrimitiveContext& context);

}  // namespace rangeseg::seg
