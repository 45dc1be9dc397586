// Per-column sums of the cells of one cell row (segmentation/cells.cpp), written against the
// vector interface of detail/simd.hpp and compiled per instruction set by
// detail/simd_instances.hpp. Every lane is one pixel column of a cell and performs the float
// operations of the scalar code in cells.cpp in the same order (contraction is off in that file),
// so the sums equal the scalar ones bit for bit whatever the vector width.

using F = V::F;
using M = V::M;
constexpr int kLanes = V::kLanes;
/// Cells side by side in one vector (AVX-512: 2), and vectors per cell row (SSE2: 2).
constexpr int kCellsPerVector = kLanes >= kCellSide ? kLanes / kCellSide : 1;
constexpr int kVectorsPerRow = kLanes >= kCellSide ? 1 : kCellSide / kLanes;
static_assert(kCellsPerVector * kCellSide == kLanes * kVectorsPerRow);

/// Cells [0, count) of the cell row at `in` (lattice step 1): whether each is complete
/// (`complete`, see Cell) and, for the complete ones, the kCellSums per-column float sums of
/// its points relative to its first point, its normals and curvatures, at
/// sums[k * count * kCellSide + cell * kCellSide + column]. Handles the cells of whole vectors;
/// returns how many cells that is (the caller does the rest).
RANGESEG_KERNEL int cell_row_sums(const CellRowInput& in, int count, float* sums,
                                  std::uint8_t* complete) {
  constexpr int last = kCellSide - 1;
  // Lane l needs the right edge unless it is a cell's last column; every row but the last
  // needs the down edge.
  M need_right[kVectorsPerRow];
  for (int r = 0; r < kVectorsPerRow; ++r) {
    alignas(64) std::int32_t lanes[kLanes];
    for (int l = 0; l < kLanes; ++l) lanes[l] = (r * kLanes + l) % kCellSide < last ? 1 : 0;
    std::memcpy(&need_right[r], lanes, sizeof lanes);
  }
  const M need_down = V::set1i(4), zero = V::set1i(0);
  const F huge = V::set1(3e38f);
  const std::ptrdiff_t plane = static_cast<std::ptrdiff_t>(count) * kCellSide;
  constexpr int kGroup = kCellsPerVector;
  int cu = 0;
  for (; cu + kGroup <= count; cu += kGroup) {
    const std::ptrdiff_t base = static_cast<std::ptrdiff_t>(cu) * kCellSide;
    M ok = V::set1i(-1);
    for (int j = 0; j < kCellSide; ++j) {
      const std::ptrdiff_t row = j * in.stride + base;
      for (int r = 0; r < kVectorsPerRow; ++r) {
        const std::ptrdiff_t p = row + static_cast<std::ptrdiff_t>(r) * kLanes;
        const M need = need_right[r] | (j < last ? need_down : zero);
        const F nz = V::load(in.nz + p);
        const M bits = V::bytes_to_lanes(in.edges + p);
        ok &= (M)((bits & need) == need) & (M)(nz == nz) & (M)(V::load(in.curvature + p) <= huge);
      }
    }
    alignas(64) std::int32_t ok_lanes[kLanes];
    std::memcpy(ok_lanes, &ok, sizeof ok);
    bool any = false;
    for (int g = 0; g < kGroup; ++g) {
      // With several vectors per row, `ok` holds lanes of every vector and'ed together.
      std::int32_t all = -1;
      const int first = kCellsPerVector > 1 ? g * kCellSide : 0;
      const int lanes = kCellsPerVector > 1 ? kCellSide : kLanes;
      for (int l = 0; l < lanes; ++l) all &= ok_lanes[first + l];
      complete[cu + g] = all != 0 ? 1 : 0;
      any |= all != 0;
    }
    if (!any) continue;
    alignas(64) float origin[3][kLanes];
    for (int l = 0; l < kLanes; ++l) {
      const std::ptrdiff_t o = base + (kCellsPerVector > 1 ? (l / kCellSide) * kCellSide : 0);
      origin[0][l] = in.x[o];
      origin[1][l] = in.y[o];
      origin[2][l] = in.z[o];
    }
    const F x0 = V::load(origin[0]), y0 = V::load(origin[1]), z0 = V::load(origin[2]);
    F acc[kCellSums][kVectorsPerRow];
    for (auto& a : acc) {
      for (F& v : a) v = V::set1(0.0f);
    }
    for (int j = 0; j < kCellSide; ++j) {
      const std::ptrdiff_t row = j * in.stride + base;
      for (int r = 0; r < kVectorsPerRow; ++r) {
        const std::ptrdiff_t p = row + static_cast<std::ptrdiff_t>(r) * kLanes;
        const F x = V::load(in.x + p) - x0, y = V::load(in.y + p) - y0, z = V::load(in.z + p) - z0;
        acc[0][r] += x;
        acc[1][r] += y;
        acc[2][r] += z;
        acc[3][r] += x * x;
        acc[4][r] += x * y;
        acc[5][r] += x * z;
        acc[6][r] += y * y;
        acc[7][r] += y * z;
        acc[8][r] += z * z;
        acc[9][r] += V::load(in.nx + p);
        acc[10][r] += V::load(in.ny + p);
        acc[11][r] += V::load(in.nz + p);
        acc[12][r] += V::load(in.curvature + p);
      }
    }
    for (int k = 0; k < kCellSums; ++k) {
      for (int r = 0; r < kVectorsPerRow; ++r) {
        V::store(sums + k * plane + base + static_cast<std::ptrdiff_t>(r) * kLanes, acc[k][r]);
      }
    }
  }
  return cu;
}
