// Built against an installed rangeseg: proves the exported target and headers are usable.
#include <rangeseg/camera.hpp>
#include <rangeseg/cloud.hpp>
#include <rangeseg/version.hpp>

#include <cstdio>
#include <vector>

int main() {
  std::vector<std::uint16_t> depth(std::size_t{4} * 3, 1000);  // 4 x 3 pixels
  depth[5] = 0;
  const rangeseg::CameraIntrinsics cam{.fx = 2, .fy = 2, .cx = 1.5, .cy = 1};
  const rangeseg::OrganizedCloud cloud =
      rangeseg::depth_to_cloud({depth.data(), 4, 3, 4}, cam, 0.001);
  const std::size_t valid = cloud.count_valid();
  std::printf("consumer of rangeseg %s: %zu valid points\n", RANGESEG_VERSION_STRING, valid);
  static_assert(RANGESEG_VERSION_MAJOR == 0 && RANGESEG_VERSION_MINOR >= 1);
  return valid == 11 ? 0 : 1;
}
