// Segmentation (stage 4) on a real Kinect frame; mesh and normals are computed once outside.
#include <benchmark/benchmark.h>

#include <string>

#include "bench_data.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/segmentation.hpp"

namespace {

void run_segmentation(benchmark::State& state, rangeseg::RegionModel model,
                      bool coarse_cells = true) {
  const std::string path = RANGESEG_SOURCE_DIR "/../shared/data/kinect/grabber_frame0.pcd";
  if (!rangeseg::bench::have_shared_data(state, path)) return;
  const rangeseg::OrganizedCloud cloud = rangeseg::io::read_pcd(path);
  const rangeseg::Mesh mesh = rangeseg::build_mesh(cloud);
  const rangeseg::NormalMap normals = rangeseg::compute_normals(cloud, mesh);
  rangeseg::SegmentationSettings settings = rangeseg::preset("kinect");
  settings.model = model;
  settings.coarse_cells = coarse_cells;
  rangeseg::Segmenter segmenter;
  rangeseg::Segmentation out;
  for (auto _ : state) {
    segmenter.segment(cloud, mesh, normals, settings, out);
    benchmark::DoNotOptimize(out.labels.row(0));
  }
  state.counters["segments"] = static_cast<double>(out.segments.size());
}

void BM_SegmentPlanes(benchmark::State& state) {
  run_segmentation(state, rangeseg::RegionModel::plane);
}
/// The reference without the coarse level: every pixel grown individually.
void BM_SegmentPlanesPixelwise(benchmark::State& state) {
  run_segmentation(state, rangeseg::RegionModel::plane, false);
}
void BM_SegmentSmooth(benchmark::State& state) {
  run_segmentation(state, rangeseg::RegionModel::smooth);
}

}  // namespace

BENCHMARK(BM_SegmentPlanes)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SegmentPlanesPixelwise)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SegmentSmooth)->Unit(benchmark::kMillisecond);
