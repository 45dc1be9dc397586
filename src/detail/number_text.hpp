// Numbers in messages as the shortest text that reads back as the same value: std::to_string
// prints "%f", which turns 1e-09 into "0.000000" and 1.0000001 into "1.000000" (a value the
// message then calls invalid).
#pragma once

#include <array>
#include <charconv>
#include <string>

namespace rangeseg::detail {

template <class T>
std::string number_text(T value) {
  std::array<char, 64> text{};
  const auto result = std::to_chars(text.data(), text.data() + text.size(), value);
  return {text.data(), result.ptr};
}

}  // namespace rangeseg::detail
