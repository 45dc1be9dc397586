// Internal: the k-d tree (nanoflann) over packed points that build_rings and the grazing-plane
// search of unorganized clouds use.
#pragma once

#include <nanoflann.hpp>

#include <cstddef>
#include <cstdint>

#include "unorganized/internal.hpp"

namespace rangeseg::unorganized {

/// nanoflann's dataset interface over packed points (x, y, z of point i at xyz + 3 i).
struct PackedCloud {
  const float* xyz = nullptr;
  std::size_t n = 0;
  std::size_t kdtree_get_point_count() const { return n; }
  float kdtree_get_pt(std::size_t i, std::size_t dim) const { return xyz[3 * i + dim]; }
  template <class Box>
  bool kdtree_get_bbox(Box& /*box*/) const {
    return false;
  }
};
using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, PackedCloud>,
                                                 PackedCloud, 3, std::uint32_t>;

/// The tree refers to `data` (by reference), so the two live together; kept from frame to frame
/// and rebuilt in place (buildIndex after setting `data`).
struct RingTree {
  PackedCloud data;
  Tree tree{3, data,
            nanoflann::KDTreeSingleIndexAdaptorParams(
                16, nanoflann::KDTreeSingleIndexAdaptorFlags::SkipInitialBuildIndex)};
};

}  // namespace rangeseg::unorganized
