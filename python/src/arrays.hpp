// NumPy arrays to and from the library's image planes and clouds (copies, C order).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

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

/// Memory for the arrays of a pipeline's results that comes back when the arrays are freed and
/// goes to the next frame's: a stream of frames then writes into memory already mapped. (glibc
/// returns freed blocks of megabytes to the system, and the next frame's arrays fault them in
/// again: 3,700 page faults and 35 ms more per 640 x 480 frame whose result was dropped.) Keeps
/// at most kKept blocks. Every call holds the GIL, as do the arrays' capsule destructors.
class ArrayPool : public std::enable_shared_from_this<ArrayPool> {
 public:
  ArrayPool() = default;
  ~ArrayPool();
  ArrayPool(const ArrayPool&) = delete;
  ArrayPool& operator=(const ArrayPool&) = delete;

  /// An uninitialised C-order array of `shape` on a block of the pool.
  template <class T>
  py::array_t<T> array(const std::vector<py::ssize_t>& shape);

 private:
  static constexpr std::size_t kKept = 8;
  struct Block;
  static void release(void* block);
  std::vector<std::pair<std::size_t, void*>> free_;  ///< bytes, memory
};

/// (H, W, 3) float32 of three planes, or (W, 3) when `organized` is false (height 1); from
/// `pool` when given.
py::array_t<float> xyz_array(const FloatPlane& x, const FloatPlane& y, const FloatPlane& z,
                             bool organized, ArrayPool* pool = nullptr);
inline py::array_t<float> points_array(const OrganizedCloud& cloud, ArrayPool* pool = nullptr) {
  return xyz_array(cloud.x, cloud.y, cloud.z, cloud.is_organized(), pool);
}
inline py::array_t<float> normals_array(const NormalMap& normals, bool organized,
                                        ArrayPool* pool = nullptr) {
  return xyz_array(normals.nx, normals.ny, normals.nz, organized, pool);
}

/// (H, W) of one plane, or (W,) when `organized` is false; from `pool` when given.
py::array_t<float> plane_array(const FloatPlane& plane, bool organized, ArrayPool* pool = nullptr);
py::array_t<std::int32_t> plane_array(const LabelImage& plane, bool organized,
                                      ArrayPool* pool = nullptr);
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
