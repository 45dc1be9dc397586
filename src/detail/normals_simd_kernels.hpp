// Row kernels of compute_normals (src/normals.cpp), written against the vector interface of
// detail/simd.hpp. No include guard: normals.cpp includes this file once per instruction set,
// inside a namespace that defines `V` (the simd traits) and the function attribute macro
// RANGESEG_KERNEL, and after the declarations of PointRow and Vec3Row.
//
// Inputs are padded lattice rows (see compute_normals_rows): points readable from index -1 to
// the end of the last vector + 1 (padding NaN), face and edge bytes up to the end of the last
// vector (padding 0), so every kernel works on whole vectors.

using F = V::F;
using M = V::M;
constexpr int kLanes = V::kLanes;

RANGESEG_KERNEL RANGESEG_SIMD_INLINE M has_bit(M bits, M bit) { return (M)(bits & bit) == bit; }

// What one cell's faces add to the normal sums of its corners a, b, c, d (the unnormalised
// cross products, twice the face area times the unit normal). Faces are selected, not
// multiplied by 0/1: a face with an invalid corner has a NaN cross product that a
// multiplication would keep; a cell without faces adds +0.
struct Corners {
  F ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz;
};
template <bool kQuad>
RANGESEG_KERNEL RANGESEG_SIMD_INLINE Corners cell_block(PointRow top, PointRow bottom, M f, int i) {
  const int w = i + 1;
  const F ax = V::load(top.x + i), ay = V::load(top.y + i), az = V::load(top.z + i);
  const F bx = V::load(top.x + w), by = V::load(top.y + w), bz = V::load(top.z + w);
  const F cx = V::load(bottom.x + i), cy = V::load(bottom.y + i), cz = V::load(bottom.z + i);
  const F dx = V::load(bottom.x + w), dy = V::load(bottom.y + w), dz = V::load(bottom.z + w);
  if constexpr (kQuad) {
    // Quad (a,c,d,b): the cross product of the diagonals is twice its vector area.
    const F ex = dx - ax, ey = dy - ay, ez = dz - az;
    const F gx = bx - cx, gy = by - cy, gz = bz - cz;
    const M q = has_bit(f, V::set1i(face_bits::quad));
    const F qx = V::keep(ey * gz - ez * gy, q), qy = V::keep(ez * gx - ex * gz, q);
    const F qz = V::keep(ex * gy - ey * gx, q);
    return {qx, qy, qz, qx, qy, qz, qx, qy, qz, qx, qy, qz};
  } else {
    // Diagonal a-d: t0 = (a,d,b), t1 = (a,c,d); diagonal b-c: t0 = (a,c,b), t1 = (b,c,d).
    const M bc = has_bit(f, V::set1i(face_bits::diag_bc));
    const F px = V::pick(bc, cx, dx), py = V::pick(bc, cy, dy), pz = V::pick(bc, cz, dz);
    const F rx = V::pick(bc, bx, ax), ry = V::pick(bc, by, ay), rz = V::pick(bc, bz, az);
    const F e0x = px - ax, e0y = py - ay, e0z = pz - az;
    const F g0x = bx - ax, g0y = by - ay, g0z = bz - az;
    const F e1x = cx - rx, e1y = cy - ry, e1z = cz - rz;
    const F g1x = dx - rx, g1y = dy - ry, g1z = dz - rz;
    const M k0 = has_bit(f, V::set1i(face_bits::tri0));
    const M k1 = has_bit(f, V::set1i(face_bits::tri1));
    const F t0x = V::keep(e0y * g0z - e0z * g0y, k0), t0y = V::keep(e0z * g0x - e0x * g0z, k0);
    const F t0z = V::keep(e0x * g0y - e0y * g0x, k0);
    const F t1x = V::keep(e1y * g1z - e1z * g1y, k1), t1y = V::keep(e1z * g1x - e1x * g1z, k1);
    const F t1z = V::keep(e1x * g1y - e1y * g1x, k1);
    // The diagonal's ends touch both triangles, the other two corners one each.
    const F sx = t0x + t1x, sy = t0y + t1y, sz = t0z + t1z;
    return {V::pick(bc, t0x, sx), V::pick(bc, t0y, sy), V::pick(bc, t0z, sz), V::pick(bc, sx, t0x),
            V::pick(bc, sy, t0y), V::pick(bc, sz, t0z), V::pick(bc, sx, t1x), V::pick(bc, sy, t1y),
            V::pick(bc, sz, t1z), V::pick(bc, t1x, sx), V::pick(bc, t1y, sy), V::pick(bc, t1z, sz)};
  }
}

// Cells and normals of lattice row `top`, in one pass: the normal sum of vertex i is
//   (a of cell i + b of cell i - 1) + (c of cell i above + d of cell i - 1 above),
// the second half computed by the previous row's pass (`above`, 3 rows x, y, z). Each cell is
// computed once; its b and d reach vertex i + 1 through a one-lane shift, carried from block to
// block. The sum is normalised and oriented towards the viewpoint into lattice columns
// [0, count) of nx, ny, nz; `below` receives this row's c + d sums for the next row.
// `bottom` and `faces` are those of the cell row under `top` (no faces on the last row).
struct NormalConsts {
  F vx, vy, vz, zero, one, nan;
  M sign;
};
template <bool kQuad>
RANGESEG_KERNEL RANGESEG_SIMD_INLINE void cell_normal_block(
    PointRow top, PointRow bottom, const std::uint8_t* faces, Vec3Row above, Vec3Row below,
    const NormalConsts& k, int i, Corners& previous, float* onx, float* ony, float* onz) {
  // (Only b and d of `previous` are read.)
  const Corners cell = cell_block<kQuad>(top, bottom, V::bytes_to_lanes(faces + i), i);
  // b and d of cell i - 1 for vertex i.
  const F bx = V::shift_in(previous.bx, cell.bx), by = V::shift_in(previous.by, cell.by);
  const F bz = V::shift_in(previous.bz, cell.bz);
  const F dx = V::shift_in(previous.dx, cell.dx), dy = V::shift_in(previous.dy, cell.dy);
  const F dz = V::shift_in(previous.dz, cell.dz);
  previous = cell;
  V::store(below.x + i, cell.cx + dx);
  V::store(below.y + i, cell.cy + dy);
  V::store(below.z + i, cell.cz + dz);
  const F sx = (cell.ax + bx) + V::load(above.x + i);
  const F sy = (cell.ay + by) + V::load(above.y + i);
  const F sz = (cell.az + bz) + V::load(above.z + i);
  const F len2 = sx * sx + sy * sy + sz * sz;
  const F inv = V::pick((M)(len2 > k.zero), k.one / V::sqrt(len2), k.nan);
  const F px = V::load(top.x + i), py = V::load(top.y + i), pz = V::load(top.z + i);
  F nx = sx * inv, ny = sy * inv, nz = sz * inv;
  const F facing = nx * (k.vx - px) + ny * (k.vy - py) + nz * (k.vz - pz);
  const M flip = (M)facing & k.sign;
  V::store(onx, (F)((M)nx ^ flip));
  V::store(ony, (F)((M)ny ^ flip));
  V::store(onz, (F)((M)nz ^ flip));
}

template <bool kQuad>
RANGESEG_KERNEL void cell_normal_row(PointRow top, PointRow bottom,
                                     const std::uint8_t* __restrict faces, const Vec3Row& above_row,
                                     const Vec3Row& below_row, const float* viewpoint, int count,
                                     float* __restrict nx, float* __restrict ny,
                                     float* __restrict nz) {
  const Vec3Row above = above_row, below = below_row;
  const NormalConsts k{V::set1(viewpoint[0]),
                       V::set1(viewpoint[1]),
                       V::set1(viewpoint[2]),
                       V::set1(0.0f),
                       V::set1(1.0f),
                       V::set1(kNaN),
                       V::set1i(static_cast<int>(0x80000000u))};
  // Nothing left of column 0: the carried b and d start at +0.
  Corners previous{k.zero, k.zero, k.zero, k.zero, k.zero, k.zero,
                   k.zero, k.zero, k.zero, k.zero, k.zero, k.zero};
  int i = 0;
  for (; i + kLanes <= count; i += kLanes) {
    cell_normal_block<kQuad>(top, bottom, faces, above, below, k, i, previous, nx + i, ny + i,
                             nz + i);
  }
  if (i < count) {  // the last partial vector, through a buffer
    float tx[kLanes], ty[kLanes], tz[kLanes];
    cell_normal_block<kQuad>(top, bottom, faces, above, below, k, i, previous, tx, ty, tz);
    for (int lane = 0; i + lane < count; ++lane) {
      nx[i + lane] = tx[lane], ny[i + lane] = ty[lane], nz[i + lane] = tz[lane];
    }
  }
}

// One neighbour of the 1-ring: adds q - p to the sum and |q - p|^2 to the spread when bit kBit
// of the ring is set (then q is a valid point), +0 otherwise.
template <int kBit>
RANGESEG_KERNEL RANGESEG_SIMD_INLINE void ring_add(M ring, F px, F py, F pz, const float* qx,
                                                   const float* qy, const float* qz, F& sx, F& sy,
                                                   F& sz, F& spread) {
  const typename V::Selector on = V::template bit_selector<kBit>(ring);
  const F dx = V::keep_selected(V::load(qx) - px, on);
  const F dy = V::keep_selected(V::load(qy) - py, on);
  const F dz = V::keep_selected(V::load(qz) - pz, on);
  sx = sx + dx, sy = sy + dy, sz = sz + dz;
  spread = spread + (dx * dx + dy * dy + dz * dz);
}

// Vertex row, pass 2: the curvature 2 |sum (q - p) . n| / sum |q - p|^2 over the ring
// neighbours q in Mesh::edges, with n the normals of pass 1, into columns [0, count) of `out`.
struct CurvatureConsts {
  F two, nan;
  M abs, none;
};
// nx, ny, nz and out point at column i.
RANGESEG_KERNEL RANGESEG_SIMD_INLINE void curvature_block(PointRow up, PointRow mid, PointRow down,
                                                          const std::uint8_t* edges,
                                                          const float* nx, const float* ny,
                                                          const float* nz, const CurvatureConsts& k,
                                                          int i, float* out) {
  const F px = V::load(mid.x + i), py = V::load(mid.y + i), pz = V::load(mid.z + i);
  const M ring = V::bytes_to_lanes(edges + i);
  const int l = i - 1, r = i + 1;
  // kNeighbourDu/Dv order: right, down-right, down, down-left, left, up-left, up, up-right.
  // The sums start with the first term rather than +0 + term: that differs only in the sign of
  // a zero sum, which |sum . n| does not see.
  const typename V::Selector on = V::template bit_selector<0>(ring);
  F ax = V::keep_selected(V::load(mid.x + r) - px, on);
  F ay = V::keep_selected(V::load(mid.y + r) - py, on);
  F az = V::keep_selected(V::load(mid.z + r) - pz, on);
  F spread = ax * ax + ay * ay + az * az;
  ring_add<1>(ring, px, py, pz, down.x + r, down.y + r, down.z + r, ax, ay, az, spread);
  ring_add<2>(ring, px, py, pz, down.x + i, down.y + i, down.z + i, ax, ay, az, spread);
  ring_add<3>(ring, px, py, pz, down.x + l, down.y + l, down.z + l, ax, ay, az, spread);
  ring_add<4>(ring, px, py, pz, mid.x + l, mid.y + l, mid.z + l, ax, ay, az, spread);
  ring_add<5>(ring, px, py, pz, up.x + l, up.y + l, up.z + l, ax, ay, az, spread);
  ring_add<6>(ring, px, py, pz, up.x + i, up.y + i, up.z + i, ax, ay, az, spread);
  ring_add<7>(ring, px, py, pz, up.x + r, up.y + r, up.z + r, ax, ay, az, spread);
  const F along = ax * V::load(nx) + ay * V::load(ny) + az * V::load(nz);
  const F curvature = k.two * (F)((M)along & k.abs) / spread;
  V::store(out, V::pick((M)(ring != k.none), curvature, k.nan));
}

RANGESEG_KERNEL void curvature_row(PointRow up, PointRow mid, PointRow down,
                                   const std::uint8_t* __restrict edges, const float* nx,
                                   const float* ny, const float* nz, int count,
                                   float* __restrict curvature) {
  const CurvatureConsts k{V::set1(2.0f), V::set1(kNaN), V::set1i(0x7fffffff), V::set1i(0)};
  int i = 0;
  for (; i + kLanes <= count; i += kLanes) {
    curvature_block(up, mid, down, edges, nx + i, ny + i, nz + i, k, i, curvature + i);
  }
  if (i < count) {  // the last partial vector: normals and output through buffers
    float tx[kLanes], ty[kLanes], tz[kLanes], tc[kLanes];
    for (int lane = 0; lane < kLanes; ++lane) {
      const bool in = i + lane < count;
      tx[lane] = in ? nx[i + lane] : 0.0f;
      ty[lane] = in ? ny[i + lane] : 0.0f;
      tz[lane] = in ? nz[i + lane] : 0.0f;
    }
    curvature_block(up, mid, down, edges, tx, ty, tz, k, i, tc);
    for (int lane = 0; i + lane < count; ++lane) curvature[i + lane] = tc[lane];
  }
}
