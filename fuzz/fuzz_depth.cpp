// libFuzzer target: any depth image runs through Pipeline::process(depth, camera) without a
// crash, and its labels and segments agree (fuzz_checks.hpp). Byte 0 picks the depth type (16-bit
// raw in millimetres or float metres), the preset, threads and smoothing; byte 1 the width (2-96
// px) and the focal length; the rest are the pixels, row by row (whole rows only).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <vector>

#include "fuzz_checks.hpp"
#include "rangeseg/pipeline.hpp"

namespace {

constexpr int kMaxRows = 96;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  const unsigned pick = data[0];
  const int width = 2 + data[1] % 95;
  const bool metres = (pick & 1u) != 0;
  const std::size_t element = metres ? sizeof(float) : sizeof(std::uint16_t);
  const std::size_t row_bytes = static_cast<std::size_t>(width) * element;
  const int height = static_cast<int>(std::min<std::size_t>((size - 2) / row_bytes, kMaxRows));
  // Copied into aligned planes (the bytes need not be aligned).
  std::vector<std::uint16_t> raw(metres ? 0 : static_cast<std::size_t>(width) * height);
  std::vector<float> depth(metres ? static_cast<std::size_t>(width) * height : 0);
  if (height < 1) return 0;
  if (metres) {
    std::memcpy(depth.data(), data + 2, depth.size() * sizeof(float));
  } else {
    std::memcpy(raw.data(), data + 2, raw.size() * sizeof(std::uint16_t));
  }
  const rangeseg::CameraIntrinsics camera{.fx = width * (0.5 + data[1] / 128.0),
                                          .fy = width * (0.5 + data[1] / 128.0),
                                          .cx = (width - 1) / 2.0,
                                          .cy = (height - 1) / 2.0};
  constexpr const char* kPresets[] = {"kinect", "abw", "laser", "ideal"};
  rangeseg::PipelineSettings settings = rangeseg::pipeline_preset(kPresets[pick >> 1 & 3u]);
  settings.segmentation.model = static_cast<rangeseg::RegionModel>(pick >> 3 & 3u);
  settings.threads = (pick & 32u) != 0 ? 2 : 1;
  settings.smooth = (pick & 64u) == 0;
  try {
    rangeseg::Pipeline pipeline(settings);
    if (metres) {
      pipeline.process(rangeseg::View<const float>{depth.data(), width, height, width}, camera);
    } else {
      pipeline.process(rangeseg::View<const std::uint16_t>{raw.data(), width, height, width},
                       camera, 0.001);
    }
    if (!rangeseg::fuzz::labels_name_segments(pipeline.segmentation())) __builtin_trap();
  } catch (const std::exception&) {
    // Rejected input (fewer than 2 rows) is fine; crashes and traps are not.
  }
  return 0;
}
