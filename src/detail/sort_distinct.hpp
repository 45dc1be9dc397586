// Internal: sorting a list of 64-bit keys without its repeats, for lists where nearly every key
// repeats (the label pairs of adjacent segments, found pixel by pixel along their borders).
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <vector>

namespace rangeseg::detail {

/// Sorts `keys` ascending and drops repeats: the result of std::sort and std::unique. The
/// distinct keys are found first with an open-addressing hash table (`table`, scratch: twice
/// the keys rounded up to a power of two; reused, its capacity is kept), so that only they are
/// sorted: 5118 label pairs of 55 distinct ones on grabber_frame0.
inline void sort_distinct(std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& table) {
  constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // the empty slot; as a key, flagged
  const std::size_t n = keys.size();
  const std::size_t slots = std::bit_ceil(std::max<std::size_t>(2 * n, 64));
  const int shift = 64 - std::countr_zero(slots);
  table.assign(slots, kEmpty);
  std::size_t distinct = 0;
  bool has_empty = false;
  for (std::size_t j = 0; j < n; ++j) {
    const std::uint64_t key = keys[j];
    if (key == kEmpty) {
      has_empty = true;
      continue;
    }
    // Fibonacci hashing: the high bits of the product depend on every bit of the key.
    auto slot = static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift);
    while (table[slot] != kEmpty && table[slot] != key) slot = (slot + 1) & (slots - 1);
    if (table[slot] == kEmpty) {
      table[slot] = key;
      keys[distinct++] = key;  // distinct <= j: only keys already read are overwritten
    }
  }
  keys.resize(distinct);
  std::sort(keys.begin(), keys.end());
  if (has_empty) keys.push_back(kEmpty);
}

}  // namespace rangeseg::detail
