// The pinhole camera of an organized cloud, from a sample of its points.
#pragma once

#include "rangeseg/camera.hpp"
#include "rangeseg/cloud.hpp"

namespace rangeseg::detail {

/// fit_intrinsics (rangeseg/camera.hpp) over every `step`-th row and column only (step >= 1;
/// 1 = every point), for a caller that needs the focal length of each frame at a fraction of
/// the cost; `cloud` must be consistent.
bool fit_intrinsics_every(const OrganizedCloud& cloud, int step, CameraIntrinsics& camera,
                          double tolerance, double* max_error = nullptr);

}  // namespace rangeseg::detail
