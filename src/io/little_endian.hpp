// Appending values to a byte buffer as little-endian bytes, for the binary writers.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <vector>

namespace rangeseg::io::detail {

static_assert(std::endian::native == std::endian::little,
              "the binary writers copy floats and ints as little-endian bytes");

template <class T>
void append_le(std::vector<std::uint8_t>& out, T value) {
  const std::size_t at = out.size();
  out.resize(at + sizeof(T));
  std::memcpy(out.data() + at, &value, sizeof(T));
}

}  // namespace rangeseg::io::detail
