// Internal: the region models of issue 6 (incremental planes, automatic primitive labelling).
#pragma once

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
void fit_primitives(const Frame& frame, const SegmentationSettings& settings, Segmentation& out);

}  // namespace rangeseg::seg
