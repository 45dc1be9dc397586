// PCD (Point Cloud Library's "Point Cloud Data" format) reading and writing.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "rangeseg/cloud.hpp"

namespace rangeseg::io {

/// The three PCD data encodings. `binary_compressed` is LZF-compressed structure-of-arrays data.
enum class PcdEncoding { ascii, binary, binary_compressed };

/// What a PCD header declared, reported by the readers.
struct PcdInfo {
  std::string version;  ///< as in the file ("0.7", ".7"); empty if there is no VERSION line
  std::vector<std::string> fields;  ///< field names in file order, e.g. {"x", "y", "z", "rgba"}
  std::string fields_summary;       ///< the names joined by spaces, e.g. "x y z rgba"
  int width = 0, height = 0;        ///< grid size; height 1 = unorganized
  std::uint64_t points = 0;         ///< width * height
  PcdEncoding encoding = PcdEncoding::binary;
  /// Whether x, y and z are all stored as doubles (TYPE F, SIZE 8), which keep a map's
  /// coordinates (UTM: 5e6 m) to the nanometre; floats there lie 0.5 m apart.
  bool xyz_double = false;
  /// VIEWPOINT: the sensor's pose in the points' frame, translation tx ty tz [m] and rotation
  /// quaternion qw qx qy qz, as PCL stores it (sensor_origin_, sensor_orientation_); identity
  /// when the header has none. The reader returns the points as stored, in the file's frame.
  std::array<double, 7> viewpoint{0, 0, 0, 1, 0, 0, 0};
  /// Whether `viewpoint` is other than the identity (a cloud not in its sensor's frame).
  bool moved_from_sensor() const;
};

/// Options of read_pcd and parse_pcd.
struct PcdReadOptions {
  /// Move the points into the frame of the sensor the header's VIEWPOINT names (p' = R^T (p - t),
  /// as to_sensor_frame in cloud.hpp), computed in double from the values as stored: a PCD of
  /// doubles in map coordinates (UTM: 5e6 m, where floats lie 0.5 m apart) keeps its precision.
  /// PcdInfo::viewpoint still reports the file's VIEWPOINT. Default off: the points as stored.
  bool to_sensor_frame = false;
};

/// Reads a PCD file (VERSION 0.7 and older headers; DATA ascii, binary or binary_compressed;
/// any field order; TYPE F/U/I with SIZE 1/2/4/8; COUNT > 1 allowed).
/// Fields used: x, y, z (required, metres), `rgb` (packed 0x00RRGGBB in a float or U4) or `rgba`
/// (U4 0xAARRGGBB) -> r, g, b planes, `intensity` (any numeric type, converted to float) and
/// `label` (-> label plane). Every other field is skipped. Values are kept bit-exact (a NaN in the
/// file stays that NaN); a point is invalid when x, y or z is not finite.
/// Throws std::runtime_error naming the file and the problem for any malformed input, and never
/// allocates more than the file size can justify.
/// With `options.to_sensor_frame`, a VIEWPOINT that is no rigid motion (a non-finite value, a
/// quaternion of norm below 1e-6) is such an error too.
OrganizedCloud read_pcd(const std::string& path, PcdInfo* info = nullptr,
                        const PcdReadOptions& options = {});

/// Same as read_pcd for a file already in memory; `name` is used in error messages.
OrganizedCloud parse_pcd(const std::uint8_t* data, std::size_t size, const std::string& name,
                         PcdInfo* info = nullptr, const PcdReadOptions& options = {});

struct PcdWriteOptions {
  PcdEncoding encoding = PcdEncoding::binary;
  /// Whether x, y and z are all stored as doubles (TYPE F, SIZE 8), which keep a map's
  /// coordinates (UTM: 5e6 m) to the nanometre; floats there lie 0.5 m apart.
  bool xyz_double = false;
  /// VIEWPOINT written (see PcdInfo::viewpoint; finite values, std::invalid_argument otherwise).
  std::array<double, 7> viewpoint{0, 0, 0, 1, 0, 0, 0};
  /// Additional F4 fields written after the cloud's own, e.g. {"normal_x", &nx}. Each plane
  /// must have the cloud's width and height (std::invalid_argument otherwise).
  std::vector<std::pair<std::string, const FloatPlane*>> extra_float_fields{};
};

/// Encodes a cloud as a PCD v0.7 file: fields x y z (F4), then `intensity` (F4), `rgb` (F4
/// holding the bits 0x00RRGGBB, as PCL writes it) and `label` (U4, the int32 bits) when the
/// cloud has them, then the extra fields. WIDTH/HEIGHT are the cloud's. Reading the result back
/// gives every plane bit-exact for all three encodings.
std::vector<std::uint8_t> encode_pcd(const OrganizedCloud& cloud,
                                     const PcdWriteOptions& options = {});

/// encode_pcd, then io::write_file_atomic. Throws std::runtime_error naming the file on failure.
void write_pcd(const std::string& path, const OrganizedCloud& cloud,
               const PcdWriteOptions& options = {});

}  // namespace rangeseg::io
