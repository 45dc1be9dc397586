#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "rangeseg/io/file.hpp"
#include "rangeseg/io/pcd.hpp"

namespace {

const std::string kKinectFrame = RANGESEG_SOURCE_DIR "/../shared/data/kinect/grabber_frame0.pcd";

// Whole read_pcd of a 640x480 binary_compressed Kinect frame (file read + LZF + plane decode).
void BM_ReadPcdKinectCompressed(benchmark::State& state) {
  if (!std::filesystem::exists(kKinectFrame)) {
    state.SkipWithError(("shared data not found: " + kKinectFrame).c_str());
    return;
  }
  for (auto _ : state) {
    auto cloud = rangeseg::io::read_pcd(kKinectFrame);
    benchmark::DoNotOptimize(cloud.z.row(0));
  }
}
BENCHMARK(BM_ReadPcdKinectCompressed)->Unit(benchmark::kMillisecond);

// Decoding only, from memory, for each encoding of the same frame.
void BM_ParsePcdKinect(benchmark::State& state) {
  if (!std::filesystem::exists(kKinectFrame)) {
    state.SkipWithError(("shared data not found: " + kKinectFrame).c_str());
    return;
  }
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
  if (!std::filesystem::exists(kKinectFrame)) {
    state.SkipWithError(("shared data not found: " + kKinectFrame).c_str());
    return;
  }
  const auto cloud = rangeseg::io::read_pcd(kKinectFrame);
  for (auto _ : state) {
    auto bytes =
        rangeseg::io::encode_pcd(cloud, {.encoding = rangeseg::io::PcdEncoding::binary_compressed});
    benchmark::DoNotOptimize(bytes.data());
  }
}
BENCHMARK(BM_EncodePcdKinectCompressed)->Unit(benchmark::kMillisecond);

}  // namespace
