// Stage 1: the implicit mesh as per-pixel bit masks.
//
// One sweep over the lattice rows, each step reading and writing whole rows through small row
// buffers (structure of arrays, branch-free, so the compiler vectorises every pass):
//  1. per-pixel quantities of a row (range, eps_d^2, noise variance, ...), computed once;
//  2. edge candidates: the validity (paper, eq. 1, plus the noise gate) of the edges a-b, a-d,
//     a-c, b-c of every cell, each geometric edge tested exactly once;
//  3. faces per cell from the candidate bits of two rows, and the 1-ring bits each face edge
//     contributes to the cell's four corners; a vertex's mask is the union over its <= 4 cells.
#include "rangeseg/mesh.hpp"

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

// Scratch bits of pass 1, stored at the cell's top-left vertex a = (u, v).
constexpr std::uint8_t kEdgeAB = 1;        // a -> b (right)
constexpr std::uint8_t kEdgeAD = 2;        // a -> d (down-right)
constexpr std::uint8_t kEdgeAC = 4;        // a -> c (down)
constexpr std::uint8_t kEdgeBC = 8;        // b -> c (down-left, stored at a)
constexpr std::uint8_t kAdNotLonger = 16;  // |a-d| <= |b-c|

// Per-pixel quantities of one lattice row, relative to the viewpoint (structure of arrays, so
// that the edge tests below vectorise).
struct PixelRow {
  float* x;
  float* y;
  float* z;
  float* range;      // |p - viewpoint|
  float* cos2_r2;    // cos(eps_theta)^2 |p - viewpoint|^2
  float* max_len2;   // eps_d(range)^2
  float* noise_var;  // (jump_sigmas sigma(range))^2
};

struct EdgeParams {
  float vx, vy, vz;   // viewpoint
  float cos2;         // cos(eps_theta)^2
  float a, bs, c;     // eps_d(r) = a + bs r + c r^2 (bs = b * stride)
  float na, nb, nz0;  // sigma(r) = na + nb (r - nz0)^2
  float k2;           // jump_sigmas^2
};

// r[i] = sqrt(max(r2[i], 0)), in place; NaN becomes 0 (maxps returns its second operand then).
// A separate pass: with errno-setting math GCC keeps a branch around std::sqrt, which stopped
// the whole per-pixel loop from vectorising, so SSE is used directly.
void sqrt_clamped(float* __restrict r, int n) {
  int i = 0;
#if defined(__SSE2__)
  const __m128 zero = _mm_setzero_ps();
  for (; i + 4 <= n; i += 4) {
    _mm_storeu_ps(r + i, _mm_sqrt_ps(_mm_max_ps(_mm_loadu_ps(r + i), zero)));
  }
#endif
  for (; i < n; ++i) r[i] = std::sqrt(r[i] > 0.0f ? r[i] : 0.0f);
}

template <bool kUnitStride>
void load_row(const OrganizedCloud& cloud, const EdgeParams& p, int v, int s, int n,
              const PixelRow& out) {
  const float* __restrict xs = cloud.x.row(v);
  const float* __restrict ys = cloud.y.row(v);
  const float* __restrict zs = cloud.z.row(v);
  float* __restrict ox = out.x;
  float* __restrict oy = out.y;
  float* __restrict oz = out.z;
  float* __restrict orange = out.range;
  float* __restrict ocos = out.cos2_r2;
  float* __restrict olen = out.max_len2;
  float* __restrict ovar = out.noise_var;
  RANGESEG_IVDEP
  for (int i = 0; i < n; ++i) {
    const int u = kUnitStride ? i : i * s;
    const float x = xs[u] - p.vx, y = ys[u] - p.vy, z = zs[u] - p.vz;
    const float r2 = x * x + y * y + z * z;
    ox[i] = x;
    oy[i] = y;
    oz[i] = z;
    orange[i] = r2;
    ocos[i] = p.cos2 * r2;
  }
  // NaN points need no range (their edges fail on their NaN length): they get 0.
  sqrt_clamped(orange, n);
  RANGESEG_IVDEP
  for (int i = 0; i < n; ++i) {
    const float r = orange[i];
    const float eps = p.a + r * (p.bs + p.c * r);
    const float dr = r - p.nz0;
    const float sigma = p.na + p.nb * dr * dr;
    olen[i] = eps * eps;
    ovar[i] = p.k2 * sigma * sigma;
  }
}

// Edge p -> q (paper, eq. 1 plus the noise gate documented in mesh.hpp). eps_d is monotonic in
// the range, so eps_d(max range)^2 is the larger of the two per-pixel values. Branch-free; a
// NaN end makes len2 NaN and every comparison with it false, so validity needs no extra test.
#define RANGESEG_EDGE_OK(PX, PY, PZ, PR, PC, PL, PV, QX, QY, QZ, QR, QL, QV)        \
  [&] {                                                                             \
    const float ex = (QX) - (PX), ey = (QY) - (PY), ez = (QZ) - (PZ);               \
    const float len2 = ex * ex + ey * ey + ez * ez;                                 \
    const float dot = ex * (PX) + ey * (PY) + ez * (PZ);                            \
    const float dr = (PR) - (QR);                                                   \
    const float lim = (PL) > (QL) ? (PL) : (QL);                                    \
    return (len2 <= lim) & ((dot * dot <= len2 * (PC)) | (dr * dr <= (PV) + (QV))); \
  }()

// Pass 1 for one lattice row: the edges a-b, a-d, a-c and b-c of every cell whose top-left
// vertex is in this row, plus "a-d not longer than b-c". `below` is null on the last row.
void edge_candidates(const PixelRow& top, const PixelRow* below, int n,
                     std::uint8_t* __restrict out) {
  const float* __restrict ax = top.x;
  const float* __restrict ay = top.y;
  const float* __restrict az = top.z;
  const float* __restrict ar = top.range;
  const float* __restrict ac2 = top.cos2_r2;
  const float* __restrict al = top.max_len2;
  const float* __restrict av = top.noise_var;
  if (below == nullptr) {
    for (int i = 0; i + 1 < n; ++i) {
      const bool ab = RANGESEG_EDGE_OK(ax[i], ay[i], az[i], ar[i], ac2[i], al[i], av[i], ax[i + 1],
                                       ay[i + 1], az[i + 1], ar[i + 1], al[i + 1], av[i + 1]);
      out[i] = ab ? kEdgeAB : 0;
    }
    out[n - 1] = 0;
    return;
  }
  const float* __restrict cx = below->x;
  const float* __restrict cy = below->y;
  const float* __restrict cz = below->z;
  const float* __restrict cr = below->range;
  const float* __restrict cl = below->max_len2;
  const float* __restrict cv = below->noise_var;
  for (int i = 0; i + 1 < n; ++i) {
    const int j = i + 1;
    const bool ab = RANGESEG_EDGE_OK(ax[i], ay[i], az[i], ar[i], ac2[i], al[i], av[i], ax[j], ay[j],
                                     az[j], ar[j], al[j], av[j]);
    const bool ad = RANGESEG_EDGE_OK(ax[i], ay[i], az[i], ar[i], ac2[i], al[i], av[i], cx[j], cy[j],
                                     cz[j], cr[j], cl[j], cv[j]);
    const bool acv = RANGESEG_EDGE_OK(ax[i], ay[i], az[i], ar[i], ac2[i], al[i], av[i], cx[i],
                                      cy[i], cz[i], cr[i], cl[i], cv[i]);
    const bool bc = RANGESEG_EDGE_OK(ax[j], ay[j], az[j], ar[j], ac2[j], al[j], av[j], cx[i], cy[i],
                                     cz[i], cr[i], cl[i], cv[i]);
    const float adx = cx[j] - ax[i], ady = cy[j] - ay[i], adz = cz[j] - az[i];
    const float bcx = cx[i] - ax[j], bcy = cy[i] - ay[j], bcz = cz[i] - az[j];
    const bool ad_not_longer =
        adx * adx + ady * ady + adz * adz <= bcx * bcx + bcy * bcy + bcz * bcz;
    out[i] =
        static_cast<std::uint8_t>((ab ? kEdgeAB : 0) | (ad ? kEdgeAD : 0) | (acv ? kEdgeAC : 0) |
                                  (bc ? kEdgeBC : 0) | (ad_not_longer ? kAdNotLonger : 0));
  }
  const int i = n - 1;
  const bool acv = RANGESEG_EDGE_OK(ax[i], ay[i], az[i], ar[i], ac2[i], al[i], av[i], cx[i], cy[i],
                                    cz[i], cr[i], cl[i], cv[i]);
  out[i] = acv ? kEdgeAC : 0;
}
#undef RANGESEG_EDGE_OK

// Edge bits of Mesh::edges (kNeighbourDu/Dv order).
constexpr std::uint8_t kR = 1, kDR = 2, kD = 4, kDL = 8, kL = 16, kUL = 32, kU = 64, kUR = 128;

// Passes 2 and 3 for lattice row v: the faces of its cells from the candidate bits of rows v
// (`cand`) and v + 1 (`cand_below`), and the 1-ring bits each cell contributes to its corners:
// as_a[i] (vertex i of row v), as_b[i + 1], as_c[i] and as_d[i + 1] (row v + 1). Branch-free
// byte logic, one template instance per mesh type, so that it vectorises.
template <MeshType kType>
void faces_row(const std::uint8_t* __restrict cand, const std::uint8_t* __restrict cand_below,
               int n, std::uint8_t* __restrict faces, std::uint8_t* __restrict as_a,
               std::uint8_t* __restrict as_b, std::uint8_t* __restrict as_c,
               std::uint8_t* __restrict as_d) {
  as_b[0] = 0;
  as_d[0] = 0;
  // 0/1 bytes and bitwise logic (no bool conversions, no branches) vectorise.
  using B = std::uint8_t;
  for (int i = 0; i + 1 < n; ++i) {
    const B e = cand[i];
    const B ab = e & 1, ad = (e >> 1) & 1, ac = (e >> 2) & 1, bc = (e >> 3) & 1;
    const B bd = (cand[i + 1] >> 2) & 1, cd = cand_below[i] & 1;
    const B ad0 = ab & ad & bd, ad1 = ac & cd & ad;  // (a,d,b), (a,c,d)
    const B bc0 = ab & ac & bc, bc1 = bc & cd & bd;  // (a,c,b), (b,c,d)
    B t0 = 0, t1 = 0, q = 0, cut_bc = 0;
    if constexpr (kType == MeshType::quad) {
      q = ab & ac & bd & cd;
    } else if constexpr (kType == MeshType::right_cut) {
      t0 = ad0, t1 = ad1;
    } else if constexpr (kType == MeshType::left_cut) {
      t0 = bc0, t1 = bc1, cut_bc = bc0 | bc1;
    } else {
      const B n_ad = ad0 + ad1, n_bc = bc0 + bc1;
      const B ad_not_longer = (e >> 4) & 1;
      cut_bc = static_cast<B>(n_bc > n_ad) |
               (static_cast<B>(n_bc == n_ad) & (ad_not_longer ^ 1) & (bc0 | bc1));
      const B keep_ad = cut_bc ^ 1;
      t0 = (cut_bc & bc0) | (keep_ad & ad0);
      t1 = (cut_bc & bc1) | (keep_ad & ad1);
    }
    faces[i] = static_cast<B>(t0 * face_bits::tri0 | t1 * face_bits::tri1 | q * face_bits::quad |
                              cut_bc * face_bits::diag_bc);
    // Edges of the cell that belong to a face.
    const B any = t0 | t1, keep_ad = cut_bc ^ 1;
    const B e_ab = q | t0, e_cd = q | t1;
    const B e_ac = q | (cut_bc & t0) | (keep_ad & t1), e_bd = q | (cut_bc & t1) | (keep_ad & t0);
    const B e_ad = keep_ad & any, e_bc = cut_bc & any;
    as_a[i] = static_cast<B>(e_ab * kR | e_ad * kDR | e_ac * kD);
    as_b[i + 1] = static_cast<B>(e_ab * kL | e_bd * kD | e_bc * kDL);
    as_c[i] = static_cast<B>(e_cd * kR | e_ac * kU | e_bc * kUR);
    as_d[i + 1] = static_cast<B>(e_cd * kL | e_bd * kU | e_ad * kUL);
  }
  faces[n - 1] = 0;
  as_a[n - 1] = 0;
  as_c[n - 1] = 0;
}

using FacesRowFn = void (*)(const std::uint8_t*, const std::uint8_t*, int, std::uint8_t*,
                            std::uint8_t*, std::uint8_t*, std::uint8_t*, std::uint8_t*);
constexpr std::array<FacesRowFn, 4> kFacesRow{
    faces_row<MeshType::quad>, faces_row<MeshType::left_cut>, faces_row<MeshType::right_cut>,
    faces_row<MeshType::adaptive>};

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
  if (!(s.jump_sigmas >= 0.0f) || !std::isfinite(s.jump_sigmas)) {
    throw std::invalid_argument("build_mesh: jump_sigmas must be finite and >= 0, got " +
                                std::to_string(s.jump_sigmas));
  }
  for (double e : {s.noise.a, s.noise.b, s.noise.z0}) {
    if (!std::isfinite(e)) {
      throw std::invalid_argument("build_mesh: noise model must be finite, got a " +
                                  std::to_string(s.noise.a) + ", b " + std::to_string(s.noise.b) +
                                  ", z0 " + std::to_string(s.noise.z0));
    }
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
  // At stride 1 every element of both planes is written below, so a plane of the right size is
  // not refilled; otherwise Plane::resize keeps the allocation and zeroes the off-lattice pixels.
  if (s != 1 || mesh.faces.width() != width || mesh.faces.height() != height) {
    mesh.faces.resize(width, height, 0);
  }
  if (s != 1 || mesh.edges.width() != width || mesh.edges.height() != height) {
    mesh.edges.resize(width, height, 0);
  }

  const float cos_theta = std::cos(settings.eps_theta);
  const SensorNoise& noise = settings.noise;
  const EdgeParams params{settings.viewpoint[0],
                          settings.viewpoint[1],
                          settings.viewpoint[2],
                          cos_theta * cos_theta,
                          settings.max_edge_a,
                          settings.max_edge_b * static_cast<float>(s),
                          settings.max_edge_c,
                          static_cast<float>(noise.a),
                          static_cast<float>(noise.b),
                          static_cast<float>(noise.z0),
                          settings.jump_sigmas * settings.jump_sigmas};

  // Lattice size; all row buffers are indexed by lattice column i (pixel u = i * s).
  const int n = (width - 1) / s + 1, m = (height - 1) / s + 1;
  // Reused across calls on the same thread: no allocation per frame.
  thread_local std::vector<float> float_buffer;
  thread_local std::vector<std::uint8_t> byte_buffer;
  constexpr int kFloatsPerPixel = 7;
  float_buffer.resize(static_cast<std::size_t>(3 * kFloatsPerPixel) * n);
  byte_buffer.resize(static_cast<std::size_t>(9) * n);
  std::array<PixelRow, 3> rows{};
  for (int k = 0; k < 3; ++k) {
    float* base = float_buffer.data() + static_cast<std::size_t>(k * kFloatsPerPixel) * n;
    rows[k] = {base,         base + n,     base + 2 * n, base + 3 * n,
               base + 4 * n, base + 5 * n, base + 6 * n};
  }
  std::uint8_t* bytes = byte_buffer.data();
  std::uint8_t* cand = bytes;
  std::uint8_t* cand_below = bytes + n;
  std::uint8_t* faces = bytes + 2 * n;
  std::uint8_t* as_a = bytes + 3 * n;
  std::uint8_t* as_b = bytes + 4 * n;
  std::uint8_t* as_c = bytes + 5 * n;  // contributions to the next lattice row
  std::uint8_t* as_d = bytes + 6 * n;
  std::uint8_t* from_above_c = bytes + 7 * n;  // ... and those from the previous one
  std::uint8_t* from_above_d = bytes + 8 * n;
  std::fill(from_above_c, from_above_c + 2 * n, std::uint8_t{0});

  const auto load = [&](int lattice_row, const PixelRow& out) {
    if (s == 1) {
      load_row<true>(cloud, params, lattice_row, 1, n, out);
    } else {
      load_row<false>(cloud, params, lattice_row * s, s, n, out);
    }
  };
  const FacesRowFn faces_row_fn = kFacesRow[static_cast<int>(settings.type)];
  PixelRow* top = &rows[0];
  PixelRow* mid = &rows[1];
  PixelRow* low = &rows[2];
  load(0, *top);
  if (m > 1) load(1, *mid);
  edge_candidates(*top, m > 1 ? mid : nullptr, n, cand);
  for (int j = 0; j < m; ++j) {
    std::uint8_t* face_row = mesh.faces.row(j * s);
    std::uint8_t* edge_row = mesh.edges.row(j * s);
    if (j + 1 < m) {
      // Candidates of row j + 1 need pixel row j + 2.
      if (j + 2 < m) load(j + 2, *low);
      edge_candidates(*mid, j + 2 < m ? low : nullptr, n, cand_below);
      faces_row_fn(cand, cand_below, n, faces, as_a, as_b, as_c, as_d);
    } else {
      std::fill(faces, faces + n, std::uint8_t{0});
      std::fill(as_a, as_a + n, std::uint8_t{0});
      std::fill(as_b, as_b + n, std::uint8_t{0});
      std::fill(as_c, as_c + n, std::uint8_t{0});
      std::fill(as_d, as_d + n, std::uint8_t{0});
    }
    if (s == 1) {
      for (int i = 0; i < n; ++i) {
        face_row[i] = faces[i];
        edge_row[i] =
            static_cast<std::uint8_t>(as_a[i] | as_b[i] | from_above_c[i] | from_above_d[i]);
      }
    } else {
      for (int i = 0; i < n; ++i) {
        face_row[i * s] = faces[i];
        edge_row[i * s] =
            static_cast<std::uint8_t>(as_a[i] | as_b[i] | from_above_c[i] | from_above_d[i]);
      }
    }
    std::swap(cand, cand_below);
    std::swap(as_c, from_above_c);
    std::swap(as_d, from_above_d);
    PixelRow* const old_top = top;
    top = mid;
    mid = low;
    low = old_top;
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
