// PLY: binary little-endian meshes for MeshLab, Open3D, Blender and CloudCompare, and point
// clouds from any PLY writer (Open3D, PCL, CloudCompare, scanner software).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rangeseg/cloud.hpp"
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

/// The encoding of encode_ply, streamed into an io::AtomicFile (never half-written). Throws as
/// encode_ply, and std::runtime_error naming the file when it cannot be written.
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

/// What a PLY file read as a point cloud declared (read_ply_cloud).
struct PlyCloudInfo {
  std::string format;          ///< "ascii", "binary_little_endian" or "binary_big_endian"
  std::string fields_summary;  ///< the vertex properties in file order, e.g. "x y z red green blue"
  std::uint64_t vertices = 0;  ///< the vertex element's count
  int width = 0, height = 0;   ///< the cloud's grid (height 1: unorganized)
  /// How the vertices were put on a grid: "" (unorganized), "range_grid" (a range_grid element
  /// names each pixel's vertex), "rows" (num_cols x num_rows vertices in row order) or
  /// "viewport" (as many vertices as PCL's camera element's viewport has pixels, in row order).
  std::string grid;
  /// The sensor's pose in the points' frame from PCL's camera element (view_px .. and the axes
  /// of its orientation), as PcdInfo::viewpoint: tx ty tz [m], qw qx qy qz; the identity when
  /// the file has none. The reader returns the points as stored.
  std::array<double, 7> viewpoint{0, 0, 0, 1, 0, 0, 0};
  /// The camera element's axes are no rotation matrix (PCL writes one), so `viewpoint` is the
  /// identity although the file names a pose.
  bool viewpoint_ignored = false;
};

/// Reads the vertices of a PLY file as a cloud: format ascii, binary_little_endian or
/// binary_big_endian 1.0; properties of every PLY type (char/int8 ... double/float64) and lists.
/// Vertex properties used: x, y, z (required, metres; double is rounded to float), red, green,
/// blue (or diffuse_red, ...: uchar as is, ushort / 257, float and double 0..1 times 255),
/// intensity (or scalar_intensity; any type, as float) and label (or scalar_label; integral
/// values, uint32 ones above 2^31 - 1 kept as their bits). Of two properties with one meaning
/// the first is used. Other properties (normals, alpha, ...) and other elements (faces) are
/// skipped. The points are unorganized (height 1) unless `obj_info num_cols W` and `obj_info
/// num_rows H` give a grid, as PCL and Stanford range scans write organized clouds: either a
/// `range_grid` element of W x H lists of vertex indices places each vertex on its pixel (pixels
/// with none are NaN; of several, the first), or, without one, the W x H vertices fill a grid of
/// H > 1 rows row by row. Without obj_info, the (first) `camera` element of PCL's writer (its
/// default for organized clouds) gives the grid as `viewportx` x `viewporty` when there are that
/// many vertices. A point is invalid when x, y or z is not finite (doubles beyond float's range
/// become infinite).
/// Throws std::runtime_error naming the file and the problem (a header line, a value, the vertex
/// or grid cell) for malformed input: truncated data, counts the file cannot hold, a grid that
/// does not match the vertices, an unknown type or format; allocates at most a fixed multiple
/// (~30) of the file's size, whatever its header claims.
OrganizedCloud read_ply_cloud(const std::string& path, PlyCloudInfo* info = nullptr);

/// read_ply_cloud on bytes in memory; `name` is used in error messages.
OrganizedCloud decode_ply_cloud(const std::uint8_t* data, std::size_t size, const std::string& name,
                                PlyCloudInfo* info = nullptr);

/// Encodes a cloud as a binary_little_endian PLY that PCL, Open3D, CloudCompare and MeshLab read:
/// `float x y z`, then `float intensity`, `uchar red green blue` and `uint label` (PCL's type,
/// holding the label's int32 bits) when the cloud has them. An organized cloud is written as PCL
/// writes one: `obj_info num_cols` / `num_rows`, its valid points only, and a `range_grid` element
/// placing each on its pixel; an unorganized one keeps every point, valid or not, in order. A
/// `viewpoint` other than the identity (tx ty tz [m], qw qx qy qz, as PlyCloudInfo::viewpoint) is
/// written as PCL's camera element. read_ply_cloud gives the cloud back, its valid points bit-exact
/// and its invalid pixels as NaN, and the viewpoint to float precision. Throws
/// std::invalid_argument for a viewpoint with a non-finite value or a quaternion of norm below
/// 1e-6, or a cloud whose planes differ in size.
std::vector<std::uint8_t> encode_ply_cloud(const OrganizedCloud& cloud,
                                           const std::array<double, 7>& viewpoint = {0, 0, 0, 1, 0,
                                                                                     0, 0});

/// The encoding of encode_ply_cloud written atomically (never half-written). Throws as
/// encode_ply_cloud, and std::runtime_error naming the file when it cannot be written.
void write_ply_cloud(const std::string& path, const OrganizedCloud& cloud,
                     const std::array<double, 7>& viewpoint = {0, 0, 0, 1, 0, 0, 0});

}  // namespace rangeseg::io
