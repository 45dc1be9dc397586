// Plane polygons of every plane segment of a real Kinect frame; mesh, normals, smoothing and
// segmentation are computed once outside the loop.
//
// BM_Polygons: the library defaults (PipelineSettings{} with the "kinect" segmentation preset,
// 3 smoothing iterations). BM_PolygonsCli: the settings of `rangeseg bench` (pipeline_preset
// "kinect", one smoothing iteration), whose segmentation has more and more ragged loops.
// BM_PolygonsInPipeline: the same, but the time of the stage as the pipeline reports it after
// the other stages of a frame ran (their buffers have evicted the polygon stage's from cache):
// the number `rangeseg bench` prints.
#include <benchmark/benchmark.h>

#include <string>

#include "bench_data.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/polygons.hpp"

namespace {

const std::string kFrame = RANGESEG_SOURCE_DIR "/../shared/data/kinect/grabber_frame0.pcd";

void report(benchmark::State& state, const rangeseg::PolygonSet& out) {
  state.counters["segments"] = static_cast<double>(out.segments.size());
  state.counters["loops"] = static_cast<double>(out.loops.size());
  state.counters["vertices"] = static_cast<double>(out.points2d.size());
  std::size_t raw = 0;
  for (const auto& loop : out.loops) raw += static_cast<std::size_t>(loop.raw_count);
  state.counters["raw_vertices"] = static_cast<double>(raw);
}

rangeseg::PipelineSettings cli_settings() {
  rangeseg::PipelineSettings settings = rangeseg::pipeline_preset("kinect");
  settings.smoothing.iterations = 1;
  return settings;
}

void run_extract(benchmark::State& state, const rangeseg::PipelineSettings& settings) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return;
  const rangeseg::OrganizedCloud cloud = rangeseg::io::read_pcd(kFrame);
  rangeseg::Pipeline pipeline(settings);
  pipeline.process(cloud);
  rangeseg::PolygonExtractor extractor;
  rangeseg::PolygonSet out;
  for (auto _ : state) {
    extractor.extract(pipeline.cloud(), pipeline.mesh(), pipeline.segmentation(), {}, out);
    benchmark::DoNotOptimize(out.points2d.data());
  }
  report(state, out);
}

void BM_Polygons(benchmark::State& state) {
  rangeseg::PipelineSettings settings;
  settings.segmentation = rangeseg::preset("kinect");
  run_extract(state, settings);
}

void BM_PolygonsCli(benchmark::State& state) { run_extract(state, cli_settings()); }

void BM_PolygonsInPipeline(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return;
  const rangeseg::OrganizedCloud cloud = rangeseg::io::read_pcd(kFrame);
  rangeseg::Pipeline pipeline(cli_settings());
  pipeline.process(cloud);
  for (auto _ : state) {
    pipeline.process(cloud);
    state.SetIterationTime(pipeline.times().polygons * 1e-3);
  }
  report(state, pipeline.polygons());
}

}  // namespace

BENCHMARK(BM_Polygons)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PolygonsCli)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PolygonsInPipeline)->Unit(benchmark::kMillisecond)->UseManualTime();
