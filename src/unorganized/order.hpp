// Internal: the order in which Pipeline runs the stages over rings, and the moves into it and
// back.
#pragma once

#include <cstdint>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/unorganized.hpp"

namespace rangeseg::unorganized {

/// A permutation of a cloud's points that keeps neighbours in space close in memory, with its
/// scratch buffers (kept from frame to frame).
struct SpatialOrder {
  /// order[t]: the input index of the t-th point.
  std::vector<std::int32_t> order;
  std::vector<std::int32_t> order_tmp;
  std::vector<std::uint64_t> keys, keys_tmp;
  std::vector<float> coords;  ///< per valid point its 3 coordinates in the search space
  std::vector<float> floats;  ///< scratch of one float plane
  std::vector<std::int32_t> ints;
};

/// The valid points of `cloud` (i = v * width + u) by the Morton code of their position in the
/// rings' search space (their direction from the viewpoint, or their position, as `settings`
/// says; 21 bits per axis over the points' bounding box), then the invalid ones; points of
/// equal code keep their input order. Consecutive points then lie close together, as in a
/// range image, whatever order the cloud came in, and the order depends on the points alone:
/// the stages run on it give the same results for any order of the same points (unless two of
/// them fall into one cell of 2^-21 of the box per axis).
void spatial_order(const OrganizedCloud& cloud, const RingSettings& settings, SpatialOrder& o);

/// `out` becomes a cloud of width size(), height 1 with the points of `cloud` in `order` (x, y,
/// z and the optional planes `cloud` has).
void gather(const OrganizedCloud& cloud, const std::vector<std::int32_t>& order,
            OrganizedCloud& out);

/// Rings of the points in `order` as rings of the points in input order (`out` is resized).
void rings_to_input_order(const PointRings& ordered, const std::vector<std::int32_t>& order,
                          PointRings& out);

/// Puts a plane of values of the points in `order` (height 1) into input order, in place;
/// `scratch` holds a copy meanwhile.
void to_input_order(FloatPlane& plane, const std::vector<std::int32_t>& order,
                    std::vector<float>& scratch);
void to_input_order(LabelImage& plane, const std::vector<std::int32_t>& order,
                    std::vector<std::int32_t>& scratch);

/// The same for every plane of a normal map (curvature when present).
void to_input_order(NormalMap& normals, SpatialOrder& o);

}  // namespace rangeseg::unorganized
