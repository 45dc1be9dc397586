#include "results.hpp"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <array>
#include <cstddef>
#include <vector>

namespace rangeseg::python {
namespace {

template <std::size_t N>
py::array_t<float> points_array(const std::vector<std::array<float, N>>& points, int first,
                                int count) {
  py::array_t<float> out({static_cast<py::ssize_t>(count), static_cast<py::ssize_t>(N)});
  float* data = out.mutable_data();
  for (std::size_t i = 0; i < static_cast<std::size_t>(count); ++i) {
    const auto& p = points[static_cast<std::size_t>(first) + i];
    for (std::size_t k = 0; k < N; ++k) data[i * N + k] = p[k];
  }
  return out;
}

py::dict polygon_dict(const PolygonSet& set, const SegmentPolygons& sp) {
  py::list loops;
  for (int l = sp.first_loop; l < sp.first_loop + sp.loop_count; ++l) {
    const PolygonLoop& loop = set.loops[static_cast<std::size_t>(l)];
    loops.append(
        py::dict(py::arg("hole") = loop.is_hole, py::arg("area_m2") = loop.area,
                 py::arg("perimeter_m") = loop.perimeter,
                 py::arg("points") = points_array(set.points3d, loop.first, loop.count),
                 py::arg("points_2d") = points_array(set.points2d, loop.first, loop.count)));
  }
  const py::dict frame(py::arg("origin") = sp.frame.origin, py::arg("e1") = sp.frame.e1,
                       py::arg("e2") = sp.frame.e2);
  const py::dict hull(
      py::arg("area_m2") = sp.hull_area, py::arg("perimeter_m") = sp.hull_perimeter,
      py::arg("points") = points_array(set.hull_points3d, sp.hull_first, sp.hull_count));
  return py::dict(py::arg("frame") = frame, py::arg("area_m2") = sp.area,
                  py::arg("perimeter_m") = sp.perimeter, py::arg("loops") = loops,
                  py::arg("convex_hull") = hull);
}

py::dict surface_dict(const Segment& s) {
  py::dict d(py::arg("type") = to_string(s.kind), py::arg("rms_residual") = s.surface_rms);
  if (s.kind == SurfaceKind::sphere) {
    d["centre"] = s.centre;
    d["radius"] = s.radius;
  } else if (s.kind == SurfaceKind::cylinder) {
    d["axis_point"] = s.centre;
    d["axis"] = s.axis;
    d["radius"] = s.radius;
    d["extent"] = s.extent;
  }
  return d;
}

}  // namespace

py::list segments_list(const Segmentation& segmentation, const PolygonSet* polygons,
                       const SegmentationSettings& settings) {
  const std::vector<int> groups = coplanar_groups(segmentation, settings);
  std::vector<const SegmentPolygons*> by_label(segmentation.segments.size() + 1, nullptr);
  if (polygons != nullptr) {
    for (const SegmentPolygons& sp : polygons->segments) {
      if (sp.label > 0 && static_cast<std::size_t>(sp.label) < by_label.size()) {
        by_label[static_cast<std::size_t>(sp.label)] = &sp;
      }
    }
  }
  py::list list;
  for (const Segment& s : segmentation.segments) {
    py::dict d(py::arg("id") = s.label, py::arg("model") = to_string(s.model),
               py::arg("pixel_count") = s.pixel_count, py::arg("area_m2") = s.area_m2,
               py::arg("centroid") = s.centroid, py::arg("normal") = s.normal,
               py::arg("offset") = s.offset, py::arg("rms_residual") = s.rms_residual,
               py::arg("grazing") = s.grazing, py::arg("surface") = surface_dict(s));
    if (const SegmentPolygons* sp = by_label[static_cast<std::size_t>(s.label)]) {
      d["polygon"] = polygon_dict(*polygons, *sp);
    }
    if (s.track_id != 0) d["track_id"] = s.track_id;
    if (const int group = groups[static_cast<std::size_t>(s.label - 1)]; group != 0) {
      d["plane_group"] = group;
    }
    list.append(d);
  }
  return list;
}

}  // namespace rangeseg::python
