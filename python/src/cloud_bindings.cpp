// rangeseg.Cloud and the file readers.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>

#include "arrays.hpp"
#include "bindings.hpp"
#include "rangeseg/io/camera_file.hpp"
#include "rangeseg/io/camera_json.hpp"
#include "rangeseg/io/cloud_file.hpp"
#include "rangeseg/io/png.hpp"

namespace rangeseg::python {
namespace {

using namespace pybind11::literals;

template <class Read>
auto without_gil(Read&& read) {
  const py::gil_scoped_release release;
  return read();
}

py::dict camera_dict(const CameraIntrinsics& c) {
  return py::dict("fx"_a = c.fx, "fy"_a = c.fy, "cx"_a = c.cx, "cy"_a = c.cy, "width"_a = c.width,
                  "height"_a = c.height);
}

}  // namespace

void bind_cloud(py::module_& m) {
  py::class_<OrganizedCloud>(
      m, "Cloud", R"(A point cloud: organized (a pixel grid, height > 1) or unorganized (height 1).

The arrays are copies: points float32 (H, W, 3) or (N, 3) in metres, NaN where there
is no point; intensity (H, W) / (N,), colors uint8 (H, W, 3) / (N, 3) and labels int32
(H, W) / (N,), or None when the cloud has none.)")
      .def(py::init([](const py::object& points, const py::object& intensity,
                       const py::object& colors, const py::object& labels) {
             return cloud_from_arrays(points, intensity, colors, labels);
           }),
           "points"_a, "intensity"_a = py::none(), "colors"_a = py::none(), "labels"_a = py::none())
      .def_property_readonly(
          "points", [](const OrganizedCloud& c) { return points_array(c); },
          "float32 (H, W, 3) or (N, 3) [m], NaN where there is no point (a new copy each time)")
      .def_property_readonly(
          "intensity",
          [](const OrganizedCloud& c) -> py::object {
            if (!c.has_intensity()) return py::none();
            return plane_array(c.intensity, c.is_organized());
          },
          "float32 (H, W) or (N,), or None (a copy)")
      .def_property_readonly(
          "colors",
          [](const OrganizedCloud& c) -> py::object {
            if (!c.has_rgb()) return py::none();
            return colors_array(c);
          },
          "uint8 (H, W, 3) or (N, 3), or None (a copy)")
      .def_property_readonly(
          "labels",
          [](const OrganizedCloud& c) -> py::object {
            if (!c.has_label()) return py::none();
            return plane_array(c.label, c.is_organized());
          },
          "int32 (H, W) or (N,), or None (a copy)")
      .def_property_readonly("width", &OrganizedCloud::width, "columns (points when unorganized)")
      .def_property_readonly("height", &OrganizedCloud::height, "rows (1 when unorganized)")
      .def_property_readonly("is_organized", &OrganizedCloud::is_organized,
                             "True for a grid of at least 2 rows")
      .def("count_valid", &OrganizedCloud::count_valid, "points with finite x, y and z")
      // Pickled as the constructor's arrays (for multiprocessing, joblib, dask), with any
      // pickle protocol: the same cloud comes back.
      .def("__reduce__",
           [](const py::object& self) {
             const auto& c = self.cast<const OrganizedCloud&>();
             const bool grid = c.is_organized();
             const py::object none = py::none();
             return py::make_tuple(
                 self.attr("__class__"),
                 py::make_tuple(
                     points_array(c),
                     c.has_intensity() ? py::object(plane_array(c.intensity, grid)) : none,
                     c.has_rgb() ? py::object(colors_array(c)) : none,
                     c.has_label() ? py::object(plane_array(c.label, grid)) : none));
           })
      .def("__repr__", [](const OrganizedCloud& c) {
        return "<rangeseg.Cloud " + std::to_string(c.width()) + " x " + std::to_string(c.height()) +
               (c.is_organized() ? ", organized" : ", unorganized") + ", " +
               std::to_string(c.count_valid()) + " valid points>";
      });

  m.def(
      "read_cloud",
      [](const py::object& file) {
        const std::string path = path_of(file, "path");
        return without_gil([&] { return io::read_cloud(path); });
      },
      "path"_a,
      R"(Reads a point cloud by its extension: .pcd, .ply, .xyz / .xyzn / .xyzrgb / .pts, or a
SegComp .range image. Raises RuntimeError naming the file and the problem.)");
  m.def(
      "read_depth_png",
      [](const py::object& file) {
        const std::string path = path_of(file, "path");
        bool eight_bit = false;
        const DepthImage depth = without_gil([&] { return io::read_depth_png(path, &eight_bit); });
        if (eight_bit) {
          user_warning(path +
                       ": an 8-bit PNG, read as depth in raw units 0..255; a depth camera writes "
                       "16-bit PNGs: is it a picture or a mask?");
        }
        return plane_array(depth, true);
      },
      "path"_a,
      R"(A 16-bit depth PNG as uint16 (H, W), raw units (0 = no measurement). An 8-bit
grayscale PNG is read too, with a UserWarning.)");
  m.def(
      "read_label_png",
      [](const py::object& file) {
        const std::string path = path_of(file, "path");
        return plane_array(without_gil([&] { return io::read_label_png(path); }), true);
      },
      "path"_a, "A label PNG (e.g. labels.png of `rangeseg segment`) as int32 (H, W).");
  m.def(
      "read_camera_json",
      [](const py::object& file) {
        return camera_dict(io::read_camera_json(path_of(file, "path")));
      },
      "path"_a,
      R"(Pinhole intrinsics from a JSON file (Open3D's PinholeCameraIntrinsic or flat fx, fy,
cx, cy, width, height) as a dict, the keywords of Pipeline.process_depth; width and
height are 0 when the file does not give them.)");
  m.def(
      "read_camera",
      [](const py::object& file) {
        const std::string path = path_of(file, "path");
        const io::CameraFile camera = io::read_camera_file(path);
        if (camera.distorted()) {
          const std::string message = path + ": its lens distortion (" + camera.distortion_model +
                                      ") is not applied: the depth image is taken as a pinhole "
                                      "camera's (rectified)";
          if (PyErr_WarnEx(PyExc_UserWarning, message.c_str(), 1) != 0) {
            throw py::error_already_set();
          }
        }
        if (camera.projection_differs()) {
          const std::string message =
              path +
              ": the projection matrix P is taken as the depth image's camera (the "
              "rectified image's, as for ROS's depth_image_proc), not K";
          if (PyErr_WarnEx(PyExc_UserWarning, message.c_str(), 1) != 0) {
            throw py::error_already_set();
          }
        }
        return camera_dict(camera.intrinsics);
      },
      "path"_a,
      R"(Pinhole intrinsics from a camera file as a dict, the keywords of
Pipeline.process_depth: JSON as read_camera_json reads it, or ROS camera_info YAML (.yaml /
.yml: a camera_calibration file, or a CameraInfo message as `ros2 topic echo --once` prints
it; its projection matrix P, the rectified image's camera, when it gives one, else K). A
lens distortion the file states is not applied; a UserWarning says so, and when P is not
K.)");
}

}  // namespace rangeseg::python
