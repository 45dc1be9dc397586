// Stage 2: vertex normals (paper, eq. 2) and curvature from the implicit mesh.
//
// Pass 1 scatters each cell's unnormalised face normals (cross products, i.e. twice the face
// area times the unit normal) into the planes of its corners; pass 2 normalises, orients towards
// the viewpoint and computes the curvature from the 1-ring given by Mesh::edges.
#include "rangeseg/normals.hpp"

#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

namespace rangeseg {
namespace {

struct V3 {
  float x, y, z;
};
inline V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3 cross(V3 a, V3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
// NaN-safe masking: a multiplication by 0 would keep the NaN of a face with invalid corners.
inline V3 select(bool keep, V3 a) {
  return {keep ? a.x : 0.0f, keep ? a.y : 0.0f, keep ? a.z : 0.0f};
}
inline void add(float* nx, float* ny, float* nz, int u, V3 a) {
  nx[u] += a.x;
  ny[u] += a.y;
  nz[u] += a.z;
}

template <bool kQuad>
void scatter_face_normals(const OrganizedCloud& cloud, const Mesh& mesh, NormalMap& out) {
  const int width = cloud.width(), height = cloud.height(), s = mesh.pixel_stride;
  for (int v = 0; v + s < height; v += s) {
    const float* x0 = cloud.x.row(v);
    const float* y0 = cloud.y.row(v);
    const float* z0 = cloud.z.row(v);
    const float* x1 = cloud.x.row(v + s);
    const float* y1 = cloud.y.row(v + s);
    const float* z1 = cloud.z.row(v + s);
    const std::uint8_t* faces = mesh.faces.row(v);
    float* nx0 = out.nx.row(v);
    float* ny0 = out.ny.row(v);
    float* nz0 = out.nz.row(v);
    float* nx1 = out.nx.row(v + s);
    float* ny1 = out.ny.row(v + s);
    float* nz1 = out.nz.row(v + s);
    for (int u = 0; u + s < width; u += s) {
      const std::uint8_t f = faces[u];
      if (f == 0) continue;  // holes come in runs: a well-predicted branch skips them
      const V3 a{x0[u], y0[u], z0[u]}, b{x0[u + s], y0[u + s], z0[u + s]};
      const V3 c{x1[u], y1[u], z1[u]}, d{x1[u + s], y1[u + s], z1[u + s]};
      if constexpr (kQuad) {
        // Quad (a,c,d,b): the cross product of the diagonals is twice its vector area.
        const V3 q = cross(d - a, b - c);
        add(nx0, ny0, nz0, u, q);
        add(nx0, ny0, nz0, u + s, q);
        add(nx1, ny1, nz1, u, q);
        add(nx1, ny1, nz1, u + s, q);
      } else {
        const bool bc = f & face_bits::diag_bc;
        // Diagonal a-d: t0 = (a,d,b), t1 = (a,c,d); diagonal b-c: t0 = (a,c,b), t1 = (b,c,d).
        const V3 x = bc ? c : d;
        const V3 y = bc ? b : a;
        const V3 t0 = select(f & face_bits::tri0, cross(x - a, b - a));
        const V3 t1 = select(f & face_bits::tri1, cross(c - y, d - y));
        const V3 zero{0.0f, 0.0f, 0.0f};
        add(nx0, ny0, nz0, u, t0 + (bc ? zero : t1));
        add(nx0, ny0, nz0, u + s, t0 + (bc ? t1 : zero));
        add(nx1, ny1, nz1, u, t1 + (bc ? t0 : zero));
        add(nx1, ny1, nz1, u + s, t1 + (bc ? zero : t0));
      }
    }
  }
}

}  // namespace

void compute_normals(const OrganizedCloud& cloud, const Mesh& mesh, const NormalSettings& settings,
                     NormalMap& out) {
  require_organized(cloud, "compute_normals");
  const int width = cloud.width(), height = cloud.height(), s = mesh.pixel_stride;
  if (mesh.width() != width || mesh.height() != height || mesh.faces.width() != width ||
      mesh.faces.height() != height || s < 1) {
    throw std::invalid_argument("compute_normals: mesh " + std::to_string(mesh.width()) + "x" +
                                std::to_string(mesh.height()) + " (stride " + std::to_string(s) +
                                ") does not fit the cloud " + std::to_string(width) + "x" +
                                std::to_string(height));
  }
  for (float p : settings.viewpoint) {
    if (!std::isfinite(p)) throw std::invalid_argument("compute_normals: viewpoint must be finite");
  }
  constexpr float nan = std::numeric_limits<float>::quiet_NaN();
  out.nx.resize(width, height, 0.0f);
  out.ny.resize(width, height, 0.0f);
  out.nz.resize(width, height, 0.0f);
  out.curvature.resize(width, height, nan);

  if (mesh.type == MeshType::quad) {
    scatter_face_normals<true>(cloud, mesh, out);
  } else {
    scatter_face_normals<false>(cloud, mesh, out);
  }

  // Ring neighbour offsets in elements (all planes of the cloud share one stride).
  const std::ptrdiff_t stride = cloud.z.stride();
  std::array<std::ptrdiff_t, 8> offset{};
  for (int k = 0; k < 8; ++k) {
    offset[k] = static_cast<std::ptrdiff_t>(s) * (kNeighbourDu[k] + kNeighbourDv[k] * stride);
  }
  const float vx = settings.viewpoint[0], vy = settings.viewpoint[1], vz = settings.viewpoint[2];

  for (int v = 0; v < height; ++v) {
    float* nx = out.nx.row(v);
    float* ny = out.ny.row(v);
    float* nz = out.nz.row(v);
    if (v % s != 0) {
      for (int u = 0; u < width; ++u) nx[u] = ny[u] = nz[u] = nan;
      continue;
    }
    const float* x = cloud.x.row(v);
    const float* y = cloud.y.row(v);
    const float* z = cloud.z.row(v);
    const std::uint8_t* edges = mesh.edges.row(v);
    float* curvature = out.curvature.row(v);
    for (int u = 0; u < width; ++u) {
      // Off-lattice pixels of a lattice row have no faces: their sum is 0 and they become NaN.
      const float len2 = nx[u] * nx[u] + ny[u] * ny[u] + nz[u] * nz[u];
      // len2 == 0 (no face, or only degenerate ones) gives NaN, as documented.
      const float inv = (len2 > 0.0f) ? 1.0f / std::sqrt(len2) : nan;
      float ux = nx[u] * inv, uy = ny[u] * inv, uz = nz[u] * inv;
      const float facing = ux * (vx - x[u]) + uy * (vy - y[u]) + uz * (vz - z[u]);
      const float sign = facing < 0.0f ? -1.0f : 1.0f;
      ux *= sign;
      uy *= sign;
      uz *= sign;
      nx[u] = ux;
      ny[u] = uy;
      nz[u] = uz;
      unsigned ring = edges[u];
      if (ring == 0) continue;
      // 2 |(centroid - p) . n| / mean |q - p|^2 = 2 |sum (q - p) . n| / sum |q - p|^2.
      float along = 0.0f, spread = 0.0f;
      const float px = x[u], py = y[u], pz = z[u];
      while (ring != 0) {
        const std::ptrdiff_t o = offset[std::countr_zero(ring)];
        ring &= ring - 1;
        const float dx = x[u + o] - px, dy = y[u + o] - py, dz = z[u + o] - pz;
        along += dx * ux + dy * uy + dz * uz;
        spread += dx * dx + dy * dy + dz * dz;
      }
      curvature[u] = 2.0f * std::abs(along) / spread;
    }
  }
}

}  // namespace rangeseg
