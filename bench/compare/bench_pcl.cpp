// PCL 1.13 against rangeseg on the same frame, in one process, single thread: each PCL stage, the
// PCL frame (mesh, normals, bilateral filter, planes with their contours) and rangeseg's frame
// (mesh, normals, one smoothing pass, plane segmentation, polygons) with its stages as counters.
#include <benchmark/benchmark.h>

#include <string>

#include "../bench_data.hpp"
#include "pcl_pipeline.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg_frame.hpp"

namespace {

namespace compare = rangeseg::compare;

const std::string kFrame = RANGESEG_SOURCE_DIR "/../shared/data/kinect/grabber_frame0.pcd";

void BM_PclOrganizedFastMesh(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return;
  const compare::PclCloud::ConstPtr cloud = compare::to_pcl(rangeseg::io::read_pcd(kFrame));
  std::size_t triangles = 0;
  for (auto _ : state) triangles = compare::fast_mesh(cloud).size();
  state.counters["triangles"] = static_cast<double>(triangles);
}

void BM_PclIntegralImageNormals(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return;
  const compare::PclCloud::ConstPtr cloud = compare::to_pcl(rangeseg::io::read_pcd(kFrame));
  compare::PclNormals normals;
  for (auto _ : state) {
    compare::estimate_normals(cloud, {}, normals);
    benchmark::DoNotOptimize(normals.data());
  }
}

void BM_PclFastBilateralFilter(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return;
  const compare::PclCloud::ConstPtr cloud = compare::to_pcl(rangeseg::io::read_pcd(kFrame));
  compare::PclCloud out;
  for (auto _ : state) {
    compare::bilateral_filter(cloud, out);
    benchmark::DoNotOptimize(out.data());
  }
}

/// segmentAndRefine on precomputed normals; the planes' contours are part of its output.
void BM_PclMultiPlaneSegmentation(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return;
  const compare::PclCloud::ConstPtr cloud = compare::to_pcl(rangeseg::io::read_pcd(kFrame));
  const auto normals = std::make_shared<compare::PclNormals>();
  compare::estimate_normals(cloud, {}, *normals);
  for (auto _ : state) {
    rangeseg::LabelImage labels = compare::segment_planes(cloud, normals, {});
    benchmark::DoNotOptimize(labels.row(0));
  }
}

/// The four PCL stages on one frame, the filtered cloud feeding normals and planes.
void BM_PclFrame(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return;
  const compare::PclCloud::ConstPtr cloud = compare::to_pcl(rangeseg::io::read_pcd(kFrame));
  const auto filtered = std::make_shared<compare::PclCloud>();
  const auto normals = std::make_shared<compare::PclNormals>();
  for (auto _ : state) {
    benchmark::DoNotOptimize(compare::fast_mesh(cloud).size());
    compare::bilateral_filter(cloud, *filtered);
    compare::estimate_normals(filtered, {}, *normals);
    rangeseg::LabelImage labels = compare::segment_planes(filtered, normals, {});
    benchmark::DoNotOptimize(labels.row(0));
  }
}

/// rangeseg's frame as `rangeseg bench` times it; its stages' means as counters [ms].
void BM_RangesegFrame(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return;
  const rangeseg::OrganizedCloud cloud = rangeseg::io::read_pcd(kFrame);
  compare::time_rangeseg_frame(state, cloud, "mesh_ms");
}

}  // namespace

BENCHMARK(BM_PclOrganizedFastMesh)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PclIntegralImageNormals)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PclFastBilateralFilter)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PclMultiPlaneSegmentation)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PclFrame)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RangesegFrame)->Unit(benchmark::kMillisecond);
