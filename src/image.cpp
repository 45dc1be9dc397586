#include "rangeseg/image.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

namespace rangeseg {

template <class T>
void Plane<T>::resize(int width, int height, T fill) {
  if (width < 0 || height < 0) {
    throw std::invalid_argument("Plane::resize: negative size " + std::to_string(width) + "x" +
                                std::to_string(height));
  }
  const std::ptrdiff_t stride = (static_cast<std::ptrdiff_t>(width) + 15) / 16 * 16;
  const std::size_t count = static_cast<std::size_t>(stride) * static_cast<std::size_t>(height);
  if (count > std::numeric_limits<std::size_t>::max() / sizeof(T)) {
    throw std::invalid_argument("Plane::resize: size too large");
  }
  width_ = width;
  height_ = height;
  stride_ = stride;
  buffer_.assign(count, fill);
}

template class Plane<float>;
template class Plane<std::uint8_t>;
template class Plane<std::uint16_t>;
template class Plane<std::int32_t>;

}  // namespace rangeseg
