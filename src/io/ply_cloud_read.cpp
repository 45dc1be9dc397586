// PLY point clouds from any writer: the header's elements and properties, ASCII and binary data
// of either byte order, and the grid of organized clouds (PCL's and Stanford's range_grid).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_set>
#include <utility>
#include <vector>

#include "detail/number_text.hpp"
#include "quoted.hpp"
#include "rangeseg/io/ply.hpp"

namespace rangeseg::io {
namespace {

enum class Type : std::uint8_t { i8, u8, i16, u16, i32, u32, f32, f64 };

constexpr int kTypeSize[] = {1, 1, 2, 2, 4, 4, 4, 8};
int size_of(Type type) { return kTypeSize[static_cast<int>(type)]; }
bool is_integer(Type type) { return type != Type::f32 && type != Type::f64; }

std::optional<Type> type_named(std::string_view name) {
  static constexpr std::pair<std::string_view, Type> kNames[] = {
      {"char", Type::i8},   {"int8", Type::i8},     {"uchar", Type::u8},   {"uint8", Type::u8},
      {"short", Type::i16}, {"int16", Type::i16},   {"ushort", Type::u16}, {"uint16", Type::u16},
      {"int", Type::i32},   {"int32", Type::i32},   {"uint", Type::u32},   {"uint32", Type::u32},
      {"float", Type::f32}, {"float32", Type::f32}, {"double", Type::f64}, {"float64", Type::f64}};
  for (const auto& [text, type] : kNames) {
    if (text == name) return type;
  }
  return std::nullopt;
}

struct Property {
  std::string name;
  Type type = Type::f32;  ///< of the value, or of a list's items
  bool list = false;
  Type count_type = Type::u8;
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

enum class Format { ascii, little_endian, big_endian };

struct Header {
  Format format = Format::ascii;
  std::string format_name;
  std::vector<Element> elements;
  std::int64_t num_cols = -1, num_rows = -1;  ///< obj_info lines, -1 when absent
  std::size_t data_start = 0;
};

[[noreturn]] void fail(const std::string& name, const std::string& why) {
  throw std::runtime_error("PLY '" + name + "': " + why);
}

using detail::quoted;

std::vector<std::string_view> words(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

std::uint64_t header_count(std::string_view token, std::string_view line, const std::string& name) {
  std::uint64_t value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc{} || end != token.data() + token.size()) {
    fail(name, "expected a count in " + quoted(line));
  }
  return value;
}

Type header_type(std::string_view token, std::string_view line, const std::string& name) {
  const std::optional<Type> type = type_named(token);
  if (!type) fail(name, "unknown property type " + quoted(token) + " in " + quoted(line));
  return *type;
}

void add_property(Header& h, std::unordered_set<std::string>& names,
                  const std::vector<std::string_view>& w, std::string_view line,
                  const std::string& name) {
  if (h.elements.empty()) fail(name, "property before any element: " + quoted(line));
  Property p;
  if (w.size() == 5 && w[1] == "list") {
    p.list = true;
    p.count_type = header_type(w[2], line, name);
    if (!is_integer(p.count_type)) fail(name, "list count of a float type: " + quoted(line));
    p.type = header_type(w[3], line, name);
    p.name = w[4];
  } else if (w.size() == 3 && w[1] != "list") {
    p.type = header_type(w[1], line, name);
    p.name = w[2];
  } else {
    fail(name, "malformed property line " + quoted(line));
  }
  if (!names.insert(p.name).second) {
    fail(name, "property " + quoted(p.name) + " declared twice");
  }
  h.elements.back().properties.push_back(std::move(p));
}

Header parse_header(const std::uint8_t* data, std::size_t size, const std::string& name) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const std::size_t first_eol = text.find('\n');
  if (text.empty()) fail(name, "the file is empty");
  if (!text.starts_with("ply") || first_eol == std::string_view::npos ||
      text.substr(3, first_eol - 3).find_first_not_of(" \t\r") != std::string_view::npos) {
    fail(name, "not a PLY file (the first line is not \"ply\")");
  }
  Header h;
  std::unordered_set<std::string> names;  // of the current element's properties
  bool have_format = false;
  std::size_t pos = text.find('\n') + 1;
  for (;;) {
    // The last line may end without a newline (a file of a header alone).
    if (pos >= text.size()) fail(name, "the header ends without end_header");
    const std::size_t eol = std::min(text.find('\n', pos), text.size());
    std::string_view line = text.substr(pos, eol - pos);
    pos = std::min(eol + 1, text.size());
    if (line.ends_with('\r')) line.remove_suffix(1);
    const std::vector<std::string_view> w = words(line);
    if (w.empty() || w[0] == "comment") continue;
    if (w[0] == "end_header") break;
    if (w[0] == "format") {
      if (w.size() != 3 || w[2] != "1.0") fail(name, "unsupported format line " + quoted(line));
      if (w[1] == "ascii") {
        h.format = Format::ascii;
      } else if (w[1] == "binary_little_endian") {
        h.format = Format::little_endian;
      } else if (w[1] == "binary_big_endian") {
        h.format = Format::big_endian;
      } else {
        fail(name, "unsupported format line " + quoted(line));
      }
      h.format_name = w[1];
      have_format = true;
    } else if (w[0] == "obj_info") {
      if (w.size() == 3 && (w[1] == "num_cols" || w[1] == "num_rows")) {
        const std::uint64_t value = header_count(w[2], line, name);
        if (value > static_cast<std::uint64_t>(std::numeric_limits<int>::max())) {
          fail(name, "grid size too large in " + quoted(line));
        }
        (w[1] == "num_cols" ? h.num_cols : h.num_rows) = static_cast<std::int64_t>(value);
      }
    } else if (w[0] == "element") {
      if (w.size() != 3) fail(name, "malformed element line " + quoted(line));
      h.elements.push_back({std::string(w[1]), header_count(w[2], line, name), {}});
      names.clear();
    } else if (w[0] == "property") {
      add_property(h, names, w, line, name);
    } else {
      fail(name, "unknown header line " + quoted(line));
    }
  }
  if (!have_format) fail(name, "the header has no format line");
  h.data_start = pos;
  return h;
}

// Reads the values of the data section in file order, for either format.
class DataReader {
 public:
  DataReader(const std::uint8_t* data, std::size_t size, std::size_t pos, Format format,
             const std::string& name)
      : data_(data), size_(size), pos_(pos), format_(format), name_(name) {}

  std::size_t remaining() const { return size_ - pos_; }
  /// The element being read, for error messages.
  void at(const std::string& element) { element_ = &element; }

  double value(Type type) {
    if (format_ == Format::ascii) return ascii_value(type);
    const int n = size_of(type);
    if (remaining() < static_cast<std::size_t>(n)) fail(name_, "the data ends early" + where());
    std::uint8_t bytes[8];
    std::memcpy(bytes, data_ + pos_, n);
    pos_ += n;
    if ((format_ == Format::big_endian) == (std::endian::native == std::endian::little)) {
      std::reverse(bytes, bytes + n);
    }
    return decode(type, bytes);
  }

  // In ASCII each instance is one line: values left on it mean the header's properties are not
  // the data's (which would silently shift every later value).
  void end_instance() {
    if (format_ != Format::ascii) return;
    const char* text = reinterpret_cast<const char*>(data_);
    while (pos_ < size_ && (text[pos_] == ' ' || text[pos_] == '\t' || text[pos_] == '\r')) ++pos_;
    if (pos_ < size_ && text[pos_] != '\n') {
      fail(name_, "more values on a line than its element's properties" + where());
    }
  }

  std::uint64_t list_count(Type type) {
    const double v = value(type);
    if (!(v >= 0)) fail(name_, "negative list count " + rangeseg::detail::number_text(v) + where());
    return static_cast<std::uint64_t>(v);
  }

  // Skips `count` instances of an element, without reading values where their size is known.
  void skip(const Element& e) {
    const bool scalars = std::none_of(e.properties.begin(), e.properties.end(),
                                      [](const Property& p) { return p.list; });
    if (e.properties.empty() || e.count == 0) return;
    if (scalars && format_ != Format::ascii) {
      std::uint64_t stride = 0;
      for (const Property& p : e.properties) stride += size_of(p.type);
      if (e.count > remaining() / stride) {
        fail(name_, "truncated: element " + quoted(e.name) + " needs " + std::to_string(e.count) +
                        " x " + std::to_string(stride) + " bytes, " + std::to_string(remaining()) +
                        " left");
      }
      pos_ += e.count * stride;
      return;
    }
    for (std::uint64_t i = 0; i < e.count; ++i) {
      for (const Property& p : e.properties) {
        if (p.list) {
          skip_list(p);
        } else {
          value(p.type);
        }
      }
      end_instance();
    }
  }

  // Skips one value of a list property.
  void skip_list(const Property& p) {
    const std::uint64_t n = list_count(p.count_type);
    if (format_ == Format::ascii) {
      for (std::uint64_t k = 0; k < n; ++k) value(p.type);
      return;
    }
    const std::uint64_t bytes = n * size_of(p.type);
    if (bytes > remaining()) fail(name_, "the data ends early" + where());
    pos_ += bytes;
  }

 private:
  static double decode(Type type, const std::uint8_t* b) {
    switch (type) {
      case Type::i8:
        return static_cast<std::int8_t>(b[0]);
      case Type::u8:
        return b[0];
      case Type::i16:
        return load<std::int16_t>(b);
      case Type::u16:
        return load<std::uint16_t>(b);
      case Type::i32:
        return load<std::int32_t>(b);
      case Type::u32:
        return load<std::uint32_t>(b);
      case Type::f32:
        return load<float>(b);
      case Type::f64:
        return load<double>(b);
    }
    return 0;
  }

  template <class T>
  static T load(const std::uint8_t* bytes) {
    T v;
    std::memcpy(&v, bytes, sizeof v);
    return v;
  }

  double ascii_value(Type type) {
    const char* text = reinterpret_cast<const char*>(data_);
    const auto space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
    while (pos_ < size_ && space(text[pos_])) ++pos_;
    const std::size_t start = pos_;
    while (pos_ < size_ && !space(text[pos_])) ++pos_;
    if (pos_ == start) fail(name_, "the data ends early" + where());
    std::string_view token(text + start, pos_ - start);
    // from_chars takes no '+' sign, which some writers put on positive numbers.
    if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
    double v = 0;
    if (is_integer(type)) {
      std::int64_t i = 0;
      const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), i);
      if (ec != std::errc{} || end != token.data() + token.size()) {
        fail(name_, "expected an integer, got " + quoted(token) + where());
      }
      v = static_cast<double>(i);
      if (!fits(type, i)) fail(name_, quoted(token) + " is out of its type's range" + where());
    } else {
      const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), v);
      if (ec != std::errc{} || end != token.data() + token.size()) {
        fail(name_, "expected a number, got " + quoted(token) + where());
      }
    }
    return v;
  }

  static bool fits(Type type, std::int64_t v) {
    switch (type) {
      case Type::i8:
        return v >= -128 && v <= 127;
      case Type::u8:
        return v >= 0 && v <= 255;
      case Type::i16:
        return v >= -32768 && v <= 32767;
      case Type::u16:
        return v >= 0 && v <= 65535;
      case Type::i32:
        return v >= std::numeric_limits<std::int32_t>::min() && v <= 0x7fffffff;
      case Type::u32:
        return v >= 0 && v <= 0xffffffffLL;
      default:
        return true;
    }
  }

  // The element, and the line of a text file (counted only for the message) or the byte.
  std::string where() const {
    std::string at;
    if (format_ == Format::ascii) {
      const std::size_t end = std::min(pos_, size_);
      at = "line " + std::to_string(std::count(data_, data_ + end, '\n') + 1);
    } else {
      at = "byte " + std::to_string(pos_);
    }
    return " (" + at + (element_ == nullptr ? "" : ", element " + quoted(*element_)) + ")";
  }

  const std::uint8_t* data_;
  std::size_t size_, pos_;
  const std::string* element_ = nullptr;
  Format format_;
  const std::string& name_;
};

enum class Role : std::uint8_t { skip, x, y, z, red, green, blue, intensity, label };

Role role_of(std::string_view property) {
  std::string lower(property);
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (lower == "x") return Role::x;
  if (lower == "y") return Role::y;
  if (lower == "z") return Role::z;
  if (lower == "red" || lower == "diffuse_red") return Role::red;
  if (lower == "green" || lower == "diffuse_green") return Role::green;
  if (lower == "blue" || lower == "diffuse_blue") return Role::blue;
  if (lower == "intensity" || lower == "scalar_intensity") return Role::intensity;
  if (lower == "label" || lower == "scalar_label") return Role::label;
  return Role::skip;
}

std::vector<Role> vertex_roles(const Element& vertex, const std::string& name) {
  std::vector<Role> roles;
  bool seen[9] = {};
  for (const Property& p : vertex.properties) {
    Role role = role_of(p.name);
    // Of two with one meaning (red and diffuse_red, label and scalar_label) the first counts.
    if (role != Role::skip && seen[static_cast<int>(role)]) role = Role::skip;
    seen[static_cast<int>(role)] = true;
    if (role != Role::skip && p.list) {
      fail(name, "vertex property " + quoted(p.name) + " is a list");
    }
    const bool colour = role == Role::red || role == Role::green || role == Role::blue;
    if (colour && p.type != Type::u8 && p.type != Type::u16 && is_integer(p.type)) {
      fail(name, "colour property " + quoted(p.name) + " must be uchar, ushort, float or double");
    }
    roles.push_back(role);
  }
  if (!seen[1] || !seen[2] || !seen[3]) fail(name, "the vertex element has no x, y and z");
  if (seen[4] != seen[5] || seen[4] != seen[6]) {
    fail(name, "the vertex colour needs all of red, green and blue");
  }
  return roles;
}

// Doubles beyond float's range become infinite (an invalid point), which a plain cast leaves
// undefined.
float to_float(double v) {
  if (std::fabs(v) > std::numeric_limits<float>::max()) {
    return v > 0 ? std::numeric_limits<float>::infinity() : -std::numeric_limits<float>::infinity();
  }
  return static_cast<float>(v);
}

std::uint8_t colour_byte(Type type, double v) {
  if (type == Type::u8) return static_cast<std::uint8_t>(v);
  const double scaled = type == Type::u16 ? v / 257.0 : v * 255.0;
  if (!(scaled > 0)) return 0;  // NaN too
  return static_cast<std::uint8_t>(std::lround(std::min(scaled, 255.0)));
}

// Reads the vertex element into an unorganized cloud of `vertex.count` points.
OrganizedCloud read_vertices(DataReader& in, const Element& vertex, const Format format,
                             const std::string& name) {
  const std::vector<Role> roles = vertex_roles(vertex, name);
  const std::uint64_t n = vertex.count;
  if (n > static_cast<std::uint64_t>(std::numeric_limits<int>::max())) {
    fail(name, std::to_string(n) + " vertices are too many");
  }
  // Every vertex takes at least its scalars' bytes (binary) or a character and a separator per
  // value (ASCII): a count the file cannot hold is rejected before anything is allocated.
  std::uint64_t least = 0;
  for (const Property& p : vertex.properties) {
    least += format == Format::ascii ? 2 : (p.list ? size_of(p.count_type) : size_of(p.type));
  }
  if (n > (in.remaining() + 1) / least) {
    fail(name, "truncated: " + std::to_string(n) + " vertices cannot fit in the " +
                   std::to_string(in.remaining()) + " bytes left");
  }
  OrganizedCloud cloud(static_cast<int>(n), n > 0 ? 1 : 0);
  const auto has = [&](Role r) { return std::find(roles.begin(), roles.end(), r) != roles.end(); };
  if (has(Role::red)) cloud.add_rgb();
  if (has(Role::intensity)) cloud.add_intensity();
  if (has(Role::label)) cloud.add_label();
  for (int i = 0; i < static_cast<int>(n); ++i) {
    for (std::size_t k = 0; k < roles.size(); ++k) {
      const Property& p = vertex.properties[k];
      if (p.list) {
        in.skip_list(p);
        continue;
      }
      const double v = in.value(p.type);
      switch (roles[k]) {
        case Role::skip:
          break;
        case Role::x:
          cloud.x(i, 0) = to_float(v);
          break;
        case Role::y:
          cloud.y(i, 0) = to_float(v);
          break;
        case Role::z:
          cloud.z(i, 0) = to_float(v);
          break;
        case Role::red:
          cloud.r(i, 0) = colour_byte(p.type, v);
          break;
        case Role::green:
          cloud.g(i, 0) = colour_byte(p.type, v);
          break;
        case Role::blue:
          cloud.b(i, 0) = colour_byte(p.type, v);
          break;
        case Role::intensity:
          cloud.intensity(i, 0) = to_float(v);
          break;
        case Role::label:
          // PCL's labels are uint32: values above 2^31 - 1 keep their bits, as in a PCD.
          if (!(v == std::floor(v) && v >= std::numeric_limits<std::int32_t>::min() &&
                v <= std::numeric_limits<std::uint32_t>::max())) {
            fail(name, "vertex " + std::to_string(i) + ": label " +
                           rangeseg::detail::number_text(v) + " is not an int32 or uint32 value");
          }
          cloud.label(i, 0) = v < 0 ? static_cast<std::int32_t>(v)
                                    : std::bit_cast<std::int32_t>(static_cast<std::uint32_t>(v));
          break;
      }
    }
    in.end_instance();
  }
  return cloud;
}

// The range_grid's vertex per pixel (-1: none).
std::vector<std::int32_t> read_range_grid(DataReader& in, const Element& grid, Format format,
                                          std::uint64_t vertices, const std::string& name) {
  if (grid.properties.size() != 1 || !grid.properties[0].list ||
      !is_integer(grid.properties[0].type)) {
    fail(name, "the range_grid element must have one list of vertex indices");
  }
  const Property& p = grid.properties[0];
  const std::uint64_t least = format == Format::ascii ? 2 : size_of(p.count_type);
  if (grid.count > (in.remaining() + 1) / least) {
    fail(name, "truncated: " + std::to_string(grid.count) + " range_grid cells cannot fit in the " +
                   std::to_string(in.remaining()) + " bytes left");
  }
  std::vector<std::int32_t> pixel_vertex(grid.count, -1);
  std::vector<bool> placed(vertices, false);
  for (std::uint64_t c = 0; c < grid.count; ++c) {
    const std::uint64_t n = in.list_count(p.count_type);
    for (std::uint64_t k = 0; k < n; ++k) {
      const double index = in.value(p.type);
      if (!(index >= 0 && index < static_cast<double>(vertices))) {
        fail(name, "range_grid cell " + std::to_string(c) + " names vertex " +
                       std::to_string(static_cast<long long>(index)) +
                       (vertices == 0 ? ", but there are no vertices"
                                      : ", outside 0.." + std::to_string(vertices - 1)));
      }
      // A cell with several vertices (merged scans) keeps its first; a vertex on two pixels is
      // a broken grid.
      const auto v = static_cast<std::size_t>(index);
      if (placed[v]) {
        fail(name, "range_grid cell " + std::to_string(c) + " names vertex " + std::to_string(v) +
                       ", which an earlier cell holds");
      }
      placed[v] = true;
      if (k == 0) pixel_vertex[c] = static_cast<std::int32_t>(index);
    }
    in.end_instance();
  }
  return pixel_vertex;
}

// PCL's `camera` element (PLYWriter with use_camera, its default): the sensor's pose, and the
// viewport, which is the grid of an organized cloud written in row order.
struct CameraElement {
  std::int64_t viewport_x = 0, viewport_y = 0;
  bool pose_ignored = false;                        ///< the file has axes that are no rotation
  std::array<double, 7> pose{0, 0, 0, 1, 0, 0, 0};  ///< tx ty tz qw qx qy qz
};

CameraElement read_camera(DataReader& in, const Element& camera) {
  static constexpr std::string_view kPose[] = {"view_px", "view_py", "view_pz", "x_axisx",
                                               "x_axisy", "x_axisz", "y_axisx", "y_axisy",
                                               "y_axisz", "z_axisx", "z_axisy", "z_axisz"};
  double pose[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  CameraElement c;
  for (const Property& p : camera.properties) {
    if (p.list) {
      in.skip_list(p);
      continue;
    }
    const double v = in.value(p.type);
    const bool size = v >= 0 && v <= std::numeric_limits<int>::max() && v == std::floor(v);
    if (p.name == "viewportx" && size) c.viewport_x = static_cast<std::int64_t>(v);
    if (p.name == "viewporty" && size) c.viewport_y = static_cast<std::int64_t>(v);
    for (int k = 0; k < 12; ++k) {
      if (p.name == kPose[k]) pose[k] = v;
    }
  }
  // The axes are the rows of the orientation's rotation matrix; anything but a rotation (a
  // writer that leaves them zero) is no pose.
  Eigen::Matrix3d r;
  r << pose[3], pose[4], pose[5], pose[6], pose[7], pose[8], pose[9], pose[10], pose[11];
  const Eigen::Vector3d t(pose[0], pose[1], pose[2]);
  if (t.allFinite() && r.allFinite() &&
      (r * r.transpose() - Eigen::Matrix3d::Identity()).norm() < 1e-4 && r.determinant() > 0) {
    Eigen::Quaterniond q(r);
    if (q.w() < 0) q.coeffs() = -q.coeffs();
    c.pose = {t.x(), t.y(), t.z(), q.w(), q.x(), q.y(), q.z()};
  } else {
    c.pose_ignored = true;
  }
  return c;
}

// Puts the unorganized `points` on a width x height grid: pixel i gets point source(i), or none.
template <class Source>
OrganizedCloud on_grid(const OrganizedCloud& points, int width, int height, Source source) {
  OrganizedCloud grid(width, height);
  if (points.has_rgb()) grid.add_rgb();
  if (points.has_intensity()) grid.add_intensity();
  if (points.has_label()) grid.add_label();
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const std::int64_t i = source(static_cast<std::int64_t>(v) * width + u);
      if (i < 0) continue;
      const int s = static_cast<int>(i);
      grid.x(u, v) = points.x(s, 0), grid.y(u, v) = points.y(s, 0), grid.z(u, v) = points.z(s, 0);
      if (points.has_rgb()) {
        grid.r(u, v) = points.r(s, 0), grid.g(u, v) = points.g(s, 0), grid.b(u, v) = points.b(s, 0);
      }
      if (points.has_intensity()) grid.intensity(u, v) = points.intensity(s, 0);
      if (points.has_label()) grid.label(u, v) = points.label(s, 0);
    }
  }
  return grid;
}

}  // namespace

OrganizedCloud decode_ply_cloud(const std::uint8_t* data, std::size_t size, const std::string& name,
                                PlyCloudInfo* info) {
  const Header h = parse_header(data, size, name);
  const auto find = [&](std::string_view element) -> const Element* {
    const Element* found = nullptr;
    for (const Element& e : h.elements) {
      if (e.name != element) continue;
      if (found != nullptr) fail(name, "two " + quoted(element) + " elements");
      found = &e;
    }
    return found;
  };
  const Element* vertex = find("vertex");
  if (vertex == nullptr) fail(name, "no vertex element");
  const Element* grid = find("range_grid");
  const bool organized = h.num_cols > 0 && h.num_rows > 0 && (h.num_rows > 1 || grid != nullptr);
  if (grid != nullptr && !organized) {
    fail(name, "a range_grid element without obj_info num_cols and num_rows");
  }
  const std::uint64_t pixels = organized ? static_cast<std::uint64_t>(h.num_cols) * h.num_rows : 0;
  if (organized && pixels > static_cast<std::uint64_t>(std::numeric_limits<int>::max())) {
    fail(name, "grid of " + std::to_string(h.num_cols) + " x " + std::to_string(h.num_rows) +
                   " pixels is too large");
  }
  if (grid != nullptr && grid->count != pixels) {
    fail(name, "range_grid has " + std::to_string(grid->count) + " cells for a grid of " +
                   std::to_string(h.num_cols) + " x " + std::to_string(h.num_rows));
  }
  if (organized && grid == nullptr && vertex->count != pixels) {
    fail(name, "obj_info num_cols x num_rows is " + std::to_string(h.num_cols) + " x " +
                   std::to_string(h.num_rows) + " but there are " + std::to_string(vertex->count) +
                   " vertices and no range_grid element");
  }

  // PCL's default writer puts no grid in obj_info but a camera element with the sensor's pose
  // and a viewport that is the grid; its points, invalid ones too, are in row order.
  const Element* camera = find("camera");
  if (camera != nullptr && camera->count == 0) camera = nullptr;

  DataReader in(data, size, h.data_start, h.format, name);
  OrganizedCloud points;
  std::vector<std::int32_t> pixel_vertex;
  CameraElement sensor;
  int needed = 1 + (grid != nullptr) + (camera != nullptr);
  for (const Element& e : h.elements) {
    if (needed == 0) break;  // what follows (faces, ...) is not needed
    in.at(e.name);
    if (&e == vertex) {
      points = read_vertices(in, e, h.format, name);
    } else if (&e == grid) {
      pixel_vertex = read_range_grid(in, e, h.format, vertex->count, name);
    } else if (&e == camera) {
      sensor = read_camera(in, e);
      in.end_instance();
      if (e.count > 1) in.skip({e.name, e.count - 1, e.properties});  // one camera is the sensor
    } else {
      in.skip(e);
      continue;
    }
    --needed;
  }
  const bool by_viewport =
      !organized && sensor.viewport_x > 0 && sensor.viewport_y > 1 &&
      static_cast<std::uint64_t>(sensor.viewport_x * sensor.viewport_y) == vertex->count;

  if (info != nullptr) {
    info->format = h.format_name;
    info->fields_summary.clear();
    for (const Property& p : vertex->properties) {
      info->fields_summary += (info->fields_summary.empty() ? "" : " ") + p.name;
    }
    info->vertices = vertex->count;
    info->viewpoint = sensor.pose;
    info->viewpoint_ignored = sensor.pose_ignored;
    info->grid = grid != nullptr ? "range_grid"
                 : organized     ? "rows"
                 : by_viewport   ? "viewport"
                                 : "";
  }
  if (organized || by_viewport) {
    const int w = static_cast<int>(organized ? h.num_cols : sensor.viewport_x);
    const int hgt = static_cast<int>(organized ? h.num_rows : sensor.viewport_y);
    points = grid != nullptr
                 ? on_grid(points, w, hgt, [&](std::int64_t i) { return pixel_vertex[i]; })
                 : on_grid(points, w, hgt, [](std::int64_t i) { return i; });
  }
  if (info != nullptr) info->width = points.width(), info->height = points.height();
  return points;
}

OrganizedCloud read_ply_cloud(const std::string& path, PlyCloudInfo* info) {
  const std::vector<std::uint8_t> bytes = read_file(path);
  return decode_ply_cloud(bytes.data(), bytes.size(), path, info);
}

}  // namespace rangeseg::io
