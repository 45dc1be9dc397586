#include <lzf.h>

#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "detail/number_text.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/pcd.hpp"

static_assert(std::endian::native == std::endian::little, "PCD binary data is little-endian");

namespace rangeseg::io {
namespace {

// One 4-byte output field; `row(v)` gives the 4-byte values of row v.
struct OutField {
  std::string name;
  char type;  // 'F' or 'U'
  const std::uint8_t* data;
  std::ptrdiff_t row_bytes;  // stride of the source plane in bytes
  const std::uint8_t* row(int v) const { return data + v * row_bytes; }
};

template <class T>
OutField plane_field(std::string name, char type, const Plane<T>& plane) {
  static_assert(sizeof(T) == 4);
  return {std::move(name), type, reinterpret_cast<const std::uint8_t*>(plane.row(0)),
          plane.stride() * static_cast<std::ptrdiff_t>(sizeof(T))};
}

template <class T>
void require_size(const Plane<T>& plane, const OrganizedCloud& cloud, const std::string& what) {
  if (plane.width() != cloud.width() || plane.height() != cloud.height()) {
    throw std::invalid_argument(
        "encode_pcd: plane " + what + " is " + std::to_string(plane.width()) + "x" +
        std::to_string(plane.height()) + ", the cloud is " + std::to_string(cloud.width()) + "x" +
        std::to_string(cloud.height()));
  }
}

void append(std::vector<std::uint8_t>& out, const std::string& text) {
  out.insert(out.end(), text.begin(), text.end());
}

const char* encoding_name(PcdEncoding e) {
  switch (e) {
    case PcdEncoding::ascii:
      return "ascii";
    case PcdEncoding::binary:
      return "binary";
    case PcdEncoding::binary_compressed:
      return "binary_compressed";
  }
  throw std::invalid_argument("encode_pcd: unknown encoding " +
                              std::to_string(static_cast<int>(e)));
}

}  // namespace

std::vector<std::uint8_t> encode_pcd(const OrganizedCloud& cloud, const PcdWriteOptions& options) {
  // The cloud's own planes; the extra fields are checked below.
  require_consistent(cloud, "encode_pcd");
  if (cloud.empty()) throw std::invalid_argument("encode_pcd: the cloud has no points");
  const int w = cloud.width(), h = cloud.height();

  // Packed colour, as PCL stores it: the float whose bits are 0x00RRGGBB.
  std::vector<std::uint32_t> packed;
  std::vector<OutField> fields = {plane_field("x", 'F', cloud.x), plane_field("y", 'F', cloud.y),
                                  plane_field("z", 'F', cloud.z)};
  if (cloud.has_intensity()) {
    fields.push_back(plane_field("intensity", 'F', cloud.intensity));
  }
  if (cloud.has_rgb()) {
    packed.resize(cloud.size());
    for (int v = 0; v < h; ++v) {
      const std::uint8_t *r = cloud.r.row(v), *g = cloud.g.row(v), *b = cloud.b.row(v);
      std::uint32_t* dst = packed.data() + static_cast<std::size_t>(v) * w;
      for (int u = 0; u < w; ++u) {
        dst[u] = std::uint32_t{r[u]} << 16 | std::uint32_t{g[u]} << 8 | b[u];
      }
    }
    fields.push_back({"rgb", 'F', reinterpret_cast<const std::uint8_t*>(packed.data()),
                      static_cast<std::ptrdiff_t>(w) * 4});
  }
  if (cloud.has_label()) {
    fields.push_back(plane_field("label", 'U', cloud.label));
  }
  for (const auto& [name, plane] : options.extra_float_fields) {
    if (plane == nullptr) {
      throw std::invalid_argument("encode_pcd: extra field " + name + " has no plane");
    }
    if (name.empty() || name.find_first_of(" \t\r\n") != std::string::npos) {
      throw std::invalid_argument("encode_pcd: extra field name '" + name +
                                  "' is empty or has whitespace");
    }
    for (const OutField& f : fields) {
      if (f.name == name) throw std::invalid_argument("encode_pcd: field " + name + " given twice");
    }
    require_size(*plane, cloud, name);
    fields.push_back(plane_field(name, 'F', *plane));
  }

  const std::size_t n = cloud.size();
  const std::size_t nf = fields.size();
  // The comment names the writer: the command line removes only result files it recognises.
  std::string header =
      "# .PCD v0.7 - Point Cloud Data file format, written by rangeseg\nVERSION 0.7\nFIELDS";
  for (const OutField& f : fields) header += " " + f.name;
  header += "\nSIZE";
  for (std::size_t i = 0; i < nf; ++i) header += " 4";
  header += "\nTYPE";
  for (const OutField& f : fields) {
    // In text, PCL writes (and reads) the packed colour as the integer 0x00RRGGBB, typed U: a
    // reader that took the integer text of a TYPE F field as a float would get another colour.
    const bool text_rgb = options.encoding == PcdEncoding::ascii && f.name == "rgb";
    header += std::string(" ") + (text_rgb ? 'U' : f.type);
  }
  header += "\nCOUNT";
  for (std::size_t i = 0; i < nf; ++i) header += " 1";
  header += "\nWIDTH " + std::to_string(w) + "\nHEIGHT " + std::to_string(h) + "\nVIEWPOINT";
  for (const double v : options.viewpoint) {
    if (!std::isfinite(v)) {
      throw std::invalid_argument("encode_pcd: VIEWPOINT values must be finite, got " +
                                  rangeseg::detail::number_text(v));
    }
    // Shortest text that reads back to the same double.
    char text[32];
    const auto [end, ec] = std::to_chars(text, text + sizeof text, v);
    header += ' ';
    header.append(text, end);
  }
  header += "\nPOINTS " + std::to_string(n) + "\nDATA " + encoding_name(options.encoding) + "\n";

  std::vector<std::uint8_t> out;
  append(out, header);
  const std::size_t header_size = out.size();
  switch (options.encoding) {
    case PcdEncoding::binary: {
      out.resize(header_size + n * nf * 4);
      std::uint8_t* dst = out.data() + header_size;
      for (int v = 0; v < h; ++v) {
        for (int u = 0; u < w; ++u) {
          for (const OutField& f : fields) {
            std::memcpy(dst, f.row(v) + static_cast<std::ptrdiff_t>(u) * 4, 4);
            dst += 4;
          }
        }
      }
      break;
    }
    case PcdEncoding::binary_compressed: {
      const std::size_t raw_size = n * nf * 4;
      if (raw_size > std::numeric_limits<std::uint32_t>::max() / 2) {
        throw std::invalid_argument("encode_pcd: cloud too large for binary_compressed (" +
                                    std::to_string(raw_size) + " bytes)");
      }
      // Structure of arrays, field after field, compressed a field at a time: LZF streams
      // concatenate (a back-reference never reaches before its own block's output), so the
      // blocks decode as one, and no frame-sized copy of the points is made. The output is
      // reserved, not filled, so that only its written pages become resident.
      const std::size_t field_size = n * 4;
      const std::size_t block_capacity = field_size + field_size / 16 + 64;  // LZF: < 104 %
      std::vector<std::uint8_t> field(field_size), block(block_capacity);
      out.reserve(header_size + 8 + raw_size + raw_size / 16 + 64);
      out.resize(header_size + 8);
      for (const OutField& f : fields) {
        std::uint8_t* dst = field.data();
        for (int v = 0; v < h; ++v) {
          std::memcpy(dst, f.row(v), static_cast<std::size_t>(w) * 4);
          dst += static_cast<std::size_t>(w) * 4;
        }
        const unsigned compressed =
            lzf_compress(field.data(), static_cast<unsigned>(field_size), block.data(),
                         static_cast<unsigned>(block_capacity));
        if (compressed == 0) throw std::runtime_error("encode_pcd: LZF compression failed");
        out.insert(out.end(), block.begin(), block.begin() + compressed);
      }
      const std::uint32_t sizes[2] = {static_cast<std::uint32_t>(out.size() - header_size - 8),
                                      static_cast<std::uint32_t>(raw_size)};
      std::memcpy(out.data() + header_size, sizes, 8);
      break;
    }
    case PcdEncoding::ascii: {
      out.reserve(header_size + n * nf * 12);
      char buf[32];
      for (int v = 0; v < h; ++v) {
        for (int u = 0; u < w; ++u) {
          for (std::size_t i = 0; i < nf; ++i) {
            const OutField& f = fields[i];
            const std::uint8_t* p = f.row(v) + static_cast<std::ptrdiff_t>(u) * 4;
            std::to_chars_result r;
            if (f.type == 'U' || f.name == "rgb") {
              // Integers for label, and for rgb as PCL does (its float rendering is a subnormal).
              std::uint32_t value;
              std::memcpy(&value, p, 4);
              r = std::to_chars(buf, buf + sizeof buf, value);
            } else {
              // Shortest representation that reads back to the same float; NaN prints as "nan".
              float value;
              std::memcpy(&value, p, 4);
              r = std::to_chars(buf, buf + sizeof buf, value);
            }
            out.insert(out.end(), buf, r.ptr);
            out.push_back(i + 1 < nf ? ' ' : '\n');
          }
        }
      }
      break;
    }
  }
  return out;
}

void write_pcd(const std::string& path, const OrganizedCloud& cloud,
               const PcdWriteOptions& options) {
  write_file_atomic(path, encode_pcd(cloud, options));
}

}  // namespace rangeseg::io
