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

/// Twice the area of the faces of cells a-b-c-d (a, b top; c, d bottom) with face_bits `bits`,
/// the scalar cell_twice_area's operations per lane.
RANGESEG_KERNEL RANGESEG_SIMD_INLINE F cell_twice_area(const Corner& a, const Corner& b,
                                                       const Corner& c, const Corner& d, M bits) {
  const M quad = V::set1i(face_bits::quad), diag_bc = V::set1i(face_bits::diag_bc);
  const M tri0 = V::set1i(face_bits::tri0), tri1 = V::set1i(face_bits::tri1);
  const M is_quad = (M)((bits & quad) == quad), is_bc = (M)((bits & diag_bc) == diag_bc);
  const M has0 = (M)((bits & tri0) == tri0), has1 = (M)((bits & tri1) == tri1);
  // Diagonal b-c: (a, c, a, b) and (b, c, b, d); diagonal a-d: (a, d, a, b) and (a, c, a, d).
  const Corner e{V::pick(is_bc, c.x, d.x), V::pick(is_bc, c.y, d.y), V::pick(is_bc, c.z, d.z)};
  const Corner g{V::pick(is_bc, b.x, a.x), V::pick(is_bc, b.y, a.y), V::pick(is_bc, b.z, a.z)};
  const F triangles = V::keep(cross_norm(a, e, a, b), has0) + V::keep(cross_norm(g, c, g, d), has1);
  if (lane_bits(is_quad) == 0) return triangles;  // triangle meshes: no quad to measure
  return V::pick(is_quad, cross_norm(a, d, b, c), triangles);
}

/// Cells [0, count) with count + 1 readable points in both rows (stride 1): twice the area of
/// the faces of each cell (face_bits in `faces`) into `out`, for the cells of whole vectors;
/// returns how many cells that is (the caller does the rest).
RANGESEG_KERNEL int cell_twice_areas(const float* x0, const float* y0, const float* z0,
                                     const float* x1, const float* y1, const float* z1,
                                     const std::uint8_t* faces, int count, float* out) {
  int i = 0;
  for (; i + kLanes <= count; i += kLanes) {
    const Corner a{V::load(x0 + i), V::load(y0 + i), V::load(z0 + i)};
    const Corner b{V::load(x0 + i + 1), V::load(y0 + i + 1), V::load(z0 + i + 1)};
    const Corner c{V::load(x1 + i), V::load(y1 + i), V::load(z1 + i)};
    const Corner d{V::load(x1 + i + 1), V::load(y1 + i + 1), V::load(z1 + i + 1)};
    V::store(out + i, cell_twice_area(a, b, c, d, V::bytes_to_lanes(faces + i)));
  }
  return i;
}

using FV = float __attribute__((vector_size(kLanes * sizeof(float))));
/// Half a vector of floats and the same lanes in double: one register each.
using FH = float __attribute__((vector_size(kLanes / 2 * sizeof(float))));
using DH = double __attribute__((vector_size(kLanes / 2 * sizeof(double))));

/// Sums of the lanes of a float vector in double, per lane (low and high half).
struct LaneSums {
  DH low{}, high{};
  RANGESEG_KERNEL RANGESEG_SIMD_INLINE void add(F x) {
    const FV v = (FV)x;
    low += __builtin_convertvector(half<0>(v, std::make_integer_sequence<int, kLanes / 2>{}), DH);
    high += __builtin_convertvector(
        half<kLanes / 2>(v, std::make_integer_sequence<int, kLanes / 2>{}), DH);
  }
  template <int kFirst, int... kLane>
  RANGESEG_KERNEL RANGESEG_SIMD_INLINE static FH half(FV v, std::integer_sequence<int, kLane...>) {
    return __builtin_shufflevector(v, v, (kFirst + kLane)...);
  }
  /// Adds every lane to `sum` and clears.
  RANGESEG_KERNEL RANGESEG_SIMD_INLINE void drain(double& sum) {
    for (int k = 0; k < kLanes / 2; ++k) sum += low[k];
    for (int k = 0; k < kLanes / 2; ++k) sum += high[k];
    low = DH{};
    high = DH{};
  }
};

RANGESEG_KERNEL RANGESEG_SIMD_INLINE M load_labels(const std::int32_t* p) {
  M m;
  __builtin_memcpy(&m, p, sizeof m);
  return m;
}

/// Cells [0, count) of one row at stride 1 (count + 1 readable points and labels in both rows):
/// adds the faces of each cell to `area` as accumulate_areas does, with the faces of cells whose
/// corners all carry the current run's label summed into `run` (see AreaRun) a vector at a time.
RANGESEG_KERNEL void row_areas(const float* x0, const float* y0, const float* z0, const float* x1,
                               const float* y1, const float* z1, const std::uint8_t* faces,
                               const std::int32_t* l0, const std::int32_t* l1, int count,
                               AreaRun& run, double* area) {
  const M zero = V::set1i(0);
  const F zerof = V::set1(0.0f), inf = V::set1(__builtin_inff());
  LaneSums sum;
  F smallest = inf;
  int i = 0;
  for (; i + kLanes <= count; i += kLanes) {
    const M bits = V::bytes_to_lanes(faces + i);
    const M la = load_labels(l0 + i), lb = load_labels(l0 + i + 1);
    const M lc = load_labels(l1 + i), ld = load_labels(l1 + i + 1);
    const M skip = (M)(bits == zero) | (M)((la | lb | lc | ld) == zero);
    const unsigned to_add = lane_bits(~skip);
    if (to_add == 0) continue;  // no faces, or only unlabelled corners
    const M label = V::set1i(run.label);
    const M same = (M)(la == label) & (M)(lb == label) & (M)(lc == label) & (M)(ld == label);
    const unsigned in_run = lane_bits(same);
    const Corner a{V::load(x0 + i), V::load(y0 + i), V::load(z0 + i)};
    const Corner b{V::load(x0 + i + 1), V::load(y0 + i + 1), V::load(z0 + i + 1)};
    const Corner c{V::load(x1 + i), V::load(y1 + i), V::load(z1 + i)};
    const Corner d{V::load(x1 + i + 1), V::load(y1 + i + 1), V::load(z1 + i + 1)};
    const F twice_area = cell_twice_area(a, b, c, d, bits);
    if ((to_add & ~in_run) == 0) {
      // Every cell is empty or belongs to the run.
      const F added = V::keep(twice_area, ~skip);
      sum.add(added);
      smallest = V::min(smallest, V::pick((M)((FV)added > (FV)zerof), added, inf));
      continue;
    }
    // Cell by cell: the run's vector sums go into the run first, which may end here.
    sum.drain(run.sum);
    for (int k = 0; k < kLanes; ++k) run.smallest = std::fmin(run.smallest, smallest[k]);
    smallest = inf;
    alignas(64) float lane_area[kLanes];
    V::store(lane_area, twice_area);
    const std::int32_t run_label = run.label;
    for (unsigned todo = to_add; todo != 0; todo &= todo - 1) {
      const int k = std::countr_zero(todo);
      if ((in_run >> k & 1u) != 0 && run.label == run_label) {
        run.add(lane_area[k]);
      } else {
        area_cell(x0, y0, z0, x1, y1, z1, faces, l0, l1, i + k, lane_area[k], true, run, area);
      }
    }
  }
  sum.drain(run.sum);
  for (int k = 0; k < kLanes; ++k) run.smallest = std::fmin(run.smallest, smallest[k]);
  for (; i < count; ++i) {
    area_cell(x0, y0, z0, x1, y1, z1, faces, l0, l1, i, 0.0f, false, run, area);
  }
}

/// Pixels [begin, end) of a row at stride 1 (labels readable from begin - 1 to end in `row` and
/// `below`) whose label is not 0 and differs from that of a forward neighbour (right,
/// down-left, down, down-right), i.e. that may start a segment adjacency: their columns into
/// `out` in ascending order; returns the column up to which the row was scanned (a multiple of
/// vectors after `begin`), the caller does the rest.
RANGESEG_KERNEL int adjacency_pixels(const std::int32_t* row, const std::int32_t* below, int begin,
                                     int end, std::int32_t* out, int& found) {
  const M zero = V::set1i(0);
  int u = begin;
  for (; u + kLanes <= end; u += kLanes) {
    const M a = load_labels(row + u);
    const M differs = (M)(load_labels(row + u + 1) != a) | (M)(load_labels(below + u - 1) != a) |
                      (M)(load_labels(below + u) != a) | (M)(load_labels(below + u + 1) != a);
    for (unsigned bits = lane_bits(differs & (M)(a != zero)); bits != 0; bits &= bits - 1) {
      out[found++] = u + std::countr_zero(bits);
    }
  }
  return u;
}

/// Pixels [begin, end) of a row at stride 1 (labels readable from begin - 1 to end in `above`,
/// `row` and `below`) that are unlabelled and have a labelled pixel among their 8 neighbours:
/// their columns into `out` in ascending order; returns the column up to which the row was
/// scanned (see adjacency_pixels).
RANGESEG_KERNEL int unlabelled_border_pixels(const std::int32_t* above, const std::int32_t* row,
                                             const std::int32_t* below, int begin, int end,
                                             std::int32_t* out, int& found) {
  const M zero = V::set1i(0);
  int u = begin;
  for (; u + kLanes <= end; u += kLanes) {
    const M a = load_labels(row + u);
    const M around = load_labels(above + u - 1) | load_labels(above + u) |
                     load_labels(above + u + 1) | load_labels(row + u - 1) |
                     load_labels(row + u + 1) | load_labels(below + u - 1) |
                     load_labels(below + u) | load_labels(below + u + 1);
    for (unsigned bits = lane_bits((M)(a == zero) & (M)(around != zero)); bits != 0;
         bits &= bits - 1) {
      out[found++] = u + std::countr_zero(bits);
    }
  }
  return u;
}

/// labels[u] = remap[labels[u]] for u in [0, count), a vector at a time where all its lanes hold
/// one label (one look-up, a store only when the label changes).
RANGESEG_KERNEL void remap_labels(std::int32_t* labels, const std::int32_t* remap, int count) {
  int u = 0;
  for (; u + kLanes <= count; u += kLanes) {
    const M l = load_labels(labels + u);
    const std::int32_t first = labels[u];
    if (lane_bits((M)(l == V::set1i(first))) == (1u << kLanes) - 1) {
      const std::int32_t to = remap[first];
      if (to != first) {
        const M m = V::set1i(to);
        __builtin_memcpy(labels + u, &m, sizeof m);
      }
      continue;
    }
    for (int k = 0; k < kLanes; ++k) labels[u + k] = remap[labels[u + k]];
  }
  for (; u < count; ++u) labels[u] = remap[labels[u]];
}
