// Materialising the implicit mesh as an explicit face list.
#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "rangeseg/mesh.hpp"

namespace rangeseg {
namespace {

// Corner order per face byte, corners numbered a = 0, b = 1, c = 2, d = 3; the winding of
// face_bits (counter-clockwise seen from the sensor: with x right and y down, going a -> c -> d
// is down, then right, which turns counter-clockwise on the image as the sensor sees it).
struct CellFaces {
  std::uint8_t count;                  // faces in the cell
  std::array<std::uint8_t, 6> corner;  // up to two triangles (or one quad in the first four)
};

constexpr CellFaces cell_faces(int f) {
  CellFaces out{0, {0, 0, 0, 0, 0, 0}};
  if (f & face_bits::quad) return {1, {0, 2, 3, 1, 0, 0}};
  const bool bc = f & face_bits::diag_bc;
  const std::array<std::uint8_t, 3> t0 =
      bc ? std::array<std::uint8_t, 3>{0, 2, 1} : std::array<std::uint8_t, 3>{0, 3, 1};
  const std::array<std::uint8_t, 3> t1 =
      bc ? std::array<std::uint8_t, 3>{1, 2, 3} : std::array<std::uint8_t, 3>{0, 2, 3};
  int n = 0;
  if (f & face_bits::tri0) {
    for (int k = 0; k < 3; ++k) out.corner[3 * n + k] = t0[k];
    ++n;
  }
  if (f & face_bits::tri1) {
    for (int k = 0; k < 3; ++k) out.corner[3 * n + k] = t1[k];
    ++n;
  }
  out.count = static_cast<std::uint8_t>(n);
  return out;
}

constexpr std::array<CellFaces, 16> make_table() {
  std::array<CellFaces, 16> t{};
  for (int f = 0; f < 16; ++f) t[f] = cell_faces(f);
  return t;
}
constexpr std::array<CellFaces, 16> kCellFaces = make_table();

}  // namespace

void extract_faces(const Mesh& mesh, bool remove_unused_vertices, TriangleList& out) {
  const int width = mesh.width(), height = mesh.height(), s = mesh.pixel_stride;
  if (mesh.faces.width() != width || mesh.faces.height() != height || s < 1) {
    throw std::invalid_argument(
        "extract_faces: inconsistent mesh (faces " + std::to_string(mesh.faces.width()) + "x" +
        std::to_string(mesh.faces.height()) + ", edges " + std::to_string(width) + "x" +
        std::to_string(height) + ", stride " + std::to_string(s) + ")");
  }
  const int per_face = mesh.type == MeshType::quad ? 4 : 3;
  out.vertices_per_face = per_face;
  out.vertex_pixel.clear();
  const std::size_t n_faces = count_faces(mesh);
  const std::size_t n_indices = n_faces * static_cast<std::size_t>(per_face);
  // Every cell writes 6 indices unconditionally and advances by what it really holds; the slack
  // keeps the last write inside the buffer.
  out.indices.resize(n_indices + 6);
  std::int32_t* dst = out.indices.data();

  if (remove_unused_vertices) {
    // A vertex is used iff it has an edge; compact indices follow pixel order, so vertex_pixel
    // is the used pixels in row-major order and a running count per row gives the index.
    std::size_t used = 0;
    for (int v = 0; v < height; v += s) {
      const std::uint8_t* e = mesh.edges.row(v);
      for (int u = 0; u < width; u += s) used += e[u] != 0;
    }
    // One slot of slack: every lattice pixel is written, unused ones are overwritten by the next.
    out.vertex_pixel.resize(used + 1);
    std::int32_t* vp = out.vertex_pixel.data();
    std::int32_t next = 0;
    for (int v = 0; v < height; v += s) {
      const std::uint8_t* e = mesh.edges.row(v);
      const std::int32_t base = v * width;
      for (int u = 0; u < width; u += s) {
        vp[next] = base + u;
        next += e[u] != 0;
      }
    }
    out.vertex_pixel.resize(used);
    // Compact index of the first used vertex of each lattice row, advanced while scanning.
    std::int32_t row_start = 0;
    for (int v = 0; v + s < height; v += s) {
      const std::uint8_t* e0 = mesh.edges.row(v);
      const std::uint8_t* e1 = mesh.edges.row(v + s);
      const std::uint8_t* f = mesh.faces.row(v);
      std::int32_t top = row_start, bottom = row_start;
      for (int u = 0; u < width; u += s) bottom += e0[u] != 0;
      row_start = bottom;
      for (int u = 0; u + s < width; u += s) {
        const CellFaces& cell = kCellFaces[f[u] & 15];
        const std::int32_t a = top, c = bottom;
        const std::array<std::int32_t, 4> idx{a, a + (e0[u] != 0), c, c + (e1[u] != 0)};
        for (int k = 0; k < 6; ++k) dst[k] = idx[cell.corner[k]];
        dst += static_cast<std::ptrdiff_t>(cell.count) * per_face;
        top += e0[u] != 0;
        bottom += e1[u] != 0;
      }
    }
  } else {
    for (int v = 0; v + s < height; v += s) {
      const std::uint8_t* f = mesh.faces.row(v);
      const std::int32_t top = v * width, bottom = (v + s) * width;
      for (int u = 0; u + s < width; u += s) {
        const CellFaces& cell = kCellFaces[f[u] & 15];
        const std::array<std::int32_t, 4> idx{top + u, top + u + s, bottom + u, bottom + u + s};
        for (int k = 0; k < 6; ++k) dst[k] = idx[cell.corner[k]];
        dst += static_cast<std::ptrdiff_t>(cell.count) * per_face;
      }
    }
  }
  out.indices.resize(n_indices);
}

}  // namespace rangeseg
