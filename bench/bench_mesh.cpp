// Stage 1 and 2 on a real 640x480 Kinect frame (single thread).
#include <benchmark/benchmark.h>

#include <string>

#include "bench_data.hpp"
#include "bench_isa.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"

namespace {

const std::string kFrame = RANGESEG_SOURCE_DIR "/../shared/data/kinect/grabber_frame0.pcd";

bool load(benchmark::State& state, rangeseg::OrganizedCloud& cloud) {
  if (!rangeseg::bench::have_shared_data(state, kFrame)) return false;
  cloud = rangeseg::io::read_pcd(kFrame);
  return true;
}

void BM_MeshAdaptive(benchmark::State& state) {
  rangeseg::OrganizedCloud cloud;
  if (!load(state, cloud)) return;
  rangeseg::Mesh mesh;
  for (auto _ : state) {
    rangeseg::build_mesh(cloud, {.type = rangeseg::MeshType::adaptive}, mesh);
    benchmark::DoNotOptimize(mesh.edges.row(0));
  }
}
BENCHMARK(BM_MeshAdaptive)->Unit(benchmark::kMillisecond);

void BM_Normals(benchmark::State& state) {
  rangeseg::OrganizedCloud cloud;
  if (!load(state, cloud)) return;
  const rangeseg::Mesh mesh = rangeseg::build_mesh(cloud);
  rangeseg::NormalMap normals;
  for (auto _ : state) {
    rangeseg::compute_normals(cloud, mesh, {}, normals);
    benchmark::DoNotOptimize(normals.curvature.row(0));
  }
}
BENCHMARK(BM_Normals)->Unit(benchmark::kMillisecond);

// The same with the kernels capped at an instruction set (0 = baseline, SSE2 on x86-64; 1 = AVX2;
// 2 = AVX-512), where the CPU has it.
void BM_MeshAdaptiveIsa(benchmark::State& state) {
  rangeseg::bench::with_isa_limit(state, BM_MeshAdaptive);
}
BENCHMARK(BM_MeshAdaptiveIsa)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_NormalsIsa(benchmark::State& state) { rangeseg::bench::with_isa_limit(state, BM_Normals); }
BENCHMARK(BM_NormalsIsa)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_ExtractFaces(benchmark::State& state) {
  rangeseg::OrganizedCloud cloud;
  if (!load(state, cloud)) return;
  const rangeseg::Mesh mesh = rangeseg::build_mesh(cloud);
  rangeseg::TriangleList faces;
  const bool compact = state.range(0) != 0;
  for (auto _ : state) {
    rangeseg::extract_faces(mesh, compact, faces);
    benchmark::DoNotOptimize(faces.indices.data());
  }
  state.counters["faces"] = static_cast<double>(faces.indices.size()) / 3.0;
}
BENCHMARK(BM_ExtractFaces)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
