// Binary little-endian PLY meshes for MeshLab, Open3D, Blender and CloudCompare.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rangeseg/io/file.hpp"

namespace rangeseg::io {

/// A polygon mesh as flat arrays. Vertex positions in metres.
struct PlyMesh {
  std::vector<float> xyz;           ///< 3 per vertex
  std::vector<float> normals;       ///< empty or 3 per vertex (unit vectors)
  std::vector<std::uint8_t> rgb;    ///< empty or 3 per vertex (0..255)
  std::vector<std::int32_t> faces;  ///< vertices_per_face vertex indices per face
  int vertices_per_face = 3;        ///< 3 for triangles, 4 for quads, ...

  std::size_t vertex_count() const { return xyz.size() / 3; }
  std::size_t face_count() const {
    return vertices_per_face > 0 ? faces.size() / static_cast<std::size_t>(vertices_per_face) : 0;
  }
};

/// Encodes a binary_little_endian 1.0 PLY: `element vertex` with `float x y z`, then
/// `float nx ny nz` and `uchar red green blue` when present, and `element face` with
/// `property list uchar int vertex_indices`. Throws std::invalid_argument (with the sizes or
/// the offending face and index) if xyz.size() is not a multiple of 3, normals/rgb are neither
/// empty nor 3 per vertex, vertices_per_face is outside 3..255, faces.size() is not a multiple
/// of it, or an index is outside 0..vertex_count-1.
std::vector<std::uint8_t> encode_ply(const PlyMesh& mesh);

/// The encoding of encode_ply, streamed into an io::AtomicFile (never half-written).
void write_ply(const std::string& path, const PlyMesh& mesh);

/// What a PLY written element by element holds (PlyWriter).
struct PlyLayout {
  std::size_t vertices = 0;
  std::size_t faces = 0;
  int vertices_per_face = 3;  ///< 3..255
  bool normals = false;       ///< float nx ny nz per vertex
  bool rgb = false;           ///< uchar red green blue per vertex
};

/// Writes the encoding of encode_ply vertex by vertex, then face by face, in chunks of ~1 MB
/// into an io::AtomicFile: for meshes whose vertices live elsewhere (e.g. in a cloud's planes),
/// which would otherwise be copied into a PlyMesh first. commit() renames the file into place
/// once every vertex and face of the layout is written; destroyed without it (e.g. by an
/// exception), the writer leaves no file behind. Throws std::invalid_argument for a layout
/// encode_ply would reject, a missing normal or colour the layout has, an element beyond the
/// layout's counts or a face index outside 0..vertices-1, and std::logic_error from commit() when
/// elements are missing; file errors throw std::runtime_error naming the file.
class PlyWriter {
 public:
  PlyWriter(const std::string& path, const PlyLayout& layout);
  void vertex(const float* xyz, const float* normal = nullptr, const std::uint8_t* rgb = nullptr);
  void face(const std::int32_t* indices);
  void commit();

 private:
  void flush_if_full();

  std::string path_;
  PlyLayout layout_;
  AtomicFile file_;
  std::vector<std::uint8_t> buffer_;
  std::size_t vertices_ = 0, faces_ = 0;
};

/// Reads a PLY of exactly the layout encode_ply writes (binary_little_endian; vertex x y z as
/// float with optional nx ny nz float and red green blue uchar; faces as list uchar int, all
/// with the same vertex count; comments and obj_info lines ignored). Anything else (ASCII or
/// big-endian files, other properties or types) throws std::runtime_error naming the file and
/// the offending header line, as do truncated data and out-of-range indices.
PlyMesh read_ply(const std::string& path);

/// read_ply on bytes in memory; `name` is used in error messages.
PlyMesh decode_ply(const std::uint8_t* data, std::size_t size, const std::string& name);

}  // namespace rangeseg::io
