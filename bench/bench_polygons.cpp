// Plane polygons of every plane segment of a real Kinect frame; mesh, normals, smoothing and
// segmentation are computed once outside the loop.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "rangeseg/io/pcd.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/polygons.hpp"

namespace {

void BM_Polygons(benchmark::State& state) {
  const std::string path = RANGESEG_SOURCE_DIR "/../shared/data/kinect/grabber_frame0.pcd";
  if (!std::filesystem::exists(path)) {
    state.SkipWithError(("shared data not found: " + path).c_str());
    return;
  }
  const rangeseg::OrganizedCloud cloud = rangeseg::io::read_pcd(path);
  rangeseg::PipelineSettings settings;
  settings.segmentation = rangeseg::preset("kinect");
  rangeseg::Pipeline pipeline(settings);
  pipeline.process(cloud);
  rangeseg::PolygonExtractor extractor;
  rangeseg::PolygonSet out;
  for (auto _ : state) {
    extractor.extract(pipeline.cloud(), pipeline.mesh(), pipeline.segmentation(), {}, out);
    benchmark::DoNotOptimize(out.points2d.data());
  }
  state.counters["segments"] = static_cast<double>(out.segments.size());
  state.counters["loops"] = static_cast<double>(out.loops.size());
  state.counters["vertices"] = static_cast<double>(out.points2d.size());
  std::size_t raw = 0;
  for (const auto& loop : out.loops) raw += static_cast<std::size_t>(loop.raw_count);
  state.counters["raw_vertices"] = static_cast<double>(raw);
}

}  // namespace

BENCHMARK(BM_Polygons)->Unit(benchmark::kMillisecond);
