// Open3D's point-cloud stages, called the way its tutorials call them.
#include "open3d_pipeline.hpp"

#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/utility/Random.h>

#include <algorithm>

namespace rangeseg::compare {

open3d::geometry::PointCloud to_open3d(const OrganizedCloud& cloud,
                                       std::vector<std::size_t>& pixels) {
  const OrganizedCloud valid = valid_points(cloud, &pixels);
  open3d::geometry::PointCloud out;
  out.points_.reserve(valid.size());
  for (int i = 0; i < valid.width(); ++i) {
    out.points_.emplace_back(valid.x(i, 0), valid.y(i, 0), valid.z(i, 0));
  }
  return out;
}

void estimate_normals(open3d::geometry::PointCloud& points) {
  points.EstimateNormals(open3d::geometry::KDTreeSearchParamKNN(30));
}

namespace {

/// Gives each DBSCAN cluster of the plane's `inliers` (indices into `rest`, whose point j is
/// point index[j] of the frame) with at least settings.min_points points a new label after
/// `label`.
void label_clusters(const open3d::geometry::PointCloud& rest,
                    const std::vector<std::size_t>& inliers, const std::vector<std::size_t>& index,
                    const Open3dSettings& settings, std::int32_t& label,
                    std::vector<std::int32_t>& labels) {
  const std::vector<int> cluster = rest.SelectByIndex(inliers)->ClusterDBSCAN(
      settings.cluster_radius, std::max<std::size_t>(settings.min_points / 10, 1));
  const int clusters = cluster.empty() ? 0 : *std::max_element(cluster.begin(), cluster.end()) + 1;
  std::vector<std::size_t> size(static_cast<std::size_t>(clusters), 0);
  for (const int c : cluster) {
    if (c >= 0) ++size[static_cast<std::size_t>(c)];
  }
  std::vector<std::int32_t> cluster_label(size.size(), 0);
  for (std::size_t c = 0; c < size.size(); ++c) {
    if (size[c] >= settings.min_points) cluster_label[c] = ++label;
  }
  for (std::size_t k = 0; k < inliers.size(); ++k) {
    if (cluster[k] >= 0) {
      labels[index[inliers[k]]] = cluster_label[static_cast<std::size_t>(cluster[k])];
    }
  }
}

}  // namespace

std::vector<std::int32_t> segment_planes(const open3d::geometry::PointCloud& points,
                                         const Open3dSettings& settings) {
  open3d::utility::random::Seed(static_cast<int>(settings.seed));
  std::vector<std::int32_t> labels(points.points_.size(), 0);
  // rest: the points no plane has taken yet, in their order; its point j is point index[j].
  std::vector<std::size_t> index(points.points_.size());
  for (std::size_t j = 0; j < index.size(); ++j) index[j] = j;
  open3d::geometry::PointCloud rest;
  rest.points_ = points.points_;
  std::int32_t label = 0;
  for (int plane = 0; plane < settings.max_planes && index.size() >= settings.min_points; ++plane) {
    auto [model, inliers] = rest.SegmentPlane(settings.distance_threshold, 3, settings.iterations);
    if (inliers.size() < settings.min_points) break;
    if (settings.cluster_radius > 0) {
      label_clusters(rest, inliers, index, settings, label, labels);
    } else {
      ++label;
      for (const std::size_t k : inliers) labels[index[k]] = label;
    }
    std::vector<char> taken(index.size(), 0);
    for (const std::size_t k : inliers) taken[k] = 1;
    std::size_t kept = 0;
    for (std::size_t j = 0; j < index.size(); ++j) {
      if (taken[j] == 0) index[kept++] = index[j];
    }
    index.resize(kept);
    rest.points_.resize(kept);
    for (std::size_t j = 0; j < kept; ++j) rest.points_[j] = points.points_[index[j]];
  }
  return labels;
}

}  // namespace rangeseg::compare
