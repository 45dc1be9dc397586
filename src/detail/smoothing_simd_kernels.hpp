// One bilateral smoothing pass (src/smoothing.cpp), written against the vector interface of
// detail/simd.hpp. No include guard: smoothing.cpp includes this file once per instruction set,
// inside a namespace that defines `V` (the simd traits) and the function attribute macro
// RANGESEG_KERNEL, after the declarations of PassParams and PassScratch.
//
// One sweep over the lattice rows. Each edge of the 1-ring is evaluated once, from its upper
// (or left) end: lattice row j computes its forward edges (right, down-right, down, down-left)
// and adds each edge's terms straight into the per-pixel sums of both ends, the sums of row j
// and of row j + 1 (two compact accumulator rows that alternate). Contributions to the
// neighbouring column move one lane through a register shift, so every store is aligned to the
// block and nothing but the two accumulator rows is written per row. Once row j's own edges are
// in, its sums are complete and its output is written.
//
// Every pixel's sum receives its terms in a fixed order (from row j - 1: down-right, down,
// down-left; then from row j: right, right-of-left, down-right, down, down-left-of-right), so
// the output does not depend on where a band of rows starts: a band first replays the lattice
// row above it into the sums of its first row. The arithmetic is the same sequence of IEEE
// operations for every vector width, except that mul_add is fused on AVX2 / AVX-512 and the
// reciprocals start from each instruction set's own estimate: widths agree to float rounding.

using F = V::F;
using M = V::M;
constexpr int kLanes = V::kLanes;

/// The terms of kLanes edges.
struct Terms {
  F w, a0, a1, a2, n0, n1, n2;
};

struct Consts {
  F zero, one, max_exponent, inv_intensity;
  F noise_a, noise_b, noise_z0, spacing, kd2, quarter, half_inv_sn, two;
  F ox, oy, oz, tiny;
  M abs_mask;
};

RANGESEG_KERNEL RANGESEG_SIMD_INLINE F abs(F x, const Consts& k) { return (F)((M)x & k.abs_mask); }

/// exp(-a) for a in [0, kMaxExponent]: e^-a = 2^n e^-h with n = round(-a / ln 2) and
/// h = a + n ln 2 (|h| <= ln 2 / 2 = 0.347), e^-h from its degree-4 Taylor polynomial (relative
/// error <= h^5 / 120 < 5e-5, far below what a weight needs; checked in tests against std::exp
/// through the filter output).
RANGESEG_KERNEL RANGESEG_SIMD_INLINE F exp_neg(F a) {
  const F n = V::round_nearest(a * V::set1(-1.44269504f));
  const F h = V::mul_add(n, V::set1(0.693147181f), a);
  F p = V::mul_add(h, V::set1(1.0f / 24), V::set1(-1.0f / 6));
  p = V::mul_add(p, h, V::set1(0.5f));
  p = V::mul_add(p, h, V::set1(-1.0f));
  p = V::mul_add(p, h, V::set1(1.0f));
  return V::scale_pow2(p, n);
}

/// Per-pixel half inverse scales of one lattice row, blocks * kLanes columns: 1 / (4 s_d^2) and
/// 1 / (2 s_n), from the depth-dependent noise sigma(z) and pixel spacing.
template <bool kDistance, bool kNormal>
RANGESEG_KERNEL void scales_row(const float* z, int blocks, const Consts& k, float* hd, float* hn) {
  for (int i = 0; i < blocks * kLanes; i += kLanes) {
    const F zu = V::load(z + i), dz = zu - k.noise_z0;
    const F sigma = k.noise_a + k.noise_b * dz * dz;
    const F spacing = k.spacing * abs(zu, k);
    if constexpr (kDistance) {
      V::store(hd + i, k.quarter * V::reciprocal(k.kd2 * V::mul_add(k.two * sigma, sigma,
                                                                    spacing * spacing)));
    }
    if constexpr (kNormal) {
      const F ratio = spacing * V::reciprocal(sigma);
      V::store(hn + i, k.half_inv_sn * V::min(ratio, k.one));
    }
  }
}

/// Terms of the edges from the points of row `c` at index i to the points at index iq of the
/// row `q_off` elements further on (in every plane of c; 0 = the same row), where bit kBit of
/// `ring` (the edge byte of the edge's first end) says whether the edge exists.
template <bool kDistance, bool kNormal, bool kIntensity, bool kAlongRay, bool kFilterNormals,
          int kBit>
RANGESEG_KERNEL RANGESEG_SIMD_INLINE Terms edge_terms(const InRow& c, const float* hdc,
                                                      const float* hnc, int i, std::ptrdiff_t q_off,
                                                      const float* hdq, const float* hnq, int iq,
                                                      M ring, const Consts& k) {
  const std::ptrdiff_t j = q_off + iq;
  const F cx = V::load(c.x + i), cy = V::load(c.y + i), cz = V::load(c.z + i);
  const F qx = V::load(c.x + j), qy = V::load(c.y + j), qz = V::load(c.z + j);
  const F dx = qx - cx, dy = qy - cy, dz = qz - cz;
  const F dnx = V::load(c.nx + j) - V::load(c.nx + i);
  const F dny = V::load(c.ny + j) - V::load(c.ny + i);
  const F dnz = V::load(c.nz + j) - V::load(c.nz + i);
  const F l1 = abs(dnx, k) + abs(dny, k) + abs(dnz, k);
  F arg = k.zero;
  // Symmetric scales (the sum of both ends' half inverse scales), so that w_ij = w_ji.
  if constexpr (kDistance) {
    const F d2 = V::mul_add(dz, dz, V::mul_add(dy, dy, dx * dx));
    arg = d2 * (V::load(hdc + i) + V::load(hdq + iq));
  }
  if constexpr (kNormal) arg = V::mul_add(l1, V::load(hnc + i) + V::load(hnq + iq), arg);
  if constexpr (kIntensity) {
    arg = V::mul_add(abs(V::load(c.in + j) - V::load(c.in + i), k), k.inv_intensity, arg);
  }
  // NaN (a NaN normal or intensity) fails the comparison.
  const auto use = V::both(V::template bit_selector<kBit>(ring), V::less(arg, k.max_exponent));
  Terms t{};
  t.w = V::keep_selected(exp_neg(V::min(arg, k.max_exponent)), use);
  if constexpr (kAlongRay) {
    t.a0 = V::keep_selected(t.w * V::mul_add(qz, cz, V::mul_add(qy, cy, qx * cx)), use);
  } else {
    t.a0 = V::keep_selected(t.w * dx, use);
    t.a1 = V::keep_selected(t.w * dy, use);
    t.a2 = V::keep_selected(t.w * dz, use);
  }
  if constexpr (kFilterNormals) {
    // Without the normal term a NaN normal at either end must be skipped explicitly.
    const auto use_n = kNormal ? use : V::both(use, V::ordered(l1));
    t.n0 = V::keep_selected(t.w * dnx, use_n);
    t.n1 = V::keep_selected(t.w * dny, use_n);
    t.n2 = V::keep_selected(t.w * dnz, use_n);
  }
  return t;
}

/// Adds `t` (kSign = +1) or its antisymmetric parts negated (kSign = -1: the far end of an
/// edge sees p_i - p_j) to the sums at column i.
template <bool kAlongRay, bool kFilterNormals, int kSign>
RANGESEG_KERNEL RANGESEG_SIMD_INLINE void add_terms(Terms& acc, const Terms& t) {
  acc.w = acc.w + t.w;
  if constexpr (kAlongRay) {
    acc.a0 = acc.a0 + t.a0;
  } else if constexpr (kSign > 0) {
    acc.a0 = acc.a0 + t.a0, acc.a1 = acc.a1 + t.a1, acc.a2 = acc.a2 + t.a2;
  } else {
    acc.a0 = acc.a0 - t.a0, acc.a1 = acc.a1 - t.a1, acc.a2 = acc.a2 - t.a2;
  }
  if constexpr (kFilterNormals) {
    if constexpr (kSign > 0) {
      acc.n0 = acc.n0 + t.n0, acc.n1 = acc.n1 + t.n1, acc.n2 = acc.n2 + t.n2;
    } else {
      acc.n0 = acc.n0 - t.n0, acc.n1 = acc.n1 - t.n1, acc.n2 = acc.n2 - t.n2;
    }
  }
}

/// The terms of lanes i - 1 .. i + kLanes - 2: the last lane of `previous`, then `t`'s first.
template <bool kAlongRay, bool kFilterNormals>
RANGESEG_KERNEL RANGESEG_SIMD_INLINE Terms shifted(const Terms& previous, const Terms& t) {
  Terms s{};
  s.w = V::shift_in(previous.w, t.w);
  s.a0 = V::shift_in(previous.a0, t.a0);
  if constexpr (!kAlongRay) {
    s.a1 = V::shift_in(previous.a1, t.a1);
    s.a2 = V::shift_in(previous.a2, t.a2);
  }
  if constexpr (kFilterNormals) {
    s.n0 = V::shift_in(previous.n0, t.n0);
    s.n1 = V::shift_in(previous.n1, t.n1);
    s.n2 = V::shift_in(previous.n2, t.n2);
  }
  return s;
}

template <bool kAlongRay, bool kFilterNormals>
RANGESEG_KERNEL RANGESEG_SIMD_INLINE Terms load_sums(const SumRow& r, int i) {
  constexpr std::ptrdiff_t L = kLanes;
  const float* p = r.base + 7 * static_cast<std::ptrdiff_t>(i);  // column i's block (i % L == 0)
  Terms t{};
  t.w = V::load(p);
  t.a0 = V::load(p + L);
  if constexpr (!kAlongRay) t.a1 = V::load(p + 2 * L), t.a2 = V::load(p + 3 * L);
  if constexpr (kFilterNormals) {
    t.n0 = V::load(p + 4 * L), t.n1 = V::load(p + 5 * L);
    t.n2 = V::load(p + 6 * L);
  }
  return t;
}
template <bool kAlongRay, bool kFilterNormals>
RANGESEG_KERNEL RANGESEG_SIMD_INLINE void store_sums(const SumRow& r, int i, const Terms& t) {
  constexpr std::ptrdiff_t L = kLanes;
  float* p = r.base + 7 * static_cast<std::ptrdiff_t>(i);
  V::store(p, t.w);
  V::store(p + L, t.a0);
  if constexpr (!kAlongRay) V::store(p + 2 * L, t.a1), V::store(p + 3 * L, t.a2);
  if constexpr (kFilterNormals) {
    V::store(p + 4 * L, t.n0), V::store(p + 5 * L, t.n1);
    V::store(p + 6 * L, t.n2);
  }
}
template <bool kAlongRay, bool kFilterNormals>
RANGESEG_KERNEL RANGESEG_SIMD_INLINE Terms zero_terms(const Consts& k) {
  return Terms{k.zero, k.zero, k.zero, k.zero, k.zero, k.zero, k.zero};
}

/// Output rows of a lattice row (x, y, z and, when normals are filtered, nx, ny, nz).
struct OutRow {
  float *x, *y, *z, *nx, *ny, *nz;
};

/// Output of kLanes pixels at column i of lattice row `c` from their completed sums `s`, into
/// the output rows at `o` (already offset to the block).
template <bool kAlongRay, bool kFilterNormals>
RANGESEG_KERNEL RANGESEG_SIMD_INLINE void finish_block(const InRow& c, const Terms& s, int i,
                                                       const Consts& k, const OutRow& o) {
  const F qx = V::load(c.x + i), qy = V::load(c.y + i), qz = V::load(c.z + i);
  const F sum_w = k.one + s.w;
  if constexpr (kAlongRay) {
    // p' = o + q (q . m) / (q . q) with m the weighted mean of the origin-relative points: the
    // mean projected onto the viewing ray; the centre's own term of the sum is q . q.
    const F qq = V::mul_add(qz, qz, V::mul_add(qy, qy, qx * qx));
    const F sum_t = qq + s.a0;
    // Without a ring term the point stays where it is: the estimated reciprocal is not exact,
    // and qq / qq would move it by an ulp.
    const M moves = (M)(qq > k.zero) & (M)(s.w > k.zero);
    const F scale = V::pick(moves, sum_t * V::reciprocal(sum_w * qq), k.one);
    V::store(o.x, V::mul_add(qx, scale, k.ox));
    V::store(o.y, V::mul_add(qy, scale, k.oy));
    V::store(o.z, V::mul_add(qz, scale, k.oz));
  } else {
    // sum_j w_j p_j / sum_j w_j = p + sum_j w_j (p_j - p) / sum_j w_j.
    const F inv = V::reciprocal(sum_w);
    V::store(o.x, k.ox + qx + s.a0 * inv);
    V::store(o.y, k.oy + qy + s.a1 * inv);
    V::store(o.z, k.oz + qz + s.a2 * inv);
  }
  if constexpr (kFilterNormals) {
    // sum_j w_j n_j = n sum_j w_j + sum_j w_j (n_j - n). Opposite normals can cancel; then (and
    // for NaN) the pixel keeps its normal.
    const F nx = V::load(c.nx + i), ny = V::load(c.ny + i), nz = V::load(c.nz + i);
    const F ax = V::mul_add(nx, sum_w, s.n0), ay = V::mul_add(ny, sum_w, s.n1);
    const F az = V::mul_add(nz, sum_w, s.n2);
    const F len2 = V::mul_add(az, az, V::mul_add(ay, ay, ax * ax));
    const M ok = (M)(len2 > k.tiny);
    const F inv = V::rsqrt(V::pick(ok, len2, k.one));
    V::store(o.nx, V::pick(ok, ax * inv, nx));
    V::store(o.ny, V::pick(ok, ay * inv, ny));
    V::store(o.nz, V::pick(ok, az * inv, nz));
  }
}

/// finish_block for the block at column i of a row of `count` pixels: a last partial block
/// goes through a buffer, so nothing outside the row is written.
template <bool kAlongRay, bool kFilterNormals>
RANGESEG_KERNEL RANGESEG_SIMD_INLINE void finish(const InRow& c, const Terms& s, int i, int count,
                                                 const Consts& k, const OutRow& out) {
  if (i + kLanes <= count) {
    const OutRow o{out.x + i, out.y + i, out.z + i, out.nx + i, out.ny + i, out.nz + i};
    finish_block<kAlongRay, kFilterNormals>(c, s, i, k, o);
    return;
  }
  float t[6][kLanes];
  finish_block<kAlongRay, kFilterNormals>(c, s, i, k, OutRow{t[0], t[1], t[2], t[3], t[4], t[5]});
  for (int lane = 0; i + lane < count; ++lane) {
    out.x[i + lane] = t[0][lane], out.y[i + lane] = t[1][lane], out.z[i + lane] = t[2][lane];
    if constexpr (kFilterNormals) {
      out.nx[i + lane] = t[3][lane], out.ny[i + lane] = t[4][lane], out.nz[i + lane] = t[5][lane];
    }
  }
}

/// Outputs of columns [0, count) of a lattice row from its completed sums. (A separate sweep:
/// inside edges_row the extra live vectors cost more than the sums' round trip through L1.)
/// Unless `out_ahead` is 0, the output rows that many elements further on are prefetched for
/// writing (see edges_row).
template <bool kAlongRay, bool kFilterNormals>
RANGESEG_KERNEL void finish_row(const InRow& in, const SumRow& sums, int count, const Consts& k,
                                const OutRow& out_row, std::ptrdiff_t out_ahead) {
  // Local copies: the compiler cannot tell that the output stores leave the row pointers
  // unchanged, and would reload them from the referenced structs every block.
  const InRow c = in;
  const OutRow out = out_row;
  int i = 0;
  for (; i + kLanes <= count; i += kLanes) {
    const OutRow o{out.x + i, out.y + i, out.z + i, out.nx + i, out.ny + i, out.nz + i};
    if (out_ahead != 0) {
      __builtin_prefetch(o.x + out_ahead, 1);
      __builtin_prefetch(o.y + out_ahead, 1);
      __builtin_prefetch(o.z + out_ahead, 1);
      if constexpr (kFilterNormals) {
        __builtin_prefetch(o.nx + out_ahead, 1);
        __builtin_prefetch(o.ny + out_ahead, 1);
        __builtin_prefetch(o.nz + out_ahead, 1);
      }
    }
    finish_block<kAlongRay, kFilterNormals>(c, load_sums<kAlongRay, kFilterNormals>(sums, i), i, k,
                                            o);
  }
  if (i < count) {
    finish<kAlongRay, kFilterNormals>(c, load_sums<kAlongRay, kFilterNormals>(sums, i), i, count, k,
                                      out);
  }
}

/// The forward edges of lattice row `c` (with the row below `q_off` elements further on in
/// every plane; 0 on the last row, where no downward edge exists): their terms into the sums of
/// both ends, `own` (this row, which holds the terms of the edges from the row above) and
/// `next` (the row below, overwritten: no other row adds to it before). One offset rather than
/// a second set of row pointers keeps the pointers in registers. Unless `ahead` is 0, the input
/// rows `ahead` elements further on are prefetched: the pass streams some 16 planes at once,
/// more than the hardware prefetchers follow, and a block is about one cache line per plane
/// (measured 4-10 % faster).
template <bool kDistance, bool kNormal, bool kIntensity, bool kAlongRay, bool kFilterNormals>
RANGESEG_KERNEL void edges_row(const InRow& c, const float* hdc, const float* hnc,
                               std::ptrdiff_t q_off, std::ptrdiff_t ahead, const float* hdq,
                               const float* hnq, const std::uint8_t* edges, int blocks,
                               const Consts& k, const SumRow& own, const SumRow& next) {
#define RANGESEG_TERMS(ci, off, hdq_, hnq_, qi, ring, bit)                    \
  edge_terms<kDistance, kNormal, kIntensity, kAlongRay, kFilterNormals, bit>( \
      c, hdc, hnc, ci, off, hdq_, hnq_, qi, ring, k)
  Terms prev_right = zero_terms<kAlongRay, kFilterNormals>(k);
  Terms prev_down_right = prev_right, prev_down_left = prev_right;
  const Terms none = prev_right;
  for (int i = 0; i < blocks * kLanes; i += kLanes) {
    if (ahead != 0) {
      __builtin_prefetch(c.x + ahead + i);
      __builtin_prefetch(c.y + ahead + i);
      __builtin_prefetch(c.z + ahead + i);
      __builtin_prefetch(c.nx + ahead + i);
      __builtin_prefetch(c.ny + ahead + i);
      __builtin_prefetch(c.nz + ahead + i);
      if constexpr (kIntensity) __builtin_prefetch(c.in + ahead + i);
    }
    // A block whose pixels, and the pixels either side, have no edge (holes, outside the
    // sensor's range) adds nothing: every term would be +0.
    std::uint8_t any_edge = 0;
    for (int b = -1; b <= kLanes; ++b) any_edge |= edges[i + b];
    if (any_edge == 0) {
      prev_right = none, prev_down_right = none, prev_down_left = none;
      store_sums<kAlongRay, kFilterNormals>(next, i, none);
      continue;
    }
    const M ring = V::bytes_to_lanes(edges + i);
    // Each direction's terms go into the sums as soon as they exist, so that few vectors are
    // live at once. Edges leaving columns i ..: right and down-right end one column further
    // right; the down-left edges are those leaving columns i + 1 .., ending in columns i ...
    Terms sums = load_sums<kAlongRay, kFilterNormals>(own, i);
    Terms below = none;
    const Terms right = RANGESEG_TERMS(i, 0, hdc, hnc, i + 1, ring, 0);
    add_terms<kAlongRay, kFilterNormals, 1>(sums, right);
    add_terms<kAlongRay, kFilterNormals, -1>(sums,
                                             shifted<kAlongRay, kFilterNormals>(prev_right, right));
    prev_right = right;
    const Terms down_right = RANGESEG_TERMS(i, q_off, hdq, hnq, i + 1, ring, 1);
    add_terms<kAlongRay, kFilterNormals, 1>(sums, down_right);
    add_terms<kAlongRay, kFilterNormals, -1>(
        below, shifted<kAlongRay, kFilterNormals>(prev_down_right, down_right));
    prev_down_right = down_right;
    const Terms down = RANGESEG_TERMS(i, q_off, hdq, hnq, i, ring, 2);
    add_terms<kAlongRay, kFilterNormals, 1>(sums, down);
    add_terms<kAlongRay, kFilterNormals, -1>(below, down);
    const Terms down_left =
        RANGESEG_TERMS(i + 1, q_off, hdq, hnq, i, V::bytes_to_lanes(edges + i + 1), 3);
    add_terms<kAlongRay, kFilterNormals, 1>(
        sums, shifted<kAlongRay, kFilterNormals>(prev_down_left, down_left));
    add_terms<kAlongRay, kFilterNormals, -1>(below, down_left);
    prev_down_left = down_left;
    store_sums<kAlongRay, kFilterNormals>(own, i, sums);
    store_sums<kAlongRay, kFilterNormals>(next, i, below);
  }
#undef RANGESEG_TERMS
}

RANGESEG_KERNEL inline Consts make_consts(const PassParams& prm) {
  Consts k{};
  k.zero = V::set1(0.0f);
  k.one = V::set1(1.0f);
  k.two = V::set1(2.0f);
  k.quarter = V::set1(0.25f);
  k.max_exponent = V::set1(kMaxExponent);
  k.inv_intensity = V::set1(prm.inv_intensity_scale);
  k.abs_mask = V::set1i(0x7fffffff);
  k.noise_a = V::set1(prm.noise_a);
  k.noise_b = V::set1(prm.noise_b);
  k.noise_z0 = V::set1(prm.noise_z0);
  k.spacing = V::set1(prm.spacing);
  k.kd2 = V::set1(prm.kd2);
  k.half_inv_sn = V::set1(0.5f * prm.inv_normal_scale);
  k.ox = V::set1(prm.origin[0]);
  k.oy = V::set1(prm.origin[1]);
  k.oz = V::set1(prm.origin[2]);
  k.tiny = V::set1(1e-12f);
  return k;
}

/// Output rows [v0, v1) of one pass (see PassFn in smoothing.cpp).
template <bool kDistance, bool kNormal, bool kIntensity, bool kAlongRay, bool kFilterNormals>
RANGESEG_KERNEL void pass(const OrganizedCloud& src, const NormalMap& nm, const Mesh& mesh,
                          const PassParams& prm, PassScratch& scratch, OrganizedCloud& dst,
                          NormalMap& dst_normals, int v0, int v1) {
  const int width = src.width(), height = src.height(), s = prm.stride;
  const int n = (width - 1) / s + 1, m = (height - 1) / s + 1;
  const int blocks = (n + kLanes - 1) / kLanes;
  const PassLayout lay = scratch.lay_out(blocks * kLanes, kLanes);
  const Consts k = make_consts(prm);

  // Rows without vertices (v % s != 0) and, at stride > 1, the columns between vertices keep
  // their input (the output planes are written in full).
  if (s > 1) {
    for (int v = v0; v < v1; ++v) {
      copy_row<kFilterNormals>(src, nm, prm, v, dst, dst_normals);
      copy_curvature_row(prm, v);
    }
  }
  const int j_begin = (v0 + s - 1) / s, j_end = std::min(m, (v1 + s - 1) / s);
  if (j_begin >= j_end) return;

  // Rows are read in place where every plane has the same row stride (so that one offset
  // reaches the row below in all of them) and the reads stay inside the planes; else, and for
  // a last row whose reads would leave the planes, rows j and j + 1 are copied into the slots.
  const std::ptrdiff_t plane_stride = common_stride(src, nm, prm);
  // The output planes all have the cloud's size, hence one stride; the rows two ahead are
  // prefetched for writing (a prefetch never faults, so nothing depends on it being exact).
  const std::ptrdiff_t out_stride = dst.z.stride();
  const int len = blocks * kLanes;
  const bool in_place = s == 1 && plane_stride > 0 && len < 2 * plane_stride;
  const auto readable = [&](int j) { return in_place && (j + 1 < m || len < plane_stride); };
  // A band starting below row 0 first replays the lattice row above it for its first row's sums.
  const int j_start = std::max(j_begin - 1, 0);
  int cur = 0;  // slot of row j's scales and sums (and inputs if copied); row j + 1 uses 1 - cur
  bool c_copied = false;  // row j is already in slot cur
  lay.clear_sums(cur);    // the first row's edges from above: none (or replayed)
  for (int j = j_start; j < j_end; ++j) {
    const int nxt = 1 - cur;
    const bool has_below = j + 1 < m;
    InRow c;
    std::ptrdiff_t q_off = 0;
    const bool both_in_place = readable(j) && (!has_below || readable(j + 1));
    if (both_in_place) {
      c = plane_row(src, nm, prm, j);
      q_off = has_below ? plane_stride : 0;
      c_copied = false;
    } else {
      c = copy_lattice_row(src, nm, prm, lay, j, s, n, cur, c_copied);
      if (has_below) {
        copy_lattice_row(src, nm, prm, lay, j + 1, s, n, nxt, false);
        q_off = lay.input(nxt, 0) - lay.input(cur, 0);
      }
      c_copied = has_below;
    }
    if constexpr (kDistance || kNormal) {
      if (j == j_start) scales_row<kDistance, kNormal>(c.z, blocks, k, lay.hd(cur), lay.hn(cur));
      if (has_below) {
        scales_row<kDistance, kNormal>(c.z + q_off, blocks, k, lay.hd(nxt), lay.hn(nxt));
      }
    }
    const float* hdq = has_below ? lay.hd(nxt) : lay.hd(cur);
    const float* hnq = has_below ? lay.hn(nxt) : lay.hn(cur);
    const std::uint8_t* edges = lay.edge_bytes(mesh, j, s, n);
    const int v = j * s;
    float* o = lay.compact();
    const std::size_t ol = lay.row_len;
    const OutRow out =
        s == 1 ? OutRow{dst.x.row(v),          dst.y.row(v),          dst.z.row(v),
                        dst_normals.nx.row(v), dst_normals.ny.row(v), dst_normals.nz.row(v)}
               : OutRow{o, o + ol, o + 2 * ol, o + 3 * ol, o + 4 * ol, o + 5 * ol};
    const bool output = j >= j_begin;  // else the replayed row above a band
    const std::ptrdiff_t ahead =
        both_in_place && j + 2 < m && readable(j + 2) ? 2 * plane_stride : 0;
    edges_row<kDistance, kNormal, kIntensity, kAlongRay, kFilterNormals>(
        c, lay.hd(cur), lay.hn(cur), q_off, ahead, hdq, hnq, edges, blocks, k, lay.sums(cur),
        lay.sums(nxt));
    if (output) {
      const std::ptrdiff_t out_ahead = s == 1 && v + 2 < height ? 2 * out_stride : 0;
      finish_row<kAlongRay, kFilterNormals>(c, lay.sums(cur), n, k, out, out_ahead);
      if (s == 1) {
        copy_curvature_row(prm, v);
      } else {
        scatter_row<kFilterNormals>(o, ol, n, s, v, dst, dst_normals);
      }
    }
    cur = nxt;
  }
}
