// Plain-text point clouds, one point per line: Open3D's .xyz, .xyzn, .xyzrgb and .pts.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "rangeseg/cloud.hpp"

namespace rangeseg::io {

/// The column layouts of the text formats, told apart by the file's extension.
enum class TextCloudFormat {
  xyz,     ///< x y z [more columns, ignored]
  xyzn,    ///< x y z nx ny nz (the normals are not kept)
  xyzrgb,  ///< x y z r g b, colours 0..1
  pts,     ///< an optional first line with the point count, then x y z, x y z i, x y z r g b or
           ///< x y z i r g b (colours 0..255), the same columns on every line
};

/// The format an extension names (".xyz", ".xyzn", ".xyzrgb", ".pts", any case); throws
/// std::invalid_argument for any other.
TextCloudFormat text_cloud_format(const std::string& extension);

/// Whether text_cloud_format knows the extension.
bool is_text_cloud_extension(const std::string& extension);

/// Reads a text cloud as an unorganized cloud (height 1), one point per line in file order, in
/// metres. Numbers are separated by spaces, tabs or commas; empty lines and lines starting with
/// '#' or "//" are skipped (and a UTF-8 byte order mark); "nan" marks an invalid point. Colours
/// become r, g, b (0..255), a .pts intensity column `intensity` unless it is the same at every
/// point (Open3D writes 0), which measures nothing. Throws std::runtime_error naming the file, the
/// line and the problem for a line that is not numbers, has fewer columns than the format needs or
/// another count than the first point's, a colour out of range, a .pts count that is not
/// the number of points, or a file without a point.
OrganizedCloud read_text_cloud(const std::string& path);

/// read_text_cloud on bytes in memory; `name` is used in error messages.
OrganizedCloud decode_text_cloud(const std::uint8_t* data, std::size_t size,
                                 const std::string& name, TextCloudFormat format);

}  // namespace rangeseg::io
