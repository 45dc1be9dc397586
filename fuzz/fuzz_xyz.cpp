// libFuzzer target: decode_text_cloud must reject malformed input with an exception, never
// crash. Byte 0 picks the format (.xyz, .xyzn, .xyzrgb, .pts); the rest is the file.
#include <cstddef>
#include <cstdint>
#include <exception>

#include "rangeseg/io/xyz.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const auto format = static_cast<rangeseg::io::TextCloudFormat>(data[0] % 4);
  try {
    const rangeseg::OrganizedCloud cloud =
        rangeseg::io::decode_text_cloud(data + 1, size - 1, "fuzz.xyz", format);
    volatile std::size_t valid = cloud.count_valid();
    (void)valid;
  } catch (const std::exception&) {
  }
  return 0;
}
