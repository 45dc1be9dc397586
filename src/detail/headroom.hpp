// Growing the scratch vectors of a stream's stages with headroom.
#pragma once

#include <cstddef>

namespace rangeseg::detail {

/// v.resize(n), reserving half as much again first when n exceeds the capacity. A resize beyond
/// the capacity allocates exactly n; buffers whose size follows a frame's content (outline
/// points, seeds) would then allocate in every frame that needs a little more than any before,
/// and a stream would not settle.
template <class Vector>
void resize_with_headroom(Vector& v, std::size_t n) {
  if (n > v.capacity()) v.reserve(n + n / 2);
  v.resize(n);
}

/// v.assign(n, value), with the headroom of resize_with_headroom.
template <class Vector, class T>
void assign_with_headroom(Vector& v, std::size_t n, const T& value) {
  if (n > v.capacity()) v.reserve(n + n / 2);
  v.assign(n, value);
}

/// v.insert(v.end(), first, last), with the headroom of resize_with_headroom: inserting into
/// an empty vector (a list cleared for a new frame) would allocate exactly what it needs.
template <class Vector, class Iterator>
void append_with_headroom(Vector& v, Iterator first, Iterator last) {
  const std::size_t n = v.size() + static_cast<std::size_t>(last - first);
  if (n > v.capacity()) v.reserve(n + n / 2);
  v.insert(v.end(), first, last);
}

}  // namespace rangeseg::detail
