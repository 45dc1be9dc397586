#include "rangeseg/smoothing.hpp"

#include "detail/smoothing_rows.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace rangeseg {

namespace {

// The row loops use distinct buffers (inputs and outputs never alias, checked in run()); tell
// the compiler so instead of letting it version every loop for aliasing.
#if defined(__clang__)
#define RANGESEG_VECTORIZE _Pragma("clang loop vectorize(assume_safety)")
#elif defined(__GNUC__)
#define RANGESEG_VECTORIZE _Pragma("GCC ivdep")
#else
#define RANGESEG_VECTORIZE
#endif

#if defined(__GNUC__) || defined(__clang__)
#define RANGESEG_INLINE inline __attribute__((always_inline))
#else
#define RANGESEG_INLINE inline
#endif

// The pass is compiled twice, for the baseline ISA and for AVX2 + FMA, and chosen at run time:
// the build does not assume -march=native, and 8-lane vectors halve the filter's time.
#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define RANGESEG_SMOOTH_AVX2 1
#else
#define RANGESEG_SMOOTH_AVX2 0
#endif

/// Weights exp(-a) with a >= kMaxExponent are treated as 0 (e^-30 ~ 1e-13, far below the
/// centre's weight 1).
constexpr float kMaxExponent = 30.0f;

/// exp(-a) for a in [0, kMaxExponent]: 2^y = 2^n 2^f with n = round(y), |f| <= 1/2, and 2^f from
/// its degree-4 Taylor polynomial in g = f ln 2 (|g| <= 0.347, relative error <= g^5 / 120 <
/// 5e-5, far below what a weight needs; checked in tests against std::exp through the filter
/// output). Branch-free and integer-free except for bit casts, so the row loops vectorise.
RANGESEG_INLINE float exp_neg(float a) {
  constexpr float kRound = 12582912.0f;  // 1.5 * 2^23: adding it rounds to an integer
  const float y = a * -1.44269504f;      // -a log2(e), in [-43.3, 0]
  const float t = y + kRound;
  const float n = t - kRound;
  const float g = (y - n) * 0.693147181f;
  const float p = 1.0f + g * (1.0f + g * (0.5f + g * (1.0f / 6 + g * (1.0f / 24))));
  const std::int32_t exponent =
      std::bit_cast<std::int32_t>(t) - std::bit_cast<std::int32_t>(kRound);
  return std::bit_cast<float>(std::bit_cast<std::int32_t>(p) + exponent * (1 << 23));
}

/// c ? a : b on the bits. A plain ?: on floats lets the compiler sink the arithmetic that
/// computes `a` into a branch, which (floating-point ops may trap) it then cannot vectorise.
RANGESEG_INLINE float select(bool c, float a, float b) {
  const std::uint32_t mask = 0u - static_cast<std::uint32_t>(c);
  return std::bit_cast<float>((std::bit_cast<std::uint32_t>(a) & mask) |
                              (std::bit_cast<std::uint32_t>(b) & ~mask));
}

/// 1 / sqrt(x) for finite x > 0: the classic bit-level first guess and three Newton steps
/// (relative error ~1e-7, float rounding). std::sqrt keeps the loop scalar: with errno
/// semantics it has a branch to the library call for negative arguments.
RANGESEG_INLINE float inverse_sqrt(float x) {
  float r = std::bit_cast<float>(0x5f375a86 - (std::bit_cast<std::int32_t>(x) >> 1));
  const float half_x = 0.5f * x;
  r = r * (1.5f - half_x * r * r);
  r = r * (1.5f - half_x * r * r);
  r = r * (1.5f - half_x * r * r);
  return r;
}

template <class T>
void ensure_size(Plane<T>& plane, int width, int height) {
  if (plane.width() != width || plane.height() != height) plane.resize(width, height);
}

void copy_plane(const FloatPlane& from, FloatPlane& to) {
  ensure_size(to, from.width(), from.height());
  for (int v = 0; v < from.height(); ++v) {
    std::copy(from.row(v), from.row(v) + from.width(), to.row(v));
  }
}

/// Per-frame constants of one pass.
struct PassParams {
  int stride = 1;
  float kd2 = 0;      // distance_scale^2
  float spacing = 0;  // stride * pixel_angle [rad]
  float noise_a = 0, noise_b = 0, noise_z0 = 0;
  float inv_normal_scale = 0;
  float inv_intensity_scale = 0;  // 1 / (c_I s_I)
  std::array<float, 3> origin{};  // added to the output points (inputs are origin-relative)
  const FloatPlane* intensity = nullptr;
};

/// Row buffers of one pass. Edge rows hold, per forward direction k = 0..3 (right, down-right,
/// down, down-left) and per lattice row, the quantities of edge (i, j = i + d_k): weight w,
/// w q_i.q_j (along the ray) or w (p_j - p_i) (mean), w (n_j - n_i). Two slots alternate between
/// the current and the previous lattice row. Every edge row has `pad` zero floats on both sides,
/// so that the gather reads zeros for edges leaving the grid.
struct RowBuffers {
  static constexpr int kEdgeArrays = 7;  // w, t or dp (3), dn (3): at most 1 + 3 + 3
  float* base = nullptr;
  std::size_t row_len = 0;  // width + 2 pad
  int pad = 0;
  /// Array a (0: w, 1..3: t / dp, 4..6: dn) of direction k in slot s.
  float* edge(int slot, int k, int a) const {
    return base + ((static_cast<std::size_t>(slot) * 4 + k) * kEdgeArrays + a) * row_len + pad;
  }
  /// Per-pixel half inverse scales of slot s: 0 = 1 / (4 s_d^2), 1 = 1 / (2 s_n).
  float* scale(int slot, int a) const {
    return base + (2 * 4 * kEdgeArrays + static_cast<std::size_t>(slot) * 2 + a) * row_len + pad;
  }
  /// 1 + the sum of the weights of the current row's pixels (points loop -> normals loop).
  float* sum_w() const { return base + (2 * 4 * kEdgeArrays + 4) * row_len + pad; }
  static std::size_t floats_needed(int width, int pad) {
    return (2 * 4 * kEdgeArrays + 5) * (static_cast<std::size_t>(width) + 2 * pad);
  }
};

template <bool kDistance, bool kNormal>
RANGESEG_INLINE void compute_scales(const float* __restrict z, int lo, int hi,
                                    const PassParams& prm, float* __restrict half_inv2sd2,
                                    float* __restrict half_inv_sn) {
  RANGESEG_VECTORIZE
  for (int u = lo; u < hi; ++u) {
    const float zu = z[u], dz = zu - prm.noise_z0;
    const float sigma = prm.noise_a + prm.noise_b * dz * dz;
    const float spacing = prm.spacing * std::fabs(zu);
    if constexpr (kDistance) {
      half_inv2sd2[u] = 0.25f / (prm.kd2 * (spacing * spacing + 2.0f * sigma * sigma));
    }
    // Normal noise grows with sigma / spacing: 1 / s_n = min(1, spacing / sigma) / normal_scale.
    if constexpr (kNormal) {
      const float ratio = spacing / sigma;
      half_inv_sn[u] = 0.5f * prm.inv_normal_scale * select(ratio < 1.0f, ratio, 1.0f);
    }
  }
}

/// The edges of lattice row v in direction k (du, dv) that start in columns [lo, hi) into the
/// slot's edge rows.
template <bool kDistance, bool kNormal, bool kIntensity, bool kAlongRay, bool kFilterNormals>
RANGESEG_INLINE void edge_row(const OrganizedCloud& src, const NormalMap& nm, const Mesh& mesh,
                              const PassParams& prm, const RowBuffers& rb, int v, int k,
                              int cur_slot, int next_slot, int lo, int hi) {
  const int width = src.width(), s = prm.stride;
  const int du = s * kNeighbourDu[k], vn = v + s * kNeighbourDv[k];
  // Edges leaving the grid are absent from the mask; the pad (and here the unused range) is 0.
  const int u_begin = std::max(lo, -du), u_end = std::min(hi, width - du);
  float* __restrict ew = rb.edge(cur_slot, k, 0);
  float* __restrict e1 = rb.edge(cur_slot, k, 1);
  float* __restrict e2 = rb.edge(cur_slot, k, 2);
  float* __restrict e3 = rb.edge(cur_slot, k, 3);
  float* __restrict en0 = rb.edge(cur_slot, k, 4);
  float* __restrict en1 = rb.edge(cur_slot, k, 5);
  float* __restrict en2 = rb.edge(cur_slot, k, 6);
  // Only the arrays the gather reads; the ranges are a few elements (edges leaving the grid),
  // so plain loops rather than a memset call per array.
  auto clear = [&](int from, int to) {
    for (int u = from; u < to; ++u) {
      ew[u] = 0.0f;
      e1[u] = 0.0f;
      if constexpr (!kAlongRay) {
        e2[u] = 0.0f;
        e3[u] = 0.0f;
      }
      if constexpr (kFilterNormals) {
        en0[u] = 0.0f;
        en1[u] = 0.0f;
        en2[u] = 0.0f;
      }
    }
  };
  if (vn >= src.height()) {
    clear(lo, hi);
    return;
  }
  clear(lo, u_begin);
  clear(u_end, hi);

  const float* __restrict xc = src.x.row(v);
  const float* __restrict yc = src.y.row(v);
  const float* __restrict zc = src.z.row(v);
  const float* __restrict nxc = nm.nx.row(v);
  const float* __restrict nyc = nm.ny.row(v);
  const float* __restrict nzc = nm.nz.row(v);
  const float* __restrict ic = kIntensity ? prm.intensity->row(v) : nullptr;
  const float* __restrict hd_c = rb.scale(cur_slot, 0);
  const float* __restrict hn_c = rb.scale(cur_slot, 1);
  const std::uint8_t* __restrict edges = mesh.edges.row(v);
  const float* __restrict xn = src.x.row(vn) + du;
  const float* __restrict yn = src.y.row(vn) + du;
  const float* __restrict zn = src.z.row(vn) + du;
  const float* __restrict nxn = nm.nx.row(vn) + du;
  const float* __restrict nyn = nm.ny.row(vn) + du;
  const float* __restrict nzn = nm.nz.row(vn) + du;
  const float* __restrict in = kIntensity ? prm.intensity->row(vn) + du : nullptr;
  const int scale_slot = vn == v ? cur_slot : next_slot;
  const float* __restrict hd_n = rb.scale(scale_slot, 0) + du;
  const float* __restrict hn_n = rb.scale(scale_slot, 1) + du;
  const float inv_intensity_scale = prm.inv_intensity_scale;
  const unsigned bit = 1u << k;

  RANGESEG_VECTORIZE
  for (int u = u_begin; u < u_end; ++u) {
    const float dx = xn[u] - xc[u], dy = yn[u] - yc[u], dz = zn[u] - zc[u];
    const float dnx = nxn[u] - nxc[u], dny = nyn[u] - nyc[u], dnz = nzn[u] - nzc[u];
    const float l1 = std::fabs(dnx) + std::fabs(dny) + std::fabs(dnz);
    float arg = 0.0f;
    // Symmetric scales (the mean of both ends' inverse scales), so that w_ij = w_ji.
    if constexpr (kDistance) arg += (dx * dx + dy * dy + dz * dz) * (hd_c[u] + hd_n[u]);
    if constexpr (kNormal) arg += l1 * (hn_c[u] + hn_n[u]);
    if constexpr (kIntensity) arg += std::fabs(in[u] - ic[u]) * inv_intensity_scale;
    // Everything is evaluated for every lane and then selected, so that the loop has no
    // branches and vectorises. NaN (a NaN normal or intensity) fails the comparison.
    const bool use = ((edges[u] & bit) != 0) & (arg < kMaxExponent);
    const float w = select(use, exp_neg(select(arg < kMaxExponent, arg, kMaxExponent)), 0.0f);
    ew[u] = w;
    if constexpr (kAlongRay) {
      e1[u] = select(use, w * (xn[u] * xc[u] + yn[u] * yc[u] + zn[u] * zc[u]), 0.0f);
    } else {
      e1[u] = select(use, w * dx, 0.0f);
      e2[u] = select(use, w * dy, 0.0f);
      e3[u] = select(use, w * dz, 0.0f);
    }
    if constexpr (kFilterNormals) {
      // Without the normal term a NaN normal at either end must be skipped explicitly.
      const bool use_n = kNormal ? use : (use & (l1 == l1));
      en0[u] = select(use_n, w * dnx, 0.0f);
      en1[u] = select(use_n, w * dny, 0.0f);
      en2[u] = select(use_n, w * dnz, 0.0f);
    }
  }
}

/// Output rows [v0, v1), columns [u0, u1) of one pass. Each edge's weight is computed once per
/// block (edge_row, forward directions only) and gathered by both ends: pixel (u, v) reads the
/// forward edges of its own row and, negated where antisymmetric, the forward edges of row
/// v - s that end in it. A block computes the edges of columns [u0 - s, u1 + s) (and of the
/// lattice row above v0), so blocks are independent, and every edge and every pixel's sum is
/// evaluated by the same operations in the same order whatever the blocks: the output is
/// bit-identical to one block covering the image (row bands for threads, see
/// detail/smoothing_rows.hpp).
template <bool kDistance, bool kNormal, bool kIntensity, bool kAlongRay, bool kFilterNormals>
RANGESEG_INLINE void smooth_block(const OrganizedCloud& src, const NormalMap& nm, const Mesh& mesh,
                                  const PassParams& prm, const RowBuffers& rb, OrganizedCloud& dst,
                                  NormalMap& dst_normals, int u0, int u1, int v0, int v1) {
  const int width = src.width(), height = src.height(), s = prm.stride;
  const float ox = prm.origin[0], oy = prm.origin[1], oz = prm.origin[2];
  constexpr bool kScales = kDistance || kNormal;
  const int edge_lo = std::max(0, u0 - s), edge_hi = std::min(width, u1 + s);
  // Edge (u, u + du) needs the scales of both ends.
  const int scale_lo = std::max(0, u0 - 2 * s), scale_hi = std::min(width, u1 + 2 * s);
  const int v_first = (v0 + s - 1) / s * s;  // first lattice row of the block
  int slot = 0;
  if (v0 > 0 && v_first - s < height) {
    // The lattice row above the block: its edges into slot 1, the previous-row slot of v_first.
    const int vp = v_first - s;
    if constexpr (kScales) {
      compute_scales<kDistance, kNormal>(src.z.row(vp), scale_lo, scale_hi, prm, rb.scale(1, 0),
                                         rb.scale(1, 1));
      if (v_first < height) {
        compute_scales<kDistance, kNormal>(src.z.row(v_first), scale_lo, scale_hi, prm,
                                           rb.scale(0, 0), rb.scale(0, 1));
      }
    }
    for (int k = 0; k < 4; ++k) {
      edge_row<kDistance, kNormal, kIntensity, kAlongRay, kFilterNormals>(
          src, nm, mesh, prm, rb, vp, k, 1, 0, edge_lo, edge_hi);
    }
  } else {
    if constexpr (kScales) {
      if (v_first < height) {
        compute_scales<kDistance, kNormal>(src.z.row(v_first), scale_lo, scale_hi, prm,
                                           rb.scale(0, 0), rb.scale(0, 1));
      }
    }
    // The previous-row slot starts as zeros: no edges come from above row 0.
    for (int k = 1; k < 4; ++k) {
      for (int a = 0; a < RowBuffers::kEdgeArrays; ++a) {
        std::fill(rb.edge(1, k, a) + edge_lo, rb.edge(1, k, a) + edge_hi, 0.0f);
      }
    }
  }
  for (int v = v0; v < v1; ++v) {
    const float* __restrict xc = src.x.row(v);
    const float* __restrict yc = src.y.row(v);
    const float* __restrict zc = src.z.row(v);
    const float* __restrict nxc = nm.nx.row(v);
    const float* __restrict nyc = nm.ny.row(v);
    const float* __restrict nzc = nm.nz.row(v);
    float* __restrict xo = dst.x.row(v);
    float* __restrict yo = dst.y.row(v);
    float* __restrict zo = dst.z.row(v);
    float* __restrict nxo = dst_normals.nx.row(v);
    float* __restrict nyo = dst_normals.ny.row(v);
    float* __restrict nzo = dst_normals.nz.row(v);
    if (v % s != 0) {  // no vertex in this row: copied
      RANGESEG_VECTORIZE
      for (int u = u0; u < u1; ++u) {
        xo[u] = xc[u] + ox;
        yo[u] = yc[u] + oy;
        zo[u] = zc[u] + oz;
      }
      if constexpr (kFilterNormals) {
        std::copy(nxc + u0, nxc + u1, nxo + u0);
        std::copy(nyc + u0, nyc + u1, nyo + u0);
        std::copy(nzc + u0, nzc + u1, nzo + u0);
      }
      continue;
    }
    const int next = 1 - slot;
    if constexpr (kScales) {
      if (v + s < height) {
        compute_scales<kDistance, kNormal>(src.z.row(v + s), scale_lo, scale_hi, prm,
                                           rb.scale(next, 0), rb.scale(next, 1));
      }
    }
    for (int k = 0; k < 4; ++k) {
      edge_row<kDistance, kNormal, kIntensity, kAlongRay, kFilterNormals>(
          src, nm, mesh, prm, rb, v, k, slot, next, edge_lo, edge_hi);
    }

    // Pixel u gathers the forward edges of this row (F) and the forward edges ending in it (B):
    // direction k's edge ending in u starts at u - s du_k, in row v for k = 0 and in the previous
    // lattice row (slot `next`, zeros above row 0) for k = 1..3.
    const int prev = next;
#define RANGESEG_EDGES(name, a)                               \
  const float* __restrict name##f0 = rb.edge(slot, 0, a);     \
  const float* __restrict name##f1 = rb.edge(slot, 1, a);     \
  const float* __restrict name##f2 = rb.edge(slot, 2, a);     \
  const float* __restrict name##f3 = rb.edge(slot, 3, a);     \
  const float* __restrict name##b0 = rb.edge(slot, 0, a) - s; \
  const float* __restrict name##b1 = rb.edge(prev, 1, a) - s; \
  const float* __restrict name##b2 = rb.edge(prev, 2, a);     \
  const float* __restrict name##b3 = rb.edge(prev, 3, a) + s;
#define RANGESEG_SYM(name)                                       \
  (((name##f0[u] + name##b0[u]) + (name##f1[u] + name##b1[u])) + \
   ((name##f2[u] + name##b2[u]) + (name##f3[u] + name##b3[u])))
#define RANGESEG_ANTI(name)                                      \
  (((name##f0[u] - name##b0[u]) + (name##f1[u] - name##b1[u])) + \
   ((name##f2[u] - name##b2[u]) + (name##f3[u] - name##b3[u])))
    RANGESEG_EDGES(w, 0)
    float* __restrict sum_w_row = rb.sum_w();
    if constexpr (kAlongRay) {
      RANGESEG_EDGES(t, 1)
      RANGESEG_VECTORIZE
      for (int u = u0; u < u1; ++u) {
        // p' = o + q (q . m) / (q . q) with m the weighted mean of the origin-relative points:
        // the mean projected onto the viewing ray; the centre's own term of the sum is q . q.
        const float qx = xc[u], qy = yc[u], qz = zc[u];
        const float qq = qx * qx + qy * qy + qz * qz;
        const float sum_w = 1.0f + RANGESEG_SYM(w);
        sum_w_row[u] = sum_w;
        const float sum_t = qq + RANGESEG_SYM(t);
        const float scale = select(qq > 0.0f, sum_t / (sum_w * qq), 1.0f);
        xo[u] = ox + qx * scale;
        yo[u] = oy + qy * scale;
        zo[u] = oz + qz * scale;
      }
    } else {
      RANGESEG_EDGES(px, 1)
      RANGESEG_EDGES(py, 2)
      RANGESEG_EDGES(pz, 3)
      RANGESEG_VECTORIZE
      for (int u = u0; u < u1; ++u) {
        // sum_j w_j p_j / sum_j w_j = p + sum_j w_j (p_j - p) / sum_j w_j.
        const float sum_w = 1.0f + RANGESEG_SYM(w);
        sum_w_row[u] = sum_w;
        const float inv = 1.0f / sum_w;
        xo[u] = ox + xc[u] + RANGESEG_ANTI(px) * inv;
        yo[u] = oy + yc[u] + RANGESEG_ANTI(py) * inv;
        zo[u] = oz + zc[u] + RANGESEG_ANTI(pz) * inv;
      }
    }
    if constexpr (kFilterNormals) {
      RANGESEG_EDGES(nx, 4)
      RANGESEG_EDGES(ny, 5)
      RANGESEG_EDGES(nz, 6)
      RANGESEG_VECTORIZE
      for (int u = u0; u < u1; ++u) {
        // sum_j w_j n_j = n sum_j w_j + sum_j w_j (n_j - n). Without the normal term, a
        // neighbour without a normal keeps its weight on the pixel's own normal.
        const float sum_w = sum_w_row[u];
        const float ax = nxc[u] * sum_w + RANGESEG_ANTI(nx);
        const float ay = nyc[u] * sum_w + RANGESEG_ANTI(ny);
        const float az = nzc[u] * sum_w + RANGESEG_ANTI(nz);
        const float len2 = ax * ax + ay * ay + az * az;
        // Opposite normals can cancel; then (and for NaN) the pixel keeps its normal.
        const bool ok = len2 > 1e-12f;
        const float inv = inverse_sqrt(select(ok, len2, 1.0f));
        nxo[u] = select(ok, ax * inv, nxc[u]);
        nyo[u] = select(ok, ay * inv, nyc[u]);
        nzo[u] = select(ok, az * inv, nzc[u]);
      }
    }
#undef RANGESEG_EDGES
#undef RANGESEG_SYM
#undef RANGESEG_ANTI
    slot = next;
  }
}

/// Output rows [v0, v1) of one pass. (Column strips of 128 pixels, which keep a strip's edge
/// rows in L1, measured 1.4 times slower: the loops get short and the per-row overhead grows.)
template <bool kDistance, bool kNormal, bool kIntensity, bool kAlongRay, bool kFilterNormals>
RANGESEG_INLINE void smooth_pass_body(const OrganizedCloud& src, const NormalMap& nm,
                                      const Mesh& mesh, const PassParams& prm, RowBuffers rb,
                                      OrganizedCloud& dst, NormalMap& dst_normals, int v0, int v1) {
  smooth_block<kDistance, kNormal, kIntensity, kAlongRay, kFilterNormals>(
      src, nm, mesh, prm, rb, dst, dst_normals, 0, src.width(), v0, v1);
}

template <bool kDistance, bool kNormal, bool kIntensity, bool kAlongRay, bool kFilterNormals>
void smooth_pass(const OrganizedCloud& src, const NormalMap& nm, const Mesh& mesh,
                 const PassParams& prm, RowBuffers rb, OrganizedCloud& dst, NormalMap& dst_normals,
                 int v0, int v1) {
  smooth_pass_body<kDistance, kNormal, kIntensity, kAlongRay, kFilterNormals>(
      src, nm, mesh, prm, rb, dst, dst_normals, v0, v1);
}

#if RANGESEG_SMOOTH_AVX2
template <bool kDistance, bool kNormal, bool kIntensity, bool kAlongRay, bool kFilterNormals>
__attribute__((target("avx2,fma"))) void smooth_pass_avx2(const OrganizedCloud& src,
                                                          const NormalMap& nm, const Mesh& mesh,
                                                          const PassParams& prm, RowBuffers rb,
                                                          OrganizedCloud& dst,
                                                          NormalMap& dst_normals, int v0, int v1) {
  smooth_pass_body<kDistance, kNormal, kIntensity, kAlongRay, kFilterNormals>(
      src, nm, mesh, prm, rb, dst, dst_normals, v0, v1);
}

bool cpu_has_avx2_fma() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
#endif

using PassFn = void (*)(const OrganizedCloud&, const NormalMap&, const Mesh&, const PassParams&,
                        RowBuffers, OrganizedCloud&, NormalMap&, int, int);

template <int kFlags, bool kAvx2>
constexpr PassFn pass_for() {
  constexpr bool d = (kFlags & 1) != 0, n = (kFlags & 2) != 0, i = (kFlags & 4) != 0,
                 r = (kFlags & 8) != 0, f = (kFlags & 16) != 0;
#if RANGESEG_SMOOTH_AVX2
  if constexpr (kAvx2) return &smooth_pass_avx2<d, n, i, r, f>;
#endif
  return &smooth_pass<d, n, i, r, f>;
}

template <bool kAvx2, int... kFlags>
constexpr std::array<PassFn, sizeof...(kFlags)> make_pass_table(
    std::integer_sequence<int, kFlags...>) {
  return {pass_for<kFlags, kAvx2>()...};
}

constexpr auto kPassTable = make_pass_table<false>(std::make_integer_sequence<int, 32>{});
#if RANGESEG_SMOOTH_AVX2
constexpr auto kPassTableAvx2 = make_pass_table<true>(std::make_integer_sequence<int, 32>{});
#endif

void require_same_size(const FloatPlane& plane, const OrganizedCloud& cloud, const char* what) {
  if (plane.width() != cloud.width() || plane.height() != cloud.height()) {
    throw std::invalid_argument(
        std::string("smooth: ") + what + " is " + std::to_string(plane.width()) + "x" +
        std::to_string(plane.height()) + ", the cloud " + std::to_string(cloud.width()) + "x" +
        std::to_string(cloud.height()));
  }
}

/// Grey value of every pixel from RGB (ITU-R BT.601 luma), into `grey` (sized by the caller).
RANGESEG_INLINE void rgb_to_grey_body(const OrganizedCloud& cloud, FloatPlane& grey) {
  for (int v = 0; v < cloud.height(); ++v) {
    const std::uint8_t* __restrict r = cloud.r.row(v);
    const std::uint8_t* __restrict g = cloud.g.row(v);
    const std::uint8_t* __restrict b = cloud.b.row(v);
    float* __restrict out = grey.row(v);
    for (int u = 0; u < cloud.width(); ++u) {
      out[u] = 0.299f * static_cast<float>(r[u]) + 0.587f * static_cast<float>(g[u]) +
               0.114f * static_cast<float>(b[u]);
    }
  }
}

void rgb_to_grey_generic(const OrganizedCloud& cloud, FloatPlane& grey) {
  rgb_to_grey_body(cloud, grey);
}

#if RANGESEG_SMOOTH_AVX2
// AVX2 without FMA: products and sums stay separately rounded, so the grey values equal the
// generic build's bit for bit.
__attribute__((target("avx2"))) void rgb_to_grey_avx2(const OrganizedCloud& cloud,
                                                      FloatPlane& grey) {
  rgb_to_grey_body(cloud, grey);
}
#endif

void rgb_to_grey(const OrganizedCloud& cloud, FloatPlane& grey) {
  ensure_size(grey, cloud.width(), cloud.height());
#if RANGESEG_SMOOTH_AVX2
  if (cpu_has_avx2_fma()) {
    rgb_to_grey_avx2(cloud, grey);
    return;
  }
#endif
  rgb_to_grey_generic(cloud, grey);
}

/// max - min of `intensity` over the valid points of `cloud` (0 when none). Branch-free, so
/// that it vectorises: x - x == 0 is false exactly for NaN and infinities. kLanes independent
/// running minima and maxima (min and max are exact, so the order does not change the result)
/// let the compiler keep them in vector registers instead of one serial scalar chain.
RANGESEG_INLINE float intensity_range_body(const OrganizedCloud& cloud,
                                           const FloatPlane& intensity) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  constexpr int kLanes = 16;
  std::array<float, kLanes> lo, hi;
  lo.fill(kInf);
  hi.fill(-kInf);
  const int width = cloud.width();
  for (int v = 0; v < cloud.height(); ++v) {
    const float* __restrict z = cloud.z.row(v);
    const float* __restrict in = intensity.row(v);
    int u = 0;
    for (; u + kLanes <= width; u += kLanes) {
      for (int i = 0; i < kLanes; ++i) {
        const float zi = z[u + i], ii = in[u + i];
        const bool ok = ((zi - zi) == 0.0f) & ((ii - ii) == 0.0f);
        lo[i] = std::min(lo[i], select(ok, ii, kInf));
        hi[i] = std::max(hi[i], select(ok, ii, -kInf));
      }
    }
    for (; u < width; ++u) {
      const bool ok = ((z[u] - z[u]) == 0.0f) & ((in[u] - in[u]) == 0.0f);
      lo[0] = std::min(lo[0], select(ok, in[u], kInf));
      hi[0] = std::max(hi[0], select(ok, in[u], -kInf));
    }
  }
  float low = kInf, high = -kInf;
  for (int i = 0; i < kLanes; ++i) {
    low = std::min(low, lo[i]);
    high = std::max(high, hi[i]);
  }
  return high >= low ? high - low : 0.0f;
}

float intensity_range_generic(const OrganizedCloud& cloud, const FloatPlane& intensity) {
  return intensity_range_body(cloud, intensity);
}

#if RANGESEG_SMOOTH_AVX2
__attribute__((target("avx2,fma"))) float intensity_range_avx2(const OrganizedCloud& cloud,
                                                               const FloatPlane& intensity) {
  return intensity_range_body(cloud, intensity);
}
#endif

void check_positive(float value, const char* name) {
  if (!(value > 0.0f) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string("SmoothingSettings::") + name +
                                " must be positive and finite, got " + std::to_string(value));
  }
}

void check_finite(float value, const char* name) {
  if (!std::isfinite(value)) {
    throw std::invalid_argument(std::string("SmoothingSettings::") + name +
                                " must be finite, got " + std::to_string(value));
  }
}

/// A pass function and its per-frame constants.
struct PassSetup {
  PassParams prm;
  PassFn pass = nullptr;
};

/// The pass for `st` on a mesh of stride `stride`, with the intensity term on `intensity` of
/// range c_I = `range` (off for nullptr or range <= 0: a constant intensity carries no edge).
PassSetup make_pass(const SmoothingSettings& st, int stride, const FloatPlane* intensity,
                    float range) {
  PassSetup setup;
  PassParams& prm = setup.prm;
  prm.stride = stride;
  prm.origin = st.viewpoint;
  prm.kd2 = st.distance_scale * st.distance_scale;
  prm.spacing = static_cast<float>(stride) * st.pixel_angle;
  prm.noise_a = static_cast<float>(st.noise.a);
  prm.noise_b = static_cast<float>(st.noise.b);
  prm.noise_z0 = static_cast<float>(st.noise.z0);
  prm.inv_normal_scale = 1.0f / st.normal_scale;
  const bool use_intensity = st.use_intensity && intensity != nullptr && range > 0.0f;
  if (use_intensity) {
    prm.intensity = intensity;
    prm.inv_intensity_scale = 1.0f / (range * st.intensity_scale);
  }
  const bool filter_normals = !st.recompute_normals;
  const int flags = (st.use_distance ? 1 : 0) | (st.use_normals ? 2 : 0) | (use_intensity ? 4 : 0) |
                    (st.move_along_ray ? 8 : 0) | (filter_normals ? 16 : 0);
  setup.pass = kPassTable[static_cast<std::size_t>(flags)];
#if RANGESEG_SMOOTH_AVX2
  if (cpu_has_avx2_fma()) setup.pass = kPassTableAvx2[static_cast<std::size_t>(flags)];
#endif
  return setup;
}

/// Row buffers for rows of `width` pixels in `rows`; `layout` remembers the row length the zero
/// pads were laid out for (a new layout starts from a zeroed buffer; passes write inside only).
RowBuffers layout_rows(std::vector<float>& rows, std::size_t& layout, int width, int stride) {
  RowBuffers rb;
  rb.pad = stride;
  rb.row_len = static_cast<std::size_t>(width) + 2 * static_cast<std::size_t>(rb.pad);
  const std::size_t needed = RowBuffers::floats_needed(width, rb.pad);
  if (rows.size() != needed || layout != rb.row_len) {
    rows.assign(needed, 0.0f);
    layout = rb.row_len;
  }
  rb.base = rows.data();
  return rb;
}

}  // namespace

namespace detail {

float frame_intensity_range(const OrganizedCloud& cloud, const FloatPlane& intensity) {
#if RANGESEG_SMOOTH_AVX2
  if (cpu_has_avx2_fma()) return intensity_range_avx2(cloud, intensity);
#endif
  return intensity_range_generic(cloud, intensity);
}

void smooth_rows(const SmoothRowsInput& in, const SmoothingSettings& settings, int v0, int v1,
                 SmoothRowsScratch& scratch, OrganizedCloud& out_cloud, NormalMap& out_normals) {
  assert(in.cloud != nullptr && in.mesh != nullptr && in.normals != nullptr);
  const OrganizedCloud& cloud = *in.cloud;
  const int width = cloud.width(), height = cloud.height();
  assert(0 <= v0 && v0 <= v1 && v1 <= height);
  assert(out_cloud.z.width() == width && out_cloud.z.height() == height);
  assert(out_normals.nz.width() == width && out_normals.nz.height() == height);
  (void)height;
  const PassSetup setup =
      make_pass(settings, in.mesh->pixel_stride, in.intensity, in.intensity_range);
  const RowBuffers rb = layout_rows(scratch.rows, scratch.layout, width, in.mesh->pixel_stride);
  setup.pass(cloud, *in.normals, *in.mesh, setup.prm, rb, out_cloud, out_normals, v0, v1);
}

}  // namespace detail

void validate(const SmoothingSettings& settings) {
  if (settings.iterations < 0) {
    throw std::invalid_argument("SmoothingSettings::iterations must be >= 0, got " +
                                std::to_string(settings.iterations));
  }
  check_positive(settings.distance_scale, "distance_scale");
  check_positive(settings.pixel_angle, "pixel_angle");
  check_positive(settings.noise.a, "noise_a");
  check_finite(settings.noise.b, "noise_b");
  if (settings.noise.b < 0.0f) {
    throw std::invalid_argument("SmoothingSettings::noise_b must be >= 0, got " +
                                std::to_string(settings.noise.b));
  }
  check_finite(settings.noise.z0, "noise_z0");
  check_positive(settings.normal_scale, "normal_scale");
  check_positive(settings.intensity_scale, "intensity_scale");
  check_finite(settings.intensity_range, "intensity_range");
  if (settings.intensity_range < 0.0f) {
    throw std::invalid_argument("SmoothingSettings::intensity_range must be >= 0, got " +
                                std::to_string(settings.intensity_range));
  }
  for (float c : settings.viewpoint) check_finite(c, "viewpoint");
}

Smoother::Smoother(const SmoothingSettings& settings) : settings_(settings) { validate(settings_); }

void Smoother::run(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
                   OrganizedCloud& out_cloud, NormalMap& out_normals) {
  require_organized(cloud, "smooth");
  if (&out_cloud == &cloud || &out_normals == &normals) {
    throw std::invalid_argument("smooth: the output objects must differ from the inputs");
  }
  if (mesh.width() != cloud.width() || mesh.height() != cloud.height()) {
    throw std::invalid_argument(
        "smooth: mesh is " + std::to_string(mesh.width()) + "x" + std::to_string(mesh.height()) +
        ", the cloud " + std::to_string(cloud.width()) + "x" + std::to_string(cloud.height()));
  }
  if (mesh.pixel_stride < 1) {
    throw std::invalid_argument("smooth: mesh pixel_stride must be >= 1, got " +
                                std::to_string(mesh.pixel_stride));
  }
  require_same_size(cloud.x, cloud, "x");
  require_same_size(cloud.y, cloud, "y");
  require_same_size(normals.nx, cloud, "normals.nx");
  require_same_size(normals.ny, cloud, "normals.ny");
  require_same_size(normals.nz, cloud, "normals.nz");
  const bool pass_curvature = !settings_.recompute_normals;
  if (pass_curvature) require_same_size(normals.curvature, cloud, "normals.curvature");

  const int width = cloud.width(), height = cloud.height();
  const SmoothingSettings& st = settings_;

  // Outputs: x, y, z and normals are written in full by every pass; optional planes are copied.
  for (FloatPlane* p : {&out_cloud.x, &out_cloud.y, &out_cloud.z}) ensure_size(*p, width, height);
  out_cloud.intensity = cloud.intensity;
  out_cloud.r = cloud.r;
  out_cloud.g = cloud.g;
  out_cloud.b = cloud.b;
  out_cloud.label = cloud.label;
  for (FloatPlane* p : {&out_normals.nx, &out_normals.ny, &out_normals.nz}) {
    ensure_size(*p, width, height);
  }
  if (pass_curvature) copy_plane(normals.curvature, out_normals.curvature);

  if (st.iterations == 0) {
    copy_plane(cloud.x, out_cloud.x);
    copy_plane(cloud.y, out_cloud.y);
    copy_plane(cloud.z, out_cloud.z);
    copy_plane(normals.nx, out_normals.nx);
    copy_plane(normals.ny, out_normals.ny);
    copy_plane(normals.nz, out_normals.nz);
    if (!pass_curvature) copy_plane(normals.curvature, out_normals.curvature);
    return;
  }

  const FloatPlane* intensity = nullptr;
  float range = 0.0f;
  if (st.use_intensity && (cloud.has_intensity() || cloud.has_rgb())) {
    if (cloud.has_intensity()) {
      require_same_size(cloud.intensity, cloud, "intensity");
      intensity = &cloud.intensity;
    } else {
      rgb_to_grey(cloud, grey_);
      intensity = &grey_;
    }
    range = st.intensity_range > 0.0f ? st.intensity_range
                                      : detail::frame_intensity_range(cloud, *intensity);
  }
  const PassSetup setup = make_pass(st, mesh.pixel_stride, intensity, range);
  const PassParams& prm = setup.prm;
  const PassFn pass = setup.pass;
  const bool filter_normals = !st.recompute_normals;
  const RowBuffers rb = layout_rows(rows_, rows_layout_, width, mesh.pixel_stride);

  // The pass works on origin-relative points (q = p - viewpoint) and adds the viewpoint back.
  const bool shifted = st.viewpoint != std::array<float, 3>{0.0f, 0.0f, 0.0f};
  if (shifted) {
    for (FloatPlane* p : {&shifted_.x, &shifted_.y, &shifted_.z}) ensure_size(*p, width, height);
  }

  if (st.iterations > 1) {
    for (FloatPlane* p : {&scratch_cloud_.x, &scratch_cloud_.y, &scratch_cloud_.z,
                          &scratch_normals_.nx, &scratch_normals_.ny, &scratch_normals_.nz}) {
      ensure_size(*p, width, height);
    }
    if (!filter_normals) ensure_size(scratch_normals_.curvature, width, height);
  }

  const NormalSettings normal_settings{.viewpoint = st.viewpoint};
  const OrganizedCloud* src = &cloud;
  const NormalMap* src_normals = &normals;
  for (int i = 0; i < st.iterations; ++i) {
    // Ping-pong so that the last pass lands in the outputs.
    const bool to_output = (st.iterations - 1 - i) % 2 == 0;
    OrganizedCloud& dst = to_output ? out_cloud : scratch_cloud_;
    NormalMap& dst_normals = to_output ? out_normals : scratch_normals_;
    if (shifted) {
      for (int v = 0; v < height; ++v) {
        for (int u = 0; u < width; ++u) {
          shifted_.x(u, v) = src->x(u, v) - st.viewpoint[0];
          shifted_.y(u, v) = src->y(u, v) - st.viewpoint[1];
          shifted_.z(u, v) = src->z(u, v) - st.viewpoint[2];
        }
      }
    }
    pass(shifted ? shifted_ : *src, *src_normals, mesh, prm, rb, dst, dst_normals, 0, height);
    if (!filter_normals) compute_normals(dst, mesh, normal_settings, dst_normals);
    src = &dst;
    src_normals = &dst_normals;
  }
}

void smooth(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
            const SmoothingSettings& settings, OrganizedCloud& out_cloud, NormalMap& out_normals) {
  Smoother smoother(settings);
  smoother.run(cloud, mesh, normals, out_cloud, out_normals);
}

}  // namespace rangeseg
