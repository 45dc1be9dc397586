// Segments and polygons as Python dictionaries, with the keys of `rangeseg segment`'s
// segments.json and NumPy arrays for point lists.
#pragma once

#include <pybind11/pybind11.h>

#include "rangeseg/polygons.hpp"
#include "rangeseg/segmentation.hpp"

namespace rangeseg::python {

namespace py = pybind11;

/// One dict per segment, by label: id, model, pixel_count, area_m2, centroid, normal, offset,
/// rms_residual, grazing, plane_group (planes: coplanar_groups under `settings`), surface {type,
/// rms_residual, and centre / radius or axis_point / axis / radius / extent}, and for plane
/// segments with polygons `polygon` {frame, area_m2, perimeter_m, loops [{hole, area_m2,
/// perimeter_m, points (K, 3), points_2d (K, 2)}], convex_hull {area_m2, perimeter_m, points (M,
/// 3)}}.
py::list segments_list(const Segmentation& segmentation, const PolygonSet* polygons,
                       const SegmentationSettings& settings);

}  // namespace rangeseg::python
