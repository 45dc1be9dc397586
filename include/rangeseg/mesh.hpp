// Stage 1 of Holz & Behnke: an approximate triangle mesh read straight off the pixel grid.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"

namespace rangeseg {

/// How each grid quad (u,v),(u+1,v),(u,v+1),(u+1,v+1) is turned into faces (paper, Fig. 2).
enum class MeshType : std::uint8_t {
  quad,       ///< one quad face per cell
  left_cut,   ///< two triangles, cut from top right to bottom left
  right_cut,  ///< two triangles, cut from top left to bottom right
  adaptive,   ///< two triangles, cut along the shorter diagonal
};

/// Settings of mesh construction (paper, eq. 1). Edge (p_i, p_j) is valid when both points are
/// valid, the edge is not within eps_theta of the viewing ray through p_i, and its length is at
/// most eps_d(z) = max_edge_a + max_edge_b z + max_edge_c z^2 with z the larger depth of the two
/// points (sensor noise, and the spacing of neighbouring pixels, grow with depth).
struct MeshSettings {
  MeshType type = MeshType::adaptive;
  float eps_theta = 0.2182f;    ///< min angle between edge and viewing ray [rad] (12.5 deg)
  float max_edge_a = 0.0f;      ///< eps_d constant term [m]
  float max_edge_b = 0.0f;      ///< eps_d linear term [m per m]
  float max_edge_c = 0.02f;     ///< eps_d quadratic term [1/m]
  std::array<float, 3> viewpoint{0.0f, 0.0f, 0.0f};  ///< sensor origin [m], camera frame
  int pixel_stride = 1;         ///< mesh every k-th pixel in u and v (1 = full resolution)
};

/// Bits of `Mesh::faces` for the cell whose top-left pixel is (u, v); corners
/// a = (u,v), b = (u+s,v), c = (u,v+s), d = (u+s,v+s) with s = pixel_stride.
namespace face_bits {
constexpr std::uint8_t tri0 = 1;      ///< diagonal a-d: (a,d,b); diagonal b-c: (a,c,b)
constexpr std::uint8_t tri1 = 2;      ///< diagonal a-d: (a,c,d); diagonal b-c: (b,c,d)
constexpr std::uint8_t quad = 4;      ///< quad face (a,c,d,b) (MeshType::quad only)
constexpr std::uint8_t diag_bc = 8;   ///< set: the cell is cut along b-c, else along a-d
}  // namespace face_bits

/// The 8 neighbour directions of `Mesh::edges`, bit k set when the edge from pixel (u,v) to
/// pixel (u + s*kNeighbourDu[k], v + s*kNeighbourDv[k]) belongs to at least one face.
/// Order: right, down-right, down, down-left, left, up-left, up, up-right.
inline constexpr std::array<int, 8> kNeighbourDu{1, 1, 0, -1, -1, -1, 0, 1};
inline constexpr std::array<int, 8> kNeighbourDv{0, 1, 1, 1, 0, -1, -1, -1};

/// The implicit mesh: per-pixel bit masks on the input grid, so that every later stage reads a
/// pixel's 1-ring without searching. Both planes have the size of the cloud; only pixels on the
/// stride lattice (u % s == 0 and v % s == 0) are vertices.
struct Mesh {
  MeshType type = MeshType::adaptive;
  int pixel_stride = 1;
  BytePlane faces;  ///< face_bits per cell, indexed by the cell's top-left pixel
  BytePlane edges;  ///< 1-ring mask per vertex (bit k: neighbour kNeighbourDu/Dv[k])

  int width() const { return edges.width(); }
  int height() const { return edges.height(); }
};

/// Builds the implicit mesh of an organized cloud into `mesh`, reusing its buffers.
/// Throws std::invalid_argument for an unorganized cloud or invalid settings.
void build_mesh(const OrganizedCloud& cloud, const MeshSettings& settings, Mesh& mesh);
inline Mesh build_mesh(const OrganizedCloud& cloud, const MeshSettings& settings = {}) {
  Mesh mesh;
  build_mesh(cloud, settings, mesh);
  return mesh;
}

/// Number of faces (triangles, or quads for MeshType::quad).
std::size_t count_faces(const Mesh& mesh);

/// An explicit face list: `indices` holds `vertices_per_face` int32 vertex indices per face.
/// Without compaction a vertex index is the pixel index v * width + u; with compaction vertices
/// unused by any face are removed and `vertex_pixel[i]` gives the pixel index of vertex i.
/// Faces are ordered so that, seen from the viewpoint, their corners run counter-clockwise
/// (the right-handed normal points towards the sensor).
struct TriangleList {
  int vertices_per_face = 3;
  std::vector<std::int32_t> indices;
  std::vector<std::int32_t> vertex_pixel;  ///< filled only when compacted
};

/// Materialises the faces of `mesh`, reusing `out`'s buffers.
void extract_faces(const Mesh& mesh, bool remove_unused_vertices, TriangleList& out);

}  // namespace rangeseg
