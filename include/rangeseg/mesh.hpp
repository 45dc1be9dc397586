// Stage 1 of Holz & Behnke: an approximate triangle mesh read straight off the pixel grid.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"
#include "rangeseg/sensor.hpp"

namespace rangeseg {

/// How each grid quad (u,v),(u+1,v),(u,v+1),(u+1,v+1) is turned into faces (paper, Fig. 2).
enum class MeshType : std::uint8_t {
  quad,       ///< one quad face per cell
  left_cut,   ///< two triangles, cut from top right to bottom left
  right_cut,  ///< two triangles, cut from top left to bottom right
  adaptive,   ///< two triangles, cut along the shorter diagonal
};

/// The mesh type of a name: "adaptive", "quad", "left" (left_cut) or "right" (right_cut). Throws
/// std::invalid_argument naming the valid types for any other name.
MeshType mesh_type_from_string(std::string_view name);
/// The name of a mesh type, as mesh_type_from_string takes it.
const char* to_string(MeshType type);

/// Settings of mesh construction (paper, eq. 1). Edge (p_i, p_j) is valid when both points are
/// valid (finite), the edge is not within eps_theta of the viewing ray through p_i,
///   |cos angle(p_j - p_i, p_i - viewpoint)| <= cos(eps_theta),
/// unless the range difference is explained by sensor noise (then the angle test is skipped),
///   |r_i - r_j| <= jump_sigmas * sqrt(sigma(r_i)^2 + sigma(r_j)^2),
/// and its length is at most
///   eps_d(r) = max_edge_a + max_edge_b * pixel_stride * r + max_edge_c * r^2,
/// with r the larger distance of the two points from the viewpoint (the range; it equals the
/// depth z on the optical axis of a depth camera and stays meaningful for 360-degree laser scans
/// whose z axis is not the viewing direction).
///
/// Why these defaults (a Kinect / PrimeSense, f ~ 525 px, noise sigma(z) ~ 0.0012 + 0.0019
/// (z - 0.4)^2 m after Nguyen et al. 2012):
/// - eps_theta 12.5 deg (the paper's and PCL's value): an edge between two neighbouring pixels
///   spans ~ s r / f laterally, so it is cut when the depth step exceeds ~4.5 s r / f, i.e.
///   depth jumps of more than ~9 mm at 1 m and ~34 mm at 4 m. Surfaces seen at more than ~77
///   degrees from their normal are cut too; on the Kinect frames in ../shared/data 0.2-5 % of
///   neighbour pairs at 0.5-2 m fall below 12.5 deg (mostly true depth jumps, < 5 deg), up to
///   ~11 % on a steep floor at 1.5-2.5 m (between 7.5 and 12.5 deg).
/// - max_edge_b 0.012 per pixel of stride: an edge on a surface inclined by up to the
///   77.5 degrees the angle test admits is 1/sin(12.5 deg) = 4.6 times its lateral span, a
///   diagonal sqrt(2) more: 6.5 / 525 ~ 0.012.
/// - max_edge_a 0.006 m and max_edge_c 0.008 / m: depth noise of the two ends, 3 sqrt(2) sigma(z)
///   = 0.005 + 0.008 (z - 0.4)^2 <= 0.0063 + 0.008 z^2 (z > 0).
/// - jump_sigmas 3 with the sensor's noise model `noise` (sigma evaluated at the range r): the
///   angle test alone reads ordinary depth noise as occlusions beyond ~2 m (a neighbour step of
///   ~4.5 s r / f = 34 mm at 4 m is below the 1.4 sigma = 36 mm of the difference of two Kinect
///   depths there, plus disparity quantisation steps of z^2 / (8 b f) = 5 cm), so a third of the
///   edges of a fronto-parallel plane at 4 m were cut. The gate keeps steps up to
///   3 sqrt(2) sigma(z): 8 mm at 1 m, 26 mm at 2 m, 60 mm at 3 m, 110 mm at 4 m (which also
///   covers two quantisation steps); 0.3 % of noise-only steps exceed it. Depth jumps smaller
///   than that are not cut: they cannot be told from noise edge by edge. jump_sigmas = 0
///   disables the gate (the paper's pure angle test).
/// This gives eps_d = 0.026 m at 1 m, 0.062 m at 2 m, 0.37 m at 6 m (stride 1): smooth Kinect
/// surfaces stay connected (99 % of neighbour distances are < 5 r / f at 0.5-1.5 m). Depth jumps
/// are cut mainly by the angle test: an edge that passes it is at most sqrt(2) s r / (f sin
/// eps_theta) long, so with these defaults the length test only adds the noise margin's worth
/// and matters for data whose lateral spacing differs from the camera model (laser scans,
/// another viewpoint) or when eps_theta is lowered. Large values disable it.
///
/// MeshType::adaptive cuts along the shorter diagonal, except when the other diagonal yields
/// more triangles (one or more edges invalid): then that one is used, so a cell with one
/// invalid corner or edge always keeps the triangle that avoids it.
struct MeshSettings {
  MeshType type = MeshType::adaptive;  ///< triangulation of each cell (default adaptive)
  float eps_theta = 0.2182f;           ///< min angle between edge and viewing ray [rad] (12.5 deg)
  float max_edge_a = 0.006f;           ///< eps_d constant term [m]
  float max_edge_b = 0.012f;           ///< eps_d linear term [m per m of range per pixel of stride]
  float max_edge_c = 0.008f;           ///< eps_d quadratic term [1/m]
  std::array<float, 3> viewpoint{0.0f, 0.0f, 0.0f};  ///< sensor origin [m], camera frame
  int pixel_stride = 1;  ///< mesh every k-th pixel in u and v [pixels] (1 = full resolution)
  SensorNoise noise{};   ///< axial noise sigma(range) of the sensor [m] (default: the Kinect's)
  /// range steps up to this many sigma of the difference are noise (dimensionless, default 3;
  /// 0 = off)
  float jump_sigmas = 3.0f;
};

/// Bits of `Mesh::faces` for the cell whose top-left pixel is (u, v); corners
/// a = (u,v), b = (u+s,v), c = (u,v+s), d = (u+s,v+s) with s = pixel_stride.
namespace face_bits {
constexpr std::uint8_t tri0 = 1;     ///< diagonal a-d: (a,d,b); diagonal b-c: (a,c,b)
constexpr std::uint8_t tri1 = 2;     ///< diagonal a-d: (a,c,d); diagonal b-c: (b,c,d)
constexpr std::uint8_t quad = 4;     ///< quad face (a,c,d,b) (MeshType::quad only)
constexpr std::uint8_t diag_bc = 8;  ///< set: the cell is cut along b-c, else along a-d
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

/// Throws std::invalid_argument naming the field and its value for settings build_mesh rejects
/// (an unknown type, eps_theta outside [0, pi/2], negative or non-finite bounds, pixel_stride
/// below 1).
void validate(const MeshSettings& settings);
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
