// libFuzzer target: any cloud that parses runs through the whole pipeline without a crash, and
// its labels and segments agree. Byte 0 picks the sensor preset, region model, mesh type (for an
// unorganized cloud: rings by direction or by distance, and whether a pixel grid its points lie
// on is restored), thread count and smoothing; the rest is a PCD file (small clouds only, to keep
// runs fast; organized ones run on the grid, unorganized ones on their pixel grid or over
// k-nearest-neighbour rings).
#include <cstddef>
#include <cstdint>
#include <exception>

#include "fuzz_checks.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/pipeline.hpp"

namespace {

constexpr int kMaxPixels = 96 * 96;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const unsigned pick = data[0];
  rangeseg::OrganizedCloud cloud;
  try {
    cloud = rangeseg::io::parse_pcd(data + 1, size - 1, "fuzz.pcd");
  } catch (const std::exception&) {
    return 0;
  }
  if (cloud.size() > static_cast<std::size_t>(kMaxPixels)) return 0;
  constexpr const char* kPresets[] = {"kinect", "abw", "laser", "ideal"};
  rangeseg::PipelineSettings settings = rangeseg::pipeline_preset(kPresets[pick & 3u]);
  settings.segmentation.model = static_cast<rangeseg::RegionModel>(pick >> 2 & 3u);
  settings.mesh.type = static_cast<rangeseg::MeshType>(pick >> 4 & 3u);
  settings.rings.by_direction = (pick & 16u) != 0;
  settings.restore_grid = (pick & 32u) != 0;
  settings.threads = (pick & 64u) != 0 ? 2 : 1;
  settings.smooth = (pick & 128u) == 0;
  try {
    rangeseg::Pipeline pipeline(settings);
    pipeline.process(cloud);
    if (!rangeseg::fuzz::labels_name_segments(pipeline.segmentation())) __builtin_trap();
  } catch (const std::exception&) {
    // Rejected input (e.g. planes of different sizes) is fine; crashes and traps are not.
  }
  return 0;
}
