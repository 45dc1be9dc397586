// Row kernels of build_mesh (src/mesh.cpp), written against the vector interface of
// detail/simd.hpp. No include guard: mesh.cpp includes this file once per instruction set,
// inside a namespace that defines `V` (the simd traits) and the function attribute macro
// RANGESEG_KERNEL, and after the declarations of PixelRow, EdgeParams and the bit constants.
//
// All buffers are lattice rows padded on the right (see build_mesh_rows for the sizes), so every
// kernel works on whole vectors; padding pixels are NaN points, whose edges are all invalid.

using F = V::F;
using M = V::M;
using B = V::B;
constexpr int kLanes = V::kLanes;
constexpr int kBlock = 4 * kLanes;  // cells per byte vector

// Pass 1: per-pixel quantities of `count` points of one row, relative to the viewpoint.
// (Parameters are copied into local vectors and row pointers into locals: the vector stores
// may alias anything, so members read through a reference would be reloaded after each.)
struct QuantityConsts {
  F vx, vy, vz, cos2, a, bs, c, na, nb, nz0, k2, zero, inf, nan;
};
RANGESEG_KERNEL RANGESEG_SIMD_INLINE void quantities_block(F x, F y, F z, const QuantityConsts& p,
                                                           PixelRow out, int i) {
  const F r2 = x * x + y * y + z * z;
  // A point with an infinite coordinate (e.g. "no return" in REP 117) or so far away that r^2
  // overflows is no point: its x becomes NaN, so that its edges fail on their NaN length as a
  // NaN point's do (with an infinite range, eps_d and the noise gate would pass them).
  V::store(out.x + i, V::pick((M)(r2 < p.inf), x, p.nan));
  V::store(out.y + i, y);
  V::store(out.z + i, z);
  V::store(out.cos2_r2 + i, p.cos2 * r2);
  // NaN points get range 0 (maxps returns its second operand for NaN); their edges fail on
  // their NaN length.
  const F r = V::sqrt(V::max(r2, p.zero));
  V::store(out.range + i, r);
  const F eps = p.a + r * (p.bs + p.c * r);
  const F dr = r - p.nz0;
  const F sigma = p.na + p.nb * dr * dr;
  V::store(out.max_len2 + i, eps * eps);
  V::store(out.noise_var + i, p.k2 * sigma * sigma);
}

RANGESEG_KERNEL void pixel_quantities(const float* __restrict xs, const float* __restrict ys,
                                      const float* __restrict zs, int count,
                                      const EdgeParams& params, const PixelRow& row) {
  const QuantityConsts p{V::set1(params.vx),   V::set1(params.vy), V::set1(params.vz),
                         V::set1(params.cos2), V::set1(params.a),  V::set1(params.bs),
                         V::set1(params.c),    V::set1(params.na), V::set1(params.nb),
                         V::set1(params.nz0),  V::set1(params.k2), V::set1(0.0f),
                         V::set1(kInf),        V::set1(kNaN)};
  const PixelRow out = row;
  int i = 0;
  for (; i + kLanes <= count; i += kLanes) {
    quantities_block(V::load(xs + i) - p.vx, V::load(ys + i) - p.vy, V::load(zs + i) - p.vz, p, out,
                     i);
  }
  if (i < count) {  // the last partial vector, padded with NaN points
    float tx[kLanes], ty[kLanes], tz[kLanes];
    for (int k = 0; k < kLanes; ++k) {
      const bool in = i + k < count;
      tx[k] = in ? xs[i + k] : kNaN;
      ty[k] = in ? ys[i + k] : kNaN;
      tz[k] = in ? zs[i + k] : kNaN;
    }
    quantities_block(V::load(tx) - p.vx, V::load(ty) - p.vy, V::load(tz) - p.vz, p, out, i);
  }
}

// Edge p -> q (paper, eq. 1 plus the noise gate documented in mesh.hpp). eps_d is monotonic in
// the range, so eps_d(max range)^2 is the larger of the two per-pixel values. A NaN end makes
// len2 NaN and every comparison with it false. `len2` is returned for the diagonal comparison.
struct EdgePoint {
  F x, y, z, r, l, v;
};
RANGESEG_KERNEL RANGESEG_SIMD_INLINE EdgePoint edge_point(PixelRow row, int i) {
  return {V::load(row.x + i),     V::load(row.y + i),        V::load(row.z + i),
          V::load(row.range + i), V::load(row.max_len2 + i), V::load(row.noise_var + i)};
}
RANGESEG_KERNEL RANGESEG_SIMD_INLINE M edge_ok(const EdgePoint& p, F p_cos2_r2, const EdgePoint& q,
                                               F& len2) {
  const F ex = q.x - p.x, ey = q.y - p.y, ez = q.z - p.z;
  len2 = ex * ex + ey * ey + ez * ez;
  const F dot = ex * p.x + ey * p.y + ez * p.z;
  const F dr = p.r - q.r;
  const F lim = V::max(p.l, q.l);
  return (M)(len2 <= lim) & ((M)(dot * dot <= len2 * p_cos2_r2) | (M)(dr * dr <= p.v + q.v));
}

// Pass 2: for `blocks` * kBlock cells with top-left vertex a in row `top`, the edges a-b, a-d,
// a-c, b-c and "a-d not longer than b-c" as kEdge* bits; `below` is null on the last row (then
// only a-b).
RANGESEG_KERNEL void edge_bits(const PixelRow& top_row, const PixelRow* below_row, int blocks,
                               std::uint8_t* __restrict out) {
  const PixelRow top = top_row;
  const M bit_ab = V::set1i(kEdgeAB);
  if (below_row == nullptr) {
    for (int blk = 0; blk < blocks; ++blk) {
      M bits[4];
      for (int part = 0; part < 4; ++part) {
        const int i = blk * kBlock + part * kLanes;
        F len2_ab;
        bits[part] =
            edge_ok(edge_point(top, i), V::load(top.cos2_r2 + i), edge_point(top, i + 1), len2_ab) &
            bit_ab;
      }
      V::storeb(out + static_cast<std::ptrdiff_t>(blk) * kBlock,
                V::pack4(bits[0], bits[1], bits[2], bits[3]));
    }
    return;
  }
  const PixelRow below = *below_row;
  const M bit_ad = V::set1i(kEdgeAD), bit_ac = V::set1i(kEdgeAC), bit_bc = V::set1i(kEdgeBC);
  const M bit_shorter = V::set1i(kAdNotLonger);
  for (int blk = 0; blk < blocks; ++blk) {
    M bits[4];
    for (int part = 0; part < 4; ++part) {
      const int i = blk * kBlock + part * kLanes;
      const EdgePoint a = edge_point(top, i), b = edge_point(top, i + 1);
      const EdgePoint c = edge_point(below, i), d = edge_point(below, i + 1);
      const F a_cos2_r2 = V::load(top.cos2_r2 + i), b_cos2_r2 = V::load(top.cos2_r2 + i + 1);
      F len2_ab, len2_ad, len2_ac, len2_bc;
      const M ab = edge_ok(a, a_cos2_r2, b, len2_ab);
      const M ad = edge_ok(a, a_cos2_r2, d, len2_ad);
      const M ac = edge_ok(a, a_cos2_r2, c, len2_ac);
      const M bc = edge_ok(b, b_cos2_r2, c, len2_bc);
      const M shorter = (M)(len2_ad <= len2_bc);
      bits[part] =
          (ab & bit_ab) | (ad & bit_ad) | (ac & bit_ac) | (bc & bit_bc) | (shorter & bit_shorter);
    }
    V::storeb(out + static_cast<std::ptrdiff_t>(blk) * kBlock,
              V::pack4(bits[0], bits[1], bits[2], bits[3]));
  }
}

// The faces of a cell and which of its edges belong to a face (all-ones / zero byte masks),
// from the kEdge* bits of the cell (`e`), of its right neighbour (its a-c is the cell's b-d)
// and of the cell below (its a-b is the cell's c-d).
struct CellFaces {
  B t0, t1, q, cut_bc;
  B e_ab, e_cd, e_ac, e_bd, e_ad, e_bc;
};
RANGESEG_KERNEL RANGESEG_SIMD_INLINE B has(B x, std::uint8_t bit) { return (B)((x & bit) == bit); }
template <MeshType kType>
RANGESEG_KERNEL RANGESEG_SIMD_INLINE CellFaces cell_faces(B e, B e_right, B e_below) {
  const B ab = has(e, kEdgeAB), ad = has(e, kEdgeAD), ac = has(e, kEdgeAC), bc = has(e, kEdgeBC);
  const B bd = has(e_right, kEdgeAC), cd = has(e_below, kEdgeAB);
  const B ad0 = ab & ad & bd, ad1 = ac & cd & ad;  // (a,d,b), (a,c,d)
  const B bc0 = ab & ac & bc, bc1 = bc & cd & bd;  // (a,c,b), (b,c,d)
  const B none{};
  CellFaces f{none, none, none, none, none, none, none, none, none, none};
  if constexpr (kType == MeshType::quad) {
    f.q = ab & ac & bd & cd;
  } else if constexpr (kType == MeshType::right_cut) {
    f.t0 = ad0, f.t1 = ad1;
  } else if constexpr (kType == MeshType::left_cut) {
    f.t0 = bc0, f.t1 = bc1, f.cut_bc = bc0 | bc1;
  } else {
    // More triangles along b-c, or as many (and at least one) with a-d the longer diagonal.
    const B both_ad = ad0 & ad1, any_ad = ad0 | ad1, both_bc = bc0 & bc1, any_bc = bc0 | bc1;
    const B more_bc = (both_bc & ~both_ad) | (any_bc & ~any_ad);
    const B same = ~((both_bc ^ both_ad) | (any_bc ^ any_ad));
    f.cut_bc = more_bc | (same & ~has(e, kAdNotLonger) & any_bc);
    const B keep_ad = ~f.cut_bc;
    f.t0 = (f.cut_bc & bc0) | (keep_ad & ad0);
    f.t1 = (f.cut_bc & bc1) | (keep_ad & ad1);
  }
  const B any = f.t0 | f.t1, keep_ad = ~f.cut_bc;
  f.e_ab = f.q | f.t0;
  f.e_cd = f.q | f.t1;
  f.e_ac = f.q | (f.cut_bc & f.t0) | (keep_ad & f.t1);
  f.e_bd = f.q | (f.cut_bc & f.t1) | (keep_ad & f.t0);
  f.e_ad = keep_ad & any;
  f.e_bc = f.cut_bc & any;
  return f;
}

// Pass 3 for one lattice row: the faces of its cells and the 1-ring of its vertices. Vertex i
// collects the bits of cell i (as its corner a), of cell i - 1 (corner b) and, from the row
// above, `from_above[i]` (corners c and d of the cells above); `to_below` receives the same for
// the next row. `cand` and `cand_below` are the edge bits of this row and the next; both have a
// zero at index -1 and are readable up to blocks * kBlock + 1.
template <MeshType kType>
RANGESEG_KERNEL void faces_and_rings(const std::uint8_t* __restrict cand,
                                     const std::uint8_t* __restrict cand_below,
                                     const std::uint8_t* __restrict from_above, int blocks,
                                     std::uint8_t* __restrict faces, std::uint8_t* __restrict edges,
                                     std::uint8_t* __restrict to_below) {
  for (int blk = 0; blk < blocks; ++blk) {
    const int i = blk * kBlock;
    const B e_left = V::loadb(cand + i - 1), e = V::loadb(cand + i);
    const B e_right = V::loadb(cand + i + 1);
    const B below_left = V::loadb(cand_below + i - 1), below = V::loadb(cand_below + i);
    const CellFaces here = cell_faces<kType>(e, e_right, below);
    const CellFaces left = cell_faces<kType>(e_left, e, below_left);
    V::storeb(faces + i, (here.t0 & face_bits::tri0) | (here.t1 & face_bits::tri1) |
                             (here.q & face_bits::quad) | (here.cut_bc & face_bits::diag_bc));
    const B as_a = (here.e_ab & kR) | (here.e_ad & kDR) | (here.e_ac & kD);
    const B as_b = (left.e_ab & kL) | (left.e_bd & kD) | (left.e_bc & kDL);
    V::storeb(edges + i, as_a | as_b | V::loadb(from_above + i));
    const B as_c = (here.e_cd & kR) | (here.e_ac & kU) | (here.e_bc & kUR);
    const B as_d = (left.e_cd & kL) | (left.e_bd & kU) | (left.e_ad & kUL);
    V::storeb(to_below + i, as_c | as_d);
  }
}
