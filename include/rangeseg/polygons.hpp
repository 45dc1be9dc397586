// Plane polygons (paper, Fig. 1d): the outline of every planar segment as closed polygons on its
// fitted plane (outer boundary and holes), simplified, with area, perimeter and convex hull.
//
// A mesh face belongs to segment L when all its corners carry label L. The boundary of the
// segment is the set of edges used by exactly one of its faces; they are chained into closed
// loops. Where two loops touch in one vertex (a "pinch"), each loop turns into the tightest
// wedge of the segment at that vertex and a walk that visits a vertex twice is cut there, so
// every loop visits each vertex at most once and loops never cross.
//
// Loop vertices are mesh vertices projected onto the segment's plane along their viewing ray
// (from `PolygonSettings::viewpoint`): the projection of the pixel grid onto a plane is a
// homography, so depth noise does not fold the outline (an orthogonal projection does, and mixing
// the two does too). Only a ray that misses the plane's front side falls back to the orthogonal
// projection. Near grazing incidence a point's noise is stretched along the ray (by
// 1 / cos(incidence)); the mesh's angle test (MeshSettings::eps_theta) keeps such faces rare.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/segmentation.hpp"

namespace rangeseg {

struct PointRings;  // unorganized.hpp
class ThreadPool;   // thread_pool.hpp

/// An orthonormal 2D frame on a plane. A point with plane coordinates (x, y) is the camera-frame
/// point origin + x e1 + y e2; a camera-frame point p on the plane has x = (p - origin) . e1,
/// y = (p - origin) . e2. e1 x e2 = normal (the segment's normal, facing the camera), so seen
/// from the camera (e1, e2) is a right-handed frame: counter-clockwise in 2D is counter-clockwise
/// on the image. e1 is the camera's x axis (image right) projected onto the plane; for planes
/// nearly perpendicular to it, e2 is the camera's -y axis (image up) projected instead.
struct PlaneFrame {
  std::array<double, 3> origin{};  ///< plane point closest to the segment centroid [m]
  std::array<double, 3> normal{};  ///< unit, facing the camera
  std::array<double, 3> e1{};      ///< unit, in the plane
  std::array<double, 3> e2{};      ///< unit, in the plane, normal x e1
  double offset = 0;               ///< normal . x + offset = 0 [m]
};

/// Settings of `PolygonExtractor::extract`.
struct PolygonSettings {
  /// Douglas-Peucker tolerance: max distance of a dropped boundary vertex from the simplified
  /// loop [m]. The tolerance used for a loop is the larger of this (capped by
  /// `simplify_inradius_fraction`) and `simplify_tolerance_pixels` pixel footprints. 0 and 0 =
  /// no simplification.
  double simplify_tolerance = 0.01;
  /// Caps `simplify_tolerance` at this fraction of the loop's inradius, 2 area / perimeter (a
  /// square's half side, a disc's radius; a long strip's width) [dimensionless]. Dropping
  /// vertices within t of the simplified loop changes its area by at most t times its
  /// perimeter, so the cap bounds that change to 2 x 0.05 = 10 % of the area, whatever the
  /// scale: 1 cm stays 1 cm for a table, and becomes 0.3 mm for a 15 x 10 mm face of a
  /// 0.1 mm structured-light scan. Unorganized clouds take the segment's area as a square's.
  /// 0 disables the absolute tolerance; a large value disables the cap.
  double simplify_inradius_fraction = 0.05;
  /// Depth-aware part of the tolerance, in pixel footprints at the loop (one footprint = mean
  /// length of the loop's mesh boundary edges) [dimensionless]. The mesh outline is a staircase
  /// on the pixel grid whose steps are up to one footprint, plus ~1 pixel of edge dropouts.
  double simplify_tolerance_pixels = 1.5;
  /// Compute a convex hull per segment (Andrew's monotone chain on the boundary vertices).
  bool convex_hull = true;
  /// Segments with fewer pixels are skipped [pixels].
  int min_segment_pixels = 0;
  /// Only segments whose surface is a plane (`is_plane`; smooth, cylinder and sphere segments
  /// are curved: their plane is a fit).
  bool planes_only = true;
  /// Holes and further outer loops (islands) whose area in the image is smaller are dropped
  /// (e.g. single dropped pixels) [pixel^2]; the largest outer loop is always kept. 0 keeps all.
  double min_loop_pixels = 8.0;
  /// Sensor origin for the ray projection [m], camera frame.
  std::array<float, 3> viewpoint{0.0f, 0.0f, 0.0f};
};

/// Throws std::invalid_argument naming the field and its value unless the tolerances and
/// min_loop_pixels are finite and >= 0, min_segment_pixels >= 0 and the viewpoint finite.
void validate(const PolygonSettings& settings);

/// One closed loop, vertices [first, first + count) of the PolygonSet point arrays, without
/// repeating the first vertex at the end. Outer loops run counter-clockwise in the plane frame
/// (positive area), holes clockwise.
struct PolygonLoop {
  int segment = 0;  ///< index into PolygonSet::segments
  int label = 0;    ///< segment label (Segmentation::labels value)
  bool is_hole = false;
  int parent = -1;       ///< holes: index in PolygonSet::loops of the enclosing outer loop; else -1
  int first = 0;         ///< first vertex in points3d / points2d / pixels
  int count = 0;         ///< number of vertices (>= 3)
  double area = 0;       ///< |area| of the simplified loop [m^2]
  double perimeter = 0;  ///< of the simplified loop [m]
  double raw_area = 0;   ///< |area| of the unsimplified mesh boundary [m^2]
  double raw_perimeter = 0;  ///< of the unsimplified mesh boundary [m] (a staircase: longer)
  int raw_count = 0;         ///< vertices of the unsimplified loop
  double tolerance = 0;      ///< simplification tolerance used [m] (0: kept unsimplified)
};

/// Per segment: its frame, loops, hull and areas.
struct SegmentPolygons {
  int label = 0;
  PlaneFrame frame;
  /// loops[first_loop] is the outer loop that encloses the most pixels in the image
  int first_loop = 0;
  /// Loops of this segment: the outer loops by the pixels they enclose in the image, descending
  /// (their areas in the plane, `PolygonLoop::area`, after simplification, may be ordered
  /// otherwise where depths differ), then the holes grouped by parent in the order of their
  /// parents (each group in tracing order).
  int loop_count = 0;
  int hull_first = 0;  ///< range into hull_points2d / hull_points3d / hull_pixels (CCW)
  int hull_count = 0;
  double area = 0;            ///< outer loops minus holes, simplified (0 at least) [m^2]
  double raw_area = 0;        ///< the same for the mesh boundary (= projected mesh area) [m^2]
  double perimeter = 0;       ///< sum over all loops, simplified [m]
  double hull_area = 0;       ///< [m^2]
  double hull_perimeter = 0;  ///< [m]
};

/// All polygons of one frame in flat arrays (no container per polygon).
struct PolygonSet {
  int width = 0, height = 0;              ///< image size the pixels refer to
  std::vector<SegmentPolygons> segments;  ///< processed segments, by label ascending
  std::vector<PolygonLoop> loops;
  std::vector<std::array<float, 3>> points3d;  ///< on the plane, camera frame [m]
  std::vector<std::array<float, 2>> points2d;  ///< plane frame (PlaneFrame) [m]
  /// image (u, v) of the mesh vertex [pixel]; empty for an unorganized cloud (unorganized.hpp)
  std::vector<std::array<float, 2>> pixels;
  std::vector<std::array<float, 3>> hull_points3d;
  std::vector<std::array<float, 2>> hull_points2d;
  std::vector<std::array<float, 2>> hull_pixels;

  /// The polygons of the segment labelled `label`, or null when it has none (a curved segment,
  /// one below min_segment_pixels): a binary search over `segments`.
  const SegmentPolygons* find(int label) const {
    const auto at =
        std::lower_bound(segments.begin(), segments.end(), label,
                         [](const SegmentPolygons& s, int wanted) { return s.label < wanted; });
    return at != segments.end() && at->label == label ? &*at : nullptr;
  }

  /// Empties every array, keeping their capacity (the extractors start each frame so).
  void clear() {
    segments.clear();
    loops.clear();
    points3d.clear();
    points2d.clear();
    pixels.clear();
    hull_points3d.clear();
    hull_points2d.clear();
    hull_pixels.clear();
  }
};

/// Computes plane polygons frame after frame. Reusing one extractor and one PolygonSet for a
/// stream of frames of one size allocates nothing after the first frames (buffers only grow).
/// Not thread-safe; use one per thread.
class PolygonExtractor {
 public:
  PolygonExtractor();
  ~PolygonExtractor();
  PolygonExtractor(PolygonExtractor&&) noexcept;
  PolygonExtractor& operator=(PolygonExtractor&&) noexcept;

  /// `cloud` is the cloud the segmentation was computed on (e.g. Pipeline::cloud()), `mesh` its
  /// mesh. Throws std::invalid_argument for mismatched sizes, invalid settings, or a label that
  /// names no segment.
  void extract(const OrganizedCloud& cloud, const Mesh& mesh, const Segmentation& segmentation,
               const PolygonSettings& settings, PolygonSet& out);
  /// The same, the segments split among the pool's threads (consecutive runs of about equal
  /// boundary length); the result is identical to the single-threaded one.
  void extract(const OrganizedCloud& cloud, const Mesh& mesh, const Segmentation& segmentation,
               const PolygonSettings& settings, PolygonSet& out, ThreadPool& pool);
  /// The polygons of an unorganized cloud over its k-nearest-neighbour rings, without a mesh:
  /// see extract_polygons in unorganized.hpp.
  void extract(const OrganizedCloud& cloud, const PointRings& rings,
               const Segmentation& segmentation, const PolygonSettings& settings, PolygonSet& out);

  struct Scratch;
  struct RingScratch;
  struct RingScratchDeleter {
    void operator()(RingScratch* scratch) const;
  };

 private:
  void extract_grid(const OrganizedCloud& cloud, const Mesh& mesh, const Segmentation& segmentation,
                    const PolygonSettings& settings, PolygonSet& out, ThreadPool* pool);

  std::unique_ptr<Scratch> scratch_;
  std::unique_ptr<RingScratch, RingScratchDeleter> ring_scratch_;
};

/// One-shot extraction (allocates its scratch buffers); throws as PolygonExtractor::extract.
PolygonSet extract_polygons(const OrganizedCloud& cloud, const Mesh& mesh,
                            const Segmentation& segmentation, const PolygonSettings& settings = {});

/// The pixel coordinates of loop `loop` (closed = the caller passes closed=true to
/// draw_polyline), into `out` (reused); empty when the set has no pixels (an unorganized cloud).
void loop_pixels(const PolygonSet& polygons, int loop, std::vector<std::array<float, 2>>& out);
/// The same for the convex hull of segment `segment` (index into PolygonSet::segments). Both
/// throw std::invalid_argument for an index out of range.
void hull_pixels(const PolygonSet& polygons, int segment, std::vector<std::array<float, 2>>& out);

/// Convex hull of 2D points (Andrew's monotone chain), counter-clockwise, without collinear
/// points; fewer than 3 distinct points give those points. O(n log n).
void convex_hull(const std::vector<std::array<float, 2>>& points,
                 std::vector<std::array<float, 2>>& hull);

/// Loops in flat arrays: loop i is points[first[i] .. first[i] + count[i]); outer loops
/// counter-clockwise, holes clockwise (negative area).
struct Polygons2D {
  std::vector<std::array<float, 2>> points;
  std::vector<int> first;
  std::vector<int> count;
  std::vector<std::uint8_t> is_hole;
};

/// Concave hull ("grid alpha shape") of a 2D point set without a mesh, e.g. a segment given as
/// points. The points are binned into square cells of side alpha / 2; the shape is the union of
/// occupied cells closed morphologically with a 3x3 structuring element (gaps up to ~alpha are
/// bridged, so alpha should be ~2-3 times the point spacing), and its boundary is traced and
/// simplified with tolerance alpha / 4. Every point lies inside or within alpha / 2 * sqrt(2)
/// of the result; concavities and holes wider than ~1.5 alpha are kept. Cost O(n + cells) with
/// cells = area of the bounding box / (alpha / 2)^2 (throws std::invalid_argument above 2^26
/// cells or for alpha <= 0). Several components give several outer loops.
void concave_hull(const std::vector<std::array<float, 2>>& points, double alpha, Polygons2D& out);

/// Triangulates every outer loop with its holes (holes bridged to the outer loop, then ear
/// clipping) into `triangles`: vertex index triples into PolygonSet::points3d/points2d,
/// counter-clockwise in the plane frame (seen from the camera).
void triangulate_polygons(const PolygonSet& polygons, std::vector<std::array<int, 3>>& triangles);

/// Writes the polygons as a Wavefront OBJ: one object `segment_<label>` per segment with the
/// simplified loop vertices (`v`, metres, camera frame) and the faces of
/// `triangulate_polygons` (`f`), written atomically. Given the segmentation the polygons were
/// traced from, a tracked segment's object is `segment_<label>_track_<Segment::track_id>`, so
/// that a stream's planes keep one name from frame to frame. Throws std::runtime_error naming
/// the file.
void write_polygons_obj(const std::string& path, const PolygonSet& polygons,
                        const Segmentation* segmentation = nullptr);
/// The OBJ text of write_polygons_obj.
std::string polygons_to_obj(const PolygonSet& polygons, const Segmentation* segmentation = nullptr);

}  // namespace rangeseg
