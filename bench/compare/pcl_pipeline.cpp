// PCL 1.13's organized-cloud stages, called the way PCL's own demos call them.
#include "pcl_pipeline.hpp"

#include <pcl/features/integral_image_normal.h>
#include <pcl/filters/fast_bilateral.h>
#include <pcl/segmentation/organized_multi_plane_segmentation.h>
#include <pcl/surface/organized_fast_mesh.h>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace rangeseg::compare {

PclCloud::Ptr to_pcl(const OrganizedCloud& cloud) {
  auto out = std::make_shared<PclCloud>(static_cast<std::uint32_t>(cloud.width()),
                                        static_cast<std::uint32_t>(cloud.height()));
  out->is_dense = false;
  constexpr float nan = std::numeric_limits<float>::quiet_NaN();
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      pcl::PointXYZ& p = out->at(u, v);
      if (cloud.valid(u, v)) {
        p = {cloud.x(u, v), cloud.y(u, v), cloud.z(u, v)};
      } else {
        p = {nan, nan, nan};
      }
    }
  }
  return out;
}

void estimate_normals(const PclCloud::ConstPtr& cloud, const PclSettings& settings,
                      PclNormals& normals) {
  pcl::IntegralImageNormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
  ne.setNormalEstimationMethod(ne.COVARIANCE_MATRIX);
  ne.setMaxDepthChangeFactor(settings.max_depth_change_factor);
  ne.setNormalSmoothingSize(settings.normal_smoothing_size);
  ne.setInputCloud(cloud);
  ne.compute(normals);
}

LabelImage segment_planes(const PclCloud::ConstPtr& cloud, const PclNormals::ConstPtr& normals,
                          const PclSettings& settings) {
  pcl::OrganizedMultiPlaneSegmentation<pcl::PointXYZ, pcl::Normal, pcl::Label> mps;
  mps.setMinInliers(settings.min_inliers);
  mps.setAngularThreshold(settings.angular_threshold);
  mps.setDistanceThreshold(settings.distance_threshold);
  mps.setInputNormals(normals);
  mps.setInputCloud(cloud);
  std::vector<pcl::PlanarRegion<pcl::PointXYZ>,
              Eigen::aligned_allocator<pcl::PlanarRegion<pcl::PointXYZ>>>
      regions;
  std::vector<pcl::ModelCoefficients> coefficients;
  std::vector<pcl::PointIndices> inliers, label_indices, boundaries;
  auto labels = std::make_shared<pcl::PointCloud<pcl::Label>>();
  mps.segmentAndRefine(regions, coefficients, inliers, labels, label_indices, boundaries);

  const auto width = static_cast<int>(cloud->width), height = static_cast<int>(cloud->height);
  LabelImage out(width, height, 0);
  for (std::size_t i = 0; i < inliers.size(); ++i) {
    for (const auto index : inliers[i].indices) {
      if (index < 0 || index >= width * height) {
        throw std::runtime_error("PCL returned a point index outside the cloud");
      }
      out(index % width, index / width) = static_cast<std::int32_t>(i + 1);
    }
  }
  return out;
}

std::vector<pcl::Vertices> fast_mesh(const PclCloud::ConstPtr& cloud) {
  pcl::OrganizedFastMesh<pcl::PointXYZ> mesh;
  mesh.setTrianglePixelSize(1);
  mesh.setTriangulationType(pcl::OrganizedFastMesh<pcl::PointXYZ>::TRIANGLE_ADAPTIVE_CUT);
  mesh.setInputCloud(cloud);
  std::vector<pcl::Vertices> triangles;
  mesh.reconstruct(triangles);
  return triangles;
}

void bilateral_filter(const PclCloud::ConstPtr& cloud, PclCloud& out) {
  pcl::FastBilateralFilter<pcl::PointXYZ> filter;
  filter.setInputCloud(cloud);
  filter.filter(out);
}

}  // namespace rangeseg::compare
