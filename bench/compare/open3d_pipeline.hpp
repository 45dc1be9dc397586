// The comparison pipeline of Open3D (Debian 12: 0.16), which has no organized-cloud stages: the
// valid points as one point cloud, normals from k nearest neighbours, and planes the way Open3D's
// tutorial finds several: RANSAC for one plane, its inliers removed, again. Built only with
// -DRANGESEG_COMPARE_OPEN3D=ON; nothing of rangeseg depends on it.
#pragma once

#include <open3d/geometry/PointCloud.h>

#include <cstddef>
#include <vector>

#include "rangeseg/cloud.hpp"

namespace rangeseg::compare {

/// Open3D's parameters: those of its plane-segmentation tutorial (distance 1 cm, 3 points, 1000
/// iterations), planes of at least rangeseg's `kinect` minimum of 200 points.
struct Open3dSettings {
  double distance_threshold = 0.01;  ///< SegmentPlane: inlier distance to the plane [m]
  int iterations = 1000;             ///< SegmentPlane: RANSAC iterations
  std::size_t min_points = 200;      ///< smallest plane [points]; also stops the search
  int max_planes = 100;              ///< planes searched at most
  /// When > 0, each plane's inliers are split by ClusterDBSCAN with this radius [m] (and
  /// min_points / 10 points a core), since RANSAC's inliers of one plane need not be connected.
  double cluster_radius = 0;
  unsigned seed = 1;  ///< utility::random::Seed, for repeatable RANSAC
};

/// The valid points of `cloud` as Open3D's point cloud; `pixels` receives each point's pixel
/// index (v * width + u).
open3d::geometry::PointCloud to_open3d(const OrganizedCloud& cloud,
                                       std::vector<std::size_t>& pixels);

/// EstimateNormals with the 30 nearest neighbours (Open3D's default search).
void estimate_normals(open3d::geometry::PointCloud& points);

/// Planes by repeated SegmentPlane on what earlier planes left: plane (or cluster) i gets label
/// i + 1 in the returned point labels (0 = none), one per point of `points`.
std::vector<std::int32_t> segment_planes(const open3d::geometry::PointCloud& points,
                                         const Open3dSettings& settings);

}  // namespace rangeseg::compare
