// Segmentation with the `automatic` model (planes + cylinders + spheres) against the plane model,
// 640x480: a real Kinect frame and a rendered scene with cylinders and spheres. Mesh, normals
// and smoothing are computed once outside the timed loop.
#include <benchmark/benchmark.h>

#include <string>

#include "bench_data.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/synth.hpp"
#include "rangeseg/thread_pool.hpp"

namespace {

void run(benchmark::State& state, const rangeseg::OrganizedCloud& cloud,
         rangeseg::RegionModel model, int threads = 1) {
  rangeseg::PipelineSettings settings = rangeseg::pipeline_preset("kinect");
  settings.segment = false;
  settings.polygons = false;
  rangeseg::Pipeline pipeline(settings);
  pipeline.process(cloud);
  rangeseg::SegmentationSettings seg = settings.segmentation;
  seg.model = model;
  rangeseg::Segmenter segmenter;
  rangeseg::Segmentation out;
  rangeseg::ThreadPool pool(threads);
  for (auto _ : state) {
    segmenter.segment(pipeline.cloud(), pipeline.mesh(), pipeline.normals(), seg, out, pool);
    benchmark::DoNotOptimize(out.labels.row(0));
  }
  int curved = 0;
  for (const rangeseg::Segment& s : out.segments) curved += s.kind != rangeseg::SurfaceKind::plane;
  state.counters["segments"] = static_cast<double>(out.segments.size());
  state.counters["curved"] = curved;
}

void kinect_frame(benchmark::State& state, rangeseg::RegionModel model, int threads = 1) {
  const std::string path = RANGESEG_SOURCE_DIR "/../shared/data/kinect/grabber_frame0.pcd";
  if (!rangeseg::bench::have_shared_data(state, path)) return;
  run(state, rangeseg::io::read_pcd(path), model, threads);
}

void mixed_scene(benchmark::State& state, rangeseg::RegionModel model) {
  const rangeseg::synth::Rendering r = rangeseg::synth::render(
      rangeseg::synth::random_scene(1, true), {.noise = rangeseg::synth::Noise::kinect});
  run(state, r.cloud, model);
}

void BM_KinectFramePlanes(benchmark::State& state) {
  kinect_frame(state, rangeseg::RegionModel::plane);
}
/// The plane model with the frame-wide passes on `state.range(0)` threads (growing is serial).
void BM_KinectFramePlanesThreads(benchmark::State& state) {
  kinect_frame(state, rangeseg::RegionModel::plane, static_cast<int>(state.range(0)));
}
void BM_KinectFrameAuto(benchmark::State& state) {
  kinect_frame(state, rangeseg::RegionModel::automatic);
}
void BM_KinectFrameIncrementalPlanes(benchmark::State& state) {
  kinect_frame(state, rangeseg::RegionModel::incremental_plane);
}
void BM_MixedScenePlanes(benchmark::State& state) {
  mixed_scene(state, rangeseg::RegionModel::plane);
}
void BM_MixedSceneAuto(benchmark::State& state) {
  mixed_scene(state, rangeseg::RegionModel::automatic);
}

}  // namespace

BENCHMARK(BM_KinectFramePlanes)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_KinectFramePlanesThreads)
    ->Arg(1)
    ->Arg(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_KinectFrameAuto)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_KinectFrameIncrementalPlanes)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MixedScenePlanes)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MixedSceneAuto)->Unit(benchmark::kMillisecond);
