// Internal: the sphere and cylinder fits of primitives.hpp with caller-owned buffers, so that a
// segmenter that fits hundreds of candidate regions per frame allocates nothing after its first
// frames (the public functions allocate a set per call).
#pragma once

#include <span>
#include <vector>

#include "rangeseg/primitives.hpp"

namespace rangeseg::detail {

/// Scratch of the fits; capacity only grows. Not shared between threads.
struct PrimitiveFitBuffers {
  std::vector<double> points, normals, inliers;  // 3 x n, column-major
  std::vector<double> abs_residuals;
  std::vector<char> keep, kept;
};

SphereFit fit_sphere(std::span<const Point3> points, std::span<const Point3> normals,
                     const PrimitiveFitSettings& settings, PrimitiveFitBuffers& buffers);
CylinderFit fit_cylinder(std::span<const Point3> points, std::span<const Point3> normals,
                         const PrimitiveFitSettings& settings, PrimitiveFitBuffers& buffers);

}  // namespace rangeseg::detail
