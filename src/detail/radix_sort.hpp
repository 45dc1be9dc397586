// Internal: a stable LSD radix sort of int32 items by unsigned keys (order-preserving maps of
// floats or doubles, below), for orders that must not allocate per frame (std::stable_sort does)
// and are hot enough that a comparison sort shows.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "detail/headroom.hpp"

namespace rangeseg::detail {

/// An unsigned key whose order is the order of the float values (NaN excluded); -0 and +0 map
/// to the same key, as they compare equal.
inline std::uint32_t float_order_key(float value) {
  const auto bits = std::bit_cast<std::uint32_t>(value + 0.0f);  // -0 + 0 = +0
  return (bits & 0x80000000u) != 0 ? ~bits : bits | 0x80000000u;
}

/// The same for a double.
inline std::uint64_t double_order_key(double value) {
  const auto bits = std::bit_cast<std::uint64_t>(value + 0.0);
  return (bits >> 63) != 0 ? ~bits : bits | (std::uint64_t{1} << 63);
}

/// Sorts `items` by ascending keys[j] (keys[j] belongs to items[j]; Key is std::uint32_t or
/// std::uint64_t), stably: items with equal keys keep their order. `keys` is reordered
/// alongside; `item_tmp` and `key_tmp` are scratch (resized to items.size(), never shrunk).
/// Passes of 11 bits (3 for 32-bit keys, 6 for 64-bit ones), each skipped when all keys share
/// that digit.
template <class Key>
void radix_sort_by_key(std::vector<std::int32_t>& items, std::vector<Key>& keys,
                       std::vector<std::int32_t>& item_tmp, std::vector<Key>& key_tmp) {
  static_assert(std::is_same_v<Key, std::uint32_t> || std::is_same_v<Key, std::uint64_t>);
  assert(items.size() == keys.size());
  const std::size_t n = items.size();
  if (n < 2) return;
  if (item_tmp.size() < n) resize_with_headroom(item_tmp, n);
  if (key_tmp.size() < n) resize_with_headroom(key_tmp, n);
  constexpr int kBits = 11;
  constexpr std::uint32_t kDigits = 1u << kBits;
  std::int32_t* from_items = items.data();
  Key* from_keys = keys.data();
  std::int32_t* to_items = item_tmp.data();
  Key* to_keys = key_tmp.data();
  const auto digit = [](Key key, int shift) {
    return static_cast<std::uint32_t>(key >> shift) & (kDigits - 1);
  };
  for (int shift = 0; shift < static_cast<int>(8 * sizeof(Key)); shift += kBits) {
    std::array<std::uint32_t, kDigits> start{};
    for (std::size_t j = 0; j < n; ++j) ++start[digit(from_keys[j], shift)];
    if (start[digit(from_keys[0], shift)] == n) continue;  // one digit: order kept
    std::uint32_t at = 0;
    for (std::uint32_t& s : start) {
      const std::uint32_t count = s;
      s = at;
      at += count;
    }
    for (std::size_t j = 0; j < n; ++j) {
      const std::uint32_t slot = start[digit(from_keys[j], shift)]++;
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
