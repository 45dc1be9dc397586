// Images as separate planes with a row stride (structure of arrays).
#pragma once

#include <algorithm>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <new>
#include <utility>
#include <vector>

namespace rangeseg {

/// Non-owning view of one image plane: `height` rows of `width` elements, row `y` starting at
/// `data + y * stride` (stride in elements, >= width; not in bytes: a ROS image's `step` or
/// OpenCV's `Mat::step` is divided by sizeof(T)). T is float, std::uint8_t, std::uint16_t or
/// std::int32_t in this library.
template <class T>
struct View {
  T* data = nullptr;
  int width = 0;
  int height = 0;
  std::ptrdiff_t stride = 0;

  T* row(int y) const {
    assert(y >= 0 && y < height);
    return data + static_cast<std::ptrdiff_t>(y) * stride;
  }
  T& operator()(int x, int y) const {
    assert(x >= 0 && x < width);
    return row(y)[x];
  }
  bool empty() const { return width <= 0 || height <= 0; }
  operator View<const T>() const { return {data, width, height, stride}; }  // NOLINT: intended
};

namespace detail {
/// Maps the pages of a large new allocation (>= 256 KB) in one system call where the kernel
/// offers that (Linux 5.14+: MADV_POPULATE_WRITE), instead of one page fault per 4 KB page at
/// first touch: a first frame at 640x480 takes ~100 -> ~67 ms in a virtual machine, where
/// faults are costly. Returns whether the pages were mapped (false for small blocks or without
/// kernel support).
bool populate_pages(void* data, std::size_t bytes) noexcept;

/// Allocates on cache-line (64-byte) boundaries. With the row stride a multiple of 16 elements,
/// every row of a float or int32 plane then starts on a cache line, so that no 16-lane vector
/// load or store of a row straddles two lines. Large blocks are mapped at once (populate_pages).
template <class T>
struct CacheLineAllocator {
  using value_type = T;
  static constexpr std::align_val_t kAlignment{64};
  CacheLineAllocator() = default;
  template <class U>
  CacheLineAllocator(const CacheLineAllocator<U>& /*unused*/) noexcept {}  // NOLINT: rebinding
  T* allocate(std::size_t n) {
    T* p = static_cast<T*>(::operator new(n * sizeof(T), kAlignment));
    populate_pages(p, n * sizeof(T));
    return p;
  }
  void deallocate(T* p, std::size_t /*n*/) noexcept { ::operator delete(p, kAlignment); }
  friend bool operator==(const CacheLineAllocator&, const CacheLineAllocator&) { return true; }
};
/// A vector on cache-line boundaries, for row scratch buffers of the kernels.
template <class T>
using CacheLineVector = std::vector<T, CacheLineAllocator<T>>;
/// Row buffers of a band of the mesh or normals kernels (detail/row_bands.hpp), reused call
/// after call; one per thread that runs bands at once.
struct RowBuffers {
  CacheLineVector<float> floats;
  CacheLineVector<std::uint8_t> bytes;
};
}  // namespace detail

/// Owning image plane. The row stride is the width rounded up to 16 elements on cache-line
/// aligned storage, so that every row of a 4-byte plane starts on a cache line. `resize` keeps
/// the allocation when it is large enough, so a plane reused frame after frame allocates only
/// once.
template <class T>
class Plane {
 public:
  Plane() = default;
  Plane(int width, int height, T fill = T{}) { resize(width, height, fill); }
  Plane(const Plane&) = default;
  Plane& operator=(const Plane&) = default;
  /// The moved-from plane is empty (0 x 0), ready to be resized and reused.
  Plane(Plane&& other) noexcept
      : buffer_(std::move(other.buffer_)),
        width_(std::exchange(other.width_, 0)),
        height_(std::exchange(other.height_, 0)),
        stride_(std::exchange(other.stride_, 0)) {
    other.buffer_.clear();
  }
  Plane& operator=(Plane&& other) noexcept {
    if (this != &other) {
      buffer_ = std::move(other.buffer_);
      other.buffer_.clear();
      width_ = std::exchange(other.width_, 0);
      height_ = std::exchange(other.height_, 0);
      stride_ = std::exchange(other.stride_, 0);
    }
    return *this;
  }
  ~Plane() = default;

  /// Sets the size and fills every element with `fill`. Throws std::invalid_argument for
  /// negative sizes.
  void resize(int width, int height, T fill = T{});
  void fill(T value) { std::fill(buffer_.begin(), buffer_.end(), value); }
  void clear() {
    width_ = height_ = 0;
    stride_ = 0;
    buffer_.clear();
  }

  int width() const { return width_; }
  int height() const { return height_; }
  std::ptrdiff_t stride() const { return stride_; }
  bool empty() const { return width_ == 0 || height_ == 0; }

  T* row(int y) { return buffer_.data() + static_cast<std::ptrdiff_t>(y) * stride_; }
  const T* row(int y) const { return buffer_.data() + static_cast<std::ptrdiff_t>(y) * stride_; }
  T& operator()(int x, int y) {
    assert(x >= 0 && x < width_ && y >= 0 && y < height_);
    return row(y)[x];
  }
  const T& operator()(int x, int y) const {
    assert(x >= 0 && x < width_ && y >= 0 && y < height_);
    return row(y)[x];
  }

  View<T> view() { return {buffer_.data(), width_, height_, stride_}; }
  View<const T> view() const { return {buffer_.data(), width_, height_, stride_}; }

 private:
  detail::CacheLineVector<T> buffer_;
  int width_ = 0;
  int height_ = 0;
  std::ptrdiff_t stride_ = 0;
};

using FloatPlane = Plane<float>;
using BytePlane = Plane<std::uint8_t>;
using LabelImage = Plane<std::int32_t>;   ///< segment / ground-truth label per pixel, 0 = none
using DepthImage = Plane<std::uint16_t>;  ///< raw sensor depth, 0 = no measurement

extern template class Plane<float>;
extern template class Plane<std::uint8_t>;
extern template class Plane<std::uint16_t>;
extern template class Plane<std::int32_t>;

}  // namespace rangeseg
