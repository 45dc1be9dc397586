#include "arrays.hpp"
#include "bindings.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace rangeseg::python {
namespace {

template <class T>
using CArray = py::array_t<T, py::array::c_style | py::array::forcecast>;

int checked_size(py::ssize_t n, const char* name) {
  if (n < 1 || n > INT_MAX) {
    throw std::invalid_argument(std::string(name) + " has " + std::to_string(n) +
                                " points along an axis; 1 to " + std::to_string(INT_MAX) +
                                " are supported");
  }
  return static_cast<int>(n);
}

/// Throws std::invalid_argument naming `name` unless `a` has the points' shape (H, W) or (N,),
/// with `channels` > 0 a last axis of that length.
void require_shape(const py::array& a, int width, int height, bool organized, int channels,
                   const char* name) {
  std::vector<py::ssize_t> want;
  if (organized) want.push_back(height);
  want.push_back(width);
  if (channels > 0) want.push_back(channels);
  bool same = a.ndim() == static_cast<py::ssize_t>(want.size());
  for (std::size_t i = 0; same && i < want.size(); ++i) same = a.shape(i) == want[i];
  if (!same) {
    std::string text = "(";
    for (std::size_t i = 0; i < want.size(); ++i) {
      text += (i > 0 ? ", " : "") + std::to_string(want[i]);
    }
    text += want.size() == 1 ? ",)" : ")";
    throw std::invalid_argument(std::string(name) + " must have the points' shape " + text +
                                ", got " + shape_text(a));
  }
}

template <class T, class U>
void copy_rows(const U* data, Plane<T>& plane) {
  const auto width = static_cast<std::size_t>(plane.width());
  for (int v = 0; v < plane.height(); ++v) {
    const U* in = data + static_cast<std::size_t>(v) * width;
    std::copy(in, in + width, plane.row(v));
  }
}

void set_colors(const py::array& a, OrganizedCloud& cloud) {
  cloud.add_rgb();
  if (a.dtype().is(py::dtype::of<std::uint8_t>())) {  // as they are, without a check
    const CArray<std::uint8_t> values = CArray<std::uint8_t>::ensure(a);
    const std::uint8_t* data = values.data();
    for (int v = 0; v < cloud.height(); ++v) {
      const std::uint8_t* in = data + static_cast<std::size_t>(v) * cloud.width() * 3;
      for (int u = 0; u < cloud.width(); ++u) {
        const std::size_t k = 3 * static_cast<std::size_t>(u);
        cloud.r(u, v) = in[k];
        cloud.g(u, v) = in[k + 1];
        cloud.b(u, v) = in[k + 2];
      }
    }
    return;
  }
  const bool floating = a.dtype().kind() == 'f';
  const CArray<double> values = CArray<double>::ensure(a);
  const double* data = values.data();
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      const double* c = data + (static_cast<std::size_t>(v) * cloud.width() + u) * 3;
      std::array<std::uint8_t, 3> rgb{};
      for (int k = 0; k < 3; ++k) {
        const double value = floating ? c[k] * 255.0 : c[k];
        if (!(value >= -0.5 && value < 255.5)) {
          throw std::invalid_argument(
              std::string("colors must be uint8 0..255 or floats 0..1; point ") +
              std::to_string(static_cast<std::size_t>(v) * cloud.width() + u) + " has " +
              number_text(c[k]));
        }
        rgb[static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(std::lround(value));
      }
      cloud.r(u, v) = rgb[0];
      cloud.g(u, v) = rgb[1];
      cloud.b(u, v) = rgb[2];
    }
  }
}

template <class T>
py::array_t<T> new_array(const std::vector<py::ssize_t>& shape, ArrayPool* pool) {
  return pool != nullptr ? pool->array<T>(shape) : py::array_t<T>(shape);
}

template <class T>
py::array_t<T> plane_array_of(const Plane<T>& plane, bool organized, ArrayPool* pool = nullptr) {
  std::vector<py::ssize_t> shape;
  if (organized) shape.push_back(plane.height());
  shape.push_back(plane.width());
  py::array_t<T> out = new_array<T>(shape, pool);
  T* data = out.mutable_data();
  const auto width = static_cast<std::size_t>(plane.width());
  for (int v = 0; v < plane.height(); ++v) {
    std::copy(plane.row(v), plane.row(v) + width, data + static_cast<std::size_t>(v) * width);
  }
  return out;
}

/// The integers of `a` as int64, each checked to fit in int32; `name` is used in errors.
CArray<std::int64_t> int32_values(const py::array& a, const char* name) {
  if (a.dtype().kind() == 'f') throw std::invalid_argument(std::string(name) + " must be integers");
  const std::string range = std::string(name) + " must fit in 32-bit integers";
  // Compared in NumPy first: a uint64 beyond 2^63 would wrap to a negative int64.
  if (a.dtype().kind() == 'u' && a.dtype().itemsize() == 8 &&
      py::bool_(a.attr("__gt__")(INT_MAX).attr("any")())) {
    throw std::invalid_argument(range);
  }
  CArray<std::int64_t> values = CArray<std::int64_t>::ensure(a);
  const std::int64_t* data = values.data();
  const auto n = static_cast<std::size_t>(values.size());
  if (std::any_of(data, data + n, [](std::int64_t x) { return x < INT_MIN || x > INT_MAX; })) {
    throw std::invalid_argument(range);
  }
  return values;
}

}  // namespace

std::string shape_text(const py::array& a) {
  std::string text = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) {
    if (i > 0) text += ", ";
    text += std::to_string(a.shape(i));
  }
  return text + (a.ndim() == 1 ? ",)" : ")");
}

py::array numeric_array(const py::handle& object, const char* name) {
  py::array a = py::reinterpret_steal<py::array>(py::handle());  // null, unlike py::array()
  if (!object.is_none() && !py::isinstance<py::str>(object) && !py::isinstance<py::bytes>(object)) {
    a = py::array::ensure(object);  // null when NumPy cannot make an array of it
  }
  const char kind = a ? a.dtype().kind() : 'O';
  if (kind != 'f' && kind != 'i' && kind != 'u') {
    const std::string type = py::str(py::type::of(object).attr("__name__"));
    std::string hint;
    if (type == "PointCloud") hint = " (for an Open3D PointCloud: np.asarray(pcd.points))";
    throw std::invalid_argument(
        std::string(name) + " must be an array of real numbers, got " +
        (a && a.ndim() > 0 ? "dtype '" + std::string(py::str(a.dtype())) + "'" : type) + hint);
  }
  return a;
}

std::string path_of(const py::handle& path, const char* what) {
  if (py::isinstance<py::str>(path) || py::isinstance<py::bytes>(path) ||
      py::hasattr(path, "__fspath__")) {
    const py::object text = py::module_::import("os").attr("fsdecode")(path);
    return text.cast<std::string>();
  }
  throw std::invalid_argument(std::string(what) + " must be a path (str or os.PathLike), got " +
                              std::string(py::str(py::type::of(path).attr("__name__"))));
}

OrganizedCloud cloud_from_arrays(const py::handle& points, const py::handle& intensity,
                                 const py::handle& colors, const py::handle& labels) {
  OrganizedCloud cloud;
  cloud_from_arrays(points, intensity, colors, labels, cloud);
  return cloud;
}

void cloud_from_arrays(const py::handle& points, const py::handle& intensity,
                       const py::handle& colors, const py::handle& labels, OrganizedCloud& cloud) {
  const py::array a = numeric_array(points, "points");
  const bool organized = a.ndim() == 3;
  if ((a.ndim() != 2 && a.ndim() != 3) || a.shape(a.ndim() - 1) != 3) {
    throw std::invalid_argument("points must have the shape (H, W, 3) of an organized cloud or " +
                                std::string("(N, 3) of an unorganized one, got ") + shape_text(a));
  }
  if (organized && a.shape(0) < 2) {
    throw std::invalid_argument(
        "points of an organized cloud (H, W, 3) need at least 2 rows, got " + shape_text(a) +
        "; an unorganized cloud is (N, 3)");
  }
  const int width = checked_size(a.shape(organized ? 1 : 0), "points");
  const int height = organized ? checked_size(a.shape(0), "points") : 1;
  // The pipeline's input cloud keeps its memory from frame to frame (fresh pages cost ~1 ms per
  // MB in a virtual machine); inf, NaN and (0, 0, 0) are no point.
  const CArray<float> xyz = CArray<float>::ensure(a);
  interleaved_to_cloud(xyz.data(), width, height, 3 * sizeof(float), cloud);
  if (!intensity.is_none()) {
    const py::array i = numeric_array(intensity, "intensity");
    require_shape(i, width, height, organized, 0, "intensity");
    cloud.add_intensity();
    copy_rows(CArray<float>::ensure(i).data(), cloud.intensity);
  }
  if (!colors.is_none()) {
    const py::array c = numeric_array(colors, "colors");
    require_shape(c, width, height, organized, 3, "colors");
    set_colors(c, cloud);
  }
  if (!labels.is_none()) {
    const py::array l = numeric_array(labels, "labels");
    require_shape(l, width, height, organized, 0, "labels");
    const CArray<std::int64_t> values = int32_values(l, "labels");
    cloud.add_label();
    copy_rows(values.data(), cloud.label);
  }
}

struct ArrayPool::Block {
  std::shared_ptr<ArrayPool> pool;
  void* memory;
  std::size_t bytes;
};

ArrayPool::~ArrayPool() {
  for (const auto& [bytes, memory] : free_) ::operator delete(memory);
}

void ArrayPool::release(void* context) {
  const std::unique_ptr<Block> block(static_cast<Block*>(context));
  ArrayPool& pool = *block->pool;
  if (pool.free_.size() < kKept) {
    pool.free_.emplace_back(block->bytes, block->memory);
  } else {
    ::operator delete(block->memory);
  }
}

template <class T>
py::array_t<T> ArrayPool::array(const std::vector<py::ssize_t>& shape) {
  std::size_t count = 1;
  for (const py::ssize_t n : shape) count *= static_cast<std::size_t>(n);
  const std::size_t bytes = std::max<std::size_t>(count * sizeof(T), 1);
  // A block of the same size: frames of one stream have one size.
  const auto same = std::find_if(free_.begin(), free_.end(),
                                 [&](const auto& block) { return block.first == bytes; });
  void* memory = nullptr;
  if (same != free_.end()) {
    memory = same->second;
    free_.erase(same);
  } else {
    memory = ::operator new(bytes);
  }
  auto block = std::make_unique<Block>(Block{shared_from_this(), memory, bytes});
  const py::capsule owner(block.get(), &ArrayPool::release);
  static_cast<void>(block.release());  // the capsule owns it now
  return py::array_t<T>(shape, static_cast<T*>(memory), owner);
}

template py::array_t<float> ArrayPool::array<float>(const std::vector<py::ssize_t>&);
template py::array_t<std::int32_t> ArrayPool::array<std::int32_t>(const std::vector<py::ssize_t>&);

py::array_t<float> xyz_array(const FloatPlane& x, const FloatPlane& y, const FloatPlane& z,
                             bool organized, ArrayPool* pool) {
  std::vector<py::ssize_t> shape;
  if (organized) shape.push_back(z.height());
  shape.push_back(z.width());
  shape.push_back(3);
  py::array_t<float> out = new_array<float>(shape, pool);
  float* data = out.mutable_data();
  for (int v = 0; v < z.height(); ++v) {
    float* o = data + static_cast<std::size_t>(v) * z.width() * 3;
    for (int u = 0; u < z.width(); ++u) {
      const std::size_t k = 3 * static_cast<std::size_t>(u);
      o[k] = x(u, v);
      o[k + 1] = y(u, v);
      o[k + 2] = z(u, v);
    }
  }
  return out;
}

py::array_t<float> plane_array(const FloatPlane& plane, bool organized, ArrayPool* pool) {
  return plane_array_of(plane, organized, pool);
}
py::array_t<std::int32_t> plane_array(const LabelImage& plane, bool organized, ArrayPool* pool) {
  return plane_array_of(plane, organized, pool);
}
py::array_t<std::uint16_t> plane_array(const DepthImage& plane, bool organized) {
  return plane_array_of(plane, organized);
}

py::array_t<std::uint8_t> colors_array(const OrganizedCloud& cloud) {
  std::vector<py::ssize_t> shape;
  if (cloud.is_organized()) shape.push_back(cloud.height());
  shape.push_back(cloud.width());
  shape.push_back(3);
  py::array_t<std::uint8_t> out(shape);
  std::uint8_t* data = out.mutable_data();
  for (int v = 0; v < cloud.height(); ++v) {
    std::uint8_t* o = data + static_cast<std::size_t>(v) * cloud.width() * 3;
    for (int u = 0; u < cloud.width(); ++u) {
      const std::size_t k = 3 * static_cast<std::size_t>(u);
      o[k] = cloud.r(u, v);
      o[k + 1] = cloud.g(u, v);
      o[k + 2] = cloud.b(u, v);
    }
  }
  return out;
}

LabelImage labels_from_array(const py::handle& array, const char* name) {
  const py::array a = numeric_array(array, name);
  if (a.ndim() != 2) {
    throw std::invalid_argument(std::string(name) + " must be a 2D label image (H, W), got " +
                                shape_text(a));
  }
  const int height = checked_size(a.shape(0), name);
  const int width = checked_size(a.shape(1), name);
  const CArray<std::int64_t> values = int32_values(a, name);
  LabelImage labels(width, height);
  copy_rows(values.data(), labels);
  return labels;
}

}  // namespace rangeseg::python
