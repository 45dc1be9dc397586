// NumPy arrays to and from the library's image planes and clouds (copies, C order).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <string>

#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"
#include "rangeseg/normals.hpp"

namespace rangeseg::python {

namespace py = pybind11;

/// A cloud from `points`, (H, W, 3) for an organized cloud or (N, 3) for an unorganized one
/// (any real dtype; metres; NaN, inf or (0, 0, 0) = no point), and the optional arrays of its
/// shape without the last axis (`intensity`, `labels`) or with it (`colors`: uint8 0..255, or
/// floats 0..1 as Open3D keeps them). None = absent. Throws std::invalid_argument naming the
/// argument and the shapes for anything else.
OrganizedCloud cloud_from_arrays(const py::handle& points, const py::handle& intensity,
                                 const py::handle& colors, const py::handle& labels);
/// The same into `cloud`, whose planes keep their memory when it suffices.
void cloud_from_arrays(const py::handle& points, const py::handle& intensity,
                       const py::handle& colors, const py::handle& labels, OrganizedCloud& cloud);

/// (H, W, 3) float32 of three planes, or (W, 3) when `organized` is false (height 1).
py::array_t<float> xyz_array(const FloatPlane& x, const FloatPlane& y, const FloatPlane& z,
                             bool organized);
inline py::array_t<float> points_array(const OrganizedCloud& cloud) {
  return xyz_array(cloud.x, cloud.y, cloud.z, cloud.is_organized());
}
inline py::array_t<float> normals_array(const NormalMap& normals, bool organized) {
  return xyz_array(normals.nx, normals.ny, normals.nz, organized);
}

/// (H, W) of one plane, or (W,) when `organized` is false.
py::array_t<float> plane_array(const FloatPlane& plane, bool organized);
py::array_t<std::int32_t> plane_array(const LabelImage& plane, bool organized);
py::array_t<std::uint16_t> plane_array(const DepthImage& plane, bool organized);
/// (H, W, 3) uint8 of the cloud's colours, or (N, 3).
py::array_t<std::uint8_t> colors_array(const OrganizedCloud& cloud);

/// The argument as a NumPy array of a real or integer dtype (not bool, complex or object);
/// throws std::invalid_argument naming `name` otherwise.
py::array numeric_array(const py::handle& object, const char* name);

/// A file path from a str, bytes or os.PathLike (pathlib.Path); throws std::invalid_argument
/// naming `what` for anything else.
std::string path_of(const py::handle& path, const char* what);

/// "(2, 3)": the shape of an array as NumPy prints it.
std::string shape_text(const py::array& a);

/// A label image from a 2D integer array (for evaluation); `name` is used in errors.
LabelImage labels_from_array(const py::handle& array, const char* name);

}  // namespace rangeseg::python
