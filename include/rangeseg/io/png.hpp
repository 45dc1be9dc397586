// PNG images through libpng: 16-bit depth and label images, 8-bit RGB pictures.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rangeseg/colorize.hpp"
#include "rangeseg/image.hpp"

namespace rangeseg::io {

/// Largest image the readers accept, in pixels (2^28); larger headers are refused before any
/// pixel memory is allocated.
inline constexpr std::uint64_t kMaxPngPixels = std::uint64_t{1} << 28;

/// Reads a grayscale PNG as raw depth (e.g. millimetres, 0 = no measurement). 16-bit gray is
/// read as is; 8-bit gray is widened (value kept, 0..255). Any other colour type or bit depth
/// (RGB, palette, gray+alpha, 1/2/4-bit gray) throws std::runtime_error naming the file, as do
/// unreadable, truncated, corrupt or empty files. `eight_bit`, when given, is set to whether the
/// file was 8-bit (a depth camera writes 16 bits; 8 bits is more often a picture or a mask).
DepthImage read_depth_png(const std::string& path, bool* eight_bit = nullptr);

/// The decoder behind read_depth_png, on a PNG held in memory; `name` is used in error messages.
DepthImage decode_depth_png(const std::uint8_t* data, std::size_t size, const std::string& name,
                            bool* eight_bit = nullptr);

/// Reads a 16-bit (or 8-bit) grayscale PNG as integer labels, 0 = none; throws
/// std::runtime_error naming the file for any other PNG or an unreadable one.
LabelImage read_label_png(const std::string& path);

/// Encoders to an in-memory PNG file (used by the writers; exposed for tests and tools). Throw
/// std::invalid_argument for an empty image or an RGB buffer of another size than 3 w h, and
/// std::runtime_error when libpng fails.
std::vector<std::uint8_t> encode_depth_png(View<const std::uint16_t> depth);
std::vector<std::uint8_t> encode_rgb_png(const RgbImage& image);

/// Writes a 16-bit grayscale PNG (atomically, see io::write_file_atomic). Throws as the encoder,
/// and std::runtime_error naming the file when it cannot be written.
void write_depth_png(const std::string& path, View<const std::uint16_t> depth);

/// Writes labels as a 16-bit grayscale PNG, 0 = none. Throws std::invalid_argument naming the
/// file, the pixel and the value if a label is outside 0..65535.
void write_label_png(const std::string& path, const LabelImage& labels);

/// Writes an 8-bit RGB PNG. Throws std::invalid_argument if `image.rgb` does not hold
/// width * height * 3 bytes.
void write_rgb_png(const std::string& path, const RgbImage& image);

}  // namespace rangeseg::io
