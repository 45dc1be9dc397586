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
  /// order[t]: the input index of the t-th point; exact copies of an earlier point are left out.
  std::vector<std::int32_t> order;
  /// The input indices of the points left out as exact copies (x, y and z equal) ...
  std::vector<std::int32_t> copies;
  /// ... and per copy the input index of the point in `order` it copies.
  std::vector<std::int32_t> copied;
  std::size_t total = 0;  ///< the cloud's points, `order` and `copies` together
  std::vector<std::int32_t> order_tmp;
  std::vector<std::uint64_t> keys, keys_tmp;
  std::vector<float> coords;  ///< per valid point its 3 coordinates in the search space
  std::vector<float> floats;  ///< scratch of one float plane
  std::vector<std::int32_t> ints;
};

/// The valid points of `cloud` (i = v * width + u) by the Morton code of their position in the
/// rings' search space (their direction from the viewpoint, or their position, as `settings`
/// says; 21 bits per axis over the points' bounding box), then the invalid ones; points of
/// equal code keep their input order. A point equal to an earlier one in x, y and z (a merged
/// or tiled cloud's copies) goes to `copies` instead: copies would fill each other's rings with
/// edges of length 0; they take their original's results. Consecutive points then lie close
/// together, as in a range image, whatever order the cloud came in, and the order depends on the
/// points alone: the stages run on it give the same results for any order of the same points
/// (unless two of them fall into one cell of 2^-21 of the box per axis).
void spatial_order(const OrganizedCloud& cloud, const RingSettings& settings, SpatialOrder& o);

/// `out` becomes a cloud of width size(), height 1 with the points of `cloud` in `order` (x, y,
/// z and the optional planes `cloud` has).
void gather(const OrganizedCloud& cloud, const std::vector<std::int32_t>& order,
            OrganizedCloud& out);

/// Rings of the points in `o.order` as rings of the points in input order (`out` is resized);
/// a copy gets its original's ring.
void rings_to_input_order(const PointRings& ordered, const SpatialOrder& o, PointRings& out);

/// Puts a plane of values of the points in `o.order` (height 1) into input order, in place (a
/// copy gets its original's value; the plane grows to o.total); `scratch` holds a copy
/// meanwhile.
void to_input_order(FloatPlane& plane, const SpatialOrder& o, std::vector<float>& scratch);
void to_input_order(LabelImage& plane, const SpatialOrder& o, std::vector<std::int32_t>& scratch);

/// The same for every plane of a normal map (curvature when present).
void to_input_order(NormalMap& normals, SpatialOrder& o);

}  // namespace rangeseg::unorganized
