// Stages 2-4 over k-nearest-neighbour rings (unorganized.hpp) on a real Kinect frame taken as an
// unorganized cloud: its valid points in shuffled order as one row, one thread. The stages run
// on the points in the spatial order Pipeline puts them in (unorganized/order.hpp), which
// BM_RingOrder times; BM_RingPipeline is the whole frame. The frame's points lie on its pixel
// grid: BM_PixelGridFind finds it, BM_PixelGridPipeline is the whole frame on it.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "bench_data.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/pixel_grid.hpp"
#include "rangeseg/unorganized.hpp"
#include "unorganized/order.hpp"

namespace {

using namespace rangeseg;

const std::string kFrame = RANGESEG_SOURCE_DIR "/../shared/data/kinect/grabber_frame0.pcd";

/// pipeline_preset("kinect") over rings: the frame's points lie on its pixel grid, which
/// Pipeline would otherwise restore (BM_PixelGrid*).
PipelineSettings ring_settings() {
  PipelineSettings s = pipeline_preset("kinect");
  s.restore_grid = false;
  return s;
}

/// The frame's points and the stages before the measured one, with ring_settings() (whose
/// smoothing is the default, 3 passes).
struct Frame {
  PipelineSettings settings = ring_settings();
  OrganizedCloud cloud;
  PointRings rings;
  NormalMap normals;
  OrganizedCloud smoothed;
  NormalMap smoothed_normals;
  Segmentation segmentation;
  PolygonSet polygons;
};

enum class Stage { rings, normals, smoothing, segmentation, polygons };

/// Loads the frame and runs the stages before `stage`; false (benchmark skipped) without data.
bool prepare(benchmark::State& state, Stage stage, Frame& f) {
  if (!bench::have_shared_data(state, kFrame)) return false;
  const OrganizedCloud shuffled = shuffled_valid_points(io::read_pcd(kFrame), 1);
  unorganized::SpatialOrder order;
  unorganized::spatial_order(shuffled, f.settings.rings, order);
  unorganized::gather(shuffled, order.order, f.cloud);
  if (stage > Stage::rings) build_rings(f.cloud, f.settings.rings, f.rings);
  if (stage > Stage::normals) compute_normals(f.cloud, f.rings, f.settings.normals, f.normals);
  if (stage > Stage::smoothing) {
    smooth(f.cloud, f.rings, f.normals, f.settings.smoothing, f.smoothed, f.smoothed_normals);
  }
  if (stage > Stage::segmentation) {
    segment(f.smoothed, f.rings, f.smoothed_normals, f.settings.segmentation, f.segmentation);
  }
  return true;
}

/// Points per second, and the point count in the label.
void report_points(benchmark::State& state, const Frame& f) {
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(f.cloud.size()));
  state.SetLabel(std::to_string(f.cloud.size()) + " points");
}

/// Pipeline's moves of a shuffled frame into the spatial order and of the results back: the
/// order, the points, and back the rings, two normal maps, the smoothed points and the labels.
void BM_RingOrder(benchmark::State& state) {
  Frame f;
  if (!prepare(state, Stage::polygons, f)) return;
  const OrganizedCloud shuffled = shuffled_valid_points(io::read_pcd(kFrame), 1);
  unorganized::SpatialOrder order;
  OrganizedCloud ordered;
  PointRings back;
  for (auto _ : state) {
    unorganized::spatial_order(shuffled, f.settings.rings, order);
    unorganized::gather(shuffled, order.order, ordered);
    unorganized::rings_to_input_order(f.rings, order, back);
    unorganized::to_input_order(f.normals, order);
    unorganized::to_input_order(f.smoothed_normals, order);
    for (FloatPlane* p : {&f.smoothed.x, &f.smoothed.y, &f.smoothed.z}) {
      unorganized::to_input_order(*p, order, order.floats);
    }
    unorganized::to_input_order(f.segmentation.labels, order, order.ints);
    benchmark::DoNotOptimize(back.neighbours.data());
  }
  report_points(state, f);
}
BENCHMARK(BM_RingOrder)->Unit(benchmark::kMillisecond);

/// The whole frame through Pipeline (the preset's settings, plane model), one thread.
void BM_RingPipeline(benchmark::State& state) {
  Frame f;
  if (!prepare(state, Stage::rings, f)) return;
  const OrganizedCloud shuffled = shuffled_valid_points(io::read_pcd(kFrame), 1);
  Pipeline pipeline(f.settings);
  pipeline.process(shuffled);  // buffers
  for (auto _ : state) {
    pipeline.process(shuffled);
    benchmark::DoNotOptimize(pipeline.segmentation().labels.row(0));
  }
  report_points(state, f);
}
BENCHMARK(BM_RingPipeline)->Unit(benchmark::kMillisecond);

void BM_RingsBuild(benchmark::State& state) {
  Frame f;
  if (!prepare(state, Stage::rings, f)) return;
  for (auto _ : state) {
    build_rings(f.cloud, f.settings.rings, f.rings);
    benchmark::DoNotOptimize(f.rings.neighbours.data());
  }
  report_points(state, f);
}
BENCHMARK(BM_RingsBuild)->Unit(benchmark::kMillisecond);

void BM_RingNormals(benchmark::State& state) {
  Frame f;
  if (!prepare(state, Stage::normals, f)) return;
  for (auto _ : state) {
    compute_normals(f.cloud, f.rings, f.settings.normals, f.normals);
    benchmark::DoNotOptimize(f.normals.nz.row(0));
  }
  report_points(state, f);
}
BENCHMARK(BM_RingNormals)->Unit(benchmark::kMillisecond);

void BM_RingSmoothing(benchmark::State& state) {
  Frame f;
  if (!prepare(state, Stage::smoothing, f)) return;
  for (auto _ : state) {
    smooth(f.cloud, f.rings, f.normals, f.settings.smoothing, f.smoothed, f.smoothed_normals);
    benchmark::DoNotOptimize(f.smoothed.z.row(0));
  }
  report_points(state, f);
}
BENCHMARK(BM_RingSmoothing)->Unit(benchmark::kMillisecond);

/// Segmentation with `model` (the plane model of the preset, or auto: planes, then cylinders
/// and spheres), its buffers kept from call to call as Pipeline keeps them.
void ring_segmentation(benchmark::State& state, RegionModel model) {
  Frame f;
  if (!prepare(state, Stage::segmentation, f)) return;
  SegmentationSettings settings = f.settings.segmentation;
  settings.model = model;
  RingBuffers buffers;
  for (auto _ : state) {
    segment(f.smoothed, f.rings, f.smoothed_normals, settings, f.segmentation, buffers);
    benchmark::DoNotOptimize(f.segmentation.labels.row(0));
  }
  report_points(state, f);
  state.counters["segments"] = static_cast<double>(f.segmentation.segments.size());
}

void BM_RingSegmentation(benchmark::State& state) { ring_segmentation(state, RegionModel::plane); }
BENCHMARK(BM_RingSegmentation)->Unit(benchmark::kMillisecond);

void BM_RingSegmentationAuto(benchmark::State& state) {
  ring_segmentation(state, RegionModel::automatic);
}
BENCHMARK(BM_RingSegmentationAuto)->Unit(benchmark::kMillisecond);

void BM_RingPolygons(benchmark::State& state) {
  Frame f;
  if (!prepare(state, Stage::polygons, f)) return;
  for (auto _ : state) {
    extract_polygons(f.smoothed, f.rings, f.segmentation, f.settings.polygon, f.polygons);
    benchmark::DoNotOptimize(f.polygons.points2d.data());
  }
  report_points(state, f);
  state.counters["loops"] = static_cast<double>(f.polygons.loops.size());
}
BENCHMARK(BM_RingPolygons)->Unit(benchmark::kMillisecond);

/// Finding the pixel grid of the frame's shuffled points and putting them on it.
void BM_PixelGridFind(benchmark::State& state) {
  if (!bench::have_shared_data(state, kFrame)) return;
  const OrganizedCloud shuffled = shuffled_valid_points(io::read_pcd(kFrame), 1);
  RingBuffers buffers;
  PixelGrid grid;
  OrganizedCloud on_grid;
  for (auto _ : state) {
    if (!find_pixel_grid(shuffled, grid, buffers)) {
      state.SkipWithError("no pixel grid found");
      return;
    }
    scatter_to_grid(shuffled, grid, on_grid);
    benchmark::DoNotOptimize(on_grid.z.row(0));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(shuffled.size()));
  state.SetLabel(std::to_string(grid.width) + " x " + std::to_string(grid.height) + " grid");
}
BENCHMARK(BM_PixelGridFind)->Unit(benchmark::kMillisecond);

/// The whole frame through Pipeline with its pixel grid restored (PipelineSettings::
/// restore_grid, the default; plane model), one thread: against BM_RingPipeline.
void BM_PixelGridPipeline(benchmark::State& state) {
  if (!bench::have_shared_data(state, kFrame)) return;
  const OrganizedCloud shuffled = shuffled_valid_points(io::read_pcd(kFrame), 1);
  Pipeline pipeline(pipeline_preset("kinect"));
  pipeline.process(shuffled);  // buffers
  if (!pipeline.pixel_grid().found()) {
    state.SkipWithError("no pixel grid found");
    return;
  }
  for (auto _ : state) {
    pipeline.process(shuffled);
    benchmark::DoNotOptimize(pipeline.segmentation().labels.row(0));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(shuffled.size()));
}
BENCHMARK(BM_PixelGridPipeline)->Unit(benchmark::kMillisecond);

}  // namespace
