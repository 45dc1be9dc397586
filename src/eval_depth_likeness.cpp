// Whether a label image is a depth image given by mistake (see eval.hpp).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rangeseg/eval.hpp"

namespace rangeseg::eval {

DepthLikeness depth_likeness(const LabelImage& labels) {
  constexpr int kMinLowest = 100;  // [depth: mm]
  constexpr std::size_t kMinDistinct = 16;
  constexpr double kMinChangingShare = 0.2;
  constexpr std::int32_t kMaxLabel = 65535;  // a 16-bit PNG's
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(kMaxLabel) + 1, 0);
  DepthLikeness d;
  std::size_t pairs = 0, changing = 0;
  int lowest = kMaxLabel + 1;
  for (int v = 0; v < labels.height(); ++v) {
    for (int u = 0; u < labels.width(); ++u) {
      const std::int32_t l = labels(u, v);
      if (l <= 0 || l > kMaxLabel) continue;
      for (const std::int32_t n : {u + 1 < labels.width() ? labels(u + 1, v) : 0,
                                   v + 1 < labels.height() ? labels(u, v + 1) : 0}) {
        if (n <= 0 || n > kMaxLabel) continue;
        ++pairs;
        changing += n != l;
      }
      std::uint8_t& s = seen[static_cast<std::size_t>(l)];
      if (s != 0) continue;
      s = 1;
      ++d.distinct;
      lowest = std::min(lowest, static_cast<int>(l));
    }
  }
  d.lowest = d.distinct > 0 ? lowest : 0;
  d.changing_share = pairs > 0 ? static_cast<double>(changing) / static_cast<double>(pairs) : 0.0;
  d.likely =
      d.distinct >= kMinDistinct && d.lowest >= kMinLowest && d.changing_share >= kMinChangingShare;
  return d;
}

std::string describe(const DepthLikeness& likeness) {
  return "its " + std::to_string(likeness.distinct) + " labels, none below " +
         std::to_string(likeness.lowest) + ", differ between " +
         std::to_string(std::lround(100 * likeness.changing_share)) +
         "% of neighbouring pixels (a segmentation's between a few percent): is it a depth "
         "image?";
}

}  // namespace rangeseg::eval
