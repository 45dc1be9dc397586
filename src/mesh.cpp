// Stage 1: the implicit mesh as per-pixel bit masks.
//
// Three passes over the stride lattice, all reading and writing whole rows:
//  1. edge candidates: the validity (paper, eq. 1) of every lattice edge, computed once per
//     geometric edge and stored as scratch bits in `mesh.edges`;
//  2. faces: per cell, a 128-entry table maps the 6 edge bits (+ "a-d is not longer") to the
//     face bits of the mesh type;
//  3. edges: per vertex, the union of the edges of the faces in the (up to) 4 cells around it,
//     again by table, overwriting the scratch bits.
#include "rangeseg/mesh.hpp"

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

// Scratch bits of pass 1, stored at the cell's top-left vertex a = (u, v).
constexpr std::uint8_t kEdgeAB = 1;        // a -> b (right)
constexpr std::uint8_t kEdgeAD = 2;        // a -> d (down-right)
constexpr std::uint8_t kEdgeAC = 4;        // a -> c (down)
constexpr std::uint8_t kEdgeBC = 8;        // b -> c (down-left, stored at a)
constexpr std::uint8_t kAdNotLonger = 16;  // |a-d| <= |b-c|

// Bits of the 7-bit cell index of pass 2.
constexpr int kIdxAB = 1, kIdxAD = 2, kIdxAC = 4, kIdxBC = 8, kIdxShort = 16, kIdxBD = 32,
              kIdxCD = 64;

constexpr std::uint8_t cell_faces(MeshType type, int idx) {
  const bool ab = idx & kIdxAB, ad = idx & kIdxAD, ac = idx & kIdxAC, bc = idx & kIdxBC,
             ad_short = idx & kIdxShort, bd = idx & kIdxBD, cd = idx & kIdxCD;
  if (type == MeshType::quad) return (ab && ac && bd && cd) ? face_bits::quad : 0;
  // Diagonal a-d: (a,d,b) needs ad, bd, ab; (a,c,d) needs ac, cd, ad.
  const std::uint8_t faces_ad = static_cast<std::uint8_t>((ad && bd && ab ? face_bits::tri0 : 0) |
                                                          (ac && cd && ad ? face_bits::tri1 : 0));
  // Diagonal b-c: (a,c,b) needs ac, bc, ab; (b,c,d) needs bc, cd, bd.
  const std::uint8_t faces_bc = static_cast<std::uint8_t>((ac && bc && ab ? face_bits::tri0 : 0) |
                                                          (bc && cd && bd ? face_bits::tri1 : 0));
  const std::uint8_t with_bc =
      faces_bc ? static_cast<std::uint8_t>(faces_bc | face_bits::diag_bc) : 0;
  switch (type) {
    case MeshType::right_cut:
      return faces_ad;
    case MeshType::left_cut:
      return with_bc;
    default: {
      const int n_ad = std::popcount(static_cast<unsigned>(faces_ad));
      const int n_bc = std::popcount(static_cast<unsigned>(faces_bc));
      if (n_ad != n_bc) return n_ad > n_bc ? faces_ad : with_bc;
      return ad_short ? faces_ad : with_bc;
    }
  }
}

using CellTable = std::array<std::uint8_t, 128>;
constexpr CellTable make_cell_table(MeshType type) {
  CellTable t{};
  for (int i = 0; i < 128; ++i) t[i] = cell_faces(type, i);
  return t;
}
constexpr std::array<CellTable, 4> kCellTables{
    make_cell_table(MeshType::quad), make_cell_table(MeshType::left_cut),
    make_cell_table(MeshType::right_cut), make_cell_table(MeshType::adaptive)};

// Edge bits (kNeighbourDu/Dv order: 0 right, 1 down-right, 2 down, 3 down-left, 4 left,
// 5 up-left, 6 up, 7 up-right) contributed to a vertex by the faces of one adjacent cell,
// indexed by the cell's face byte, for each role the vertex plays in that cell.
enum Corner { kA, kB, kC, kD };
constexpr std::uint8_t corner_edges(Corner corner, int f) {
  constexpr std::uint8_t R = 1, DR = 2, D = 4, DL = 8, L = 16, UL = 32, U = 64, UR = 128;
  const bool t0 = f & face_bits::tri0, t1 = f & face_bits::tri1, q = f & face_bits::quad,
             bc = f & face_bits::diag_bc;
  int m = 0;
  switch (corner) {
    case kA:  // edges a-b (R), a-d (DR), a-c (D)
      if (q) m |= R | D;
      if (!bc)
        m |= (t0 ? R | DR : 0) | (t1 ? D | DR : 0);
      else
        m |= (t0 ? R | D : 0);
      break;
    case kB:  // b-a (L), b-d (D), b-c (DL)
      if (q) m |= L | D;
      if (!bc)
        m |= (t0 ? L | D : 0);
      else
        m |= (t0 ? L | DL : 0) | (t1 ? DL | D : 0);
      break;
    case kC:  // c-a (U), c-d (R), c-b (UR)
      if (q) m |= U | R;
      if (!bc)
        m |= (t1 ? U | R : 0);
      else
        m |= (t0 ? U | UR : 0) | (t1 ? UR | R : 0);
      break;
    case kD:  // d-b (U), d-c (L), d-a (UL)
      if (q) m |= U | L;
      if (!bc)
        m |= (t0 ? UL | U : 0) | (t1 ? UL | L : 0);
      else
        m |= (t1 ? U | L : 0);
      break;
  }
  return static_cast<std::uint8_t>(m);
}
using CornerTable = std::array<std::uint8_t, 16>;
constexpr CornerTable make_corner_table(Corner c) {
  CornerTable t{};
  for (int f = 0; f < 16; ++f) t[f] = corner_edges(c, f);
  return t;
}
constexpr CornerTable kAsA = make_corner_table(kA), kAsB = make_corner_table(kB),
                      kAsC = make_corner_table(kC), kAsD = make_corner_table(kD);

struct EdgeTest {
  float vx, vy, vz;  // viewpoint
  float cos2;        // cos(eps_theta)^2
  float a, bs, c;    // eps_d(r) = a + bs r + c r^2 (bs = b * stride)

  // Branch-free; any NaN coordinate makes a comparison false, so validity of both ends needs
  // no separate test.
  bool operator()(float px, float py, float pz, float qx, float qy, float qz) const {
    const float ex = qx - px, ey = qy - py, ez = qz - pz;
    const float rx = px - vx, ry = py - vy, rz = pz - vz;
    const float sx = qx - vx, sy = qy - vy, sz = qz - vz;
    const float len2 = ex * ex + ey * ey + ez * ez;
    const float rp2 = rx * rx + ry * ry + rz * rz;
    const float rq2 = sx * sx + sy * sy + sz * sz;
    const float dot = ex * rx + ey * ry + ez * rz;
    const float r = std::sqrt(rp2 > rq2 ? rp2 : rq2);
    const float eps = a + r * (bs + c * r);
    return (len2 <= eps * eps) & (dot * dot <= cos2 * len2 * rp2);
  }
};

// Pass 1 for lattice row v. kStride > 0 fixes the stride at compile time (the common s = 1
// lets the compiler vectorise); 0 reads it from `s`.
template <int kStride>
void edge_candidates_row(const OrganizedCloud& cloud, const EdgeTest& test, int v, int s,
                         std::uint8_t* out) {
  if constexpr (kStride > 0) s = kStride;
  const int width = cloud.width();
  const float* x0 = cloud.x.row(v);
  const float* y0 = cloud.y.row(v);
  const float* z0 = cloud.z.row(v);
  const int last_u = (width - 1) / s * s;
  const bool has_down = v + s < cloud.height();
  if (!has_down) {
    for (int u = 0; u < last_u; u += s) {
      out[u] = test(x0[u], y0[u], z0[u], x0[u + s], y0[u + s], z0[u + s]) ? kEdgeAB : 0;
    }
    out[last_u] = 0;
    return;
  }
  const float* x1 = cloud.x.row(v + s);
  const float* y1 = cloud.y.row(v + s);
  const float* z1 = cloud.z.row(v + s);
  for (int u = 0; u < last_u; u += s) {
    const float ax = x0[u], ay = y0[u], az = z0[u];
    const float bx = x0[u + s], by = y0[u + s], bz = z0[u + s];
    const float cx = x1[u], cy = y1[u], cz = z1[u];
    const float dx = x1[u + s], dy = y1[u + s], dz = z1[u + s];
    const float adx = dx - ax, ady = dy - ay, adz = dz - az;
    const float bcx = cx - bx, bcy = cy - by, bcz = cz - bz;
    const bool ad_not_longer =
        adx * adx + ady * ady + adz * adz <= bcx * bcx + bcy * bcy + bcz * bcz;
    out[u] = static_cast<std::uint8_t>((test(ax, ay, az, bx, by, bz) ? kEdgeAB : 0) |
                                       (test(ax, ay, az, dx, dy, dz) ? kEdgeAD : 0) |
                                       (test(ax, ay, az, cx, cy, cz) ? kEdgeAC : 0) |
                                       (test(bx, by, bz, cx, cy, cz) ? kEdgeBC : 0) |
                                       (ad_not_longer ? kAdNotLonger : 0));
  }
  out[last_u] =
      test(x0[last_u], y0[last_u], z0[last_u], x1[last_u], y1[last_u], z1[last_u]) ? kEdgeAC : 0;
}

void validate(const OrganizedCloud& cloud, const MeshSettings& s) {
  require_organized(cloud, "build_mesh");
  if (cloud.x.width() != cloud.width() || cloud.y.width() != cloud.width() ||
      cloud.x.height() != cloud.height() || cloud.y.height() != cloud.height()) {
    throw std::invalid_argument("build_mesh: x, y, z planes differ in size");
  }
  if (static_cast<long long>(cloud.width()) * cloud.height() >
      std::numeric_limits<std::int32_t>::max()) {
    throw std::invalid_argument(
        "build_mesh: cloud too large for int32 pixel indices: " + std::to_string(cloud.width()) +
        "x" + std::to_string(cloud.height()));
  }
  const int t = static_cast<int>(s.type);
  if (t < 0 || t > 3)
    throw std::invalid_argument("build_mesh: unknown MeshType " + std::to_string(t));
  if (!(s.eps_theta >= 0.0f && s.eps_theta <= 1.5707964f)) {
    throw std::invalid_argument("build_mesh: eps_theta must be in [0, pi/2] rad, got " +
                                std::to_string(s.eps_theta));
  }
  for (float e : {s.max_edge_a, s.max_edge_b, s.max_edge_c}) {
    if (!(e >= 0.0f) || !std::isfinite(e)) {
      throw std::invalid_argument("build_mesh: max_edge_a/b/c must be finite and >= 0, got " +
                                  std::to_string(s.max_edge_a) + ", " +
                                  std::to_string(s.max_edge_b) + ", " +
                                  std::to_string(s.max_edge_c));
    }
  }
  for (float p : s.viewpoint) {
    if (!std::isfinite(p)) throw std::invalid_argument("build_mesh: viewpoint must be finite");
  }
  if (s.pixel_stride < 1) {
    throw std::invalid_argument("build_mesh: pixel_stride must be >= 1, got " +
                                std::to_string(s.pixel_stride));
  }
}

}  // namespace

void build_mesh(const OrganizedCloud& cloud, const MeshSettings& settings, Mesh& mesh) {
  validate(cloud, settings);
  const int width = cloud.width(), height = cloud.height(), s = settings.pixel_stride;
  mesh.type = settings.type;
  mesh.pixel_stride = s;
  // Plane::resize keeps the allocation and only refills: no per-frame allocation.
  mesh.faces.resize(width, height, 0);
  mesh.edges.resize(width, height, 0);

  const float cos_theta = std::cos(settings.eps_theta);
  const EdgeTest test{settings.viewpoint[0], settings.viewpoint[1],
                      settings.viewpoint[2], cos_theta * cos_theta,
                      settings.max_edge_a,   settings.max_edge_b * static_cast<float>(s),
                      settings.max_edge_c};

  for (int v = 0; v < height; v += s) {
    if (s == 1) {
      edge_candidates_row<1>(cloud, test, v, s, mesh.edges.row(v));
    } else {
      edge_candidates_row<0>(cloud, test, v, s, mesh.edges.row(v));
    }
  }

  const CellTable& table = kCellTables[static_cast<int>(settings.type)];
  for (int v = 0; v + s < height; v += s) {
    const std::uint8_t* e0 = mesh.edges.row(v);
    const std::uint8_t* e1 = mesh.edges.row(v + s);
    std::uint8_t* f = mesh.faces.row(v);
    for (int u = 0; u + s < width; u += s) {
      const int idx =
          (e0[u] & 31) | ((e0[u + s] & kEdgeAC) ? kIdxBD : 0) | ((e1[u] & kEdgeAB) ? kIdxCD : 0);
      f[u] = table[idx];
    }
  }

  // Pass 3: faces of the cells (u,v), (u-s,v), (u,v-s), (u-s,v-s); rows/columns outside the
  // image contribute nothing (their cells hold 0 or do not exist).
  for (int v = 0; v < height; v += s) {
    const std::uint8_t* f0 = mesh.faces.row(v);  // cells with this vertex as a or b
    const std::uint8_t* fu = v >= s ? mesh.faces.row(v - s) : nullptr;  // as c or d
    std::uint8_t* e = mesh.edges.row(v);
    if (fu != nullptr) {
      e[0] = static_cast<std::uint8_t>(kAsA[f0[0]] | kAsC[fu[0]]);
      for (int u = s; u < width; u += s) {
        e[u] = static_cast<std::uint8_t>(kAsA[f0[u]] | kAsB[f0[u - s]] | kAsC[fu[u]] |
                                         kAsD[fu[u - s]]);
      }
    } else {
      e[0] = kAsA[f0[0]];
      for (int u = s; u < width; u += s) {
        e[u] = static_cast<std::uint8_t>(kAsA[f0[u]] | kAsB[f0[u - s]]);
      }
    }
  }
}

std::size_t count_faces(const Mesh& mesh) {
  std::size_t count = 0;
  const int width = mesh.faces.width();
  for (int v = 0; v < mesh.faces.height(); ++v) {
    const std::uint8_t* f = mesh.faces.row(v);
    std::size_t row = 0;
    for (int u = 0; u < width; ++u) row += std::popcount(static_cast<unsigned>(f[u] & 7u));
    count += row;
  }
  return count;
}

}  // namespace rangeseg
