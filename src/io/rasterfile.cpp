#include "rangeseg/io/rasterfile.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "detail/number_text.hpp"
#include "rangeseg/io/file.hpp"

namespace rangeseg::io {
namespace {

constexpr std::uint32_t kRasterMagic = 0x59a66a95;
constexpr std::size_t kHeaderBytes = 32;
constexpr std::uint64_t kMaxPixels = std::uint64_t{1} << 28;

std::uint32_t read_be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

void write_be32(std::uint8_t* p, std::uint32_t v) {
  p[0] = static_cast<std::uint8_t>(v >> 24);
  p[1] = static_cast<std::uint8_t>(v >> 16);
  p[2] = static_cast<std::uint8_t>(v >> 8);
  p[3] = static_cast<std::uint8_t>(v);
}

// Rows of a Sun rasterfile are padded to a multiple of 16 bits.
std::uint64_t padded_row_bytes(std::uint64_t width) { return (width + 1) / 2 * 2; }

}  // namespace

bool is_rasterfile(const std::uint8_t* data, std::size_t size) {
  return data != nullptr && size >= 4 && read_be32(data) == kRasterMagic;
}

BytePlane decode_rasterfile(const std::uint8_t* data, std::size_t size, const std::string& name) {
  const auto fail = [&](const std::string& why) {
    return std::runtime_error("rasterfile '" + name + "': " + why);
  };
  if (data == nullptr || size < kHeaderBytes) {
    throw fail("file has " + std::to_string(size) + " bytes, shorter than the 32-byte header");
  }
  std::array<std::uint32_t, 8> h{};
  for (std::size_t i = 0; i < 8; ++i) h[i] = read_be32(data + 4 * i);
  const auto [magic, width, height, depth, length, type, maptype, maplength] = h;
  if (magic != kRasterMagic) {
    char hex[16];
    std::snprintf(hex, sizeof hex, "0x%08x", static_cast<unsigned>(magic));
    throw fail(std::string("wrong magic number ") + hex + ", expected 0x59a66a95");
  }
  if (depth != 8) throw fail("depth " + std::to_string(depth) + " bits is not supported (only 8)");
  if (type != 0 && type != 1) {
    throw fail("type " + std::to_string(type) +
               " is not supported (only 0 and 1, uncompressed; 2 = run-length encoded)");
  }
  if (maptype > 2) throw fail("unknown colour map type " + std::to_string(maptype));
  const std::uint64_t pixels = std::uint64_t{width} * height;
  if (width == 0 || height == 0 || pixels > kMaxPixels || width > (1u << 30) ||
      height > (1u << 30)) {
    throw fail("image size " + std::to_string(width) + " x " + std::to_string(height) +
               " is empty or larger than the limit of 2^28 pixels");
  }
  const std::uint64_t row_bytes = padded_row_bytes(width);
  const std::uint64_t image_bytes = row_bytes * height;
  // Old-style (type 0) files may leave `length` as 0; otherwise it must match the sizes.
  if (length != 0 && length != image_bytes) {
    throw fail("header length " + std::to_string(length) + " disagrees with " +
               std::to_string(width) + " x " + std::to_string(height) + " 8-bit pixels (" +
               std::to_string(image_bytes) + " bytes with row padding)");
  }
  const std::uint64_t needed = kHeaderBytes + std::uint64_t{maplength} + image_bytes;
  if (size < needed) {
    throw fail("truncated: " + std::to_string(size) + " bytes, header needs " +
               std::to_string(needed) + " (32 header + " + std::to_string(maplength) +
               " colour map + " + std::to_string(image_bytes) + " pixels)");
  }
  BytePlane image(static_cast<int>(width), static_cast<int>(height));
  const std::uint8_t* pixels_begin = data + kHeaderBytes + maplength;
  for (std::uint32_t y = 0; y < height; ++y) {
    std::memcpy(image.row(static_cast<int>(y)), pixels_begin + y * row_bytes, width);
  }
  return image;
}

BytePlane read_rasterfile(const std::string& path) {
  const std::vector<std::uint8_t> bytes = read_file(path);
  return decode_rasterfile(bytes.data(), bytes.size(), path);
}

std::vector<std::uint8_t> encode_rasterfile(View<const std::uint8_t> image) {
  if (image.width <= 0 || image.height <= 0 ||
      std::uint64_t(image.width) * std::uint64_t(image.height) > kMaxPixels) {
    throw std::invalid_argument("rasterfile: cannot encode a " + std::to_string(image.width) +
                                " x " + std::to_string(image.height) + " image");
  }
  const std::size_t row_bytes = padded_row_bytes(static_cast<std::uint64_t>(image.width));
  const std::size_t image_bytes = row_bytes * static_cast<std::size_t>(image.height);
  std::vector<std::uint8_t> bytes(kHeaderBytes + image_bytes, 0);
  const std::uint32_t header[8] = {kRasterMagic,
                                   static_cast<std::uint32_t>(image.width),
                                   static_cast<std::uint32_t>(image.height),
                                   8,
                                   static_cast<std::uint32_t>(image_bytes),
                                   1,
                                   0,
                                   0};
  for (std::size_t i = 0; i < 8; ++i) write_be32(bytes.data() + 4 * i, header[i]);
  for (int y = 0; y < image.height; ++y) {
    std::memcpy(bytes.data() + kHeaderBytes + y * row_bytes, image.row(y),
                static_cast<std::size_t>(image.width));
  }
  return bytes;
}

void write_rasterfile(const std::string& path, View<const std::uint8_t> image) {
  std::vector<std::uint8_t> bytes;
  try {
    bytes = encode_rasterfile(image);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("writing '" + path + "': " + e.what());
  }
  write_file_atomic(path, bytes);
}

AbwCalibration AbwCalibration::for_image(const std::string& path) {
  const std::size_t slash = path.find_last_of("/\\");
  const std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  const std::string prefix = "abw.test.";
  if (name.compare(0, prefix.size(), prefix) == 0) {
    std::size_t end = prefix.size();
    while (end < name.size() && name[end] >= '0' && name[end] <= '9') ++end;
    const bool number_ends = end > prefix.size() && (end == name.size() || name[end] == '.');
    if (number_ends && end - prefix.size() <= 3) {
      const int index = std::stoi(name.substr(prefix.size(), end - prefix.size()));
      for (const int second : {0, 19, 21, 25, 27, 28, 29}) {
        if (index == second) return {.offset = 785.410786, .scal = 0.773545, .f = -1610.981722};
      }
    }
  }
  return {};
}

OrganizedCloud abw_range_to_cloud(View<const std::uint8_t> range, const AbwCalibration& calib) {
  if (!(calib.scal > 0) || !std::isfinite(calib.offset) || !(std::abs(calib.f) > 0) ||
      !std::isfinite(calib.f) || !(calib.c > 0) || !std::isfinite(calib.c) ||
      !std::isfinite(calib.scal)) {
    throw std::invalid_argument("abw_range_to_cloud: invalid calibration offset " +
                                rangeseg::detail::number_text(calib.offset) + ", scal " +
                                rangeseg::detail::number_text(calib.scal) + ", f " +
                                rangeseg::detail::number_text(calib.f) + ", c " +
                                rangeseg::detail::number_text(calib.c));
  }
  OrganizedCloud cloud(range.width, range.height);
  const double inv_f = 1.0 / std::abs(calib.f);
  for (int r = 0; r < range.height; ++r) {
    const std::uint8_t* in = range.row(r);
    float* xs = cloud.x.row(r);
    float* ys = cloud.y.row(r);
    float* zs = cloud.z.row(r);
    for (int c = 0; c < range.width; ++c) {
      if (in[c] == 0) continue;                                // stays NaN
      const double depth = in[c] / calib.scal + calib.offset;  // scanner units along the axis
      const double x_units = (c - 255) * depth * inv_f;
      const double y_units = (255 - r) / calib.c * depth * inv_f;
      xs[c] = static_cast<float>(0.001 * x_units);
      ys[c] = static_cast<float>(-0.001 * y_units);
      zs[c] = static_cast<float>(0.001 * depth);
    }
  }
  return cloud;
}

OrganizedCloud read_abw_range(const std::string& path) {
  const BytePlane range = read_rasterfile(path);
  return abw_range_to_cloud(range.view(), AbwCalibration::for_image(path));
}

LabelImage read_segcomp_gt(const std::string& path) {
  const BytePlane raw = read_rasterfile(path);
  LabelImage labels(raw.width(), raw.height());
  for (int y = 0; y < raw.height(); ++y) {
    const std::uint8_t* in = raw.row(y);
    std::int32_t* out = labels.row(y);
    for (int x = 0; x < raw.width(); ++x) out[x] = in[x];
  }
  return labels;
}

}  // namespace rangeseg::io
