// Internal: shared helpers of the stages over k-nearest-neighbour rings.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "detail/plane_stats.hpp"
#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"
#include "rangeseg/thread_pool.hpp"
#include "rangeseg/unorganized.hpp"
#include "segmentation/internal.hpp"
#include "unorganized/order.hpp"

namespace rangeseg::unorganized {

/// Element i = v * width + u of a plane (the point order of PointRings). An unorganized cloud
/// has one row: no division (per neighbour, it was a third of the time of point_area).
template <class T>
T& at(Plane<T>& plane, std::size_t i) {
  if (plane.height() == 1) return plane.row(0)[i];
  const auto w = static_cast<std::size_t>(plane.width());
  return plane.row(static_cast<int>(i / w))[i % w];
}
template <class T>
const T& at(const Plane<T>& plane, std::size_t i) {
  if (plane.height() == 1) return plane.row(0)[i];
  const auto w = static_cast<std::size_t>(plane.width());
  return plane.row(static_cast<int>(i / w))[i % w];
}

/// The cloud's points packed as x, y, z triples in ring order; NaN triples for invalid points
/// (any coordinate not finite).
void pack_points(const OrganizedCloud& cloud, std::vector<float>& xyz);

/// Throws std::invalid_argument naming `what` unless the rings and (when given) the normals have
/// the cloud's size.
void require_rings_match(const OrganizedCloud& cloud, const PointRings& rings,
                         const NormalMap* normals, const char* what);

/// Calls fn(begin, end) on disjoint ranges covering points [0, count): on the pool's threads
/// when given, else once.
template <class F>
void for_points(std::size_t count, ThreadPool* pool, F&& fn) {
  if (pool == nullptr || pool->threads() < 2) {
    fn(std::size_t{0}, count);
    return;
  }
  pool->for_each_band(static_cast<int>(count), 1, [&](int, int begin, int end) {
    fn(static_cast<std::size_t>(begin), static_cast<std::size_t>(end));
  });
}

/// build_rings' k-d tree, kept from frame to frame (rings.cpp).
struct RingTree;
struct RingTreeDeleter {
  void operator()(RingTree* tree) const;
};

/// sin(2 deg), the floor of the sine of a ray's angle to a plane seen at grazing incidence in
/// the patch a sample covers (sample_area, the grazing footprints of the polygons): the search
/// takes no plane closer to the rays (SegmentationSettings::grazing_min_angle, 2 deg).
inline constexpr double kMinGrazingSine = 0.03489949670250097;

/// A candidate of the grazing-plane search (grazing.cpp): not yet in a component, or in one.
enum class GrazingState : std::uint8_t { free, visited };

/// A point of a plane segment that lies closer to an adjacent segment's plane (refine_borders).
struct BorderMove {
  std::int32_t point = 0, target = 0;
  double distance = 0;  ///< to the target's plane [m]
};

/// Per point and pass of the filter: the inverse scales of the distance and normal terms.
struct Scales {
  float inv_distance = 0;  // 1 / (2 s_d^2)
  float inv_normal = 0;    // 1 / s_n
};

/// The unit vector from `viewpoint` to p into out (0, 0, 0 at the viewpoint): the search space
/// of rings by viewing direction.
inline void direction_from(const std::array<float, 3>& viewpoint, const float* p, float* out) {
  const float dx = p[0] - viewpoint[0], dy = p[1] - viewpoint[1], dz = p[2] - viewpoint[2];
  const float r = std::sqrt(dx * dx + dy * dy + dz * dz);
  const float inv = r > 0 ? 1.0f / r : 0.0f;
  out[0] = dx * inv;
  out[1] = dy * inv;
  out[2] = dz * inv;
}

inline float squared_distance(const float* a, const float* b) {
  const float dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
  return dx * dx + dy * dy + dz * dz;
}

/// The offset in a plane of row stride `stride` of pixel `pixel` (v * width + u, as
/// PixelGrid::pixel holds it) of a grid `width` wide.
inline std::ptrdiff_t grid_offset(std::int32_t pixel, std::uint32_t width, std::ptrdiff_t stride) {
  const auto p = static_cast<std::uint32_t>(pixel);
  const std::uint32_t v = p / width;  // 32-bit: the grid is at most 16384 a side
  return static_cast<std::ptrdiff_t>(v) * stride + (p - v * width);
}

}  // namespace rangeseg::unorganized

namespace rangeseg {

/// The buffers of one RingBuffers (their capacity only grows).
struct RingBuffers::Impl {
  // Pipeline: the spatial order of the points (order.hpp).
  unorganized::SpatialOrder spatial;
  // build_rings: the valid points packed, their indices in the cloud, their directions.
  std::vector<float> valid_xyz, directions;
  std::vector<std::int32_t> original;
  // build_rings: the same in the tree's leaf order (see `build`).
  std::vector<float> leaf_xyz, leaf_directions;
  std::vector<std::int32_t> leaf_original;
  // build_rings: the tree over them, rebuilt in place each call (its index array is reused;
  // nanoflann takes its nodes from its own malloc pool, emptied and refilled per build).
  std::unique_ptr<unorganized::RingTree, unorganized::RingTreeDeleter> tree;
  // All stages: the cloud's points packed. smooth: normals packed (this pass and the next),
  // grey values, scales.
  std::vector<float> xyz, n, xyz_next, n_next, grey;
  std::vector<unorganized::Scales> scales;
  // segment: packed points, normals, curvature, sigma(r), cosine of the angle bound; seeds,
  // their keys, raw labels, the growth queue.
  std::vector<float> seg_xyz, seg_n, curvature, sigma, cos_angle;
  std::vector<std::int32_t> seeds, seeds_tmp, labels, queue;
  std::vector<std::uint32_t> seed_keys, seed_keys_tmp;
  // segment: per raw label, whether its region is large or wide enough to keep.
  std::vector<std::uint8_t> keep;
  // segment, auto model: raw label counts, noise samples, the points and averaged normals as
  // planes, the primitive pass's buffers.
  std::vector<std::int64_t> counts;
  std::vector<double> noise_samples;
  std::vector<float> planar, pass_normals, pass_normals_next;
  seg::PrimitiveScratchPtr primitive;
  // segment: splitting planes, the grid's scratch and per raw label local residual sums and
  // noise references.
  std::unique_ptr<Segmenter::Scratch> split;
  std::vector<double> local_sums, references;
  // segment: per raw label statistics and fits, merge pairs and union-find parents,
  // re-assignment moves, final order and labels.
  std::vector<detail::PlaneStats> stats;
  std::vector<detail::PlaneFit> fits;
  std::vector<std::uint64_t> pairs;
  std::vector<std::int32_t> parent, order, final_label;
  std::vector<std::pair<std::size_t, std::int32_t>> moves;
  // segment, border refinement: the moves of a round, the points moved, planes to refit.
  std::vector<unorganized::BorderMove> border_moves;
  std::vector<std::int32_t> moved;
  std::vector<std::uint8_t> refit;
  // segment, grazing planes: per raw label whether the search found it; the unlabelled points
  // (candidates), their directions, ranges and links, the tree over the directions, the search's
  // state, starts, component and packed points.
  std::vector<std::uint8_t> grazing;
  double grazing_spacing = 0;  // the scan's angular spacing the search used [rad]
  std::vector<std::int32_t> grazing_candidates, grazing_link_first, grazing_links, grazing_cursor,
      grazing_starts, grazing_component;
  std::vector<float> grazing_directions;
  std::vector<double> grazing_range, grazing_points;
  std::vector<std::uint64_t> grazing_pairs;
  std::unique_ptr<unorganized::RingTree, unorganized::RingTreeDeleter> grazing_tree;
  std::vector<unorganized::GrazingState> grazing_state;
  // find_pixel_grid: the valid points, their x / z and y / z, a sample of one axis sorted, the
  // columns of an axis, the grid's taken pixels.
  std::vector<std::int32_t> grid_items, grid_sorted, grid_items_tmp;
  std::vector<float> grid_tu, grid_tv;
  std::vector<std::uint32_t> grid_sorted_keys, grid_keys_tmp;
  std::vector<double> grid_columns;
  std::vector<std::uint8_t> grid_taken;
};

}  // namespace rangeseg
