// Sun rasterfiles as used by the SegComp range image database (ABW images and their ground
// truth), and the conversion of ABW range images to 3D points.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"

namespace rangeseg::io {

/// Reads an 8-bit Sun rasterfile: a 32-byte big-endian header (magic 0x59a66a95, width, height,
/// depth, length, type, maptype, maplength), `maplength` bytes of colour map (skipped), then
/// `height` rows of `width` bytes, each row padded to an even number of bytes. Only depth 8 and
/// type 0 (old) or 1 (standard), i.e. uncompressed, are supported. The SegComp ABW files are
/// 512 x 512, type 1 (.range) or 0 (.gt-seg), no colour map, no padding.
/// Throws std::runtime_error naming the file for a wrong magic, unsupported depth or type,
/// sizes above 2^28 pixels, a `length` field that disagrees with the sizes, or truncated data.
BytePlane read_rasterfile(const std::string& path);

/// Whether the bytes start with the rasterfile magic number (0x59a66a95, big-endian).
bool is_rasterfile(const std::uint8_t* data, std::size_t size);

/// The decoder behind read_rasterfile, on bytes in memory; `name` is used in error messages.
BytePlane decode_rasterfile(const std::uint8_t* data, std::size_t size, const std::string& name);

/// Encodes an 8-bit image as a standard (type 1) rasterfile without colour map.
std::vector<std::uint8_t> encode_rasterfile(View<const std::uint8_t> image);

/// Writes an 8-bit rasterfile atomically (e.g. SegComp machine segmentations, .ms-seg). Both
/// throw std::invalid_argument for an empty or too large image; the writer std::runtime_error
/// naming the file when it cannot be written.
void write_rasterfile(const std::string& path, View<const std::uint8_t> image);

/// Calibration of the ABW structured-light scanner from the SegComp tools (USF rangetocoords).
/// Scanner units are about a millimetre.
struct AbwCalibration {
  double offset = 771.016866;  ///< OFFSET [scanner units]
  double scal = 0.791686;      ///< SCAL [range value per scanner unit]
  double f = -1586.072821;     ///< F, focal length [pixel]; only |F| enters the formula
  double c = 1.4508;           ///< C, aspect ratio of rows to columns [dimensionless]

  /// The calibration the SegComp tools use for an image file: the second set (OFFSET 785.410786,
  /// SCAL 0.773545, F -1610.981722) for abw.test.{0,19,21,25,27,28,29}, the default otherwise.
  /// Only the file name (after the last '/') matters, e.g. "dir/abw.test.19.range".
  static AbwCalibration for_image(const std::string& path);
};

/// Converts an ABW range image to an organized cloud in metres.
///
/// SegComp's conversion of pixel (row r, column c) with range value R (R = 0: no data, NaN here)
/// gives scanner coordinates
///   X = (c - 255) (R/SCAL + OFFSET) / |F|,  Y = (255 - r) / C (R/SCAL + OFFSET) / |F|,
///   Z = (255 - R) / SCAL.
/// This library's camera frame has x right, y down, z forward from the projection centre, so
///   x = 0.001 X,  y = -0.001 Y,  z = 0.001 (R/SCAL + OFFSET),
/// i.e. (X, -Y, K - Z) with K = 255/SCAL + OFFSET, scaled by 0.001 m per unit: a rigid motion
/// (a rotation by 180 degrees about x plus a shift along z) and a uniform scale, so planes stay
/// planes and angles between them are preserved; the sensor is at the origin and z is the depth
/// along the viewing direction (x = (c - 255) z / |F|, a pinhole with fx = |F|, fy = C |F|).
/// Throws std::invalid_argument for a calibration with a non-finite value, scal or C <= 0, or
/// F = 0.
OrganizedCloud abw_range_to_cloud(View<const std::uint8_t> range, const AbwCalibration& calib);

/// read_rasterfile + abw_range_to_cloud with AbwCalibration::for_image(path). The readers throw
/// std::runtime_error naming the file for an unreadable, truncated or malformed one.
OrganizedCloud read_abw_range(const std::string& path);

/// Reads a SegComp ground truth (.gt-seg) or machine segmentation rasterfile as labels, keeping
/// the raw byte values: 0 = no data / shadow, 1 and 2 = unlabelled, >= 10 = one region each.
LabelImage read_segcomp_gt(const std::string& path);

}  // namespace rangeseg::io
