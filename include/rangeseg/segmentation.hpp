// Stage 4 of Holz & Behnke (paper, Sec. III-D): region growing over the mesh 1-ring with an
// exchangeable region model, followed by plane refitting, merging, small-region removal and
// re-assignment of boundary points.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string_view>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/sensor.hpp"
#include "rangeseg/thread_pool.hpp"

namespace rangeseg {

/// The region model a segment is grown with.
enum class RegionModel : std::uint8_t {
  /// Planes: a point joins when its normal is within `max_normal_angle` of the region's mean
  /// normal and its distance to the region's plane (through the centroid, with the mean normal)
  /// is at most `max_distance_sigmas` * sigma(z).
  plane,
  /// Regions of local surface continuity: a neighbour joins when its normal is within
  /// `max_smooth_angle` of the current point's normal and its curvature is at most
  /// `max_curvature`. There is no global model, so curved surfaces form one segment.
  smooth,
  /// Planes grown incrementally (Poppinga et al. 2008): a point joins when its distance to the
  /// region's least-squares plane (running moments) is at most `max_distance_sigmas` * sigma(z)
  /// and the region's mean squared residual, in units of sigma(z)^2 of its points, stays <= 1.
  /// Post-processing as for `plane`.
  incremental_plane,
  /// Planes, cylinders and spheres: plane segmentation, then adjacent segments whose union a
  /// cylinder or sphere explains within the noise are merged, and every segment is labelled
  /// with the simplest surface that explains it (`Segment::kind`).
  automatic,
};

/// The surface a segment's points are explained by (see `Segment`).
enum class SurfaceKind : std::uint8_t { plane, cylinder, sphere, smooth };
const char* to_string(SurfaceKind kind);
const char* to_string(RegionModel model);
/// The model of a name: "plane", "smooth", "incremental_plane" (or "incremental") or "auto".
/// Throws std::invalid_argument naming the valid models for any other name.
RegionModel region_model_from_string(std::string_view name);
using SegmentModel = RegionModel;

/// Settings of `segment`. Distances scale with the sensor noise, so one setting serves the whole
/// depth range of a sensor; see `preset` for physically motivated values per sensor (the
/// defaults here are the Kinect's noise and bounds, with a smaller `min_region_size` than
/// `preset("kinect")`'s 200).
struct SegmentationSettings {
  /// The region model (default plane; see RegionModel).
  RegionModel model = RegionModel::plane;
  /// Axial noise sigma(z) of the sensor [m] that the distance bounds scale with (default: the
  /// Kinect's, 1.2 mm + 1.9 mm/m^2 (z - 0.4 m)^2).
  SensorNoise noise{};

  // --- region growing ---
  /// plane: max angle between a point's normal and the region's mean normal [rad] (25 deg).
  /// Generous because 1-ring normals of raw data are noisy; the distance test does the work.
  double max_normal_angle = 0.4363;
  /// plane: max point-to-plane distance in multiples of sigma(z) of the point (k, dimensionless)
  double max_distance_sigmas = 3.0;
  /// plane: the normal test's angle is also bounded by this many standard deviations of the
  /// frame's normal noise at the point's depth, sigma_n(z) = c sigma(z) / z, with c measured per
  /// frame from the normal spread inside the 8x8 cells (median over complete cells). Near the
  /// sensor, or with smoothed normals, this is far tighter than `max_normal_angle` and keeps
  /// regions from creeping over shallow creases. Far away, where it is wider, an 8x8 cell of
  /// points still counts as one plane when its normals spread by up to 1.5 sigma_n(z), although
  /// many of them are over `max_normal_angle` off. 0 = off (dimensionless).
  double normal_noise_sigmas = 3.0;
  /// plane: the noise-derived angle bound is never below this [rad] (5 deg), for noise-free data
  /// and surfaces that are not exactly planar.
  double min_normal_angle = 0.0873;
  /// smooth: max angle between neighbouring normals [rad] (8 deg)
  double max_smooth_angle = 0.1396;
  /// smooth: points with larger curvature are neither seeds nor added [1/m]
  double max_curvature = 50.0;
  /// Pixels with larger curvature are not used as seeds [1/m] (every model; the default 1e30
  /// admits all).
  double max_seed_curvature = 1e30;
  /// plane: a pixel seed needs every pixel within this many lattice steps of it (a square of
  /// 2r + 1 pixels) to be unlabelled. Between two regions the growth test leaves a band a few
  /// pixels wide where 1-ring normals (and smoothing) mix both surfaces, at creases and
  /// occlusion boundaries; regions seeded there are slivers, which post-processing dissolves
  /// again (on a 640x480 Kinect frame hundreds of them). A face narrower than 2r + 1 pixels
  /// between labelled regions gets no pixel seed [lattice steps] (0..32; 0 = no such test).
  int seed_clearance = 3;
  /// plane: grow over 8x8-vertex cells first (cf. CAPE): a cell whose points and normals pass
  /// the region tests as a whole (from its moments) joins as a unit, the rest of the region is
  /// grown pixel by pixel from the border of its cells. Same model, ~10x fewer per-pixel tests;
  /// false grows every pixel individually (the reference).
  bool coarse_cells = true;
  /// plane and automatic models: the frame is grown as this many horizontal bands of whole cell
  /// rows (incremental_plane and smooth grow the whole frame at once), each on
  /// its own (concurrently, with threads), and the regions a band seam cuts in two are joined
  /// again by merging (`merge_planes`) and boundary re-assignment, which see the whole frame.
  /// Results depend on this number, never on the thread count. A band is at least 4 cell rows
  /// (32 lattice rows) tall, so small frames use fewer. 1 = the whole frame at once, in one
  /// seed order (dimensionless, 1..64). Default 2, so that region growing, most of
  /// segmentation, runs on two threads when there are two (a 640x480 Kinect frame: plane
  /// segmentation ~0.75x the time of one band, the whole frame 1.4-1.75x faster than on one
  /// thread, against 0.85-1.4x with one band); on one thread 2 bands cost ~6 % more segmentation
  /// instructions. A region seeded in one band no longer claims pixels of the other before that
  /// band's own seeds do; `boundary_refine_sigmas` puts the borders at creases back on the
  /// surfaces (SegComp ABW: 88.5 % of the regions correct with 2 or 4 bands, 88.0 % with 1).
  int growth_bands = 2;

  // --- post-processing ---
  /// Segments with fewer pixels are removed (their pixels become unlabelled and may then be
  /// re-assigned to an adjacent plane) [pixels]. Plane models keep a region of at least half as
  /// many pixels when it is, in 3D, at least sqrt(2 min_region_size) pixel footprints wide in
  /// its narrower direction (a face seen obliquely covers fewer pixels than its size warrants;
  /// slivers along creases are narrow): its frontal area is then twice the minimum's. Over
  /// k-nearest-neighbour rings (plane model), a footprint is the median angle between a point
  /// and its nearest ring neighbour, seen from the origin.
  int min_region_size = 100;
  /// The focal length of the camera whose pixels `min_region_size` counts [pixel]. Where a
  /// Pipeline knows the frame's camera (a depth image's intrinsics, `process(cloud, camera_fx)`,
  /// the pixel grid of an unorganized cloud, else the pinhole camera fitted to an organized
  /// cloud's points) and it is coarser, it counts min_region_size_for(settings, fx /
  /// pixel_stride) pixels, the same solid angle: 200 pixels of a 640x480 Kinect are 50 of its
  /// 320x240 stream (49 at 160x120, see min_region_size_for), so that a smaller stream keeps
  /// the objects the full one finds. A finer camera keeps min_region_size pixels. 0 =
  /// min_region_size counts the frame's own pixels, as Segmenter and the free function `segment`
  /// always do.
  /// Presets kinect and ideal: 525 (a Kinect at 640x480); abw, laser and perceptron: 0 (their
  /// scanners' own grids).
  double min_region_fx = 525.0;
  /// plane: merge adjacent segments whose least-squares planes agree. On a grid whose columns go
  /// once round the sensor (a spinning lidar's organized scan; the angle between the first and
  /// the last column's rays at most 2.5 times that between neighbouring columns), segments that
  /// meet across the first and last columns are adjacent too.
  bool merge_planes = true;
  /// Max angle between the normals of two planes to merge [rad] (5 deg).
  double merge_angle = 0.0873;
  /// Max distance of each plane's centroid to the other plane, in multiples of sigma(z) at that
  /// centroid (dimensionless). Also the bound of the third merge test: adjacent segments merge
  /// when the points of each lie on the least-squares plane of their union with an RMS distance
  /// of at most this many times the surface's noise, max(sigma(z), pooled RMS residual of the two
  /// fits) (a large plane's residual includes the scanner's systematic distortion, which cuts it
  /// into slightly tilted pieces), their normals agree within `merge_rms_max_angle` plus this
  /// many standard errors of the smaller part's normal (its residual floored at sigma(z), so a
  /// thin strip such as one range-quantisation terrace may join) and the merged RMS stays within
  /// 1.5 times the larger part's RMS plus sigma(z) / 2 (plus nothing when the parts' normals
  /// differ by more than `merge_angle` plus this many of the smaller part's standard errors:
  /// two compact, well-fitted faces a few degrees apart stay two segments).
  double merge_distance_sigmas = 3.0;
  /// Adjacent segments also merge when one least-squares plane fits the union of their points
  /// with an RMS residual of at most this many sigma(z) (and not much more than the parts' own
  /// residuals, as bounded under `merge_distance_sigmas`), e.g. the strips range quantisation
  /// cuts a grazing surface into (dimensionless).
  double merge_rms_sigmas = 1.0;
  /// ... provided their normals are within this angle [rad] (20 deg).
  double merge_rms_max_angle = 0.349;
  /// plane, with `merge_planes`: after merging, a segment whose RMS residual about its plane, in
  /// units of sigma(z) at its centroid, is more than this many times what the frame's good
  /// planes achieve (the lower tercile of the other segments' ratios) is cut into two to four
  /// planes, each part of at least `min_region_size` pixels, unless merging joins them again: a
  /// region that crept over a crease or a step while growing (dimensionless; 0 = off).
  double split_residual_factor = 2.5;
  /// plane and incremental_plane, with `merge_planes`: after merging and splitting, a point on
  /// the border of two plane segments (joined by a mesh edge; over k-nearest-neighbour rings,
  /// with the other segment in its ring, sigma of the range) moves to the other one when it
  /// lies closer to that plane by more than this many sigma(z), and within
  /// `max_distance_sigmas` sigma(z) of it; the planes are refitted and the neighbours of the
  /// points that moved tested in turn (up to 8 rounds). Near a crease the points lie within the
  /// growth test's distance bound of both planes, so region growing gives them to whichever
  /// region reaches them first: the border follows the seed order (and, with `growth_bands`,
  /// the band seams) instead of the surfaces. Not for `automatic`, whose plane facets may be
  /// pieces of one curved surface (dimensionless; 0 = off).
  double boundary_refine_sigmas = 1.0;
  /// plane models: a surface seen within a few degrees of its plane (a table or box top a
  /// little below the sensor, a wall edge-on) has its rows centimetres apart in depth, as far
  /// as the depth noise or farther, so its 1-ring normals scatter by tens of degrees and the
  /// mesh may be cut there: growth leaves it unlabelled or in fragments. After boundary
  /// re-assignment each set of unlabelled points connected over the lattice (neighbours at most
  /// footprint z / tan(grazing_min_angle) + sqrt(2) max_distance_sigmas sigma(z) apart in depth)
  /// is fitted with a plane robustly (from the grazing plane with most support among its
  /// least-squares plane and planes through sampled point triples, then four rounds, down to its
  /// points within max_distance_sigmas sigma(z) sin(angle to the ray) of it, that sine floored at
  /// sin(grazing_max_angle); when a plane is taken, the rest of the set is searched again, so a
  /// box's top and side that meet there both count); a plane at least this angle [rad]
  /// (2 deg) and at most `grazing_max_angle` off the viewing ray at its centroid, with an RMS
  /// residual of at most sigma(z) sin(grazing_max_angle), becomes a segment, merged with its
  /// neighbours as any other, when its points cover the area of `min_region_size` pixels facing
  /// the sensor (at least min_region_size times the sine of its angle to the rays, and half
  /// min_region_size, as for any region); one below min_region_size points and not wide in 3D
  /// must be wider, across the image, than sqrt(12) sigma(z) sin(grazing_max_angle), the width
  /// a plane through its points edge-on would fit as well. The lower bound keeps out the points
  /// that a depth step leaves between its two sides (a laser scanner's veil), which lie in a plane
  /// through the sensor. Over the k-nearest-neighbour rings of an unorganized cloud the same (but
  /// the width test), with each unlabelled point's 8 nearest unlabelled points by viewing
  /// direction within 2.5 footprints as its neighbours (its range, not z). 0 = off.
  double grazing_min_angle = 0.0349;
  /// ... [rad] (25 deg: twice the mesh's default eps_theta, below which the 1-ring normals of
  /// Kinect data at a few metres are unreliable).
  double grazing_max_angle = 0.4363;
  /// plane: unlabelled valid points adjacent (mesh 1-ring) to a plane segment join the closest
  /// adjacent plane if within `max_distance_sigmas` * sigma(z) of it (perpendicular distance).
  bool reassign_boundary = true;
  /// ... and, unless `reassign_across_mesh_cuts`, if the point's normal is within this angle
  /// [rad] of the plane's normal (60 deg; a point without a normal is placed by distance
  /// alone). A point on a crease has a 1-ring normal between the two faces (45 deg from each at
  /// a right angle), while a point of the other face is ~90 deg off, although near the crease
  /// it lies within the distance bound of both planes. (Where mesh cuts are crossed, the points
  /// are those of grazing surfaces whose 1-ring normals are unreliable: distance alone.)
  double reassign_max_normal_angle = 1.047;
  /// plane, with `reassign_boundary`: adjacency also over the image 8-neighbours the mesh's
  /// depth-jump gate cut off. For sensors whose noise is far below the pixel footprint (abw
  /// preset), the gate cuts surfaces seen at grazing incidence into single columns, whose points
  /// the perpendicular plane test still places; off by default (a little slower; with noise
  /// larger than the footprint, as for the Kinect at range, the gate rarely cuts a surface).
  bool reassign_across_mesh_cuts = false;
  /// Compute Segment::area_m2 (one extra pass over the mesh faces).
  bool compute_area = true;
};

/// Settings for a sensor: "kinect" (structured light, 0.5-6 m, sigma = 0.0012 + 0.0019 (z-0.4)^2
/// m), "abw" (SegComp ABW structured-light scanner in metres, sigma ~ 0.5 mm over 0.8-1.1 m,
/// dominated by the 8-bit range quantisation), "laser" (time-of-flight laser scanner, sigma ~
/// 15 mm constant), "perceptron" (SegComp's Perceptron laser: "laser" with 100-pixel regions),
/// "ideal" (noise-free or simulated depth, sigma 0.5 mm constant; the pipeline preset does not
/// smooth). Throws std::invalid_argument naming the valid presets for any other
/// name.
SegmentationSettings preset(std::string_view name);

/// One segment. The plane fields are a least-squares fit over the segment's points (also for
/// smooth segments, where they describe the best plane through a curved surface).
struct Segment {
  int label = 0;  ///< value in Segmentation::labels, 1..N
  SegmentModel model = SegmentModel::plane;
  int pixel_count = 0;  ///< [pixels]
  /// sum of the mesh face areas split among vertices (see grazing); over rings see
  /// unorganized.hpp's `segment`. A Pipeline that extracts polygons gives a plane segment its
  /// polygon's area instead (SegmentPolygons::area, in the plane), as noise tilts the faces:
  /// those of a Kinect wall at 4-6 m sum to 1.2 times its area [m^2]
  double area_m2 = 0;
  std::array<double, 3> centroid{};  ///< [m], camera frame
  std::array<double, 3> normal{};    ///< unit, facing the camera (normal . centroid <= 0)
  double offset = 0;                 ///< normal . x + offset = 0 [m], offset >= 0
  double rms_residual = 0;           ///< RMS point-to-plane distance [m]

  /// The surface that explains the points: plane for the plane models, smooth for `smooth`;
  /// with `automatic` cylinder or sphere when one explains the points within the noise much
  /// better than a plane, else plane (`automatic` does not produce smooth segments yet; its
  /// `model` is plane for plane segments and automatic for curved ones).
  SurfaceKind kind = SurfaceKind::plane;
  /// RMS geometric distance of the points to the surface of `kind` [m] (= rms_residual for
  /// planes and smooth segments).
  double surface_rms = 0;
  /// sphere: centre; cylinder: the point of the axis at the start of the points' extent [m].
  std::array<double, 3> centre{};
  /// cylinder: unit axis direction, pointing up in the camera frame (y <= 0; a horizontal axis
  /// towards +x, or +z when along z)
  std::array<double, 3> axis{};
  double radius = 0;  ///< sphere / cylinder radius [m]
  double extent = 0;  ///< cylinder: length of the points along the axis from `centre` [m]
  /// Holds points of a plane found seen at grazing incidence
  /// (SegmentationSettings::grazing_min_angle), where the mesh has few faces: `area_m2` counts
  /// the segment's cells as `close_grazing_cells` closes them, and Pipeline closes them in its
  /// mesh before it traces the polygons (an unorganized cloud has no mesh: the flag only says
  /// how the plane was found).
  bool grazing = false;
  /// The segment's track in a stream (SegmentTracker, PipelineSettings::track): the same id as
  /// the segment of the previous frame it continues, else a new one; 0 when not tracked.
  std::uint32_t track_id = 0;
};

struct Segmentation {
  LabelImage labels;              ///< size of the cloud; 0 = no segment, else 1..N
  std::vector<Segment> segments;  ///< segments[i].label == i + 1, by pixel count descending
};

/// Adds the faces of every mesh cell whose four corners carry the label of one `grazing`
/// segment (two triangles on the cell's diagonal, or a quad for MeshType::quad), with their
/// edges: on a surface seen at grazing incidence the mesh's jump test cut most of them, although
/// the segment's points lie on one plane. Does nothing when no segment is `grazing`. Throws
/// std::invalid_argument when the sizes differ or a label names no segment.
void close_grazing_cells(const Segmentation& segmentation, Mesh& mesh);

/// Owns the scratch buffers of segmentation (seed buckets, processing queue, per-region
/// statistics, union-find). Reusing one Segmenter and one Segmentation for a stream of frames of
/// the same size allocates nothing after the first frame (unless a frame has more regions than
/// any before). Not thread-safe; use one per thread.
class Segmenter {
 public:
  Segmenter();
  ~Segmenter();
  Segmenter(Segmenter&&) noexcept;
  Segmenter& operator=(Segmenter&&) noexcept;

  /// Segments an organized cloud with its mesh and normals (all of the same size; vertices on
  /// the mesh's stride lattice only). Throws std::invalid_argument for mismatched sizes or
  /// invalid settings.
  void segment(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
               const SegmentationSettings& settings, Segmentation& out);
  /// As above, with the passes over the whole frame (cell statistics, seed scan, label remaps,
  /// the scans for boundary and adjacent pixels) split into `pool.threads()` row bands that run
  /// concurrently, and region growing's `growth_bands` bands run concurrently too; merging,
  /// boundary re-assignment and the grazing-plane search stay serial. The result is
  /// bit-identical to the single-threaded call.
  void segment(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
               const SegmentationSettings& settings, Segmentation& out, ThreadPool& pool);

  /// Sets Segment::area_m2 of every segment of `out` (a segmentation of this cloud and mesh,
  /// e.g. made with compute_area = false) [m^2]: a third of each mesh triangle's area and a
  /// quarter of each quad's go to each of its labelled corners, label j + 1 being segments[j].
  /// Reads only the labels, points and faces and writes only the areas, so it may run while
  /// another thread reads the rest of `out` (Pipeline does so alongside the polygons). Throws
  /// std::invalid_argument for mismatched sizes or a label outside [0, segments.size()].
  void compute_areas(const OrganizedCloud& cloud, const Mesh& mesh, Segmentation& out);

  struct Scratch;

 private:
  void run(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
           const SegmentationSettings& settings, Segmentation& out, ThreadPool* pool);

  std::unique_ptr<Scratch> scratch_;
};

/// Whether a segment's surface is a plane: its `kind` is plane and its `model` is not smooth (a
/// smooth segment's plane is only a fit), e.g. for the plane, incremental_plane and auto models'
/// plane segments.
inline bool is_plane(const Segment& segment) {
  return segment.kind == SurfaceKind::plane && segment.model != RegionModel::smooth;
}

/// Groups of coplanar plane segments: per segment (index label - 1) the label of the largest
/// segment whose plane it shares, directly or through others, or 0 for a segment that is no
/// plane (is_plane). Segments are connected regions, so one surface that an object cuts apart
/// (a table seen on both sides of a box) is several segments of one group, as are two box tops
/// at one height. Two planes are one when their normals agree within `merge_angle` plus
/// `merge_distance_sigmas` standard errors of both normals and each centroid lies on the other
/// plane within `merge_distance_sigmas` times the root sum of squares of its own scatter (the
/// noise sigma at its range, or its rms_residual when larger: a large plane's fit also sees the
/// sensor's bending), the other plane's rms_residual, and the other normal's error over the
/// distance between the centroids. A normal's standard error is max(rms_residual, sigma) /
/// sqrt(pixel_count * area_m2 / (4 pi)), a disc's spread of that area. O(segments^2); throws
/// std::invalid_argument for invalid settings.
std::vector<int> coplanar_groups(const Segmentation& segmentation,
                                 const SegmentationSettings& settings = {});

/// `min_region_size` for a frame of a camera with focal length `camera_fx` [pixel]: for a
/// camera coarser than min_region_fx, min_region_size (camera_fx / min_region_fx)^2 rounded, but
/// not below a pixel seed's window, (2 seed_clearance + 1)^2 pixels (49), where a region would be
/// mostly the band that blurs its borders, unless min_region_size is smaller; min_region_size
/// itself for a finer camera, or when min_region_fx or camera_fx is 0 (unknown).
int min_region_size_for(const SegmentationSettings& settings, double camera_fx);

/// Throws std::invalid_argument naming the field and its value for settings `segment` rejects
/// (e.g. min_region_size below 1, angles outside their ranges, a non-finite noise model).
void validate(const SegmentationSettings& settings);

/// One-shot segmentation (allocates its scratch buffers; use a Segmenter for streams).
void segment(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
             const SegmentationSettings& settings, Segmentation& out);
inline Segmentation segment(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
                            const SegmentationSettings& settings = {}) {
  Segmentation out;
  segment(cloud, mesh, normals, settings, out);
  return out;
}

}  // namespace rangeseg
