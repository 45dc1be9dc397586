// Plain-text point clouds, one point per line (Open3D's .xyz, .xyzn, .xyzrgb and .pts).
#include "rangeseg/io/xyz.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "detail/number_text.hpp"
#include "quoted.hpp"
#include "rangeseg/io/file.hpp"

namespace rangeseg::io {
namespace {

[[noreturn]] void fail(const std::string& name, std::size_t line, const std::string& why) {
  throw std::runtime_error("point cloud '" + name + "', line " + std::to_string(line) + ": " + why);
}

using detail::quoted;

bool separator(char c) { return c == ' ' || c == '\t' || c == ',' || c == '\r'; }

// The numbers of one line; false for a comment or an empty line.
bool numbers_of(std::string_view line, std::vector<double>& out, const std::string& name,
                std::size_t line_no) {
  out.clear();
  std::size_t i = 0;
  while (i < line.size() && separator(line[i])) ++i;
  if (i == line.size() || line[i] == '#' || line.substr(i).starts_with("//")) return false;
  while (i < line.size()) {
    const std::size_t start = i;
    while (i < line.size() && !separator(line[i])) ++i;
    std::string_view token = line.substr(start, i - start);
    // from_chars takes no '+' sign, which some writers put on positive numbers.
    if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
    double v = 0;
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
    if (ec != std::errc{} || end != token.data() + token.size()) {
      fail(name, line_no, "expected a number, got " + quoted(token));
    }
    out.push_back(v);
    while (i < line.size() && separator(line[i])) ++i;
  }
  return true;
}

// Where the columns are for a first point of `n` numbers.
struct Columns {
  int count = 3;
  int intensity = -1;  ///< column, or -1
  int rgb = -1;        ///< first of three columns, or -1
  double colour_max = 255;
};

Columns columns_for(TextCloudFormat format, std::size_t n, const std::string& name,
                    std::size_t line_no) {
  Columns c;
  c.count = static_cast<int>(n);
  const auto need = [&](std::size_t least, const char* what) {
    if (n < least) {
      fail(name, line_no,
           std::to_string(n) + (n == 1 ? " number, " : " numbers, ") + what + " needs at least " +
               std::to_string(least));
    }
  };
  switch (format) {
    case TextCloudFormat::xyz:
      need(3, ".xyz (x y z)");
      break;
    case TextCloudFormat::xyzn:
      need(6, ".xyzn (x y z nx ny nz)");
      break;
    case TextCloudFormat::xyzrgb:
      need(6, ".xyzrgb (x y z r g b)");
      c.rgb = 3, c.colour_max = 1;
      break;
    case TextCloudFormat::pts:
      if (n == 4 || n == 7) c.intensity = 3;
      if (n == 6 || n == 7) c.rgb = static_cast<int>(n) - 3;
      if (n != 3 && n != 4 && n != 6 && n != 7) {
        fail(name, line_no,
             std::to_string(n) +
                 " numbers; a .pts point is x y z, x y z i, x y z r g b or "
                 "x y z i r g b");
      }
      break;
  }
  return c;
}

}  // namespace

namespace {

std::optional<TextCloudFormat> format_of(const std::string& extension) {
  std::string e = extension;
  std::transform(e.begin(), e.end(), e.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (e == ".xyz") return TextCloudFormat::xyz;
  if (e == ".xyzn") return TextCloudFormat::xyzn;
  if (e == ".xyzrgb") return TextCloudFormat::xyzrgb;
  if (e == ".pts") return TextCloudFormat::pts;
  return std::nullopt;
}

}  // namespace

bool is_text_cloud_extension(const std::string& extension) {
  return format_of(extension).has_value();
}

TextCloudFormat text_cloud_format(const std::string& extension) {
  if (const auto format = format_of(extension)) return *format;
  throw std::invalid_argument("text_cloud_format: '" + extension +
                              "' is not .xyz, .xyzn, .xyzrgb or .pts");
}

OrganizedCloud decode_text_cloud(const std::uint8_t* data, std::size_t size,
                                 const std::string& name, TextCloudFormat format) {
  std::string_view text(reinterpret_cast<const char*>(data), size);
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);  // a UTF-8 byte order mark
  std::vector<float> xyz, intensity;
  std::vector<std::uint8_t> rgb;
  std::vector<double> v;
  Columns columns;
  bool first = true;
  long long declared = -1;  // a .pts file's count line
  std::size_t line_no = 0, pos = 0;
  while (pos < text.size()) {
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string_view::npos) eol = text.size();
    const std::string_view line = text.substr(pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    if (!numbers_of(line, v, name, line_no)) continue;
    if (format == TextCloudFormat::pts && first && declared < 0 && v.size() == 1) {
      if (!(v[0] >= 0 && v[0] == std::floor(v[0]) && v[0] < 1e12)) {
        fail(name, line_no, "the point count " + quoted(line) + " is no count");
      }
      declared = static_cast<long long>(v[0]);
      continue;
    }
    if (first) {
      columns = columns_for(format, v.size(), name, line_no);
      first = false;
    } else if (static_cast<int>(v.size()) != columns.count) {
      fail(name, line_no,
           std::to_string(v.size()) + " numbers where the first point has " +
               std::to_string(columns.count));
    }
    if (xyz.size() / 3 >= static_cast<std::size_t>(std::numeric_limits<int>::max())) {
      fail(name, line_no, "more than 2^31 - 1 points");
    }
    for (int k = 0; k < 3; ++k) xyz.push_back(static_cast<float>(v[k]));
    if (columns.intensity >= 0) intensity.push_back(static_cast<float>(v[columns.intensity]));
    if (columns.rgb >= 0) {
      for (int k = 0; k < 3; ++k) {
        const double c = v[columns.rgb + k];
        if (!(c >= 0 && c <= columns.colour_max)) {
          fail(name, line_no,
               "colour " + rangeseg::detail::number_text(c) + " outside 0.." +
                   (columns.colour_max == 1 ? std::string("1 (.xyzrgb colours are 0..1)")
                                            : std::string("255")));
        }
        rgb.push_back(static_cast<std::uint8_t>(std::lround(c * (255 / columns.colour_max))));
      }
    }
  }
  const std::size_t n = xyz.size() / 3;
  if (n == 0 && declared <= 0) {
    // As an empty PCD or PLY file is an error: a cloud of no point is no input.
    throw std::runtime_error(
        "point cloud '" + name + "': no point (" +
        (size == 0 ? std::string("an empty file") : "only comments and blank lines") + ")");
  }
  if (declared >= 0 && static_cast<std::size_t>(declared) != n) {
    fail(name, line_no,
         "the first line gives " + std::to_string(declared) + " points, the file has " +
             std::to_string(n));
  }
  // An intensity that is the same at every point measures nothing (Open3D writes 0 for every
  // point): dropped, so that the smoothing's intensity term takes grey from the colours.
  if (std::all_of(intensity.begin(), intensity.end(),
                  [&](float i) { return i == intensity.front(); })) {
    intensity.clear();
  }
  OrganizedCloud cloud(static_cast<int>(n), n > 0 ? 1 : 0);
  if (!intensity.empty()) cloud.add_intensity();
  if (!rgb.empty()) cloud.add_rgb();
  for (std::size_t i = 0; i < n; ++i) {
    const int u = static_cast<int>(i);
    cloud.x(u, 0) = xyz[3 * i], cloud.y(u, 0) = xyz[3 * i + 1], cloud.z(u, 0) = xyz[3 * i + 2];
    if (!intensity.empty()) cloud.intensity(u, 0) = intensity[i];
    if (!rgb.empty()) {
      cloud.r(u, 0) = rgb[3 * i], cloud.g(u, 0) = rgb[3 * i + 1], cloud.b(u, 0) = rgb[3 * i + 2];
    }
  }
  return cloud;
}

OrganizedCloud read_text_cloud(const std::string& path) {
  TextCloudFormat format{};
  try {
    format = text_cloud_format(extension(path));
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  const std::vector<std::uint8_t> bytes = read_file(path);
  return decode_text_cloud(bytes.data(), bytes.size(), path, format);
}

}  // namespace rangeseg::io
