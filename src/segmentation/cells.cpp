// The coarse level of region growing: per-cell point and normal statistics.
// Contraction into fused multiply-adds is off in this file, so that the vectorised per-column
// sums equal the scalar ones on every CPU.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

#include <cmath>
#include <cstdint>
#include <cstring>

#include "detail/simd.hpp"
#include "segmentation/internal.hpp"

namespace rangeseg::seg {

namespace {

/// Per-column float sums of a cell: x, y, z relative to the cell's first point, their products
/// xx, xy, xz, yy, yz, zz, the normal components and the curvature.
constexpr int kCellSums = 13;

/// The planes of one row of cells (lattice step 1), at the top-left pixel of its first cell.
struct CellRowInput {
  const float *x, *y, *z, *nx, *ny, *nz, *curvature;
  const std::uint8_t* edges;
  std::ptrdiff_t stride;  ///< [elements]
};

#define RANGESEG_SIMD_KERNEL_FILE "segmentation/cells_simd_kernels.hpp"
#include "detail/simd_instances.hpp"
#undef RANGESEG_SIMD_KERNEL_FILE

using CellRowFn = int (*)(const CellRowInput&, int, float*, std::uint8_t*);
#define RANGESEG_CELL_KERNEL(ns) &ns::cell_row_sums
const CellRowFn& cell_row_kernel() { RANGESEG_SIMD_PICK(CellRowFn, RANGESEG_CELL_KERNEL); }
#undef RANGESEG_CELL_KERNEL

/// Whether the cell at `origin` is complete: every vertex has a point, a normal and its
/// right/down edges inside the cell. Branch-free (NaN fails every comparison).
bool cell_complete(const Frame& f, std::ptrdiff_t origin, std::ptrdiff_t step,
                   std::ptrdiff_t down) {
  constexpr int last = kCellSide - 1;
  constexpr unsigned right_bit = 1u << 0, down_bit = 1u << 2;
  int complete = 1;
  for (int j = 0; j < kCellSide; ++j) {
    const std::ptrdiff_t row = origin + j * down;
    const unsigned need_down = j < last ? down_bit : 0u;
    for (int i = 0; i < kCellSide; ++i) {
      const std::ptrdiff_t p = row + i * step;
      const unsigned need = need_down | (i < last ? right_bit : 0u);
      complete &= static_cast<int>((f.edges[p] & need) == need) &
                  static_cast<int>(f.nz[p] == f.nz[p]) & static_cast<int>(f.curvature[p] <= 3e38f);
    }
  }
  return complete != 0;
}

/// The per-column sums of the cell at `origin` into sums[k * plane + column]: one float
/// accumulator per column and quantity, so that every column is an independent chain of float
/// additions in row order (the vector kernels compute the same chains lane by lane).
void cell_column_sums(const Frame& f, std::ptrdiff_t origin, std::ptrdiff_t step,
                      std::ptrdiff_t down, float* sums, std::ptrdiff_t plane) {
  const float x0 = f.x[origin], y0 = f.y[origin], z0 = f.z[origin];
  float acc[kCellSums][kCellSide]{};
  for (int j = 0; j < kCellSide; ++j) {
    const std::ptrdiff_t row = origin + j * down;
    for (int i = 0; i < kCellSide; ++i) {
      const std::ptrdiff_t p = row + i * step;
      const float x = f.x[p] - x0, y = f.y[p] - y0, z = f.z[p] - z0;
      acc[0][i] += x;
      acc[1][i] += y;
      acc[2][i] += z;
      acc[3][i] += x * x;
      acc[4][i] += x * y;
      acc[5][i] += x * z;
      acc[6][i] += y * y;
      acc[7][i] += y * z;
      acc[8][i] += z * z;
      acc[9][i] += f.nx[p];
      acc[10][i] += f.ny[p];
      acc[11][i] += f.nz[p];
      acc[12][i] += f.curvature[p];
    }
  }
  for (int k = 0; k < kCellSums; ++k) std::memcpy(sums + k * plane, acc[k], sizeof acc[k]);
}

/// A complete cell from its per-column sums (sums[k * plane + column]) and first point: the
/// columns are added in double and shifted to absolute sums once per cell.
void finish_cell(const float* sums, std::ptrdiff_t plane, float x0, float y0, float z0,
                 Cell& cell) {
  double total[kCellSums];
  for (int k = 0; k < kCellSums; ++k) {
    double t = 0;
    for (int i = 0; i < kCellSide; ++i) t += sums[k * plane + i];
    total[k] = t;
  }
  const double sx = total[0], sy = total[1], sz = total[2], sxx = total[3], sxy = total[4],
               sxz = total[5], syy = total[6], syz = total[7], szz = total[8];
  constexpr double n = kCellSide * kCellSide;
  const double X = x0, Y = y0, Z = z0;
  detail::PlaneStats& st = cell.stats;
  st.count = std::int64_t{kCellSide} * kCellSide;
  st.sx = sx + n * X;
  st.sy = sy + n * Y;
  st.sz = sz + n * Z;
  st.sxx = sxx + 2 * X * sx + n * X * X;
  st.syy = syy + 2 * Y * sy + n * Y * Y;
  st.szz = szz + 2 * Z * sz + n * Z * Z;
  st.sxy = sxy + X * sy + Y * sx + n * X * Y;
  st.sxz = sxz + X * sz + Z * sx + n * X * Z;
  st.syz = syz + Y * sz + Z * sy + n * Y * Z;
  cell.snx = total[9];
  cell.sny = total[10];
  cell.snz = total[11];
  cell.curvature = static_cast<float>(total[12]);
  cell.complete = true;
}

/// A cell that misses at most kCellMaxMissing vertices (no normal or curvature), whose valid
/// vertices have every right and down mesh edge to a valid vertex inside it: its sums over the
/// valid vertices, added in double like a region's. Called only for cells that are not
/// complete, so it leaves `cell` incomplete unless some vertex is missing.
void finish_gapped_cell(const Frame& f, std::ptrdiff_t origin, std::ptrdiff_t step,
                        std::ptrdiff_t down, Cell& cell) {
  constexpr int last = kCellSide - 1;
  constexpr unsigned right_bit = 1u << 0, down_bit = 1u << 2;
  const auto valid = [&](std::ptrdiff_t p) { return cell_vertex_valid(f, p); };
  int missing = 0;
  for (int j = 0; j < kCellSide; ++j) {
    for (int i = 0; i < kCellSide; ++i) {
      const std::ptrdiff_t p = origin + j * down + i * step;
      if (!valid(p)) {
        if (++missing > kCellMaxMissing) return;
        continue;
      }
      const bool right = i < last && valid(p + step), below = j < last && valid(p + down);
      const unsigned need = (right ? right_bit : 0u) | (below ? down_bit : 0u);
      if ((f.edges[p] & need) != need) return;
    }
  }
  if (missing == 0) return;
  double snx = 0, sny = 0, snz = 0, curvature = 0;
  for (int j = 0; j < kCellSide; ++j) {
    for (int i = 0; i < kCellSide; ++i) {
      const std::ptrdiff_t p = origin + j * down + i * step;
      if (!valid(p)) continue;
      cell.stats.add(f.x[p], f.y[p], f.z[p]);
      snx += f.nx[p];
      sny += f.ny[p];
      snz += f.nz[p];
      curvature += f.curvature[p];
    }
  }
  cell.snx = snx;
  cell.sny = sny;
  cell.snz = snz;
  cell.curvature = static_cast<float>(curvature);
  cell.complete = true;
}

/// Cell rows [cv_begin, cv_end): `sums` and `complete` hold one cell row at a time.
void compute_cell_rows(const Frame& f, Segmenter::Scratch& s, int cv_begin, int cv_end, float* sums,
                       std::uint8_t* complete) {
  const int step = f.pixel_stride;
  const int cols = s.cell_cols;
  const std::ptrdiff_t plane = static_cast<std::ptrdiff_t>(cols) * kCellSide;
  const std::ptrdiff_t down = static_cast<std::ptrdiff_t>(step) * f.stride;
  const CellRowFn kernel = step == 1 ? cell_row_kernel() : nullptr;
  for (int cv = cv_begin; cv < cv_end; ++cv) {
    const std::ptrdiff_t row_origin = static_cast<std::ptrdiff_t>(cv) * kCellSide * down;
    int done = 0;
    if (kernel != nullptr) {
      const CellRowInput in{f.x + row_origin,         f.y + row_origin,     f.z + row_origin,
                            f.nx + row_origin,        f.ny + row_origin,    f.nz + row_origin,
                            f.curvature + row_origin, f.edges + row_origin, f.stride};
      done = kernel(in, cols, sums, complete);
    }
    for (int cu = done; cu < cols; ++cu) {
      const std::ptrdiff_t column = static_cast<std::ptrdiff_t>(cu) * kCellSide;
      const std::ptrdiff_t origin = row_origin + column * step;
      complete[cu] = cell_complete(f, origin, step, down) ? 1 : 0;
      if (complete[cu]) cell_column_sums(f, origin, step, down, sums + column, plane);
    }
    for (int cu = 0; cu < cols; ++cu) {
      Cell& cell = s.cells[static_cast<std::size_t>(cv) * cols + cu];
      cell = Cell{};
      const std::ptrdiff_t column = static_cast<std::ptrdiff_t>(cu) * kCellSide;
      const std::ptrdiff_t origin = row_origin + column * step;
      if (!complete[cu]) {
        finish_gapped_cell(f, origin, step, down, cell);
        continue;
      }
      finish_cell(sums + column, plane, f.x[origin], f.y[origin], f.z[origin], cell);
    }
  }
}

}  // namespace

// Sums relative to each cell's first point in float (a cell spans centimetres), one accumulator
// per column so that the columns are vector lanes; shifted to absolute double sums once per cell.
// Cells depend only on their own pixels, so bands of cell rows run concurrently.
void compute_cells(const Frame& f, Segmenter::Scratch& s) {
  const int step = f.pixel_stride;
  const int lattice_width = (f.width + step - 1) / step;
  const int lattice_height = (f.height + step - 1) / step;
  const int cols = lattice_width / kCellSide, rows = lattice_height / kCellSide;
  s.cell_cols = cols;
  s.cell_rows = rows;
  s.cells.resize(static_cast<std::size_t>(cols) * rows);
  s.cell_label.assign(static_cast<std::size_t>(cols) * rows, 0);
  const std::size_t sums = static_cast<std::size_t>(kCellSums) * cols * kCellSide;
  const auto bands = static_cast<std::size_t>(band_count(s));
  s.cell_sums.resize(sums);
  s.cell_complete.resize(cols);
  if (s.band_cell_sums.size() < bands) {
    s.band_cell_sums.resize(bands);
    s.band_cell_complete.resize(bands);
  }
  for (std::size_t b = 1; b < bands; ++b) {
    s.band_cell_sums[b].resize(sums);
    s.band_cell_complete[b].resize(cols);
  }
  for_each_band(s, rows, 1, [&](int band, int cv_begin, int cv_end) {
    const auto b = static_cast<std::size_t>(band);
    float* const band_sums = b == 0 ? s.cell_sums.data() : s.band_cell_sums[b].data();
    std::uint8_t* const band_complete =
        b == 0 ? s.cell_complete.data() : s.band_cell_complete[b].data();
    compute_cell_rows(f, s, cv_begin, cv_end, band_sums, band_complete);
  });
}

}  // namespace rangeseg::seg
