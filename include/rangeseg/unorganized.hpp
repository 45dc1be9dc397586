// Unorganized clouds (no pixel grid, e.g. a lidar scan without its ring order, a cloud with the
// invalid points removed, a merged or cropped cloud): stages 2-4 of the method over
// k-nearest-neighbour rings instead of the mesh 1-ring, and stage 5 (plane polygons) without a
// mesh. These functions take the points in the order given: ties (seeds of equal curvature,
// neighbours at equal distance) follow it, and points scattered in memory (a shuffled cloud)
// take 1.3-2.3x longer. Pipeline::process first puts the points in spatial order and its results
// back, which makes them independent of the input order.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/polygons.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/sensor.hpp"
#include "rangeseg/smoothing.hpp"
#include "rangeseg/thread_pool.hpp"

namespace rangeseg {

/// Settings of the k-nearest-neighbour rings, the stand-in for the mesh 1-ring. The ring of a
/// valid point p_i holds its `k` nearest valid points (a k-d tree, nanoflann; nearest by viewing
/// direction or by distance, see `by_direction`), without those the mesh's edge tests
/// (`MeshSettings`) would cut:
/// - farther than `max_distance` from p_i (when > 0);
/// - on an occlusion veil: the edge is within `eps_theta` of the viewing ray through p_i, unless
///   the range difference is explained by the noise, |r_i - r_j| <= jump_sigmas *
///   sqrt(sigma(r_i)^2 + sigma(r_j)^2), with r the distance from `viewpoint`.
/// For a cloud merged from several viewpoints set eps_theta = 0 (the veil test is off).
/// A point closer than sigma(r_i) / 100 and a hundredth of the ring's median neighbour distance
/// to p_i, or to a point already in the ring, is the same point measured again (overlapping
/// scans, tiles stored twice): it takes no place in the ring, which holds k others instead.
struct RingSettings {
  int k = 12;                 ///< ring size: nearest neighbours per point [1], 2..64
  float max_distance = 0.0f;  ///< neighbours farther away are not in the ring [m]; 0 = no bound
  float eps_theta = 0.2182f;  ///< min angle between edge and viewing ray [rad] (12.5 deg); 0 = off
  float jump_sigmas = 3.0f;   ///< range steps up to this many sigma of the difference are noise [1]
  SensorNoise noise{};        ///< axial noise sigma(range) of the sensor [m]
  std::array<float, 3> viewpoint{0.0f, 0.0f, 0.0f};  ///< sensor origin [m], cloud frame
  /// true: the nearest neighbours by viewing direction from `viewpoint` (the points projected
  /// onto the unit sphere), as the pixels of a range image are neighbours: for the points of one
  /// sensor in its own frame (the noise model assumes that too). By 3D distance, a depth camera's
  /// range quantisation splits a far wall into terraces a few centimetres apart whose points
  /// have all their nearest neighbours on their own terrace (synthetic Kinect box scenes,
  /// unorganized: 24 of 99 regions correct by distance, 64 by direction). false: by 3D distance,
  /// for clouds merged from several viewpoints (then also set eps_theta = 0).
  bool by_direction = true;
  /// true (and k >= 6): where the k nearest neighbours lie along a line (their scatter about p_i in
  /// the search space has its second principal axis below 0.1 of the first: the scan line of a
  /// multi-beam lidar, whose beams are further apart than its points), the ring is instead
  /// chosen from the 4k nearest in turn per 45-degree sector about p_i (the nearest of each
  /// sector, then the second nearest of each, ...), so that it surrounds p_i as the mesh's
  /// 1-ring surrounds a pixel. A 16-beam lidar's room scan (beams 2 deg apart, points 0.2 deg):
  /// 6 of 6 walls, floor and ceiling one segment each, 0 of 6 without.
  bool balanced = true;
};

/// Throws std::invalid_argument naming the field for k outside 2..64, a negative or non-finite
/// distance or angle, or eps_theta >= pi / 2.
void validate(const RingSettings& settings);

/// Buffers of the stages over rings, kept from call to call so that a stream of
/// clouds does not map fresh memory for every frame (tens of MB for a 640 x 480 frame; Pipeline
/// keeps one). Not thread-safe: one per thread.
class RingBuffers {
 public:
  RingBuffers();
  ~RingBuffers();
  RingBuffers(RingBuffers&&) noexcept;
  RingBuffers& operator=(RingBuffers&&) noexcept;

  struct Impl;
  Impl& impl();

 private:
  std::unique_ptr<Impl> impl_;
};

/// The ring of every point of a cloud, indexed like the cloud's points (i = v * width + u).
struct PointRings {
  int k = 0;  ///< slots per point
  /// size() * k point indices; point i's ring is neighbours[i * k, i * k + count[i]), nearest
  /// first, the rest of its slots -1.
  std::vector<std::int32_t> neighbours;
  std::vector<std::uint8_t> count;  ///< per point: ring size, 0 for an invalid point
  /// The rings are nearest by viewing direction from `viewpoint` (RingSettings::by_direction;
  /// build_rings sets both): `compute_normals` then orders each ring about the viewing ray.
  bool by_direction = false;
  std::array<float, 3> viewpoint{0.0f, 0.0f, 0.0f};  ///< sensor origin of the directions [m]

  std::size_t size() const { return count.size(); }
  std::span<const std::int32_t> ring(std::size_t i) const {
    return {neighbours.data() + i * static_cast<std::size_t>(k), count[i]};
  }
};

/// Builds the rings of `cloud` into `out`, reusing its buffers. Any cloud works: an organized one
/// is taken as a list of points (its grid is ignored). The k-d tree is built per call.
/// Throws std::invalid_argument for invalid settings or an inconsistent cloud, and
/// std::length_error for more than 2^31 - 1 points.
void build_rings(const OrganizedCloud& cloud, const RingSettings& settings, PointRings& out);
/// As above, with the queries split over `pool.threads()` threads (the same result).
void build_rings(const OrganizedCloud& cloud, const RingSettings& settings, PointRings& out,
                 ThreadPool& pool);
/// As above, on the pool's threads when `pool` is given, reusing `buffers`.
void build_rings(const OrganizedCloud& cloud, const RingSettings& settings, PointRings& out,
                 ThreadPool* pool, RingBuffers& buffers);
inline PointRings build_rings(const OrganizedCloud& cloud, const RingSettings& settings = {}) {
  PointRings out;
  build_rings(cloud, settings, out);
  return out;
}

/// Stage 2 over the rings. The ring of p_i, ordered by angle about an axis, is a fan of
/// triangles (p_i, q_j, q_j+1); a gap wider than 120 degrees between consecutive neighbours is a
/// border and gets no triangle. The axis is the viewing ray through p_i for rings by direction
/// (`rings.by_direction`): the neighbours then go round p_i as the pixels of a range image go
/// round a pixel, and the fan is the mesh's 1-ring. Otherwise it is the least-squares (PCA)
/// normal of p_i and its ring. The normal is the normalised sum of the fan's unnormalised
/// (area-weighted) face normals (paper, eq. 2), facing `settings.viewpoint`; the curvature
/// [1/m] is NormalMap's, 2 |(c - p) . n| / r^2 over the ring. NaN for a point without a
/// triangle, or whose fan spans no plane (its ring lies along a line: the fan's area is below
/// 1e-3 of the ring's mean squared edge length). `out` gets the cloud's width and height.
/// Throws std::invalid_argument when the rings were built for a cloud of another size.
void compute_normals(const OrganizedCloud& cloud, const PointRings& rings,
                     const NormalSettings& settings, NormalMap& out);
/// As above, with the points split over `pool.threads()` threads (the same result).
void compute_normals(const OrganizedCloud& cloud, const PointRings& rings,
                     const NormalSettings& settings, NormalMap& out, ThreadPool& pool);
/// As above, on the pool's threads when `pool` is given, reusing `buffers`.
void compute_normals(const OrganizedCloud& cloud, const PointRings& rings,
                     const NormalSettings& settings, NormalMap& out, ThreadPool* pool,
                     RingBuffers& buffers);
inline NormalMap compute_normals(const OrganizedCloud& cloud, const PointRings& rings,
                                 const NormalSettings& settings = {}) {
  NormalMap out;
  compute_normals(cloud, rings, settings, out);
  return out;
}

/// The area a point stands for [m^2]: an ellipse holding its ring at a uniform density,
/// 4 pi sqrt(lambda_1 lambda_2) / (count + 1), with lambda_1, lambda_2 the two larger
/// eigenvalues of the ring's second moments about p_i (for points on a square grid of spacing h
/// and k = 8 or 12: 1.05 h^2 or 1.13 h^2; an ellipse, not a disc, because a ring by viewing
/// direction on a slanted surface is stretched by 1 / cos(incidence)). 0 for a point without a
/// ring.
double point_area(const OrganizedCloud& cloud, const PointRings& rings, std::size_t i);

/// Stage 3 over the rings: the bilateral filter of `smooth` (SmoothingSettings; its terms,
/// iterations, move_along_ray and viewpoint) with the ring in place of the mesh 1-ring, and with
/// the expected ring edge length at p_i measured instead of taken from the pixel angle: the RMS
/// distance from p_i to its ring, so s_d(i)^2 = distance_scale^2 * mean(|q_j - p_i|^2) and
/// s_n(i) = normal_scale * max(1, sigma(r_i) / rms distance). `pixel_angle` is not used.
/// With move_along_ray, p_i moves along its viewing ray to where the ray meets the plane through
/// the weighted mean normal to the filtered normal (the mean's projection onto the ray where the
/// ray runs within 5 degrees of that plane): a ring need not lie around its point, as a
/// lidar's scan lines lie further apart than its points, and on a slanted surface projecting
/// the mean onto the ray would move the point off it. A pass moves a point by at most sigma(r_i),
/// the depth noise at its range.
/// Optional planes are copied unchanged; points without a ring keep their values.
/// Throws std::invalid_argument for invalid settings, size mismatches, or when an output
/// object is the corresponding input.
void smooth(const OrganizedCloud& cloud, const PointRings& rings, const NormalMap& normals,
            const SmoothingSettings& settings, OrganizedCloud& out_cloud, NormalMap& out_normals);
/// As above, with the points split over `pool.threads()` threads (the same result).
void smooth(const OrganizedCloud& cloud, const PointRings& rings, const NormalMap& normals,
            const SmoothingSettings& settings, OrganizedCloud& out_cloud, NormalMap& out_normals,
            ThreadPool& pool);
/// As above, on the pool's threads when `pool` is given, reusing `buffers`.
void smooth(const OrganizedCloud& cloud, const PointRings& rings, const NormalMap& normals,
            const SmoothingSettings& settings, OrganizedCloud& out_cloud, NormalMap& out_normals,
            ThreadPool* pool, RingBuffers& buffers);

/// Stage 4 over the rings, for RegionModel::plane, smooth and automatic. Seeds are taken in
/// ascending curvature; a region grows over the rings with the model's tests as on the grid.
/// plane: the point's normal is within an angle of the region's normal (the mean normal, from 8
/// points the PCA normal) and its distance to the region's plane within max_distance_sigmas
/// sigma(r), r the distance from the origin (points in the sensor frame). The angle is
/// max_normal_angle, or normal_noise_sigmas times the RMS angle of the normals in the point's
/// ring about their mean where that is wider (far from a depth camera normals scatter beyond
/// any fixed angle; the grid's cells measure the same spread). smooth: max_smooth_angle to the
/// neighbour's normal and max_curvature. Then, for planes: segments of fewer than
/// min_region_size points are dropped, adjacent segments (joined by a ring edge or through the
/// ring of one unlabelled point) whose least-squares planes agree (merge_angle, and each
/// centroid within merge_distance_sigmas sigma of the other plane) are merged, segments that
/// one plane explains split_residual_factor times worse than their own rings (the RMS distance
/// of ring neighbours from each point's tangent plane) are split as on the grid, and unlabelled
/// points next to a plane join the closest one within max_distance_sigmas sigma(r) and
/// reassign_max_normal_angle (widened like the growth's angle); before merging, the points
/// left are searched for planes seen at grazing incidence as on the grid (grazing_min_angle,
/// grazing_max_angle; each point's neighbours there are its nearest unlabelled points by
/// viewing direction, as the rings' veil test cuts such a surface into scan lines), and the
/// borders between plane segments are refined as on the grid. Smooth segments below
/// min_region_size are dropped. automatic: the plane model's segments, then, as on the grid,
/// the points left are grown as smooth regions and tentative patches, adjacent segments that
/// one sphere or cylinder explains are joined and every segment is labelled with its surface
/// kind and parameters (Segment::kind, centre, axis, radius, extent); the ring is the
/// neighbourhood, sigma is sigma(r), and the normals compared with the models' are averaged
/// over the ring twice first (ring normals of depth-camera data scatter more than the grid's).
/// Segment::area_m2 is the sum of `point_area`, or on a plane found seen at grazing incidence
/// (Segment::grazing; its points' rings are lines) of (h r)^2 / sin(angle between the ray and
/// the plane) per point, h being the scan's angular spacing (the median angle between a point
/// and its nearest ring neighbour). (A Pipeline that extracts polygons gives a plane over rings
/// its polygon's area instead: the union of its points' footprints, which the sum exceeds where
/// rings span scan lines far apart, up to 2.7 times on a 16-beam lidar's room.) The grid-only
/// settings (cells, bands, seed clearance) are
/// not used. `out.labels` has the
/// cloud's size. Throws std::invalid_argument for RegionModel::incremental_plane, invalid
/// settings or size mismatches.
void segment(const OrganizedCloud& cloud, const PointRings& rings, const NormalMap& normals,
             const SegmentationSettings& settings, Segmentation& out);
/// As above, reusing `buffers`.
void segment(const OrganizedCloud& cloud, const PointRings& rings, const NormalMap& normals,
             const SegmentationSettings& settings, Segmentation& out, RingBuffers& buffers);
inline Segmentation segment(const OrganizedCloud& cloud, const PointRings& rings,
                            const NormalMap& normals, const SegmentationSettings& settings = {}) {
  Segmentation out;
  segment(cloud, rings, normals, settings, out);
  return out;
}

/// Stage 5 without a mesh: the plane polygons of an unorganized cloud's segments, in the
/// grid's PolygonSet (the same frames, loop order, areas, hulls and settings). Each point of a
/// segment covers a footprint on the segment's plane: the ellipse of `point_area` in plane
/// coordinates (points projected along their viewing ray from `settings.viewpoint`, as on the
/// grid), taken as its bounding box; on a square grid of spacing h and k = 12 the box is 1.2 h
/// wide, so it covers the gaps to the neighbours as a range image's pixel squares do. The union
/// of the boxes is rasterised (cells of the median half-width of the boxes, at most 2^21
/// cells per segment), closed with a 3x3 square and traced into outer loops and holes (no
/// concavity or hole narrower than about a point spacing survives), which are simplified as on
/// the grid. One "pixel" of the settings is the segment's median footprint side (the square
/// root of its area): the simplification tolerance is the larger of simplify_tolerance (capped
/// by simplify_inradius_fraction of the segment's inradius, its area taken as a square's) and
/// simplify_tolerance_pixels footprints, and loops smaller than min_loop_pixels footprints are
/// dropped (except the largest outer loop). `raw_*` describe the traced raster outline; the
/// convex hull is that of the outer loops' vertices. `pixels` and `hull_pixels` stay empty
/// (there is no image); `out.width` and `out.height` are the cloud's. A segment whose points
/// have no extent gets no loops. Throws std::invalid_argument for rings or labels of another
/// size and for invalid settings.
void extract_polygons(const OrganizedCloud& cloud, const PointRings& rings,
                      const Segmentation& segmentation, const PolygonSettings& settings,
                      PolygonSet& out);
inline PolygonSet extract_polygons(const OrganizedCloud& cloud, const PointRings& rings,
                                   const Segmentation& segmentation,
                                   const PolygonSettings& settings = {}) {
  PolygonSet out;
  extract_polygons(cloud, rings, segmentation, settings, out);
  return out;
}

}  // namespace rangeseg
