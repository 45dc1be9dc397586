// Twice the mesh area of each cell of a row (segmentation/postprocess.cpp), written against the
// vector interface of detail/simd.hpp and compiled per instruction set by
// detail/simd_instances.hpp. The same float operations in the same order as cross_norm in
// postprocess.cpp, so the areas equal the scalar ones bit for bit.

using F = V::F;
using M = V::M;
constexpr int kLanes = V::kLanes;

/// |(p1 - p0) x (p3 - p2)| per lane.
struct Corner {
  F x, y, z;
};
RANGESEG_KERNEL RANGESEG_SIMD_INLINE F cross_norm(const Corner& p0, const Corner& p1,
                                                  const Corner& p2, const Corner& p3) {
  const F ux = p1.x - p0.x, uy = p1.y - p0.y, uz = p1.z - p0.z;
  const F vx = p3.x - p2.x, vy = p3.y - p2.y, vz = p3.z - p2.z;
  const F cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
  return V::sqrt(cx * cx + cy * cy + cz * cz);
}

/// Cells [0, count) with count + 1 readable points in both rows (stride 1): twice the area of
/// the faces of each cell (face_bits in `faces`) into `out`, for the cells of whole vectors;
/// returns how many cells that is (the caller does the rest).
RANGESEG_KERNEL int cell_twice_areas(const float* x0, const float* y0, const float* z0,
                                     const float* x1, const float* y1, const float* z1,
                                     const std::uint8_t* faces, int count, float* out) {
  const M quad = V::set1i(face_bits::quad), diag_bc = V::set1i(face_bits::diag_bc);
  const M tri0 = V::set1i(face_bits::tri0), tri1 = V::set1i(face_bits::tri1);
  int i = 0;
  for (; i + kLanes <= count; i += kLanes) {
    const Corner a{V::load(x0 + i), V::load(y0 + i), V::load(z0 + i)};
    const Corner b{V::load(x0 + i + 1), V::load(y0 + i + 1), V::load(z0 + i + 1)};
    const Corner c{V::load(x1 + i), V::load(y1 + i), V::load(z1 + i)};
    const Corner d{V::load(x1 + i + 1), V::load(y1 + i + 1), V::load(z1 + i + 1)};
    const M bits = V::bytes_to_lanes(faces + i);
    const M is_quad = (M)((bits & quad) == quad), is_bc = (M)((bits & diag_bc) == diag_bc);
    const M has0 = (M)((bits & tri0) == tri0), has1 = (M)((bits & tri1) == tri1);
    // Diagonal b-c: (a, c, a, b) and (b, c, b, d); diagonal a-d: (a, d, a, b) and (a, c, a, d).
    const Corner e{V::pick(is_bc, c.x, d.x), V::pick(is_bc, c.y, d.y), V::pick(is_bc, c.z, d.z)};
    const Corner g{V::pick(is_bc, b.x, a.x), V::pick(is_bc, b.y, a.y), V::pick(is_bc, b.z, a.z)};
    const F triangles =
        V::keep(cross_norm(a, e, a, b), has0) + V::keep(cross_norm(g, c, g, d), has1);
    V::store(out + i, V::pick(is_quad, cross_norm(a, d, b, c), triangles));
  }
  return i;
}
