// Invariants the fuzz targets check on a pipeline's results.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "rangeseg/segmentation.hpp"

namespace rangeseg::fuzz {

/// Labels 0..N, segment i labelled i + 1 with as many pixels as carry it.
inline bool labels_name_segments(const Segmentation& seg) {
  std::vector<std::int64_t> counts(seg.segments.size() + 1, 0);
  for (int v = 0; v < seg.labels.height(); ++v) {
    for (int u = 0; u < seg.labels.width(); ++u) {
      const int l = seg.labels(u, v);
      if (l < 0 || static_cast<std::size_t>(l) > seg.segments.size()) return false;
      ++counts[static_cast<std::size_t>(l)];
    }
  }
  for (std::size_t i = 0; i < seg.segments.size(); ++i) {
    if (seg.segments[i].label != static_cast<int>(i + 1) ||
        seg.segments[i].pixel_count != counts[i + 1]) {
      return false;
    }
  }
  return true;
}

}  // namespace rangeseg::fuzz
