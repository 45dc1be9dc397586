#include "rangeseg/pipeline.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "detail/fit_camera.hpp"
#include "detail/gather_points.hpp"
#include "detail/number_text.hpp"
#include "detail/row_bands.hpp"
#include "segmentation/internal.hpp"
#include "unorganized/internal.hpp"
#include "unorganized/order.hpp"

namespace rangeseg {
namespace {

using Clock = std::chrono::steady_clock;

/// The points of a plane found seen at grazing incidence (Segment::grazing) that no mesh face
/// reaches, whose 1-ring normal is NaN, take the plane's normal and curvature 0: on a box top a
/// little below the sensor that is most of its points.
void planes_give_faceless_points_normals(const Segmentation& segmentation, NormalMap& normals) {
  const LabelImage& labels = segmentation.labels;
  const bool with_curvature =
      normals.curvature.height() == labels.height() && normals.curvature.width() == labels.width();
  for (int v = 0; v < labels.height(); ++v) {
    const std::int32_t* row = labels.row(v);
    float* nx = normals.nx.row(v);
    float* ny = normals.ny.row(v);
    float* nz = normals.nz.row(v);
    float* curvature = with_curvature ? normals.curvature.row(v) : nullptr;
    for (int u = 0; u < labels.width(); ++u) {
      if (row[u] == 0 || !std::isnan(nz[u])) continue;
      const Segment& segment = segmentation.segments[static_cast<std::size_t>(row[u] - 1)];
      if (!segment.grazing) continue;
      nx[u] = static_cast<float>(segment.normal[0]);
      ny[u] = static_cast<float>(segment.normal[1]);
      nz[u] = static_cast<float>(segment.normal[2]);
      if (curvature != nullptr) curvature[u] = 0.0f;
    }
  }
}

/// Each plane segment's area_m2 becomes its polygon's area (outer loops minus holes), which lies
/// in its plane. The faces of the mesh or the rings' ellipses it replaces are tilted by the
/// depth noise: the faces of a Kinect wall at 4-6 m summed to 1.22 times its area.
void planes_take_polygon_areas(const PolygonSet& polygons, Segmentation& segmentation) {
  for (const SegmentPolygons& sp : polygons.segments) {
    Segment& segment = segmentation.segments[static_cast<std::size_t>(sp.label - 1)];
    if (segment.kind == SurfaceKind::plane) segment.area_m2 = sp.area;
  }
}

/// Rows per band of the interleaved mesh and normals: the cloud rows and mesh bits of a band
/// (~0.6 MB at 640 columns) stay in a 1 MB L2 cache; each band recomputes one row of cells.
constexpr int kMeshBandRows = 64;

/// Frames smaller than this run on one thread even with settings.threads > 1: mesh, normals and
/// smoothing then take tens of microseconds, as long as handing a band to another core
/// (measured at 160x120 on a 2-core VM: 2 threads slower than 1) [pixels].
constexpr long kMinPixelsForThreads = 1L << 16;

/// The camera of an organized cloud is fitted to every k-th row and column, k the largest whole
/// number that leaves at least this many pixels (every 8th at 640x480, ~0.04 ms; every 2nd at
/// 160x120, where fitting all 19200 points doubled the filter's time, 0.10 -> 0.19-0.26 ms)
/// [pixels].
constexpr long kFitSamplePixels = 4800;

double ms_since(Clock::time_point& start) {
  const Clock::time_point now = Clock::now();
  const double ms = std::chrono::duration<double, std::milli>(now - start).count();
  start = now;
  return ms;
}

}  // namespace

void set_noise(PipelineSettings& settings, const SensorNoise& noise) {
  settings.segmentation.noise = noise;
  settings.smoothing.noise = noise;
  settings.mesh.noise = noise;
  settings.rings.noise = noise;
}

PipelineSettings pipeline_preset(std::string_view sensor) {
  PipelineSettings s;
  s.segmentation = preset(sensor);
  set_noise(s, s.segmentation.noise);
  // Angle between neighbouring pixel rays: 1 / focal length in pixels.
  if (sensor == "abw") {
    s.smoothing.pixel_angle = 1.0f / 1586.0f;
    // ABW depth error is the 8-bit range staircase (1.25 mm steps), not Gaussian noise: on a
    // grazing plane neighbouring ranges differ by several whole steps, which a 3-sigma Gaussian
    // jump gate (2 mm) would cut, so the mesh's noise gate admits up to ~6 steps (7 mm, still
    // far below the object-to-background jumps of the scenes). The bilateral filter, tuned for
    // Gaussian noise, bends the terraces into separate patches (SegComp ABW dev set: 72% of
    // regions correct with it, 80% without), so segmentation works on the raw points.
    s.mesh.jump_sigmas = 10.0f;
    s.smooth = false;
  }
  if (sensor == "laser") s.smoothing.pixel_angle = 0.0087f;        // 0.5 degree scan resolution
  if (sensor == "perceptron") s.smoothing.pixel_angle = 0.00176f;  // 51.65 deg over 512 columns
  if (sensor == "ideal") s.smooth = false;  // exact points: see preset("ideal")
  return s;
}

void validate(const PipelineSettings& settings) {
  if (settings.threads < 1 || settings.threads > 256) {
    throw std::invalid_argument("PipelineSettings::threads = " + std::to_string(settings.threads) +
                                " must be in [1, 256]");
  }
  validate(settings.mesh);
  validate(settings.normals);
  validate(settings.smoothing);
  validate(settings.segmentation);
  validate(settings.polygon);
  validate(settings.rings);
  validate(settings.tracking);
}

Pipeline::Pipeline(const PipelineSettings& settings)
    : settings_(settings), smoother_(settings.smoothing) {
  validate(settings);
  tracker_ = SegmentTracker(settings.tracking);
  if (settings.threads > 1) pool_ = std::make_unique<ThreadPool>(settings.threads);
}

void Pipeline::process_unorganized(const OrganizedCloud& cloud) {
  Clock::time_point t = Clock::now();
  const Clock::time_point start = t;
  const auto& viewpoint = settings_.rings.viewpoint;
  if (settings_.restore_grid && viewpoint[0] == 0 && viewpoint[1] == 0 && viewpoint[2] == 0 &&
      find_pixel_grid(cloud, grid_, ring_buffers_)) {
    process_restored(cloud, ms_since(t));
    return;
  }
  grid_.clear();
  const RegionModel model = settings_.segmentation.model;
  if (settings_.segment && model == RegionModel::incremental_plane) {
    throw std::invalid_argument(std::string("Pipeline::process: the ") + to_string(model) +
                                " model is not available for unorganized clouds over rings "
                                "(plane, smooth or auto)");
  }
  set_input(cloud);
  times_ = {};
  mesh_ = Mesh{};
  ThreadPool* const pool =
      cloud.size() >= static_cast<std::size_t>(kMinPixelsForThreads) ? pool_.get() : nullptr;
  // The stages run on the points in spatial order: their neighbours then lie close in memory
  // whatever the input order (a shuffled 640 x 480 frame: 1.3-2.3x faster in all), and the results
  // do not depend on it. They are put back into input order at the end.
  unorganized::SpatialOrder& order = ring_buffers_.impl().spatial;
  unorganized::spatial_order(cloud, settings_.rings, order);
  unorganized::gather(cloud, order.order, ordered_input_);
  times_.input = ms_since(t);
  const OrganizedCloud& in = ordered_input_;
  build_rings(in, settings_.rings, ordered_rings_, pool, ring_buffers_);
  times_.mesh = ms_since(t);
  compute_normals(in, ordered_rings_, settings_.normals, raw_normals_, pool, ring_buffers_);
  times_.normals = ms_since(t);
  if (settings_.smooth) {
    smooth(in, ordered_rings_, raw_normals_, settings_.smoothing, smoothed_cloud_,
           smoothed_normals_, pool, ring_buffers_);
    times_.smoothing = ms_since(t);
  }
  const OrganizedCloud& points = settings_.smooth ? smoothed_cloud_ : in;
  if (settings_.segment) {
    segment(points, ordered_rings_, normals(), settings_.segmentation, segmentation_,
            ring_buffers_);
    times_.segmentation = ms_since(t);
    if (settings_.polygons) {
      polygon_extractor_.extract(points, ordered_rings_, segmentation_, settings_.polygon,
                                 polygons_);
      // A point's share of a plane over rings is an ellipse holding its ring; where rings span
      // scan lines far apart (a lidar's) the ellipses overlap, and their sum was 2.3-2.7
      // times the plane's visible area. The polygon outlines their union.
      if (settings_.segmentation.compute_area) planes_take_polygon_areas(polygons_, segmentation_);
      times_.polygons = ms_since(t);
    } else {
      polygons_ = PolygonSet{};
    }
  } else {
    segmentation_ = Segmentation{};
    polygons_ = PolygonSet{};
  }
  tracker_.reset();  // labels per point of a cloud over rings are no pixels to match
  unorganized::rings_to_input_order(ordered_rings_, order, rings_);
  unorganized::to_input_order(raw_normals_, order);
  if (settings_.smooth) {
    unorganized::to_input_order(smoothed_normals_, order);
    for (FloatPlane* p : {&smoothed_cloud_.x, &smoothed_cloud_.y, &smoothed_cloud_.z}) {
      unorganized::to_input_order(*p, order, order.floats);
    }
    detail::copy_optional_planes(cloud, smoothed_cloud_);
  }
  if (settings_.segment) {
    unorganized::to_input_order(segmentation_.labels, order, order.ints);
    // A segment's points count its copies too, as its labels do.
    for (const std::int32_t copy : order.copies) {
      const std::int32_t label = segmentation_.labels.row(0)[copy];
      if (label > 0) ++segmentation_.segments[static_cast<std::size_t>(label - 1)].pixel_count;
    }
  }
  times_.input += ms_since(t);
  times_.total = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

namespace {

/// out[i] = grid[offset[i]] (offsets into the plane's buffer, row stride included) for the
/// points of an unorganized cloud, `missing` where offset[i] < 0.
template <class T>
void gather_from_grid(const Plane<T>& grid, const std::vector<std::ptrdiff_t>& offset, T missing,
                      Plane<T>& out) {
  const auto n = static_cast<int>(offset.size());
  if (out.width() != n || out.height() != 1) out.resize(n, 1);
  const T* src = grid.row(0);
  T* dst = out.row(0);
  for (std::size_t i = 0; i < offset.size(); ++i) dst[i] = offset[i] < 0 ? missing : src[offset[i]];
}

void gather_from_grid(const NormalMap& grid, const std::vector<std::ptrdiff_t>& offset,
                      NormalMap& out) {
  constexpr float nan = std::numeric_limits<float>::quiet_NaN();
  gather_from_grid(grid.nx, offset, nan, out.nx);
  gather_from_grid(grid.ny, offset, nan, out.ny);
  gather_from_grid(grid.nz, offset, nan, out.nz);
  gather_from_grid(grid.curvature, offset, nan, out.curvature);
}

}  // namespace

// The grid stages write into the pipeline's result members; those of the last restored frame
// (per point) are swapped out meanwhile and the grid's results swapped in afterwards, so that
// both sets of buffers are kept and a stream of such frames allocates nothing.
void Pipeline::process_restored(const OrganizedCloud& cloud, double find_ms) {
  Clock::time_point t = Clock::now();
  scatter_to_grid(cloud, grid_, grid_cloud_);
  const double scatter_ms = ms_since(t);
  const auto swap_results = [&] {
    std::swap(raw_normals_, grid_raw_normals_);
    std::swap(smoothed_cloud_, grid_smoothed_cloud_);
    std::swap(smoothed_normals_, grid_smoothed_normals_);
    std::swap(segmentation_.labels, grid_labels_);
  };
  swap_results();
  camera_fx_ = grid_.fx;
  process_grid(grid_cloud_);
  swap_results();
  t = Clock::now();
  constexpr float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<std::int32_t>& pixel = grid_.pixel;
  // Every plane of the grid's width has the row stride of its cloud's.
  const std::ptrdiff_t stride = grid_cloud_.z.stride();
  const auto grid_width = static_cast<std::uint32_t>(grid_.width);
  std::vector<std::ptrdiff_t>& offset = grid_offsets_;
  offset.resize(pixel.size());
  for (std::size_t i = 0; i < pixel.size(); ++i) {
    offset[i] = pixel[i] < 0 ? -1 : unorganized::grid_offset(pixel[i], grid_width, stride);
  }
  gather_from_grid(grid_raw_normals_, offset, raw_normals_);
  if (settings_.smooth) {
    gather_from_grid(grid_smoothed_normals_, offset, smoothed_normals_);
    gather_from_grid(grid_smoothed_cloud_.x, offset, nan, smoothed_cloud_.x);
    gather_from_grid(grid_smoothed_cloud_.y, offset, nan, smoothed_cloud_.y);
    gather_from_grid(grid_smoothed_cloud_.z, offset, nan, smoothed_cloud_.z);
    // The filter moves x, y and z only; invalid points keep their coordinates (NaN or inf).
    // An unorganized cloud is one row.
    for (std::size_t i = 0; i < pixel.size(); ++i) {
      if (pixel[i] >= 0) continue;
      smoothed_cloud_.x.row(0)[i] = cloud.x.row(0)[i];
      smoothed_cloud_.y.row(0)[i] = cloud.y.row(0)[i];
      smoothed_cloud_.z.row(0)[i] = cloud.z.row(0)[i];
    }
    detail::copy_optional_planes(cloud, smoothed_cloud_);
  }
  if (settings_.segment) {
    gather_from_grid(grid_labels_, offset, std::int32_t{0}, segmentation_.labels);
  } else {
    segmentation_.labels.clear();
  }
  set_input(cloud);
  const double extra = find_ms + scatter_ms + ms_since(t);
  times_.input += extra;
  times_.total += extra;
}

void Pipeline::set_input(const OrganizedCloud& cloud) {
  input_ = nullptr;
  if (&cloud == &depth_cloud_) {
    input_kind_ = InputKind::depth;
  } else if (&cloud == &own_input_) {
    input_kind_ = InputKind::own;
  } else {
    input_kind_ = InputKind::caller;
    input_ = &cloud;
  }
}

template <class Frame>
void Pipeline::guarded(Frame&& frame) {
  const detail::CallFlag::Hold frame_running(running_);
  if (!frame_running.held()) {
    throw std::logic_error(
        "Pipeline::process: called while another thread's call runs on this pipeline; a pipeline "
        "runs one frame at a time (use one pipeline per thread, or a mutex around process and "
        "the reading of its results)");
  }
  try {
    frame();
  } catch (const std::invalid_argument&) {
    throw;
  } catch (...) {
    drop_frame_state();
    throw;
  }
}

void Pipeline::drop_frame_state() {
  input_kind_ = InputKind::depth;
  input_ = nullptr;
  depth_cloud_ = {};
  own_input_ = {};
  mesh_ = {};
  rings_ = {};
  raw_normals_ = {};
  smoother_ = Smoother(settings_.smoothing);
  smoothed_cloud_ = {};
  smoothed_normals_ = {};
  ring_buffers_ = {};
  segmentation_ = {};
  polygons_ = {};
  tracker_ = SegmentTracker(settings_.tracking);
  times_ = {};
  ordered_input_ = {};
  ordered_rings_ = {};
  grid_.clear();
  grid_cloud_ = {};
  grid_smoothed_cloud_ = {};
  grid_raw_normals_ = {};
  grid_smoothed_normals_ = {};
  grid_labels_ = {};
  grid_offsets_ = {};
  // Last, once the buffers above are freed: these allocate their scratch.
  segmenter_ = Segmenter{};
  polygon_extractor_ = PolygonExtractor{};
}

void Pipeline::process(const OrganizedCloud& cloud, double camera_fx) {
  if (!(camera_fx >= 0) || !std::isfinite(camera_fx)) {
    throw std::invalid_argument("Pipeline::process: camera_fx must be >= 0 and finite, got " +
                                rangeseg::detail::number_text(camera_fx));
  }
  guarded([&] {
    camera_fx_ = camera_fx;  // a pixel grid found in an unorganized cloud names its own
    process_cloud(cloud);
  });
}

void Pipeline::process_cloud(const OrganizedCloud& cloud) {
  if (&cloud == &smoothed_cloud_) {
    // cloud() fed back: the smoothing would write the points it reads.
    own_input_ = cloud;
    process_cloud(own_input_);
    return;
  }
  if (cloud.height() == 1) {
    require_consistent(cloud, "Pipeline::process");
    process_unorganized(cloud);
    return;
  }
  require_organized(cloud, "Pipeline::process");
  grid_.clear();
  process_grid(cloud);
}

void Pipeline::process_grid(const OrganizedCloud& cloud) {
  rings_ = PointRings{};
  set_input(cloud);
  times_ = {};
  Clock::time_point t = Clock::now();
  const Clock::time_point start = t;
  // Mesh and normals band by band, so that the normals read the cloud rows and mesh bits the
  // mesh has just touched while they are still in cache (bit-identical to the whole-frame calls,
  // see detail/row_bands.hpp). A band of normals needs the mesh one lattice row beyond it.
  detail::prepare_mesh(cloud, settings_.mesh, mesh_);
  detail::prepare_normals(cloud, mesh_, settings_.normals, raw_normals_);
  times_.mesh = ms_since(t);
  const int height = cloud.height(), stride = mesh_.pixel_stride;
  ThreadPool* const pool =
      static_cast<long>(cloud.width()) * height >= kMinPixelsForThreads ? pool_.get() : nullptr;
  // The stages dispatch bands in quick succession, with serial work between them.
  std::optional<ThreadPool::KeepAwake> awake;
  if (pool != nullptr) awake.emplace(*pool);
  // Row buffers per band (sized once; again only for a pipeline moved from).
  const auto bands = static_cast<std::size_t>(pool_ != nullptr ? pool_->threads() : 1);
  if (band_rows_.size() < bands) band_rows_.resize(bands);
  if (pool != nullptr) {
    // Threads: all mesh bands, then (a band's normals read the mesh beyond it) all normal bands.
    pool->for_each_band(height, stride, [&](int band, int v0, int v1) {
      detail::build_mesh_rows(cloud, settings_.mesh, mesh_, v0, v1,
                              band_rows_[static_cast<std::size_t>(band)]);
    });
    times_.mesh += ms_since(t);
    pool->for_each_band(height, stride, [&](int band, int v0, int v1) {
      detail::compute_normals_rows(cloud, mesh_, settings_.normals, raw_normals_, v0, v1,
                                   band_rows_[static_cast<std::size_t>(band)]);
    });
    times_.normals = ms_since(t);
  }
  int normals_done = pool != nullptr ? height : 0;
  for (int v0 = normals_done; v0 < height; v0 += kMeshBandRows) {
    const int v1 = std::min(height, v0 + kMeshBandRows);
    detail::build_mesh_rows(cloud, settings_.mesh, mesh_, v0, v1, band_rows_[0]);
    times_.mesh += ms_since(t);
    const int normals_end = v1 < height ? v1 - stride : height;
    if (normals_end > normals_done) {
      detail::compute_normals_rows(cloud, mesh_, settings_.normals, raw_normals_, normals_done,
                                   normals_end, band_rows_[0]);
      normals_done = normals_end;
    }
    times_.normals += ms_since(t);
  }
  // An organized cloud names no camera: where the points are a pinhole camera's, the smoothing
  // and the minimum segment size take the focal length fitted to them (a 320x240 stream's rays
  // are twice as far apart as a 640x480 one's); a scanner's grid has none (0). Fitted at most
  // once per frame, and only when a setting asks for the camera.
  double fitted_fx = -1;
  const auto frame_fx = [&] {
    if (camera_fx_ > 0) return camera_fx_;
    if (fitted_fx < 0) {
      CameraIntrinsics fitted;
      const long pixels = static_cast<long>(cloud.width()) * height;
      const int step =
          std::max(1, static_cast<int>(std::sqrt(static_cast<double>(pixels) / kFitSamplePixels)));
      fitted_fx =
          detail::fit_intrinsics_every(cloud, step, fitted, kDefaultFitTolerance) ? fitted.fx : 0;
    }
    return fitted_fx;
  };
  if (settings_.smooth) {
    smoother_.set_camera_fx(settings_.smoothing.pixel_angle > 0 ? camera_fx_ : frame_fx());
    if (pool != nullptr) {
      smoother_.run(cloud, mesh_, raw_normals_, smoothed_cloud_, smoothed_normals_, *pool);
    } else {
      smoother_.run(cloud, mesh_, raw_normals_, smoothed_cloud_, smoothed_normals_);
    }
    times_.smoothing = ms_since(t);
  }
  if (settings_.segment) {
    // Plane segments take their polygon's area, so the models whose segments are all planes
    // need the faces' sum only for a plane the polygon settings skip. With threads, the other
    // models' areas are summed alongside the polygons (which do not read them); the auto model
    // needs them earlier, to add up the areas of the pieces it joins.
    const RegionModel model = settings_.segmentation.model;
    const bool areas = settings_.segmentation.compute_area;
    const bool areas_from_polygons =
        areas && settings_.polygons &&
        (model == RegionModel::plane || model == RegionModel::incremental_plane);
    const bool areas_alongside = pool != nullptr && settings_.polygons && areas &&
                                 !areas_from_polygons && model != RegionModel::automatic;
    SegmentationSettings segmentation = settings_.segmentation;
    if (areas_alongside || areas_from_polygons) segmentation.compute_area = false;
    if (segmentation.min_region_fx > 0) {
      // Regions count lattice vertices, pixel_stride pixels apart.
      segmentation.min_region_size = min_region_size_for(segmentation, frame_fx() / stride);
    }
    if (pool != nullptr) {
      segmenter_.segment(this->cloud(), mesh_, normals(), segmentation, segmentation_, *pool);
    } else {
      segmenter_.segment(this->cloud(), mesh_, normals(), segmentation, segmentation_);
    }
    // The mesh has few faces on surfaces seen at grazing incidence; where a segment holds such
    // a plane, its cells are closed before the polygons trace it (its area counts them so).
    // The segmenter's labels need not be checked as close_grazing_cells checks a caller's.
    if (std::any_of(segmentation_.segments.begin(), segmentation_.segments.end(),
                    [](const Segment& s) { return s.grazing; })) {
      seg::close_grazing_faces(segmentation_.labels.row(0), segmentation_.labels.stride(),
                               mesh_.width(), mesh_.height(), mesh_.pixel_stride,
                               mesh_.type == MeshType::quad, segmentation_.segments,
                               mesh_.faces.row(0), mesh_.edges.row(0));
      planes_give_faceless_points_normals(segmentation_,
                                          settings_.smooth ? smoothed_normals_ : raw_normals_);
    }
    times_.segmentation = ms_since(t);
    if (areas_alongside) {
      pool->for_each_band(2, 1, [&](int, int task_begin, int task_end) {
        for (int task = task_begin; task < task_end; ++task) {
          if (task == 0) {
            segmenter_.compute_areas(this->cloud(), mesh_, segmentation_);
          } else {
            polygon_extractor_.extract(this->cloud(), mesh_, segmentation_, settings_.polygon,
                                       polygons_);
          }
        }
      });
      planes_take_polygon_areas(polygons_, segmentation_);
      times_.polygons = ms_since(t);
    } else if (settings_.polygons) {
      if (pool != nullptr) {
        polygon_extractor_.extract(this->cloud(), mesh_, segmentation_, settings_.polygon,
                                   polygons_, *pool);
      } else {
        polygon_extractor_.extract(this->cloud(), mesh_, segmentation_, settings_.polygon,
                                   polygons_);
      }
      if (areas_from_polygons && polygons_.segments.size() < segmentation_.segments.size()) {
        segmenter_.compute_areas(this->cloud(), mesh_, segmentation_);
      }
      if (areas) planes_take_polygon_areas(polygons_, segmentation_);
      times_.polygons = ms_since(t);
    } else {
      polygons_ = PolygonSet{};
    }
    if (settings_.track) {
      tracker_.update(segmentation_);
      times_.tracking = ms_since(t);
    }
  } else {
    polygons_ = PolygonSet{};
    segmentation_.labels.clear();
    segmentation_.segments.clear();
    tracker_.reset();
  }
  times_.total = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

template <class Convert>
void Pipeline::process_depth(int width, int height, double fx, Convert&& convert_rows) {
  const Clock::time_point start = Clock::now();
  if (width < 1 || height < 2) {
    // One row would be taken for an unorganized cloud and run over rings.
    throw std::invalid_argument(
        "Pipeline::process: a depth image needs at least 1 column and 2 rows, got " +
        std::to_string(width) + " x " + std::to_string(height));
  }
  // The view, intrinsics and scale are checked before anything changes: a frame rejected with
  // std::invalid_argument leaves the last frame's results, which may read depth_cloud_.
  if (depth_cloud_.width() != width || depth_cloud_.height() != height) {
    OrganizedCloud resized;
    resized.resize(width, height);
    convert_rows(resized, 0, 0);
    depth_cloud_ = std::move(resized);
  } else {
    convert_rows(depth_cloud_, 0, 0);
  }
  ThreadPool* const pool =
      static_cast<long>(width) * height >= kMinPixelsForThreads ? pool_.get() : nullptr;
  // The workers stay awake from the conversion into the stages (guards nest).
  std::optional<ThreadPool::KeepAwake> awake;
  if (pool != nullptr) {
    awake.emplace(*pool);
    pool->for_each_band(height, 1,
                        [&](int, int v0, int v1) { convert_rows(depth_cloud_, v0, v1); });
  } else {
    convert_rows(depth_cloud_, 0, height);
  }
  const double input_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  camera_fx_ = fx;
  try {
    process_cloud(depth_cloud_);
  } catch (const std::invalid_argument&) {
    drop_frame_state();  // the last frame's results no longer match depth_cloud_
    throw;
  }
  input_kind_ = InputKind::depth;
  times_.input = input_ms;
  times_.total += input_ms;
}

void Pipeline::process(View<const std::uint16_t> depth, const CameraIntrinsics& camera,
                       double depth_scale) {
  guarded([&] {
    process_depth(depth.width, depth.height, camera.fx,
                  [&](OrganizedCloud& points, int v0, int v1) {
                    depth_to_cloud_rows(depth, camera, depth_scale, points, v0, v1);
                  });
  });
}

void Pipeline::process(View<const float> depth, const CameraIntrinsics& camera) {
  guarded([&] {
    process_depth(depth.width, depth.height, camera.fx,
                  [&](OrganizedCloud& points, int v0, int v1) {
                    depth_to_cloud_rows(depth, camera, points, v0, v1);
                  });
  });
}

}  // namespace rangeseg
