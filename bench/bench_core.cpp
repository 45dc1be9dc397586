#include <benchmark/benchmark.h>

#include "rangeseg/camera.hpp"

static void BM_DepthToCloud640x480(benchmark::State& state) {
  rangeseg::DepthImage depth(640, 480, 1500);
  for (auto _ : state) {
    auto cloud = rangeseg::depth_to_cloud(depth.view(), {}, 0.001);
    benchmark::DoNotOptimize(cloud.z.row(0));
  }
}
BENCHMARK(BM_DepthToCloud640x480)->Unit(benchmark::kMillisecond);

// The same into one reused cloud, as Pipeline::process(depth, camera) does every frame.
static void BM_DepthToCloudReused640x480(benchmark::State& state) {
  rangeseg::DepthImage depth(640, 480, 1500);
  rangeseg::OrganizedCloud cloud;
  for (auto _ : state) {
    rangeseg::depth_to_cloud(depth.view(), {}, 0.001, cloud);
    benchmark::DoNotOptimize(cloud.z.row(0));
  }
}
BENCHMARK(BM_DepthToCloudReused640x480)->Unit(benchmark::kMillisecond);
