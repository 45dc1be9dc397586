// Stage 2: vertex normals (paper, eq. 2) and curvature from the implicit mesh.
//
// One sweep over the lattice rows with small row buffers (structure of arrays, branch-free, so
// that every loop vectorises): per cell row, the unnormalised face normals (cross products, i.e.
// twice the face area times the unit normal) each cell adds to its four corners; per vertex row,
// the sum over the <= 4 cells around each vertex, normalised and oriented towards the viewpoint,
// and the curvature from the 1-ring given by Mesh::edges (a 0/1 select per ring neighbour).
#include "rangeseg/normals.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "detail/vectorize.hpp"

namespace rangeseg {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Branch-free selection with all-ones / all-zero masks on the float bits. Conditional
// expressions on floats are not enough: GCC sinks the (possibly trapping) float math into the
// taken branch and then cannot vectorise the loop.
inline std::uint32_t mask_of(std::uint32_t bit01) { return 0u - bit01; }
inline float keep(float x, std::uint32_t mask) {
  return std::bit_cast<float>(std::bit_cast<std::uint32_t>(x) & mask);
}
inline float pick(std::uint32_t mask, float a, float b) {
  return std::bit_cast<float>((std::bit_cast<std::uint32_t>(a) & mask) |
                              (std::bit_cast<std::uint32_t>(b) & ~mask));
}

// out[i] = 1 / sqrt(len2[i]) for len2 > 0, else NaN. A separate pass: with errno-setting math
// GCC neither vectorises std::sqrt nor keeps its loop branch-free, so SSE is used directly.
void inverse_lengths(const float* __restrict len2, float* __restrict out, int n) {
  int i = 0;
#if defined(__SSE2__)
  const __m128 one = _mm_set1_ps(1.0f), nan = _mm_set1_ps(kNaN), zero = _mm_setzero_ps();
  for (; i + 4 <= n; i += 4) {
    const __m128 l = _mm_loadu_ps(len2 + i);
    const __m128 inv = _mm_div_ps(one, _mm_sqrt_ps(l));
    const __m128 positive = _mm_cmpgt_ps(l, zero);
    _mm_storeu_ps(out + i, _mm_or_ps(_mm_and_ps(positive, inv), _mm_andnot_ps(positive, nan)));
  }
#endif
  for (; i < n; ++i) out[i] = len2[i] > 0.0f ? 1.0f / std::sqrt(len2[i]) : kNaN;
}

// Three float row buffers (x, y, z) of n elements.
struct Vec3Row {
  float* x;
  float* y;
  float* z;
};

// What the cells of one cell row add to their corners, indexed by the corner's lattice column:
// a[i] from cell i, b[i] from cell i - 1 (row v); c[i] from cell i, d[i] from cell i - 1
// (row v + s).
struct CornerRows {
  Vec3Row a, b, c, d;
};

// Cell row between pixel rows v and v + s. Faces are selected, not multiplied by 0/1: a face
// with an invalid corner has a NaN cross product that a multiplication would keep.
// The row functions stay out of line so that each loop is vectorised on its own.
template <bool kUnitStride, bool kQuad>
[[gnu::noinline]] void cell_row(const OrganizedCloud& cloud, const Mesh& mesh, int v, int s, int n,
                                const CornerRows& out) {
  const float* __restrict x0 = cloud.x.row(v);
  const float* __restrict y0 = cloud.y.row(v);
  const float* __restrict z0 = cloud.z.row(v);
  const float* __restrict x1 = cloud.x.row(v + s);
  const float* __restrict y1 = cloud.y.row(v + s);
  const float* __restrict z1 = cloud.z.row(v + s);
  const std::uint8_t* __restrict faces = mesh.faces.row(v);
  float* __restrict oax = out.a.x;
  float* __restrict oay = out.a.y;
  float* __restrict oaz = out.a.z;
  float* __restrict obx = out.b.x + 1;
  float* __restrict oby = out.b.y + 1;
  float* __restrict obz = out.b.z + 1;
  float* __restrict ocx = out.c.x;
  float* __restrict ocy = out.c.y;
  float* __restrict ocz = out.c.z;
  float* __restrict odx = out.d.x + 1;
  float* __restrict ody = out.d.y + 1;
  float* __restrict odz = out.d.z + 1;
  RANGESEG_IVDEP
  for (int i = 0; i + 1 < n; ++i) {
    const int u = kUnitStride ? i : i * s, w = kUnitStride ? i + 1 : (i + 1) * s;
    const int f = faces[u];
    const float ax = x0[u], ay = y0[u], az = z0[u], bx = x0[w], by = y0[w], bz = z0[w];
    const float cx = x1[u], cy = y1[u], cz = z1[u], dx = x1[w], dy = y1[w], dz = z1[w];
    if constexpr (kQuad) {
      // Quad (a,c,d,b): the cross product of the diagonals is twice its vector area.
      const float ex = dx - ax, ey = dy - ay, ez = dz - az;
      const float gx = bx - cx, gy = by - cy, gz = bz - cz;
      const std::uint32_t q = mask_of((f >> 2) & 1);
      // Computed unconditionally, then selected: GCC does not speculate trapping float math
      // inside a conditional expression, which would leave a branch in the loop.
      const float nx = ey * gz - ez * gy, ny = ez * gx - ex * gz, nz = ex * gy - ey * gx;
      const float qx = keep(nx, q), qy = keep(ny, q), qz = keep(nz, q);
      oax[i] = obx[i] = ocx[i] = odx[i] = qx;
      oay[i] = oby[i] = ocy[i] = ody[i] = qy;
      oaz[i] = obz[i] = ocz[i] = odz[i] = qz;
    } else {
      // Diagonal a-d: t0 = (a,d,b), t1 = (a,c,d); diagonal b-c: t0 = (a,c,b), t1 = (b,c,d).
      const std::uint32_t bc = mask_of((f >> 3) & 1);
      const float px = pick(bc, cx, dx), py = pick(bc, cy, dy), pz = pick(bc, cz, dz);
      const float rx = pick(bc, bx, ax), ry = pick(bc, by, ay), rz = pick(bc, bz, az);
      const float e0x = px - ax, e0y = py - ay, e0z = pz - az;
      const float g0x = bx - ax, g0y = by - ay, g0z = bz - az;
      const float e1x = cx - rx, e1y = cy - ry, e1z = cz - rz;
      const float g1x = dx - rx, g1y = dy - ry, g1z = dz - rz;
      const std::uint32_t k0 = mask_of(f & 1), k1 = mask_of((f >> 1) & 1);
      // Computed unconditionally, then selected (see the quad case).
      const float n0x = e0y * g0z - e0z * g0y, n0y = e0z * g0x - e0x * g0z;
      const float n0z = e0x * g0y - e0y * g0x;
      const float n1x = e1y * g1z - e1z * g1y, n1y = e1z * g1x - e1x * g1z;
      const float n1z = e1x * g1y - e1y * g1x;
      const float t0x = keep(n0x, k0), t0y = keep(n0y, k0), t0z = keep(n0z, k0);
      const float t1x = keep(n1x, k1), t1y = keep(n1y, k1), t1z = keep(n1z, k1);
      // The diagonal's ends touch both triangles, the other two corners one each.
      const float ad_x = t0x + t1x, ad_y = t0y + t1y, ad_z = t0z + t1z;
      oax[i] = pick(bc, t0x, ad_x), oay[i] = pick(bc, t0y, ad_y), oaz[i] = pick(bc, t0z, ad_z);
      obx[i] = pick(bc, ad_x, t0x), oby[i] = pick(bc, ad_y, t0y), obz[i] = pick(bc, ad_z, t0z);
      ocx[i] = pick(bc, ad_x, t1x), ocy[i] = pick(bc, ad_y, t1y), ocz[i] = pick(bc, ad_z, t1z);
      odx[i] = pick(bc, t1x, ad_x), ody[i] = pick(bc, t1y, ad_y), odz[i] = pick(bc, t1z, ad_z);
    }
  }
  const int last = n - 1;
  oax[last] = oay[last] = oaz[last] = ocx[last] = ocy[last] = ocz[last] = 0.0f;
  out.b.x[0] = out.b.y[0] = out.b.z[0] = out.d.x[0] = out.d.y[0] = out.d.z[0] = 0.0f;
}

void zero(const Vec3Row& r, int n) {
  std::fill(r.x, r.x + n, 0.0f);
  std::fill(r.y, r.y + n, 0.0f);
  std::fill(r.z, r.z + n, 0.0f);
}

// Vertex row v: normal sums from the cells below (`cells.a`, `cells.b`) and above (`above.c`,
// `above.d`), normalised, oriented, and the curvature
//   2 |(centroid - p) . n| / mean |q - p|^2 = 2 |sum (q - p) . n| / sum |q - p|^2
// over the ring neighbours q in Mesh::edges. `up`/`down` are the pixel rows v - s and v + s
// (clamped to v at the border, where the edge bits are 0).
template <bool kUnitStride>
[[gnu::noinline]] void vertex_row(const OrganizedCloud& cloud, const Mesh& mesh,
                                  const NormalSettings& settings, int v, int up, int down, int s,
                                  int n, const CornerRows& cells, const CornerRows& above,
                                  const Vec3Row& sum, float* __restrict len2, float* __restrict inv,
                                  NormalMap& out) {
  {
    const float* __restrict ax = cells.a.x;
    const float* __restrict ay = cells.a.y;
    const float* __restrict az = cells.a.z;
    const float* __restrict bx = cells.b.x;
    const float* __restrict by = cells.b.y;
    const float* __restrict bz = cells.b.z;
    const float* __restrict cx = above.c.x;
    const float* __restrict cy = above.c.y;
    const float* __restrict cz = above.c.z;
    const float* __restrict dx = above.d.x;
    const float* __restrict dy = above.d.y;
    const float* __restrict dz = above.d.z;
    float* __restrict sx = sum.x;
    float* __restrict sy = sum.y;
    float* __restrict sz = sum.z;
    RANGESEG_IVDEP
    for (int i = 0; i < n; ++i) {
      const float nx = (ax[i] + bx[i]) + (cx[i] + dx[i]);
      const float ny = (ay[i] + by[i]) + (cy[i] + dy[i]);
      const float nz = (az[i] + bz[i]) + (cz[i] + dz[i]);
      sx[i] = nx, sy[i] = ny, sz[i] = nz;
      len2[i] = nx * nx + ny * ny + nz * nz;
    }
  }
  inverse_lengths(len2, inv, n);

  const float vx = settings.viewpoint[0], vy = settings.viewpoint[1], vz = settings.viewpoint[2];
  const float* __restrict sx = sum.x;
  const float* __restrict sy = sum.y;
  const float* __restrict sz = sum.z;
  const float* __restrict xu = cloud.x.row(up);
  const float* __restrict yu = cloud.y.row(up);
  const float* __restrict zu = cloud.z.row(up);
  const float* __restrict xm = cloud.x.row(v);
  const float* __restrict ym = cloud.y.row(v);
  const float* __restrict zm = cloud.z.row(v);
  const float* __restrict xd = cloud.x.row(down);
  const float* __restrict yd = cloud.y.row(down);
  const float* __restrict zd = cloud.z.row(down);
  const std::uint8_t* __restrict edges = mesh.edges.row(v);
  float* __restrict onx = out.nx.row(v);
  float* __restrict ony = out.ny.row(v);
  float* __restrict onz = out.nz.row(v);
  float* __restrict ocurv = out.curvature.row(v);
  // Lattice column i with neighbour columns l and r (clamped at the border, where the edge
  // bits are 0, so that no read leaves the row).
  const auto vertex = [&](int i, int l, int r) __attribute__((always_inline)) {
    const int u = kUnitStride ? i : i * s;
    const int ul = kUnitStride ? l : l * s, ur = kUnitStride ? r : r * s;
    const float px = xm[u], py = ym[u], pz = zm[u];
    float nx = sx[i] * inv[i], ny = sy[i] * inv[i], nz = sz[i] * inv[i];
    const float facing = nx * (vx - px) + ny * (vy - py) + nz * (vz - pz);
    const std::uint32_t flip = std::bit_cast<std::uint32_t>(facing) & 0x80000000u;
    const auto flipped = [flip](float c) {
      return std::bit_cast<float>(std::bit_cast<std::uint32_t>(c) ^ flip);
    };
    nx = flipped(nx), ny = flipped(ny), nz = flipped(nz);
    onx[u] = nx, ony[u] = ny, onz[u] = nz;
    const std::uint32_t ring = edges[u];
    float ax = 0.0f, ay = 0.0f, az = 0.0f, spread = 0.0f;
    const auto add = [&](int k, float qx, float qy, float qz) __attribute__((always_inline)) {
      const std::uint32_t on = mask_of((ring >> k) & 1);
      const float ex = qx - px, ey = qy - py, ez = qz - pz;
      const float dx = keep(ex, on), dy = keep(ey, on), dz = keep(ez, on);
      ax += dx, ay += dy, az += dz;
      spread += dx * dx + dy * dy + dz * dz;
    };
    // kNeighbourDu/Dv order: right, down-right, down, down-left, left, up-left, up, up-right.
    add(0, xm[ur], ym[ur], zm[ur]);
    add(1, xd[ur], yd[ur], zd[ur]);
    add(2, xd[u], yd[u], zd[u]);
    add(3, xd[ul], yd[ul], zd[ul]);
    add(4, xm[ul], ym[ul], zm[ul]);
    add(5, xu[ul], yu[ul], zu[ul]);
    add(6, xu[u], yu[u], zu[u]);
    add(7, xu[ur], yu[ur], zu[ur]);
    const float along = ax * nx + ay * ny + az * nz;
    const float curvature = 2.0f * std::abs(along) / spread;
    ocurv[u] = pick(mask_of(ring != 0), curvature, kNaN);
  };
  vertex(0, 0, n > 1 ? 1 : 0);
  RANGESEG_IVDEP
  for (int i = 1; i + 1 < n; ++i) vertex(i, i - 1, i + 1);
  if (n > 1) vertex(n - 1, n - 2, n - 1);
}

template <bool kUnitStride>
void sweep(const OrganizedCloud& cloud, const Mesh& mesh, const NormalSettings& settings,
           NormalMap& out) {
  const int width = cloud.width(), height = cloud.height(), s = mesh.pixel_stride;
  const int n = (width - 1) / s + 1, m = (height - 1) / s + 1;
  // Reused across calls on the same thread: no allocation per frame.
  thread_local std::vector<float> buffer;
  constexpr int kRows = 23;
  buffer.resize(static_cast<std::size_t>(kRows) * (n + 1));
  const auto row = [&](int k) { return buffer.data() + static_cast<std::size_t>(k) * (n + 1); };
  const auto vec3 = [&](int k) { return Vec3Row{row(k), row(k + 1), row(k + 2)}; };
  CornerRows cells{vec3(0), vec3(3), vec3(6), vec3(9)};
  CornerRows above{vec3(12), vec3(15), vec3(12), vec3(15)};  // only c and d are read
  const Vec3Row sum = vec3(18);
  float* len2 = row(21);
  float* inv = row(22);
  zero(above.c, n);
  zero(above.d, n);
  const bool quad = mesh.type == MeshType::quad;
  for (int j = 0; j < m; ++j) {
    const int v = j * s;
    if (j + 1 < m) {
      if (quad) {
        cell_row<kUnitStride, true>(cloud, mesh, v, s, n, cells);
      } else {
        cell_row<kUnitStride, false>(cloud, mesh, v, s, n, cells);
      }
    } else {
      zero(cells.a, n);
      zero(cells.b, n);
      zero(cells.c, n);
      zero(cells.d, n);
    }
    vertex_row<kUnitStride>(cloud, mesh, settings, v, j > 0 ? v - s : v, j + 1 < m ? v + s : v, s,
                            n, cells, above, sum, len2, inv, out);
    // This row's bottom corners are the next row's cells from above.
    std::swap(cells.c, above.c);
    std::swap(cells.d, above.d);
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
  // At stride 1 the sweep writes every pixel, so planes of the right size are not refilled;
  // otherwise the off-lattice pixels are NaN (no face).
  for (FloatPlane* plane : {&out.nx, &out.ny, &out.nz, &out.curvature}) {
    if (s != 1 || plane->width() != width || plane->height() != height) {
      plane->resize(width, height, kNaN);
    }
  }
  if (s == 1) {
    sweep<true>(cloud, mesh, settings, out);
  } else {
    sweep<false>(cloud, mesh, settings, out);
  }
}

}  // namespace rangeseg
