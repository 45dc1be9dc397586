// Stage 3 (bilateral filtering of points and normals) on a real Kinect frame, one thread.
#include <benchmark/benchmark.h>

#include <string>

#include "bench_data.hpp"
#include "bench_isa.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/smoothing.hpp"

namespace {

const std::string kFrame = RANGESEG_SOURCE_DIR "/../shared/data/kinect/grabber_frame0.pcd";

void smooth_one_iteration(benchmark::State& state);

/// One pass over points and normals (the default per-pass settings, iterations = 1), with all
/// buffers reused as in a frame loop.
void BM_SmoothOneIteration(benchmark::State& state) { smooth_one_iteration(state); }
BENCHMARK(BM_SmoothOneIteration)->Unit(benchmark::kMillisecond);

/// The same on the SSE2 (0), AVX2 (1) and AVX-512 (2) kernels, where the CPU has them.
void BM_SmoothOneIterationIsa(benchmark::State& state) {
  rangeseg::bench::with_isa_limit(state, smooth_one_iteration);
}
BENCHMARK(BM_SmoothOneIterationIsa)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void smooth_one_iteration(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return;
  const rangeseg::OrganizedCloud cloud = rangeseg::io::read_pcd(kFrame);
  const rangeseg::Mesh mesh = rangeseg::build_mesh(cloud);
  const rangeseg::NormalMap normals = rangeseg::compute_normals(cloud, mesh);
  rangeseg::Smoother smoother({.iterations = 1});
  rangeseg::OrganizedCloud out;
  rangeseg::NormalMap out_normals;
  for (auto _ : state) {
    smoother.run(cloud, mesh, normals, out, out_normals);
    benchmark::DoNotOptimize(out.z.row(0));
    benchmark::DoNotOptimize(out_normals.nz.row(0));
  }
  state.counters["valid_points"] = static_cast<double>(cloud.count_valid());
}

/// The default settings (3 passes).
void BM_SmoothDefault(benchmark::State& state) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return;
  const rangeseg::OrganizedCloud cloud = rangeseg::io::read_pcd(kFrame);
  const rangeseg::Mesh mesh = rangeseg::build_mesh(cloud);
  const rangeseg::NormalMap normals = rangeseg::compute_normals(cloud, mesh);
  rangeseg::Smoother smoother;
  rangeseg::OrganizedCloud out;
  rangeseg::NormalMap out_normals;
  for (auto _ : state) {
    smoother.run(cloud, mesh, normals, out, out_normals);
    benchmark::DoNotOptimize(out.z.row(0));
  }
}
BENCHMARK(BM_SmoothDefault)->Unit(benchmark::kMillisecond);

}  // namespace
