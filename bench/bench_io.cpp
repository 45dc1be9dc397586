#include <benchmark/benchmark.h>

#include <string>

#include "bench_data.hpp"
#include "rangeseg/camera.hpp"
#include "rangeseg/colorize.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/polygons.hpp"

namespace {

const std::string kKinectFrame = RANGESEG_SOURCE_DIR "/../shared/data/kinect/grabber_frame0.pcd";
// A PrimeSense frame whose floor outline has ~500 holes (dropouts) at the `rangeseg` defaults.
const std::string kPrimeSenseFrame = RANGESEG_SOURCE_DIR "/../shared/data/depth_png/00000.png";

// Whole read_pcd of a 640x480 binary_compressed Kinect frame (file read + LZF + plane decode).
void BM_ReadPcdKinectCompressed(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kKinectFrame)) return;
  for (auto _ : state) {
    auto cloud = rangeseg::io::read_pcd(kKinectFrame);
    benchmark::DoNotOptimize(cloud.z.row(0));
  }
}
BENCHMARK(BM_ReadPcdKinectCompressed)->Unit(benchmark::kMillisecond);

// Decoding only, from memory, for each encoding of the same frame.
void BM_ParsePcdKinect(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kKinectFrame)) return;
  const auto encoding = static_cast<rangeseg::io::PcdEncoding>(state.range(0));
  const auto bytes =
      rangeseg::io::encode_pcd(rangeseg::io::read_pcd(kKinectFrame), {.encoding = encoding});
  for (auto _ : state) {
    auto cloud = rangeseg::io::parse_pcd(bytes.data(), bytes.size(), "memory.pcd");
    benchmark::DoNotOptimize(cloud.z.row(0));
  }
}
BENCHMARK(BM_ParsePcdKinect)
    ->Arg(static_cast<int>(rangeseg::io::PcdEncoding::ascii))
    ->Arg(static_cast<int>(rangeseg::io::PcdEncoding::binary))
    ->Arg(static_cast<int>(rangeseg::io::PcdEncoding::binary_compressed))
    ->ArgName("encoding")
    ->Unit(benchmark::kMillisecond);

// Encoding the frame as binary_compressed (LZF).
void BM_EncodePcdKinectCompressed(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kKinectFrame)) return;
  const auto cloud = rangeseg::io::read_pcd(kKinectFrame);
  for (auto _ : state) {
    auto bytes =
        rangeseg::io::encode_pcd(cloud, {.encoding = rangeseg::io::PcdEncoding::binary_compressed});
    benchmark::DoNotOptimize(bytes.data());
  }
}
BENCHMARK(BM_EncodePcdKinectCompressed)->Unit(benchmark::kMillisecond);

// What `rangeseg segment` writes besides the pipeline's work, per frame: the shaded overlay
// picture of the segments (colorize_labels with the cloud) encoded as PNG, and the plane
// polygons triangulated for polygons.obj. Pipeline run once outside the loop.
void BM_OverlayPng(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kKinectFrame)) return;
  const auto cloud = rangeseg::io::read_pcd(kKinectFrame);
  rangeseg::Pipeline pipeline(rangeseg::pipeline_preset("kinect"));
  pipeline.process(cloud);
  for (auto _ : state) {
    const rangeseg::RgbImage overlay =
        rangeseg::colorize_labels(pipeline.segmentation().labels, &cloud);
    auto bytes = rangeseg::io::encode_rgb_png(overlay);
    benchmark::DoNotOptimize(bytes.data());
  }
}
BENCHMARK(BM_OverlayPng)->Unit(benchmark::kMillisecond);

void BM_TriangulatePolygonsWithHoles(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kPrimeSenseFrame)) return;
  const auto depth = rangeseg::io::read_depth_png(kPrimeSenseFrame);
  const auto cloud = rangeseg::depth_to_cloud(
      depth.view(), {.fx = 525, .fy = 525, .cx = 319.5, .cy = 239.5, .width = 640, .height = 480},
      0.001);
  rangeseg::Pipeline pipeline(rangeseg::pipeline_preset("kinect"));  // as `rangeseg segment`
  pipeline.process(cloud);
  std::vector<std::array<int, 3>> triangles;
  for (auto _ : state) {
    rangeseg::triangulate_polygons(pipeline.polygons(), triangles);
    benchmark::DoNotOptimize(triangles.data());
  }
  state.counters["loops"] = static_cast<double>(pipeline.polygons().loops.size());
}
BENCHMARK(BM_TriangulatePolygonsWithHoles)->Unit(benchmark::kMillisecond);

}  // namespace
