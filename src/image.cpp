#include "rangeseg/image.hpp"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace rangeseg {

namespace detail {

bool populate_pages(void* data, std::size_t bytes) noexcept {
#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
  constexpr std::size_t kMinBytes = std::size_t{1} << 18;  // smaller blocks: few faults
  if (bytes < kMinBytes) return false;
  const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  const auto begin = reinterpret_cast<std::uintptr_t>(data);
  // The whole pages inside the block, as offsets from its start.
  const std::uintptr_t head = (page - begin % page) % page;
  const std::uintptr_t tail = (begin + bytes) % page;
  if (bytes < head + tail + page) return false;
  // Failure (an older kernel: EINVAL) leaves the pages to fault in at first touch.
  return madvise(static_cast<char*>(data) + head, bytes - head - tail, MADV_POPULATE_WRITE) == 0;
#else
  (void)data;
  (void)bytes;
  return false;
#endif
}

}  // namespace detail

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
