// The comparison pipeline: for each of rangeseg's stages, the class of PCL 1.13 a PCL user reaches
// for on an organized cloud. Built only with -DRANGESEG_COMPARE_PCL=ON; nothing of rangeseg
// depends on it.
#pragma once

#include <pcl/PointIndices.h>
#include <pcl/Vertices.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <vector>

#include "rangeseg/cloud.hpp"

namespace rangeseg::compare {

using PclCloud = pcl::PointCloud<pcl::PointXYZ>;
using PclNormals = pcl::PointCloud<pcl::Normal>;

/// PCL's parameters. The normal and plane parameters are those of PCL's
/// `organized_segmentation_demo` (apps/src/organized_segmentation_demo.cpp), except the minimum
/// plane size, which is rangeseg's `kinect` preset's `min_region_size` so that both count the
/// same regions (the demo's 10000 points would drop every box face of the synthetic scenes).
struct PclSettings {
  /// IntegralImageNormalEstimation: neighbours whose depth differs by more than this factor times
  /// the depth are left out [relative].
  float max_depth_change_factor = 0.02f;
  /// IntegralImageNormalEstimation: side of the smoothing window [pixels].
  float normal_smoothing_size = 20.0f;
  /// OrganizedMultiPlaneSegmentation: smallest plane [points].
  unsigned min_inliers = 200;
  /// OrganizedMultiPlaneSegmentation: normal angle between neighbours of one plane [rad] (3 deg).
  double angular_threshold = 0.05235987756;
  /// OrganizedMultiPlaneSegmentation: distance between neighbours' planes [m] at 1 m; PCL's
  /// segment() hands it to its comparator as depth-dependent, i.e. times the squared depth.
  double distance_threshold = 0.02;
};

/// rangeseg's cloud as PCL's: same width, height and points; invalid points are NaN.
PclCloud::Ptr to_pcl(const OrganizedCloud& cloud);

/// Normals with IntegralImageNormalEstimation, COVARIANCE_MATRIX (the demo's method).
void estimate_normals(const PclCloud::ConstPtr& cloud, const PclSettings& settings,
                      PclNormals& normals);

/// OrganizedMultiPlaneSegmentation::segmentAndRefine (its default comparators, as the demo); the
/// planes as a label image (label i + 1 for the i-th plane, 0 = none) of the cloud's size.
LabelImage segment_planes(const PclCloud::ConstPtr& cloud, const PclNormals::ConstPtr& normals,
                          const PclSettings& settings);

/// OrganizedFastMesh, TRIANGLE_ADAPTIVE_CUT over neighbouring pixels (triangle pixel size 1; PCL's
/// defaults otherwise); returns the triangles.
std::vector<pcl::Vertices> fast_mesh(const PclCloud::ConstPtr& cloud);

/// FastBilateralFilter with PCL's defaults (sigma_s 15 pixels, sigma_r 0.05 m): filters depth only.
void bilateral_filter(const PclCloud::ConstPtr& cloud, PclCloud& out);

}  // namespace rangeseg::compare
