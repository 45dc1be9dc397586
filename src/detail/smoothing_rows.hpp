// Internal: one bilateral smoothing pass (see rangeseg/smoothing.hpp) over a band of output rows,
// for in-frame multi-threading. Bands that cover the image give output bit-identical to
// Smoother::run with iterations = 1 (tests/test_smoothing.cpp checks 1, 2 and 3 bands).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "rangeseg/smoothing.hpp"

namespace rangeseg::detail {

/// The frame-wide inputs of a pass. Everything here is per frame, never per band: the
/// intensity range in particular must be the whole frame's for bands to match the whole image.
struct SmoothRowsInput {
  /// Points relative to the viewpoint (the input cloud itself when settings.viewpoint is 0,
  /// else p - viewpoint; the outputs get the viewpoint added back) [m].
  const OrganizedCloud* cloud = nullptr;
  const Mesh* mesh = nullptr;          ///< built from the cloud
  const NormalMap* normals = nullptr;  ///< unit normals of the cloud, NaN = none
  /// Intensity per pixel (cloud intensity, or grey from RGB as Smoother does: 0.299 r +
  /// 0.587 g + 0.114 b); nullptr = no intensity term.
  const FloatPlane* intensity = nullptr;
  /// c_I [intensity units]: settings.intensity_range if > 0, else
  /// frame_intensity_range(cloud, *intensity); <= 0 = no intensity term.
  float intensity_range = 0.0f;
};

/// Row buffers of one thread; reuse across calls so that nothing is allocated per band.
struct SmoothRowsScratch {
  CacheLineVector<float> rows;
  CacheLineVector<std::uint8_t> bytes;
  std::size_t layout = 0;
};

/// max - min of `intensity` over the valid points of `cloud` (0 when none), as Smoother uses
/// for intensity_range = 0.
float frame_intensity_range(const OrganizedCloud& cloud, const FloatPlane& intensity);

/// One pass over output rows [v0, v1) (0 <= v0 <= v1 <= height): writes x, y, z of `out_cloud`
/// and (unless settings.recompute_normals) nx, ny, nz of `out_normals` in those rows only;
/// the outputs must already have the cloud's size. settings.iterations is ignored. Bands may
/// run concurrently on distinct outputs rows with one scratch per thread. Sizes are asserted,
/// not checked: validate at the caller (Smoother::run checks the same conditions).
void smooth_rows(const SmoothRowsInput& in, const SmoothingSettings& settings, int v0, int v1,
                 SmoothRowsScratch& scratch, OrganizedCloud& out_cloud, NormalMap& out_normals);

}  // namespace rangeseg::detail
