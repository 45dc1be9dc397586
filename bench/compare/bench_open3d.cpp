// Open3D 0.16 against rangeseg on the valid points of the same frame (Open3D has no organized
// stages), one process, single thread (run with OMP_NUM_THREADS=1: Open3D's loops use OpenMP):
// Open3D's normals and repeated-RANSAC planes, and rangeseg's frame over k-nearest-neighbour
// rings (normals, one smoothing pass, plane segmentation, polygons) with its stages as counters.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "../bench_data.hpp"
#include "open3d_pipeline.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg_frame.hpp"

namespace {

namespace compare = rangeseg::compare;

const std::string kFrame = RANGESEG_SOURCE_DIR "/../shared/data/kinect/grabber_frame0.pcd";

open3d::geometry::PointCloud frame_points() {
  std::vector<std::size_t> pixels;
  return compare::to_open3d(rangeseg::io::read_pcd(kFrame), pixels);
}

void BM_Open3dEstimateNormals(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return;
  const open3d::geometry::PointCloud points = frame_points();
  for (auto _ : state) {
    open3d::geometry::PointCloud copy = points;
    compare::estimate_normals(copy);
    benchmark::DoNotOptimize(copy.normals_.data());
  }
  state.counters["points"] = static_cast<double>(points.points_.size());
}

void BM_Open3dSegmentPlanes(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return;
  const open3d::geometry::PointCloud points = frame_points();
  std::size_t planes = 0;
  for (auto _ : state) {
    const std::vector<std::int32_t> labels = compare::segment_planes(points, {});
    planes = static_cast<std::size_t>(*std::max_element(labels.begin(), labels.end()));
  }
  state.counters["planes"] = static_cast<double>(planes);
}

/// rangeseg's frame on the same valid points as an unorganized cloud; stage means [ms].
void BM_RangesegUnorganizedFrame(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return;
  const rangeseg::OrganizedCloud cloud = rangeseg::valid_points(rangeseg::io::read_pcd(kFrame));
  compare::time_rangeseg_frame(state, cloud, "rings_ms");
}

}  // namespace

BENCHMARK(BM_Open3dEstimateNormals)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Open3dSegmentPlanes)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RangesegUnorganizedFrame)->Unit(benchmark::kMillisecond);
