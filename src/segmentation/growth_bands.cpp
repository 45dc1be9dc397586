// Growth bands: the frame's rows split into bands that grow their regions independently, so
// that region growing runs on several threads with results that do not depend on how many.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>

#include "detail/headroom.hpp"
#include "segmentation/internal.hpp"

namespace rangeseg::seg {
namespace {

/// A band is at least this many cell rows tall: thinner bands would cut most regions.
constexpr int kMinBandCellRows = 4;

/// Direction bits (kNeighbourDv order) of the mesh edges leaving a row upwards / downwards.
constexpr unsigned edge_bits_towards(int dv) {
  unsigned bits = 0;
  for (int k = 0; k < 8; ++k) {
    if (kNeighbourDv[k] == dv) bits |= 1u << k;
  }
  return bits;
}

}  // namespace

int plan_growth_bands(const Frame& f, int requested, Segmenter::Scratch& s) {
  const int step = f.pixel_stride;
  const int cell_rows = (f.height + step - 1) / step / kCellSide;
  const int bands = std::max(1, std::min(requested, cell_rows / kMinBandCellRows));
  s.growth_rows.resize(static_cast<std::size_t>(bands) + 1);
  for (int b = 0; b < bands; ++b) {
    s.growth_rows[b] = b * cell_rows / bands * kCellSide * step;
  }
  s.growth_rows[bands] = f.height;
  if (bands == 1) return 1;  // the frame's own scratch
  if (s.growth.size() < static_cast<std::size_t>(bands)) s.growth.resize(bands);
  for (int b = 0; b < bands; ++b) {
    if (!s.growth[b]) s.growth[b] = std::make_unique<Segmenter::Scratch>();
  }
  return bands;
}

Frame growth_band_frame(const Frame& f, Segmenter::Scratch& s, int band) {
  const int v_begin = s.growth_rows[band], v_end = s.growth_rows[band + 1];
  Segmenter::Scratch& bs = *s.growth[band];
  const std::ptrdiff_t first = static_cast<std::ptrdiff_t>(v_begin) * f.stride;
  const std::size_t pixels = static_cast<std::size_t>(v_end - v_begin) * f.stride;
  Frame b = f;
  b.x += first;
  b.y += first;
  b.z += first;
  b.nx += first;
  b.ny += first;
  b.nz += first;
  b.curvature += first;
  b.faces += first;
  b.labels += first;
  b.height = v_end - v_begin;
  bs.edges.assign(f.edges + first, f.edges + first + static_cast<std::ptrdiff_t>(pixels));
  // Band starts are whole cell rows, so the first row and the last lattice row of a band are
  // lattice rows.
  const auto clear = [&](std::ptrdiff_t row, unsigned bits) {
    const auto keep = static_cast<std::uint8_t>(~bits);
    for (std::ptrdiff_t u = 0; u < f.width; ++u) bs.edges[row * f.stride + u] &= keep;
  };
  if (v_begin > 0) clear(0, edge_bits_towards(-1));
  if (v_end < f.height) clear(b.height - f.pixel_stride, edge_bits_towards(1));
  b.edges = bs.edges.data();
  if (bs.queue.size() < pixels) bs.queue.resize(pixels);
  bs.pool = nullptr;
  return b;
}

void join_growth_bands(const Frame& f, Segmenter::Scratch& s) {
  const auto bands = static_cast<int>(s.growth_rows.size()) - 1;
  s.regions.resize(1);
  for (int b = 0; b < bands; ++b) {
    const auto& regions = s.growth[b]->regions;
    detail::append_with_headroom(s.regions, regions.begin() + 1, regions.end());
  }
  for_each_band(s, bands, 1, [&](int, int b_begin, int b_end) {
    for (int b = std::max(b_begin, 1); b < b_end; ++b) {
      // Band b's labels follow the regions of the bands above it.
      std::int32_t offset = 0;
      for (int above = 0; above < b; ++above) {
        offset += static_cast<std::int32_t>(s.growth[above]->regions.size()) - 1;
      }
      std::int32_t* const labels =
          f.labels + static_cast<std::ptrdiff_t>(s.growth_rows[b]) * f.stride;
      const std::ptrdiff_t n =
          static_cast<std::ptrdiff_t>(s.growth_rows[b + 1] - s.growth_rows[b]) * f.stride;
      for (std::ptrdiff_t i = 0; i < n; ++i) labels[i] += labels[i] > 0 ? offset : 0;
    }
  });
}

}  // namespace rangeseg::seg
