// The rangeseg Python module: the library's pipeline on NumPy arrays.
#include <pybind11/pybind11.h>

#include <array>
#include <charconv>
#include <string>

#include "bindings.hpp"

namespace rangeseg::python {

std::string number_text(double value) {
  std::array<char, 64> text{};
  const auto result = std::to_chars(text.data(), text.data() + text.size(), value);
  return {text.data(), result.ptr};
}

void user_warning(const std::string& message) {
  if (PyErr_WarnEx(PyExc_UserWarning, message.c_str(), 1) != 0) throw py::error_already_set();
}

}  // namespace rangeseg::python

PYBIND11_MODULE(rangeseg, m) {
  m.doc() = R"(Fast range image segmentation and smoothing (Holz & Behnke).

Turns organized point clouds and depth images (Kinect, RealSense, laser range scans)
and unorganized clouds into smoothed points and normals, a segmentation into planes,
cylinders, spheres and smooth surfaces, and plane polygons, in milliseconds per frame.

    import rangeseg
    cloud = rangeseg.read_cloud("frame.pcd")
    result = rangeseg.Pipeline(preset="kinect").process(cloud)
    result.labels, result.segments

Units are metres and radians.)";
  m.attr("__version__") = RANGESEG_VERSION;
  rangeseg::python::bind_cloud(m);
  rangeseg::python::bind_pipeline(m);
  rangeseg::python::bind_eval(m);
}
