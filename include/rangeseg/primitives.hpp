// Least-squares fits of geometric primitives (spheres, cylinders) to points with normals, as
// used by the `auto` region model to label curved segments. All in double, camera frame, metres.
#pragma once

#include <array>
#include <cstddef>
#include <span>

namespace rangeseg {

using Point3 = std::array<double, 3>;

/// A sphere |x - centre| = radius.
struct SphereFit {
  Point3 centre{};
  double radius = 0;  ///< [m]
  double rms = 0;     ///< RMS geometric distance of the points to the sphere [m]
  bool ok = false;    ///< false for too few or degenerate points (other fields unspecified)
};

/// A finite cylinder: the axis line through `axis_point` with unit direction `axis`, the points'
/// extent along it [0, extent] from `axis_point` (so axis_point is where the extent starts).
struct CylinderFit {
  Point3 axis_point{};
  /// unit; points up in the camera frame (y <= 0; a horizontal axis towards +x, or +z when
  /// along z)
  Point3 axis{};
  double radius = 0;  ///< [m]
  double extent = 0;  ///< length of the points' projection onto the axis [m]
  double rms = 0;     ///< RMS geometric distance of the points to the cylinder surface [m]
  bool ok = false;    ///< false for too few or degenerate points (other fields unspecified)
};

struct PrimitiveFitSettings {
  /// Gauss-Newton (Levenberg-Marquardt) refinement steps of the geometric distance (0 = the
  /// closed-form initial estimate only) [iterations], default 15.
  int max_iterations = 15;
  /// Refits on the points within 10 robust standard deviations (1.4826 x the median absolute
  /// residual) of the least-squares fit, that bound fixed, until they stay the same, at most
  /// this many times (0 = least squares over all points). Points of a neighbouring surface that
  /// a segment took along its border (a lid's rim on a cylinder) then do not move the fit; the
  /// reported `rms` is still over all points [refits], default 5.
  int outlier_refits = 5;
};

/// Sphere through points with (unit, not necessarily oriented) surface normals, arrays of equal
/// length >= 4. The centre starts as the point closest (least squares) to all normal lines
/// x_i + t n_i, the radius as the mean distance to it; both are then refined by minimising the
/// geometric distances |x_i - c| - r. Points whose normal is non-finite are used only in the
/// refinement. Throws std::invalid_argument if the arrays differ in length.
SphereFit fit_sphere(std::span<const Point3> points, std::span<const Point3> normals,
                     const PrimitiveFitSettings& settings = {});

/// Cylinder through points with surface normals (arrays of equal length >= 5). The axis
/// direction starts as the direction most perpendicular to all normals (the eigenvector of the
/// smallest eigenvalue of sum n n^T), the axis point and radius as an algebraic circle fit of
/// the points projected along the axis; all five parameters are then refined by minimising the
/// geometric distances. Throws std::invalid_argument if the arrays differ in length.
CylinderFit fit_cylinder(std::span<const Point3> points, std::span<const Point3> normals,
                         const PrimitiveFitSettings& settings = {});

}  // namespace rangeseg
