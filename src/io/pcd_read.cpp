#include <lzf.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "detail/sensor_pose.hpp"
#include "quoted.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/pcd.hpp"

static_assert(std::endian::native == std::endian::little, "PCD binary data is little-endian");

namespace rangeseg::io {
namespace {

// LZF back-references expand at most ~90x; a larger ratio means the header lies and following it
// would let a tiny file demand gigabytes.
constexpr std::uint64_t kMaxCompressionRatio = 1000;
constexpr std::uint64_t kMaxCount = std::uint64_t{1} << 20;      // values per field
constexpr std::uint64_t kMaxPointSize = std::uint64_t{1} << 24;  // bytes per point

struct Field {
  std::string name;
  char type = 'F';           // 'F', 'U' or 'I'
  std::uint64_t size = 4;    // bytes per value
  std::uint64_t count = 1;   // values per point
  std::uint64_t offset = 0;  // byte offset inside one point (binary layout)
  std::uint64_t bytes() const { return size * count; }
};

struct Header {
  PcdInfo info;
  std::vector<Field> fields;
  std::uint64_t point_size = 0;   // bytes
  std::uint64_t value_count = 0;  // values per point (sum of COUNT)
  std::size_t data_offset = 0;    // first byte after the DATA line
};

[[noreturn]] void fail(const std::string& name, const std::string& what) {
  throw std::runtime_error(name + ": PCD: " + what);
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

std::string quoted(std::string_view s) { return detail::quoted(s, '\'', 40); }

std::uint64_t parse_uint(std::string_view token, const std::string& name, const char* what) {
  std::uint64_t value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc{} || end != token.data() + token.size()) {
    fail(name, std::string(what) + ": expected a non-negative integer, got " + quoted(token));
  }
  return value;
}

double parse_finite(std::string_view token, const std::string& name, const char* what) {
  double value = 0;
  const char* first = token.data();
  if (!token.empty() && *first == '+') ++first;  // from_chars rejects an explicit plus sign
  const auto [end, ec] = std::from_chars(first, token.data() + token.size(), value);
  if (ec != std::errc{} || end != token.data() + token.size() || !std::isfinite(value)) {
    fail(name, std::string(what) + ": expected a finite number, got " + quoted(token));
  }
  return value;
}

int parse_dimension(const std::vector<std::string_view>& tokens, const std::string& name,
                    const char* what) {
  if (tokens.size() != 2) fail(name, std::string(what) + " needs exactly one value");
  const std::uint64_t value = parse_uint(tokens[1], name, what);
  if (value > static_cast<std::uint64_t>(std::numeric_limits<int>::max())) {
    fail(name, std::string(what) + " " + std::to_string(value) + " is too large");
  }
  return static_cast<int>(value);
}

Header parse_header(const std::uint8_t* data, std::size_t size, const std::string& name) {
  Header h;
  std::vector<std::string_view> sizes, types, counts;
  bool have_fields = false, have_size = false, have_type = false, have_count = false;
  bool have_width = false, have_height = false, have_points = false, have_data = false;
  std::uint64_t points = 0;
  const char* text = reinterpret_cast<const char*>(data);
  std::size_t pos = 0;
  while (pos < size && !have_data) {
    const void* nl = std::memchr(text + pos, '\n', size - pos);
    const std::size_t end = nl ? static_cast<const char*>(nl) - text : size;
    const std::string_view line(text + pos, end - pos);
    pos = nl ? end + 1 : size;
    auto tokens = split(line);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    const std::string_view key = tokens[0];
    auto once = [&](bool& seen) {
      if (seen) fail(name, "header line " + std::string(key) + " appears twice");
      seen = true;
    };
    if (key == "VERSION") {
      if (tokens.size() != 2) fail(name, "VERSION needs exactly one value");
      h.info.version = std::string(tokens[1]);
    } else if (key == "FIELDS" || key == "COLUMNS") {
      once(have_fields);
      if (tokens.size() < 2) fail(name, "FIELDS line lists no field");
      for (std::size_t i = 1; i < tokens.size(); ++i) {
        h.fields.push_back({.name = std::string(tokens[i])});
      }
    } else if (key == "SIZE") {
      once(have_size);
      sizes.assign(tokens.begin() + 1, tokens.end());
    } else if (key == "TYPE") {
      once(have_type);
      types.assign(tokens.begin() + 1, tokens.end());
    } else if (key == "COUNT") {
      once(have_count);
      counts.assign(tokens.begin() + 1, tokens.end());
    } else if (key == "WIDTH") {
      once(have_width);
      h.info.width = parse_dimension(tokens, name, "WIDTH");
    } else if (key == "HEIGHT") {
      once(have_height);
      h.info.height = parse_dimension(tokens, name, "HEIGHT");
    } else if (key == "POINTS") {
      once(have_points);
      if (tokens.size() != 2) fail(name, "POINTS needs exactly one value");
      points = parse_uint(tokens[1], name, "POINTS");
    } else if (key == "VIEWPOINT") {
      if (tokens.size() != 8) {
        fail(name, "VIEWPOINT needs 7 values (tx ty tz qw qx qy qz), got " +
                       std::to_string(tokens.size() - 1));
      }
      for (std::size_t i = 0; i < 7; ++i) {
        h.info.viewpoint[i] = parse_finite(tokens[i + 1], name, "VIEWPOINT");
      }
    } else if (key == "DATA") {
      have_data = true;
      if (tokens.size() != 2) {
        fail(name, "DATA needs exactly one value (ascii, binary or binary_compressed)");
      }
      if (tokens[1] == "ascii") {
        h.info.encoding = PcdEncoding::ascii;
      } else if (tokens[1] == "binary") {
        h.info.encoding = PcdEncoding::binary;
      } else if (tokens[1] == "binary_compressed") {
        h.info.encoding = PcdEncoding::binary_compressed;
      } else {
        fail(name, "unknown DATA encoding " + quoted(tokens[1]));
      }
    } else {
      fail(name, "unknown header line starting with " + quoted(key) +
                     (pos >= size ? " (not a PCD file, or a truncated header?)" : ""));
    }
  }
  if (!have_data) fail(name, "no DATA line: not a PCD file or truncated header");
  h.data_offset = pos;
  if (!have_fields) fail(name, "no FIELDS line in the header");

  const std::size_t n = h.fields.size();
  auto check_count = [&](const std::vector<std::string_view>& list, bool have, const char* what) {
    if (have && list.size() != n) {
      fail(name, std::string(what) + " lists " + std::to_string(list.size()) +
                     " values but FIELDS lists " + std::to_string(n));
    }
  };
  check_count(sizes, have_size, "SIZE");
  check_count(types, have_type, "TYPE");
  check_count(counts, have_count, "COUNT");
  for (std::size_t i = 0; i < n; ++i) {
    Field& f = h.fields[i];
    // Headers older than v0.7 may lack SIZE/TYPE/COUNT: PCL then assumes 4-byte floats, one each.
    if (have_size) f.size = parse_uint(sizes[i], name, "SIZE");
    if (have_type) {
      if (types[i].size() != 1) {
        fail(name, "field " + f.name + ": unknown TYPE " + quoted(types[i]));
      }
      f.type = types[i][0];
    }
    if (have_count) f.count = parse_uint(counts[i], name, "COUNT");
    if (f.type != 'F' && f.type != 'U' && f.type != 'I') {
      fail(name,
           "field " + f.name + ": unknown TYPE " + quoted(types[i]) + " (expected F, U or I)");
    }
    const bool size_ok = (f.type == 'F' && (f.size == 4 || f.size == 8)) ||
                         ((f.type == 'U' || f.type == 'I') &&
                          (f.size == 1 || f.size == 2 || f.size == 4 || f.size == 8));
    if (!size_ok) {
      fail(name, "field " + f.name + ": unsupported SIZE " + std::to_string(f.size) + " for TYPE " +
                     f.type);
    }
    if (f.count < 1 || f.count > kMaxCount) {
      fail(name, "field " + f.name + ": COUNT " + std::to_string(f.count) + " out of range 1.." +
                     std::to_string(kMaxCount));
    }
    f.offset = h.point_size;
    h.point_size += f.bytes();
    h.value_count += f.count;
    if (h.point_size > kMaxPointSize) {
      fail(name, "point size over " + std::to_string(kMaxPointSize) + " bytes");
    }
    h.info.fields.push_back(f.name);
    h.info.fields_summary += (i ? " " : "") + f.name;
  }

  if (!have_width && !have_points) fail(name, "neither WIDTH nor POINTS in the header");
  if (!have_width) {
    h.info.width =
        static_cast<int>(std::min<std::uint64_t>(points, std::numeric_limits<int>::max()));
  }
  if (!have_height) h.info.height = 1;
  const std::uint64_t grid =
      static_cast<std::uint64_t>(h.info.width) * static_cast<std::uint64_t>(h.info.height);
  if (!have_points) points = grid;
  if (grid != points) {
    fail(name, "WIDTH*HEIGHT = " + std::to_string(h.info.width) + "*" +
                   std::to_string(h.info.height) + " does not match POINTS " +
                   std::to_string(points));
  }
  if (points == 0) fail(name, "no points (WIDTH*HEIGHT = 0)");
  h.info.points = points;
  return h;
}

const Field* find_field(const Header& h, std::string_view field_name) {
  for (const Field& f : h.fields) {
    if (f.name == field_name) return &f;
  }
  return nullptr;
}

// Where one field's values are: value of point i at base + i * stride.
struct Column {
  const Field* field = nullptr;
  const std::uint8_t* base = nullptr;
  std::size_t stride = 0;
};

template <class T>
T load(const std::uint8_t* p) {
  T value;
  std::memcpy(&value, p, sizeof(T));
  return value;
}

// Converts one stored value to double (for non-float4 numeric fields; rare, so not the fast path).
double load_as_double(const Field& f, const std::uint8_t* p) {
  switch (f.type) {
    case 'F':
      return f.size == 4 ? static_cast<double>(load<float>(p)) : load<double>(p);
    case 'U':
      switch (f.size) {
        case 1:
          return load<std::uint8_t>(p);
        case 2:
          return load<std::uint16_t>(p);
        case 4:
          return load<std::uint32_t>(p);
        default:
          return static_cast<double>(load<std::uint64_t>(p));
      }
    default:
      switch (f.size) {
        case 1:
          return load<std::int8_t>(p);
        case 2:
          return load<std::int16_t>(p);
        case 4:
          return load<std::int32_t>(p);
        default:
          return static_cast<double>(load<std::int64_t>(p));
      }
  }
}

void decode_float(const Column& c, FloatPlane& plane) {
  const int w = plane.width();
  if (c.field->type == 'F' && c.field->size == 4) {
    // Bit-exact copy: a NaN payload in the file survives.
    for (int v = 0; v < plane.height(); ++v) {
      const std::uint8_t* src = c.base + static_cast<std::size_t>(v) * w * c.stride;
      float* dst = plane.row(v);
      if (c.stride == sizeof(float)) {
        std::memcpy(dst, src, w * sizeof(float));
      } else {
        for (int u = 0; u < w; ++u) std::memcpy(dst + u, src + u * c.stride, sizeof(float));
      }
    }
    return;
  }
  for (int v = 0; v < plane.height(); ++v) {
    const std::uint8_t* src = c.base + static_cast<std::size_t>(v) * w * c.stride;
    float* dst = plane.row(v);
    for (int u = 0; u < w; ++u) {
      dst[u] = static_cast<float>(load_as_double(*c.field, src + u * c.stride));
    }
  }
}

// The points whose stored x, y and z are finite, moved by `pose` in double from the stored values
// (a double keeps map coordinates that a float cuts to half-metre steps); the others stay as
// decode_float made them.
void decode_in_sensor_frame(const Column& cx, const Column& cy, const Column& cz,
                            const rangeseg::detail::SensorPose& pose, OrganizedCloud& cloud) {
  const int w = cloud.width();
  for (int v = 0; v < cloud.height(); ++v) {
    const std::size_t row = static_cast<std::size_t>(v) * w;
    for (int u = 0; u < w; ++u) {
      const std::size_t i = row + static_cast<std::size_t>(u);
      const Eigen::Vector3d p(load_as_double(*cx.field, cx.base + i * cx.stride),
                              load_as_double(*cy.field, cy.base + i * cy.stride),
                              load_as_double(*cz.field, cz.base + i * cz.stride));
      if (!p.allFinite()) continue;
      const Eigen::Vector3d q = pose.apply(p);
      cloud.x(u, v) = static_cast<float>(q.x());
      cloud.y(u, v) = static_cast<float>(q.y());
      cloud.z(u, v) = static_cast<float>(q.z());
    }
  }
}

void decode_label(const Column& c, LabelImage& plane) {
  const Field& f = *c.field;
  const int w = plane.width();
  for (int v = 0; v < plane.height(); ++v) {
    const std::uint8_t* src = c.base + static_cast<std::size_t>(v) * w * c.stride;
    std::int32_t* dst = plane.row(v);
    for (int u = 0; u < w; ++u) {
      const std::uint8_t* p = src + u * c.stride;
      if (f.type != 'F' && f.size == 4) {
        dst[u] = load<std::int32_t>(p);  // U4 labels keep their bits, so writing U4 round-trips
      } else {
        const double d = load_as_double(f, p);
        const bool in_range = std::isfinite(d) && d >= std::numeric_limits<std::int32_t>::min() &&
                              d <= std::numeric_limits<std::int32_t>::max();
        dst[u] = in_range ? static_cast<std::int32_t>(d) : 0;
      }
    }
  }
}

void decode_rgb(const Column& c, OrganizedCloud& cloud) {
  const int w = cloud.width();
  for (int v = 0; v < cloud.height(); ++v) {
    const std::uint8_t* src = c.base + static_cast<std::size_t>(v) * w * c.stride;
    std::uint8_t* r = cloud.r.row(v);
    std::uint8_t* g = cloud.g.row(v);
    std::uint8_t* b = cloud.b.row(v);
    for (int u = 0; u < w; ++u) {
      const std::uint32_t packed = load<std::uint32_t>(src + u * c.stride);  // 0x(AA|00)RRGGBB
      r[u] = static_cast<std::uint8_t>(packed >> 16);
      g[u] = static_cast<std::uint8_t>(packed >> 8);
      b[u] = static_cast<std::uint8_t>(packed);
    }
  }
}

// Reads one ascii value of field `f` into its binary representation at `out`.
bool parse_ascii_value(std::string_view token, const Field& f, std::uint8_t* out) {
  const char* first = token.data();
  const char* last = first + token.size();
  if (first != last && *first == '+') ++first;  // from_chars rejects an explicit plus sign
  if (f.type == 'F' && f.size == 4 && (f.name == "rgb" || f.name == "rgba") &&
      std::all_of(first, last, [](char c) { return c >= '0' && c <= '9'; })) {
    // PCL writes a packed float rgb as the integer 0x00RRGGBB in ascii files; a float rendering
    // of those bits is a subnormal and always has a '.' or an exponent.
    std::uint32_t packed = 0;
    const auto [end, ec] = std::from_chars(first, last, packed);
    if (ec != std::errc{} || end != last) return false;
    std::memcpy(out, &packed, 4);
    return true;
  }
  if (f.type == 'F') {
    // from_chars accepts "nan", "NaN", "-nan", "inf" (any case) and rounds exactly.
    if (f.size == 4) {
      float value = 0;
      const auto [end, ec] = std::from_chars(first, last, value);
      if (ec != std::errc{} || end != last) return false;
      std::memcpy(out, &value, 4);
    } else {
      double value = 0;
      const auto [end, ec] = std::from_chars(first, last, value);
      if (ec != std::errc{} || end != last) return false;
      std::memcpy(out, &value, 8);
    }
    return true;
  }
  if (f.type == 'U') {
    std::uint64_t value = 0;
    const auto [end, ec] = std::from_chars(first, last, value);
    if (ec != std::errc{} || end != last) return false;
    if (f.size < 8 && value >> (8 * f.size) != 0) return false;
    std::memcpy(out, &value, f.size);  // little-endian: the low bytes
    return true;
  }
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(first, last, value);
  if (ec != std::errc{} || end != last) return false;
  if (f.size < 8) {
    const std::int64_t limit = std::int64_t{1} << (8 * f.size - 1);
    if (value < -limit || value >= limit) return false;
  }
  std::memcpy(out, &value, f.size);
  return true;
}

// Converts the ascii body to the binary (array of structures) layout. Only `wanted` fields are
// parsed; the others are counted and skipped.
std::vector<std::uint8_t> ascii_to_binary(const std::uint8_t* data, std::size_t size,
                                          const Header& h, const std::vector<bool>& wanted,
                                          const std::string& name) {
  const std::size_t begin = h.data_offset;
  // Every value takes at least one character plus a separator, so the file bounds the allocation.
  const std::uint64_t available = size - begin;
  if (h.info.points > (available + 1) / 2 / h.value_count) {
    fail(name, "ascii data of " + std::to_string(available) + " bytes cannot hold " +
                   std::to_string(h.info.points) + " points of " + std::to_string(h.value_count) +
                   " values (truncated file?)");
  }
  std::vector<std::uint8_t> out(h.info.points * h.point_size, 0);
  const char* text = reinterpret_cast<const char*>(data);
  std::size_t pos = begin;
  std::uint64_t point = 0;
  std::size_t line_number = 0;
  while (point < h.info.points) {
    if (pos >= size) {
      fail(name, "ascii data ends after " + std::to_string(point) + " of " +
                     std::to_string(h.info.points) + " points");
    }
    const void* nl = std::memchr(text + pos, '\n', size - pos);
    const std::size_t end = nl ? static_cast<const char*>(nl) - text : size;
    const std::string_view line(text + pos, end - pos);
    pos = nl ? end + 1 : size;
    ++line_number;
    std::uint8_t* dst = out.data() + point * h.point_size;
    std::size_t i = 0;
    std::uint64_t values = 0;
    std::size_t field = 0;
    std::uint64_t within = 0;  // index inside the current field's COUNT
    while (true) {
      while (i < line.size() && is_space(line[i])) ++i;
      if (i >= line.size()) break;
      const std::size_t start = i;
      while (i < line.size() && !is_space(line[i])) ++i;
      const std::string_view token = line.substr(start, i - start);
      if (values >= h.value_count) {
        fail(name, "ascii data line " + std::to_string(line_number) + " (point " +
                       std::to_string(point) + ") has more than " + std::to_string(h.value_count) +
                       " values");
      }
      const Field& f = h.fields[field];
      if (wanted[field] && !parse_ascii_value(token, f, dst + f.offset + within * f.size)) {
        fail(name, "ascii data line " + std::to_string(line_number) + ": bad value " +
                       quoted(token) + " for field " + f.name + " (TYPE " + f.type + " SIZE " +
                       std::to_string(f.size) + ")");
      }
      ++values;
      if (++within == f.count) {
        within = 0;
        ++field;
      }
    }
    if (values == 0) continue;  // blank line
    if (values != h.value_count) {
      fail(name, "ascii data line " + std::to_string(line_number) + " (point " +
                     std::to_string(point) + ") has " + std::to_string(values) +
                     " values, expected " + std::to_string(h.value_count));
    }
    ++point;
  }
  return out;
}

std::vector<std::uint8_t> decompress(const std::uint8_t* data, std::size_t size, const Header& h,
                                     const std::string& name) {
  const std::size_t begin = h.data_offset;
  if (size - begin < 8) fail(name, "binary_compressed data truncated before its size fields");
  const std::uint32_t compressed = load<std::uint32_t>(data + begin);
  const std::uint32_t uncompressed = load<std::uint32_t>(data + begin + 4);
  const std::uint64_t available = size - begin - 8;
  if (compressed > available) {
    fail(name, "compressed size " + std::to_string(compressed) + " is larger than the remaining " +
                   std::to_string(available) + " bytes (truncated file?)");
  }
  if (h.info.points > std::numeric_limits<std::uint32_t>::max() / h.point_size ||
      uncompressed != h.info.points * h.point_size) {
    fail(name, "uncompressed size " + std::to_string(uncompressed) +
                   " does not match POINTS*point size = " + std::to_string(h.info.points) + "*" +
                   std::to_string(h.point_size));
  }
  if (compressed == 0 || uncompressed > std::uint64_t{compressed} * kMaxCompressionRatio) {
    fail(name, "lying header: " + std::to_string(compressed) +
                   " compressed bytes cannot expand to " + std::to_string(uncompressed));
  }
  std::vector<std::uint8_t> out(uncompressed);
  const unsigned produced = lzf_decompress(data + begin + 8, compressed, out.data(), uncompressed);
  if (produced != uncompressed) {
    fail(name, "LZF data decompressed to " + std::to_string(produced) + " bytes, expected " +
                   std::to_string(uncompressed) + " (corrupt data)");
  }
  return out;
}

const Field* used_field(const Header& h, std::string_view field_name, const std::string& name) {
  const Field* f = find_field(h, field_name);
  if (f != nullptr && f->count != 1) {
    fail(name, "field " + f->name + " has COUNT " + std::to_string(f->count) + ", expected 1");
  }
  return f;
}

}  // namespace

OrganizedCloud parse_pcd(const std::uint8_t* data, std::size_t size, const std::string& name,
                         PcdInfo* info, const PcdReadOptions& options) {
  if (data == nullptr && size != 0) throw std::invalid_argument(name + ": parse_pcd: null data");
  if (size == 0) fail(name, "empty file (0 bytes)");
  const Header h = parse_header(data, size, name);

  const Field* fx = used_field(h, "x", name);
  const Field* fy = used_field(h, "y", name);
  const Field* fz = used_field(h, "z", name);
  if (!fx || !fy || !fz) {
    fail(name, "fields x, y and z are required, the file has \"" + h.info.fields_summary + "\"");
  }
  const Field* fintensity = used_field(h, "intensity", name);
  const Field* flabel = used_field(h, "label", name);
  const Field* frgb = nullptr;
  for (const Field& f : h.fields) {
    if (f.name == "rgb" || f.name == "rgba") {
      frgb = used_field(h, f.name, name);
      if (f.size != 4) {
        fail(name, "field " + f.name + " has SIZE " + std::to_string(f.size) + ", expected 4");
      }
      break;
    }
  }
  const Field* used[] = {fx, fy, fz, fintensity, flabel, frgb};

  // Locate the data block; the allocations below are bounded by the file's size.
  std::vector<std::uint8_t> buffer;
  const std::uint8_t* block = nullptr;
  bool soa = false;  // binary_compressed stores all values of field 0, then of field 1, ...
  switch (h.info.encoding) {
    case PcdEncoding::ascii: {
      std::vector<bool> wanted(h.fields.size(), false);
      for (const Field* f : used) {
        if (f) wanted[f - h.fields.data()] = true;
      }
      buffer = ascii_to_binary(data, size, h, wanted, name);
      block = buffer.data();
      break;
    }
    case PcdEncoding::binary: {
      const std::uint64_t available = size - h.data_offset;
      if (h.info.points > available / h.point_size) {
        fail(name,
             "binary data of " + std::to_string(available) +
                 " bytes is shorter than POINTS*point size = " + std::to_string(h.info.points) +
                 "*" + std::to_string(h.point_size) + " (truncated file?)");
      }
      block = data + h.data_offset;
      break;
    }
    case PcdEncoding::binary_compressed:
      buffer = decompress(data, size, h, name);
      block = buffer.data();
      soa = true;
      break;
  }
  // The planes' rows are padded to 16 elements, so a narrow cloud (WIDTH 1) needs up to 16x its
  // data; after a 1000x decompression a small file could still ask for gigabytes.
  const std::uint64_t stride = (static_cast<std::uint64_t>(h.info.width) + 15) / 16 * 16;
  const std::uint64_t pixel_bytes = 3 * sizeof(float) + (fintensity ? sizeof(float) : 0) +
                                    (frgb ? 3 : 0) + (flabel ? sizeof(std::int32_t) : 0);
  const std::uint64_t cells = stride * static_cast<std::uint64_t>(h.info.height);  // < 2^62
  if (cells > kMaxCompressionRatio * size / pixel_bytes) {
    fail(name, "a " + std::to_string(h.info.width) + "x" + std::to_string(h.info.height) +
                   " cloud needs " + std::to_string(cells) + "*" + std::to_string(pixel_bytes) +
                   " bytes, more than a file of " + std::to_string(size) + " bytes can justify");
  }

  auto column = [&](const Field* f) {
    if (soa) {
      return Column{f, block + f->offset * h.info.points, static_cast<std::size_t>(f->bytes())};
    }
    return Column{f, block + f->offset, static_cast<std::size_t>(h.point_size)};
  };

  OrganizedCloud cloud;
  const int w = h.info.width, ht = h.info.height;
  // Every plane is overwritten below; allocate without the NaN fill of OrganizedCloud::resize.
  cloud.x.resize(w, ht);
  cloud.y.resize(w, ht);
  cloud.z.resize(w, ht);
  decode_float(column(fx), cloud.x);
  decode_float(column(fy), cloud.y);
  decode_float(column(fz), cloud.z);
  if (options.to_sensor_frame && h.info.moved_from_sensor()) {
    rangeseg::detail::SensorPose pose;
    try {
      pose = rangeseg::detail::sensor_pose(h.info.viewpoint, "VIEWPOINT");
    } catch (const std::invalid_argument& e) {
      fail(name, e.what());
    }
    decode_in_sensor_frame(column(fx), column(fy), column(fz), pose, cloud);
  }
  if (fintensity) {
    cloud.add_intensity();
    decode_float(column(fintensity), cloud.intensity);
  }
  if (frgb) {
    cloud.add_rgb();
    decode_rgb(column(frgb), cloud);
  }
  if (flabel) {
    cloud.add_label();
    decode_label(column(flabel), cloud.label);
  }
  if (info) {
    *info = h.info;
    const auto is_double = [](const Field* f) { return f->type == 'F' && f->size == 8; };
    info->xyz_double = is_double(fx) && is_double(fy) && is_double(fz);
  }
  return cloud;
}

OrganizedCloud read_pcd(const std::string& path, PcdInfo* info, const PcdReadOptions& options) {
  const std::vector<std::uint8_t> bytes = read_file(path);
  return parse_pcd(bytes.data(), bytes.size(), path, info, options);
}

bool PcdInfo::moved_from_sensor() const {
  const std::array<double, 7> identity{0, 0, 0, 1, 0, 0, 0};
  // q and -q are the same rotation.
  const bool negated_identity =
      viewpoint[3] == -1 && viewpoint[4] == 0 && viewpoint[5] == 0 && viewpoint[6] == 0;
  return viewpoint != identity &&
         !(negated_identity && viewpoint[0] == 0 && viewpoint[1] == 0 && viewpoint[2] == 0);
}

}  // namespace rangeseg::io
