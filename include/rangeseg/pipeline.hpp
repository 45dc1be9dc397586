// The whole frame: mesh, normals, smoothing and segmentation with buffers reused across frames.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "rangeseg/camera.hpp"
#include "rangeseg/cloud.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/pixel_grid.hpp"
#include "rangeseg/polygons.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/smoothing.hpp"
#include "rangeseg/thread_pool.hpp"
#include "rangeseg/tracking.hpp"
#include "rangeseg/unorganized.hpp"

namespace rangeseg {

struct PipelineSettings {
  MeshSettings mesh{};
  NormalSettings normals{};
  bool smooth = true;  ///< run the bilateral filter; segmentation then uses smoothed points/normals
  SmoothingSettings smoothing{};
  bool segment = true;  ///< run segmentation (and, with `polygons`, the polygons)
  SegmentationSettings segmentation{};
  bool polygons = true;  ///< outline every plane segment (needs `segment`)
  PolygonSettings polygon{};
  /// Threads inside one frame: mesh, normals, smoothing and segmentation's frame-wide passes run
  /// on this many row bands at once, and the smooth model's segment areas are summed while the
  /// polygons are traced (then counted in StageTimes::polygons; a plane takes its polygon's
  /// area); results are bit-identical to 1 thread.
  /// Region growing runs on min(threads, growth bands) threads
  /// (SegmentationSettings::growth_bands, default 2).
  /// Frames under 65536 pixels always run on one thread (a hand-off costs as much as their
  /// work). While `process` runs, idle workers spin between the stages' bands instead of
  /// sleeping (ThreadPool::KeepAwake), so they occupy their cores for the whole frame; between
  /// frames they sleep. Give no more threads than the cores the pipeline has to itself: on a
  /// 2-core host with another process busy on one core, 2 threads ran a 640x480 frame 0.73x as
  /// fast as one. 1..256 [threads], default 1.
  int threads = 1;
  /// Unorganized clouds (height 1) only: the k-nearest-neighbour rings that stand in for the
  /// mesh (see unorganized.hpp); `mesh`, `polygon` and the grid-only segmentation settings are
  /// not used for them.
  RingSettings rings{};
  /// Unorganized clouds only: when the points lie on a pinhole camera's pixel grid (a depth
  /// camera's valid points, in any order: `find_pixel_grid`), and RingSettings::viewpoint is
  /// the origin, they are put back on that grid and run the grid stages, which are faster (a
  /// 640 x 480 frame: ~20 ms against ~600 ms) and more accurate than the rings. false: always
  /// rings (e.g. to measure them).
  bool restore_grid = true;
  /// Give the segments of consecutive frames track ids (Segment::track_id, SegmentTracker):
  /// the same id while a surface stays in view. Frames on a pixel grid only (organized clouds,
  /// depth images and unorganized clouds restored to the same grid); over rings the ids are 0
  /// and the next grid frame starts new tracks. Default false (costs 0.2-0.6 ms per 640x480
  /// frame, more for more fragmented labels).
  bool track = false;
  TrackingSettings tracking{};
};

/// Sets the sensor noise model of every stage.
void set_noise(PipelineSettings& settings, const SensorNoise& noise);

/// Settings for a sensor: "kinect" (structured light, also PrimeSense), "abw"
/// (SegComp ABW scanner in metres), "laser", "perceptron" (SegComp's Perceptron laser) or
/// "ideal" (noise-free or simulated depth: no smoothing; see `preset` in segmentation.hpp). Sets
/// the noise model of every stage and the segmentation's preset; "laser" and "perceptron" also
/// set their scanners' pixel angle (the others leave 0: from the camera), "abw" turns the
/// smoothing off and sets mesh.jump_sigmas = 10. Throws std::invalid_argument for other names,
/// listing the valid ones.
PipelineSettings pipeline_preset(std::string_view sensor);

/// Wall-clock time of each stage of the last frame [ms].
struct StageTimes {
  /// `mesh`: for an unorganized cloud over rings, building the rings.
  double mesh = 0, normals = 0, smoothing = 0, segmentation = 0, polygons = 0, total = 0;
  /// Depth image to points (the depth-image `process`); for an unorganized cloud, the moves
  /// into spatial order and back. Part of total.
  double input = 0;
  /// Segment tracking (PipelineSettings::track). Part of total.
  double tracking = 0;
};

/// Throws std::invalid_argument naming the field and its value for settings a Pipeline rejects:
/// threads outside [1, 256], or mesh, normal, smoothing, segmentation, polygon or ring settings
/// that their stage rejects (`validate` of each), or invalid tracking settings.
void validate(const PipelineSettings& settings);

/// Runs the stages on frame after frame. It owns every intermediate buffer and keeps it, so
/// after the first frame of a given size no stage allocates, except where a frame's content
/// needs more than any frame before (more segments, polygon vertices, tracks: a stream settles
/// within a few frames). Results stay valid until the next call of `process`. One thread at a
/// time: a `process` call while another thread's runs throws std::logic_error (the running
/// frame goes on); reading results while another thread processes is a data race.
class Pipeline {
 public:
  /// Throws std::invalid_argument for invalid settings (`validate`). Starts settings.threads - 1
  /// worker threads, which live as long as the pipeline.
  explicit Pipeline(const PipelineSettings& settings = {});

  /// Processes one cloud. An organized cloud runs the grid stages. An unorganized one (height
  /// 1) runs the stages over k-nearest-neighbour rings (unorganized.hpp): `rings()` instead of
  /// `mesh()` (which is left empty; StageTimes::mesh is the time of the rings), polygons from
  /// the points' footprints, and the plane, smooth and auto models (std::invalid_argument for
  /// incremental_plane, which only a restored grid, below, supports). The stages run on the points
  /// put in spatial order (by the Morton code of their direction from RingSettings::viewpoint, or
  /// of their position for rings by 3D distance), so that neighbours lie close in memory, and every
  /// result is put back into the input order: the same points in any order give the same rings,
  /// normals, points, labels, segments and polygons (StageTimes::input is the time of both moves).
  /// Where its points lie on a camera's pixel grid (PipelineSettings::restore_grid,
  /// `pixel_grid()`), the grid stages run on them instead: `mesh()` is then the grid's, as are
  /// the polygons' `pixels`, `rings()` is empty, and the points, normals and labels come back per
  /// point in input order as well (StageTimes::input: finding the grid and both moves). Its
  /// buffers, the k-d tree's included, are kept too: once they fit the largest cloud seen, nothing
  /// is allocated with `new`; the tree, rebuilt in place per frame, takes its nodes from
  /// nanoflann's pool of 8 KB malloc blocks.
  /// `camera_fx` [pixel]: the focal length of the camera an organized cloud was computed with,
  /// when known (e.g. from a depth image), for the smoothing's pixel angle (1 / fx) when
  /// SmoothingSettings::pixel_angle is 0 and the minimum segment size when
  /// SegmentationSettings::min_region_fx is not (min_region_size_for); 0 = unknown: the
  /// pinhole camera fitted to a sample of at least 4800 of the points (fit_intrinsics; every 8th
  /// row and column at 640x480, ~0.04 ms), else, when they are no such camera's (a scanner's
  /// grid), kDefaultPixelAngle and min_region_size as given. Throws std::invalid_argument for a
  /// negative or non-finite camera_fx.
  /// A frame that throws anything else (std::bad_alloc when memory runs out midway) leaves no
  /// results, and the pipeline drops its buffers and tracks: the next frame runs as a new
  /// pipeline's first. Every process overload does so.
  void process(const OrganizedCloud& cloud, double camera_fx = 0);
  /// The pipeline reads a cloud in place (cloud() is the caller's without smoothing): a
  /// temporary would be gone before its results are read. Keep the cloud in a variable.
  void process(OrganizedCloud&& cloud, double camera_fx = 0) = delete;

  /// Processes a depth image (raw units, 0 = no measurement, `depth_scale` metres per unit, e.g.
  /// 0.001 for millimetres) seen with `camera`: its points are computed (depth_to_cloud) into a
  /// cloud the pipeline owns, so a camera loop allocates nothing once its buffers fit; the
  /// smoothing's pixel angle is 1 / camera.fx unless the settings give one, and the minimum
  /// segment size is scaled to camera.fx (SegmentationSettings::min_region_fx). Throws
  /// std::invalid_argument for invalid intrinsics or depth_scale, or fewer than 2 rows, before
  /// anything changes: the last frame's results stay as they were.
  void process(View<const std::uint16_t> depth, const CameraIntrinsics& camera,
               double depth_scale = 0.001);
  /// The same for depth in metres (NaN, infinite or <= 0: no measurement; e.g. ROS 32FC1).
  void process(View<const float> depth, const CameraIntrinsics& camera);

  const PipelineSettings& settings() const { return settings_; }
  const Mesh& mesh() const { return mesh_; }
  /// The rings of the last frame when it was unorganized and run over rings, else empty.
  const PointRings& rings() const { return rings_; }
  /// The pixel grid of the last frame when it was unorganized and run on the grid it was found
  /// to lie on, else not found (PixelGrid::found()).
  const PixelGrid& pixel_grid() const { return grid_; }
  const NormalMap& raw_normals() const { return raw_normals_; }
  /// Smoothed points and normals, or the input and raw normals when smoothing is off: then the
  /// caller's cloud of `process(cloud)` (keep it alive while reading), or the pipeline's own
  /// points of a depth image (empty before the first frame).
  const OrganizedCloud& cloud() const {
    if (settings_.smooth) return smoothed_cloud_;
    switch (input_kind_) {
      case InputKind::caller:
        return *input_;
      case InputKind::own:
        return own_input_;
      case InputKind::depth:
        break;
    }
    return depth_cloud_;
  }
  /// Smoothed normals, or the raw ones when smoothing is off. A point of a plane found seen at
  /// grazing incidence (Segment::grazing) that no mesh face reaches, whose 1-ring normal is NaN,
  /// has its plane's normal and curvature 0 here (in raw_normals() too when smoothing is off).
  const NormalMap& normals() const { return settings_.smooth ? smoothed_normals_ : raw_normals_; }
  const Segmentation& segmentation() const { return segmentation_; }
  const PolygonSet& polygons() const { return polygons_; }
  const StageTimes& times() const { return times_; }
  /// Why the last frame gave no segment when its input is the cause, in words for a user (what
  /// is wrong and, where one helps, what to change), else empty: a cloud without a valid point,
  /// or a grid whose mesh joins hardly any of its points (fewer faces than a tenth of its
  /// lattice points) because its pixels seldom have valid neighbours (the rows and columns
  /// that hold points when only every k-th does, and how to mesh those) or because its camera
  /// is so coarse that neighbouring rays lie further apart than the mesh's edge bound (a
  /// max_edge_b that joins them). Empty too when the points themselves leave no face (noise,
  /// surfaces seen edge-on), when there are segments, when segmentation is off, and over rings.
  /// For the smooth model also when most points' curvature lies above its max_curvature (a
  /// noisy sensor's), with the bound that admits them. When no such cause is found, the
  /// points' implausible scale if they have one (cloud_scale_problem: millimetres read as
  /// metres, a float depth of 1e30).
  std::string why_no_segments() const;
  /// Forgets the previous frame of the segment tracks (PipelineSettings::track): the next frame
  /// starts new tracks, e.g. at a cut in a sequence.
  void reset_tracks() { tracker_.reset(); }

 private:
  std::string why_not_smooth() const;  ///< why_no_segments for the smooth model
  void process_cloud(const OrganizedCloud& cloud);
  void process_unorganized(const OrganizedCloud& cloud);
  void process_grid(const OrganizedCloud& cloud);
  void process_restored(const OrganizedCloud& cloud, double find_ms);
  template <class Convert>
  void process_depth(int width, int height, double fx, Convert&& convert_rows);

  /// Runs one frame, one call at a time (running_); if it throws anything but std::invalid_argument
  /// (which input checks throw before any state changes), drop_frame_state() first: a stage that
  /// failed midway (out of memory) may have left its buffers inconsistent with each other.
  template <class Frame>
  void guarded(Frame&& frame);
  /// Every buffer, result and track back to a new pipeline's (none): the next frame allocates
  /// as a first frame does.
  void drop_frame_state();

  /// Remembers the input of the frame for cloud(): the caller's cloud, or one of the pipeline's
  /// own (named, not pointed to, so that cloud() stays right when the pipeline is moved).
  void set_input(const OrganizedCloud& cloud);

  /// Held while a frame runs: a call from another thread meanwhile throws std::logic_error
  /// instead of overwriting the buffers the frame is using.
  detail::CallFlag running_;
  PipelineSettings settings_;
  /// Whose points the last frame's input was: the caller's (input_), the pipeline's points of a
  /// depth image (depth_cloud_, also when cloud() was fed back) or its copy of a fed-back cloud.
  enum class InputKind : std::uint8_t { caller, depth, own };
  InputKind input_kind_ = InputKind::depth;
  const OrganizedCloud* input_ = nullptr;  ///< the caller's cloud (InputKind::caller)
  OrganizedCloud depth_cloud_;             ///< the points of the last depth image
  OrganizedCloud own_input_;               ///< a copy of cloud() when it is fed back to process()
  /// fx of the frame's camera when known (a depth image's, a pixel grid's), else 0: the
  /// smoothing's pixel angle when SmoothingSettings::pixel_angle is 0
  double camera_fx_ = 0;
  Mesh mesh_;
  PointRings rings_;
  NormalMap raw_normals_;
  Smoother smoother_;
  OrganizedCloud smoothed_cloud_;
  NormalMap smoothed_normals_;
  Segmenter segmenter_;
  RingBuffers ring_buffers_;  ///< smoothing and segmentation of unorganized clouds
  Segmentation segmentation_;
  PolygonExtractor polygon_extractor_;
  PolygonSet polygons_;
  SegmentTracker tracker_;
  StageTimes times_;
  std::unique_ptr<ThreadPool> pool_;           ///< when settings.threads > 1
  std::vector<detail::RowBuffers> band_rows_;  ///< of the mesh and normal bands, one per thread
  /// Unorganized clouds: the points in the spatial order the stages run in, and their rings.
  OrganizedCloud ordered_input_;
  PointRings ordered_rings_;
  /// Unorganized clouds on a pixel grid: the grid, the points on it, and the grid stages'
  /// per-pixel results (the members above hold them per point).
  PixelGrid grid_;
  OrganizedCloud grid_cloud_, grid_smoothed_cloud_;
  NormalMap grid_raw_normals_, grid_smoothed_normals_;
  LabelImage grid_labels_;
  std::vector<std::ptrdiff_t> grid_offsets_;  ///< per point: its pixel's offset in a grid plane
};

}  // namespace rangeseg
