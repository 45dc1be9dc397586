#include "rangeseg/io/ply.hpp"

#include <bit>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "little_endian.hpp"
#include "rangeseg/io/file.hpp"

namespace rangeseg::io {
namespace {

using detail::append_le;

void validate(const PlyMesh& mesh) {
  const auto bad = [](const std::string& why) { return std::invalid_argument("PLY mesh: " + why); };
  if (mesh.xyz.size() % 3 != 0) {
    throw bad("xyz has " + std::to_string(mesh.xyz.size()) + " floats, not a multiple of 3");
  }
  const std::size_t n = mesh.vertex_count();
  if (n > 0x7fffffffu) throw bad("too many vertices for int indices: " + std::to_string(n));
  if (!mesh.normals.empty() && mesh.normals.size() != 3 * n) {
    throw bad("normals has " + std::to_string(mesh.normals.size()) + " floats, expected 0 or " +
              std::to_string(3 * n));
  }
  if (!mesh.rgb.empty() && mesh.rgb.size() != 3 * n) {
    throw bad("rgb has " + std::to_string(mesh.rgb.size()) + " bytes, expected 0 or " +
              std::to_string(3 * n));
  }
  if (mesh.vertices_per_face < 3 || mesh.vertices_per_face > 255) {
    throw bad("vertices_per_face = " + std::to_string(mesh.vertices_per_face) +
              ", expected 3..255");
  }
  if (mesh.faces.size() % static_cast<std::size_t>(mesh.vertices_per_face) != 0) {
    throw bad("faces has " + std::to_string(mesh.faces.size()) + " indices, not a multiple of " +
              std::to_string(mesh.vertices_per_face));
  }
  for (std::size_t i = 0; i < mesh.faces.size(); ++i) {
    const std::int32_t index = mesh.faces[i];
    if (index < 0 || static_cast<std::size_t>(index) >= n) {
      throw bad("face " + std::to_string(i / mesh.vertices_per_face) + " has vertex index " +
                std::to_string(index) + ", outside 0.." + std::to_string(n) + "-1");
    }
  }
}

}  // namespace

namespace {

std::string header_text(const PlyLayout& layout) {
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment written by rangeseg\n"
         << "element vertex " << layout.vertices << "\n"
         << "property float x\nproperty float y\nproperty float z\n";
  if (layout.normals) header << "property float nx\nproperty float ny\nproperty float nz\n";
  if (layout.rgb) header << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  header << "element face " << layout.faces << "\n"
         << "property list uchar int vertex_indices\nend_header\n";
  return header.str();
}

PlyLayout layout_of(const PlyMesh& mesh) {
  const std::size_t n = mesh.vertex_count();
  return {.vertices = n,
          .faces = mesh.face_count(),
          .vertices_per_face = mesh.vertices_per_face,
          .normals = !mesh.normals.empty() && n > 0,
          .rgb = !mesh.rgb.empty() && n > 0};
}

void append_vertex(std::vector<std::uint8_t>& out, const PlyLayout& layout, const float* xyz,
                   const float* normal, const std::uint8_t* rgb) {
  for (int k = 0; k < 3; ++k) append_le(out, xyz[k]);
  if (layout.normals) {
    for (int k = 0; k < 3; ++k) append_le(out, normal[k]);
  }
  if (layout.rgb) out.insert(out.end(), rgb, rgb + 3);
}

void append_face(std::vector<std::uint8_t>& out, const PlyLayout& layout,
                 const std::int32_t* indices) {
  out.push_back(static_cast<std::uint8_t>(layout.vertices_per_face));
  for (int k = 0; k < layout.vertices_per_face; ++k) append_le(out, indices[k]);
}

constexpr std::size_t kChunk = std::size_t{1} << 20;

}  // namespace

std::vector<std::uint8_t> encode_ply(const PlyMesh& mesh) {
  validate(mesh);
  const PlyLayout layout = layout_of(mesh);
  const std::string text = header_text(layout);
  std::vector<std::uint8_t> bytes(text.begin(), text.end());
  for (std::size_t i = 0; i < layout.vertices; ++i) {
    append_vertex(bytes, layout, &mesh.xyz[3 * i], layout.normals ? &mesh.normals[3 * i] : nullptr,
                  layout.rgb ? &mesh.rgb[3 * i] : nullptr);
  }
  const auto m = static_cast<std::size_t>(layout.vertices_per_face);
  for (std::size_t f = 0; f < layout.faces; ++f) append_face(bytes, layout, &mesh.faces[f * m]);
  return bytes;
}

void write_ply(const std::string& path, const PlyMesh& mesh) {
  try {
    validate(mesh);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("writing '" + path + "': " + e.what());
  }
  const PlyLayout layout = layout_of(mesh);
  PlyWriter writer(path, layout);
  for (std::size_t i = 0; i < layout.vertices; ++i) {
    writer.vertex(&mesh.xyz[3 * i], layout.normals ? &mesh.normals[3 * i] : nullptr,
                  layout.rgb ? &mesh.rgb[3 * i] : nullptr);
  }
  const auto m = static_cast<std::size_t>(layout.vertices_per_face);
  for (std::size_t f = 0; f < layout.faces; ++f) writer.face(&mesh.faces[f * m]);
  writer.commit();
}

namespace {

PlyLayout checked(const std::string& path, const PlyLayout& layout) {
  if (layout.vertices_per_face < 3 || layout.vertices_per_face > 255 ||
      layout.vertices > 0x7fffffffu) {
    throw std::invalid_argument("writing '" + path + "': PLY layout with " +
                                std::to_string(layout.vertices) + " vertices and " +
                                std::to_string(layout.vertices_per_face) +
                                " vertices per face (expected at most 2^31 - 1 and 3..255)");
  }
  return layout;
}

}  // namespace

PlyWriter::PlyWriter(const std::string& path, const PlyLayout& layout)
    : path_(path), layout_(checked(path, layout)), file_(path) {
  const std::string text = header_text(layout_);
  buffer_.reserve(kChunk + 1024);
  buffer_.assign(text.begin(), text.end());
}

void PlyWriter::vertex(const float* xyz, const float* normal, const std::uint8_t* rgb) {
  if (vertices_ == layout_.vertices || faces_ > 0 || (layout_.normals && normal == nullptr) ||
      (layout_.rgb && rgb == nullptr)) {
    throw std::invalid_argument("writing '" + path_ + "': vertex " + std::to_string(vertices_) +
                                " is beyond the layout's " + std::to_string(layout_.vertices) +
                                ", after a face, or lacks the normal or colour the layout has");
  }
  append_vertex(buffer_, layout_, xyz, normal, rgb);
  ++vertices_;
  flush_if_full();
}

void PlyWriter::face(const std::int32_t* indices) {
  if (faces_ == layout_.faces || vertices_ != layout_.vertices) {
    throw std::invalid_argument("writing '" + path_ + "': face " + std::to_string(faces_) +
                                " is beyond the layout's " + std::to_string(layout_.faces) +
                                " or comes before all " + std::to_string(layout_.vertices) +
                                " vertices");
  }
  for (int k = 0; k < layout_.vertices_per_face; ++k) {
    if (indices[k] < 0 || static_cast<std::size_t>(indices[k]) >= layout_.vertices) {
      throw std::invalid_argument("writing '" + path_ + "': face " + std::to_string(faces_) +
                                  " has vertex index " + std::to_string(indices[k]) +
                                  ", outside 0.." + std::to_string(layout_.vertices) + "-1");
    }
  }
  append_face(buffer_, layout_, indices);
  ++faces_;
  flush_if_full();
}

void PlyWriter::commit() {
  if (vertices_ != layout_.vertices || faces_ != layout_.faces) {
    throw std::logic_error("writing '" + path_ + "': " + std::to_string(vertices_) + " of " +
                           std::to_string(layout_.vertices) + " vertices and " +
                           std::to_string(faces_) + " of " + std::to_string(layout_.faces) +
                           " faces written");
  }
  if (!buffer_.empty()) file_.write(buffer_.data(), buffer_.size());
  buffer_.clear();
  file_.commit();
}

void PlyWriter::flush_if_full() {
  if (buffer_.size() >= kChunk) {
    file_.write(buffer_.data(), buffer_.size());
    buffer_.clear();
  }
}

PlyMesh decode_ply(const std::uint8_t* data, std::size_t size, const std::string& name) {
  const auto fail = [&](const std::string& why) {
    return std::runtime_error("PLY '" + name + "': " + why);
  };
  std::size_t pos = 0;
  const auto next_line = [&]() {
    std::string line;
    while (true) {
      if (pos >= size) throw fail("header ends without end_header");
      const char ch = static_cast<char>(data[pos++]);
      if (ch == '\n') break;
      if (line.size() > 4096) throw fail("header line longer than 4096 characters");
      line.push_back(ch);
    }
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return line;
  };
  if (size < 4 || std::memcmp(data, "ply", 3) != 0 || (data[3] != '\n' && data[3] != '\r')) {
    throw fail("not a PLY file (first line is not \"ply\")");
  }
  next_line();

  enum class Section { none, vertex, face, other } section = Section::none;
  std::uint64_t vertices = 0, faces = 0;
  bool seen_vertex = false, seen_face = false;
  std::vector<std::string> vertex_properties;
  bool face_list_ok = false;
  for (;;) {
    const std::string line = next_line();
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "end_header") break;
    if (keyword.empty() || keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "format") {
      std::string format, version;
      words >> format >> version;
      if (format != "binary_little_endian" || version != "1.0") {
        throw fail("unsupported format line \"" + line + "\" (only binary_little_endian 1.0)");
      }
    } else if (keyword == "element") {
      std::string element;
      std::uint64_t count = 0;
      if (!(words >> element >> count)) throw fail("bad element line \"" + line + "\"");
      if (element == "vertex" && !seen_vertex && !seen_face) {
        section = Section::vertex, vertices = count, seen_vertex = true;
      } else if (element == "face" && seen_vertex && !seen_face) {
        section = Section::face, faces = count, seen_face = true;
      } else {
        throw fail("unsupported element line \"" + line + "\" (expected vertex, then face)");
      }
    } else if (keyword == "property") {
      std::string type;
      words >> type;
      if (section == Section::vertex) {
        std::string property;
        words >> property;
        type += ' ';
        type += property;
        vertex_properties.push_back(type);
      } else if (section == Section::face) {
        std::string count_type, index_type, property;
        words >> count_type >> index_type >> property;
        if (type != "list" || count_type != "uchar" ||
            (index_type != "int" && index_type != "int32") || property != "vertex_indices" ||
            face_list_ok) {
          throw fail("unsupported face property \"" + line +
                     "\" (only one 'property list uchar int vertex_indices')");
        }
        face_list_ok = true;
      } else {
        throw fail("property outside an element: \"" + line + "\"");
      }
    } else {
      throw fail("unsupported header line \"" + line + "\"");
    }
  }
  if (!seen_vertex) throw fail("no vertex element");

  bool has_normals = false, has_rgb = false;
  {
    const std::vector<std::string> base = {"float x", "float y", "float z"};
    const std::vector<std::string> normals = {"float nx", "float ny", "float nz"};
    const std::vector<std::string> colours = {"uchar red", "uchar green", "uchar blue"};
    std::size_t i = 0;
    const auto take = [&](const std::vector<std::string>& group) {
      if (vertex_properties.size() < i + 3) return false;
      for (std::size_t k = 0; k < 3; ++k) {
        if (vertex_properties[i + k] != group[k]) return false;
      }
      i += 3;
      return true;
    };
    if (!take(base)) throw fail("vertex properties must start with float x, y, z");
    has_normals = take(normals);
    has_rgb = take(colours);
    if (i != vertex_properties.size()) {
      throw fail("unsupported vertex property \"" + vertex_properties[i] + "\"");
    }
  }
  if (seen_face && !face_list_ok) throw fail("face element without vertex_indices list");

  const std::uint64_t vertex_bytes = 12 + (has_normals ? 12 : 0) + (has_rgb ? 3 : 0);
  const std::uint64_t remaining = size - pos;
  if (vertices > remaining / vertex_bytes) {
    throw fail("truncated: " + std::to_string(vertices) + " vertices need " +
               std::to_string(vertices * vertex_bytes) + " bytes, " + std::to_string(remaining) +
               " left");
  }
  if (faces > remaining / 4) {  // every face needs at least its count byte and 3 ints
    throw fail("truncated: " + std::to_string(faces) + " faces cannot fit in " +
               std::to_string(remaining) + " bytes");
  }

  PlyMesh mesh;
  mesh.xyz.resize(3 * vertices);
  if (has_normals) mesh.normals.resize(3 * vertices);
  if (has_rgb) mesh.rgb.resize(3 * vertices);
  for (std::uint64_t i = 0; i < vertices; ++i) {
    std::memcpy(&mesh.xyz[3 * i], data + pos, 12);
    pos += 12;
    if (has_normals) {
      std::memcpy(&mesh.normals[3 * i], data + pos, 12);
      pos += 12;
    }
    if (has_rgb) {
      std::memcpy(&mesh.rgb[3 * i], data + pos, 3);
      pos += 3;
    }
  }
  for (std::uint64_t f = 0; f < faces; ++f) {
    if (pos >= size) throw fail("truncated in face " + std::to_string(f));
    const int count = data[pos++];
    if (f == 0) {
      if (count < 3) throw fail("face 0 has " + std::to_string(count) + " vertices");
      mesh.vertices_per_face = count;
      mesh.faces.reserve(faces * count);
    } else if (count != mesh.vertices_per_face) {
      throw fail("face " + std::to_string(f) + " has " + std::to_string(count) +
                 " vertices, face 0 has " + std::to_string(mesh.vertices_per_face) +
                 " (mixed polygon sizes are not supported)");
    }
    if (size - pos < 4 * static_cast<std::size_t>(count)) {
      throw fail("truncated in face " + std::to_string(f));
    }
    for (int k = 0; k < count; ++k) {
      std::int32_t index = 0;
      std::memcpy(&index, data + pos, 4);
      pos += 4;
      if (index < 0 || static_cast<std::uint64_t>(index) >= vertices) {
        throw fail("face " + std::to_string(f) + " has vertex index " + std::to_string(index) +
                   ", outside 0.." + std::to_string(vertices) + "-1");
      }
      mesh.faces.push_back(index);
    }
  }
  return mesh;
}

PlyMesh read_ply(const std::string& path) {
  const std::vector<std::uint8_t> bytes = read_file(path);
  return decode_ply(bytes.data(), bytes.size(), path);
}

}  // namespace rangeseg::io
