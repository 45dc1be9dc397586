// Stage 2 of Holz & Behnke: vertex normals and curvature from the mesh 1-ring.
#pragma once

#include <array>

#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"
#include "rangeseg/mesh.hpp"

namespace rangeseg {

/// Unit normals (nx, ny, nz) and curvature per pixel, same size as the cloud; NaN where the
/// vertex has no valid face.
struct NormalMap {
  FloatPlane nx, ny, nz;
  /// Curvature estimate [1/m]: 2 |(c - p) . n| / r^2, with c the centroid of the 1-ring, p the
  /// point, n its normal and r^2 the mean squared distance from p to its ring. For a sphere of
  /// radius R this is 1/R; 0 on a plane; independent of depth and pixel spacing.
  FloatPlane curvature;

  int width() const { return nz.width(); }
  int height() const { return nz.height(); }
};

struct NormalSettings {
  std::array<float, 3> viewpoint{0.0f, 0.0f, 0.0f};  ///< normals are flipped to face it [m]
};

/// Throws std::invalid_argument, with the value, for a non-finite viewpoint.
void validate(const NormalSettings& settings);

/// Vertex normal = normalised sum of the unnormalised (area-weighted) face normals of the faces
/// around the vertex (paper, eq. 2), oriented towards the viewpoint, plus curvature. Throws
/// std::invalid_argument for an unorganized or inconsistent cloud, a mesh of another size, or a
/// non-finite viewpoint.
void compute_normals(const OrganizedCloud& cloud, const Mesh& mesh, const NormalSettings& settings,
                     NormalMap& out);
inline NormalMap compute_normals(const OrganizedCloud& cloud, const Mesh& mesh,
                                 const NormalSettings& settings = {}) {
  NormalMap out;
  compute_normals(cloud, mesh, settings, out);
  return out;
}

}  // namespace rangeseg
