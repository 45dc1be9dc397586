// Internal: a stable LSD radix sort of int32 items by float keys, for orders that must not
// allocate per frame (std::stable_sort does) and are hot enough that a comparison sort shows.
#pragma once

#include <array>
#include <bit>
#include <cassert>
#include <cstdint>
#include <vector>

namespace rangeseg::detail {

/// An unsigned key whose order is the order of the float values (NaN excluded); -0 and +0 map
/// to the same key, as they compare equal.
inline std::uint32_t float_order_key(float value) {
  const auto bits = std::bit_cast<std::uint32_t>(value + 0.0f);  // -0 + 0 = +0
  return (bits & 0x80000000u) != 0 ? ~bits : bits | 0x80000000u;
}

/// Sorts `items` by ascending keys[j] (keys[j] belongs to items[j]), stably: items with equal
/// keys keep their order. `keys` is reordered alongside; `item_tmp` and `key_tmp` are scratch
/// (resized to items.size(), never shrunk). Three passes of 11 bits, each skipped when all keys
/// share that digit.
inline void radix_sort_by_key(std::vector<std::int32_t>& items, std::vector<std::uint32_t>& keys,
                              std::vector<std::int32_t>& item_tmp,
                              std::vector<std::uint32_t>& key_tmp) {
  assert(items.size() == keys.size());
  const std::size_t n = items.size();
  if (n < 2) return;
  if (item_tmp.size() < n) item_tmp.resize(n);
  if (key_tmp.size() < n) key_tmp.resize(n);
  constexpr int kBits = 11;
  constexpr std::uint32_t kDigits = 1u << kBits;
  std::int32_t* from_items = items.data();
  std::uint32_t* from_keys = keys.data();
  std::int32_t* to_items = item_tmp.data();
  std::uint32_t* to_keys = key_tmp.data();
  for (int shift = 0; shift < 32; shift += kBits) {
    std::array<std::uint32_t, kDigits> start{};
    for (std::size_t j = 0; j < n; ++j) ++start[(from_keys[j] >> shift) & (kDigits - 1)];
    if (start[(from_keys[0] >> shift) & (kDigits - 1)] == n) continue;  // one digit: order kept
    std::uint32_t at = 0;
    for (std::uint32_t& s : start) {
      const std::uint32_t count = s;
      s = at;
      at += count;
    }
    for (std::size_t j = 0; j < n; ++j) {
      const std::uint32_t slot = start[(from_keys[j] >> shift) & (kDigits - 1)]++;
      to_items[slot] = from_items[j];
      to_keys[slot] = from_keys[j];
    }
    std::swap(from_items, to_items);
    std::swap(from_keys, to_keys);
  }
  if (from_items != items.data()) {
    std::copy(from_items, from_items + n, items.data());
    std::copy(from_keys, from_keys + n, keys.data());
  }
}

}  // namespace rangeseg::detail
