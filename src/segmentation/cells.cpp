// The coarse level of region growing: per-cell point and normal statistics.
#include <cmath>
#include <cstdint>

#include "segmentation/internal.hpp"

namespace rangeseg::seg {

namespace {

/// The body of compute_cells; `kStep` > 0 fixes the lattice step at compile time (1: the
/// column loops run over contiguous floats and vectorise), 0 takes it from the frame.
template <int kStep>
void compute_cells_impl(const Frame& f, Segmenter::Scratch& s) {
  const int step = kStep > 0 ? kStep : f.pixel_stride;
  const int lattice_width = (f.width + step - 1) / step;
  const int lattice_height = (f.height + step - 1) / step;
  const int cols = lattice_width / kCellSide, rows = lattice_height / kCellSide;
  s.cell_cols = cols;
  s.cell_rows = rows;
  s.cells.resize(static_cast<std::size_t>(cols) * rows);
  s.cell_label.assign(static_cast<std::size_t>(cols) * rows, 0);
  const std::ptrdiff_t down = static_cast<std::ptrdiff_t>(step) * f.stride;
  constexpr int last = kCellSide - 1;
  constexpr unsigned right_bit = 1u << 0, down_bit = 1u << 2;
  for (int cv = 0; cv < rows; ++cv) {
    for (int cu = 0; cu < cols; ++cu) {
      Cell& cell = s.cells[static_cast<std::size_t>(cv) * cols + cu];
      cell = Cell{};
      const std::ptrdiff_t origin = cv * kCellSide * down + cu * kCellSide * step;
      // Complete: every vertex has a point, a normal and its right/down edges inside the cell.
      // Branch-free (NaN fails every comparison), so the column loop vectorises.
      int complete = 1;
      for (int j = 0; j < kCellSide; ++j) {
        const std::ptrdiff_t row = origin + j * down;
        const unsigned need_down = j < last ? down_bit : 0u;
        for (int i = 0; i < kCellSide; ++i) {
          const std::ptrdiff_t p = row + i * step;
          const unsigned need = need_down | (i < last ? right_bit : 0u);
          complete &= static_cast<int>((f.edges[p] & need) == need) &
                      static_cast<int>(f.nz[p] == f.nz[p]) &
                      static_cast<int>(f.curvature[p] <= 3e38f);
        }
      }
      if (!complete) continue;
      // Sums relative to the cell's first point in float (a cell spans centimetres), one
      // accumulator per column so that the loop vectorises without reassociation; shifted to
      // absolute double sums once per cell.
      const std::ptrdiff_t o = origin;
      const float x0 = f.x[o], y0 = f.y[o], z0 = f.z[o];
      float ax[kCellSide]{}, ay[kCellSide]{}, az[kCellSide]{}, axx[kCellSide]{}, axy[kCellSide]{},
          axz[kCellSide]{}, ayy[kCellSide]{}, ayz[kCellSide]{}, azz[kCellSide]{}, anx[kCellSide]{},
          any[kCellSide]{}, anz[kCellSide]{}, ac[kCellSide]{};
      for (int j = 0; j < kCellSide; ++j) {
        const std::ptrdiff_t row = origin + j * down;
        for (int i = 0; i < kCellSide; ++i) {
          const std::ptrdiff_t p = row + i * step;
          const float x = f.x[p] - x0, y = f.y[p] - y0, z = f.z[p] - z0;
          ax[i] += x;
          ay[i] += y;
          az[i] += z;
          axx[i] += x * x;
          axy[i] += x * y;
          axz[i] += x * z;
          ayy[i] += y * y;
          ayz[i] += y * z;
          azz[i] += z * z;
          anx[i] += f.nx[p];
          any[i] += f.ny[p];
          anz[i] += f.nz[p];
          ac[i] += f.curvature[p];
        }
      }
      double sx = 0, sy = 0, sz = 0, sxx = 0, sxy = 0, sxz = 0, syy = 0, syz = 0, szz = 0;
      double snx = 0, sny = 0, snz = 0, sc = 0;
      for (int i = 0; i < kCellSide; ++i) {
        sx += ax[i];
        sy += ay[i];
        sz += az[i];
        sxx += axx[i];
        sxy += axy[i];
        sxz += axz[i];
        syy += ayy[i];
        syz += ayz[i];
        szz += azz[i];
        snx += anx[i];
        sny += any[i];
        snz += anz[i];
        sc += ac[i];
      }
      constexpr double n = kCellSide * kCellSide;
      const double X = x0, Y = y0, Z = z0;
      detail::PlaneStats& st = cell.stats;
      st.count = kCellSide * kCellSide;
      st.sx = sx + n * X;
      st.sy = sy + n * Y;
      st.sz = sz + n * Z;
      st.sxx = sxx + 2 * X * sx + n * X * X;
      st.syy = syy + 2 * Y * sy + n * Y * Y;
      st.szz = szz + 2 * Z * sz + n * Z * Z;
      st.sxy = sxy + X * sy + Y * sx + n * X * Y;
      st.sxz = sxz + X * sz + Z * sx + n * X * Z;
      st.syz = syz + Y * sz + Z * sy + n * Y * Z;
      cell.snx = snx;
      cell.sny = sny;
      cell.snz = snz;
      cell.curvature = static_cast<float>(sc);
      cell.complete = true;
    }
  }
}

}  // namespace

void compute_cells(const Frame& f, Segmenter::Scratch& s) {
  if (f.pixel_stride == 1) {
    compute_cells_impl<1>(f, s);
  } else {
    compute_cells_impl<0>(f, s);
  }
}

}  // namespace rangeseg::seg
