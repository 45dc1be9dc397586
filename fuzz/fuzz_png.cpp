// libFuzzer target for the depth PNG decoder. Chunk CRCs are recomputed before decoding so that
// mutations reach the chunk parsers and inflate instead of stopping at the CRC check.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <vector>

#include "rangeseg/io/png.hpp"

namespace {

std::uint32_t crc32_of(const std::uint8_t* data, std::size_t size) {
  std::uint32_t crc = 0xffffffffu;
  for (std::size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  return crc ^ 0xffffffffu;
}

void fix_chunk_crcs(std::vector<std::uint8_t>& png) {
  std::size_t pos = 8;
  while (pos + 12 <= png.size()) {
    const std::size_t length = (std::size_t{png[pos]} << 24) | (std::size_t{png[pos + 1]} << 16) |
                               (std::size_t{png[pos + 2]} << 8) | png[pos + 3];
    if (length > png.size() - pos - 12) break;
    const std::uint32_t crc = crc32_of(png.data() + pos + 4, length + 4);
    std::uint8_t* out = png.data() + pos + 8 + length;
    for (int k = 0; k < 4; ++k) out[k] = static_cast<std::uint8_t>(crc >> (24 - 8 * k));
    pos += length + 12;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::uint8_t> png(data, data + size);
  if (!png.empty() && (png[0] & 1)) fix_chunk_crcs(png);  // half the inputs keep their CRCs
  try {
    const rangeseg::DepthImage image =
        rangeseg::io::decode_depth_png(png.data(), png.size(), "fuzz.png");
    if (image.empty()) __builtin_trap();  // a successful decode is never empty
  } catch (const std::exception&) {
  }
  return 0;
}
