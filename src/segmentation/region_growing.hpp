// Internal: the region-growing engine of the paper (Sec. III-D), generic over the region model.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <concepts>
#include <cstdint>
#include <limits>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "detail/headroom.hpp"
#include "detail/radix_sort.hpp"
#include "segmentation/internal.hpp"

namespace rangeseg::seg {

/// What the engine needs from a region model. `init` starts a region at a seed pixel (already
/// added), `accepts(frame, from, candidate)` tests a mesh neighbour `candidate` of the region
/// point `from`, `add` adds an accepted pixel, `stats` gives the region's point statistics.
/// An optional `seed_ok(frame, seed)` vetoes seed pixels.
/// Models are plain structs; the engine is instantiated per model (no virtual call per point).
template <class M>
concept RegionGrowingModel = requires(M m, const M cm, const Frame& f, std::int32_t i) {
  m.init(f, i);
  { cm.accepts(f, i, i) } -> std::convertible_to<bool>;
  m.add(f, i);
  { cm.stats() } -> std::convertible_to<const detail::PlaneStats&>;
};

/// Optional coarse level: a model that can judge a whole `Cell` from its statistics is grown
/// over cells first. `cell_seed_ok(c)` says whether a complete cell may start a region,
/// `init_cell(c)` starts one from it, `accepts_cell(c)` tests a complete neighbouring cell
/// against the region as a unit and `add_cell(c)` adds it. A cell the model does not accept as a
/// unit is not lost: the region continues pixel by pixel (`accepts`) from its cells' border, so
/// cells only shortcut the pixel-wise growing where the whole cell passes.
template <class M>
concept CellGrowingModel = RegionGrowingModel<M> && requires(M m, const M cm, const Cell& c) {
  { cm.cell_seed_ok(c) } -> std::convertible_to<bool>;
  m.init_cell(c);
  { cm.accepts_cell(c) } -> std::convertible_to<bool>;
  m.add_cell(c);
};

namespace detail_engine {

/// Index of the top-left vertex of cell (cu, cv).
inline std::ptrdiff_t cell_origin(const Frame& f, int cu, int cv) {
  return static_cast<std::ptrdiff_t>(cv) * kCellSide * f.pixel_stride * f.stride +
         static_cast<std::ptrdiff_t>(cu) * kCellSide * f.pixel_stride;
}

/// True when no vertex of the cell is labelled.
inline bool cell_free(const Frame& f, std::ptrdiff_t origin) {
  const int s = f.pixel_stride;
  std::int32_t any = 0;
  for (int j = 0; j < kCellSide; ++j) {
    const std::int32_t* row = f.labels + origin + static_cast<std::ptrdiff_t>(j) * s * f.stride;
    for (std::ptrdiff_t i = 0; i < kCellSide; ++i) any |= row[i * s];
  }
  return any == 0;
}

/// Labels the vertices of a complete cell; those of a cell with missing vertices only where
/// they count in its statistics (`cell_vertex_valid`).
inline void label_cell(const Frame& f, std::ptrdiff_t origin, std::int32_t label,
                       const Cell& cell) {
  const int s = f.pixel_stride;
  const bool whole = cell.stats.count == kCellVertices;
  for (int j = 0; j < kCellSide; ++j) {
    const std::ptrdiff_t row = origin + static_cast<std::ptrdiff_t>(j) * s * f.stride;
    if (whole) {
      for (std::ptrdiff_t i = 0; i < kCellSide; ++i) f.labels[row + i * s] = label;
    } else {
      for (std::ptrdiff_t i = 0; i < kCellSide; ++i) {
        const std::ptrdiff_t p = row + i * s;
        f.labels[p] = cell_vertex_valid(f, p) ? label : 0;
      }
    }
  }
}

/// Whether the mesh connects the border of cell (cu, cv) to its neighbour in direction k.
inline bool cells_connected(const Frame& f, std::ptrdiff_t origin, int k) {
  const int last = (kCellSide - 1) * f.pixel_stride;
  const std::ptrdiff_t down = f.pixel_stride * f.stride;
  const unsigned bit = 1u << k;
  const int du = kNeighbourDu[k], dv = kNeighbourDv[k];
  if (du != 0 && dv != 0) {  // diagonal: the corner vertex
    const std::ptrdiff_t corner =
        origin + (du > 0 ? last : 0) + (dv > 0 ? (kCellSide - 1) * down : 0);
    return (f.edges[corner] & bit) != 0;
  }
  unsigned any = 0;
  for (std::ptrdiff_t t = 0; t < kCellSide; ++t) {
    const std::ptrdiff_t p = du > 0   ? origin + last + t * down
                             : du < 0 ? origin + t * down
                             : dv > 0 ? origin + (kCellSide - 1) * down + t * f.pixel_stride
                                      : origin + t * f.pixel_stride;
    any |= f.edges[p];
  }
  return (any & bit) != 0;
}

}  // namespace detail_engine

/// A model whose `accepts` depends only on the candidate and on model state that changes only
/// together with `plane_version()` (positive, increasing over the model's lifetime).
template <class M>
concept VersionedModel = requires(const M cm) {
  { cm.plane_version() } -> std::convertible_to<std::int32_t>;
};

namespace detail_engine {

/// Bit k set when lattice neighbour k of `p` is a mesh neighbour (`edges`) that may join:
/// unlabelled and not rejected under plane version `version` (labels[q] = -version marks a
/// rejection; older marks are stale). Branch-free per neighbour: which neighbours are free is
/// unpredictable.
inline unsigned candidate_neighbours(const std::int32_t* labels, const std::ptrdiff_t* offsets,
                                     std::int32_t p, unsigned edges, std::uint32_t version) {
  // Free: -version < labels[q] <= 0, i.e. labels[q] + version - 1 in [0, version).
  const std::uint32_t bias = version - 1;
  unsigned candidates = 0;
  while (edges != 0) {
    const int k = std::countr_zero(edges);
    edges &= edges - 1;
    const auto v = static_cast<std::uint32_t>(labels[p + offsets[k]]);
    candidates |= static_cast<unsigned>(v + bias < version) << k;
  }
  return candidates;
}

#if defined(__SSE2__)
/// `candidate_neighbours` for lattice step 1 and a pixel whose 3 x 4 block starting at
/// p - stride - 1 lies inside the label plane: three vector loads instead of a loop.
inline unsigned candidate_block(const std::int32_t* labels, std::ptrdiff_t stride, std::int32_t p,
                                unsigned edges, std::uint32_t version) {
  const __m128i bias = _mm_set1_epi32(static_cast<std::int32_t>(version - 1));
  // Unsigned v + bias < version as a signed comparison of sign-flipped values.
  const __m128i flip = _mm_set1_epi32(std::numeric_limits<std::int32_t>::min());
  const __m128i limit = _mm_xor_si128(_mm_set1_epi32(static_cast<std::int32_t>(version)), flip);
  const auto free_bits = [&](const std::int32_t* at) {
    const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(at));
    const __m128i key = _mm_xor_si128(_mm_add_epi32(v, bias), flip);
    return static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmplt_epi32(key, limit)))) &
           7u;
  };
  const std::int32_t* const centre = labels + p - 1;
  const unsigned index =
      free_bits(centre - stride) | free_bits(centre) << 3 | free_bits(centre + stride) << 6;
  return kBlockDirections[index] & edges;
}
#endif

/// A vertex on the border of a cell (row and column in the cell) and the neighbour cells it
/// touches (bit k: direction k of kNeighbourDu / kNeighbourDv).
struct BorderVertex {
  std::uint8_t row, column, touches;
};
/// The border vertices of a cell, row by row.
inline constexpr auto kBorderVertices = [] {
  std::array<BorderVertex, 4 * kCellSide - 4> border{};
  constexpr int kLast = kCellSide - 1;
  std::size_t n = 0;
  for (int row = 0; row < kCellSide; ++row) {
    const bool top = row == 0, bottom = row == kLast;
    for (int column = 0; column < kCellSide; column += (top || bottom) ? 1 : kLast) {
      const bool left = column == 0, right = column == kLast;
      const unsigned touches = (right ? 1u << 0 : 0u) | (bottom ? 1u << 2 : 0u) |
                               (left ? 1u << 4 : 0u) | (top ? 1u << 6 : 0u) |
                               (right && bottom ? 1u << 1 : 0u) | (left && bottom ? 1u << 3 : 0u) |
                               (left && top ? 1u << 5 : 0u) | (right && top ? 1u << 7 : 0u);
      border[n++] = {static_cast<std::uint8_t>(row), static_cast<std::uint8_t>(column),
                     static_cast<std::uint8_t>(touches)};
    }
  }
  return border;
}();

}  // namespace detail_engine

/// The pixel-wise inner loop: pops the processing queue [head, tail) and adds accepted unlabelled
/// mesh neighbours. Returns the new tail.
/// With a `VersionedModel`, a rejected pixel is marked with -plane_version() and not tested
/// again until the model's plane changes (the same test would give the same answer); the marks
/// are negative labels, listed in `marked` (which may repeat a pixel) and cleared before
/// returning.
template <RegionGrowingModel Model>
std::int32_t grow_pixels(const Frame& f, Model& model, std::int32_t label, std::int32_t* queue,
                         std::int32_t head, std::int32_t tail,
                         [[maybe_unused]] std::size_t capacity,
                         [[maybe_unused]] std::vector<std::int32_t>* marked = nullptr,
                         std::uint8_t* touched = nullptr) {
  std::int32_t* const labels = f.labels;
  const std::uint8_t* const edges = f.edges;
  const auto offsets = f.neighbour_offset;
  if constexpr (VersionedModel<Model>) {
    marked->clear();
#if defined(__SSE2__)
    // Pixels whose 3 x 4 label block is inside the plane (lattice step 1).
    const std::ptrdiff_t block_first = f.stride + 1;
    const std::ptrdiff_t block_last =
        f.pixel_stride == 1 ? static_cast<std::ptrdiff_t>(f.height - 1) * f.stride - 3 : -1;
#endif
    const auto candidates_of = [&](std::int32_t p, unsigned edges_p, std::int32_t version) {
      const auto v = static_cast<std::uint32_t>(version);
#if defined(__SSE2__)
      if (p >= block_first && p <= block_last) {
        return detail_engine::candidate_block(labels, f.stride, p, edges_p, v);
      }
#endif
      return detail_engine::candidate_neighbours(labels, offsets.data(), p, edges_p, v);
    };
    while (head < tail) {
      const std::int32_t p = queue[head++];
      const unsigned edges_p = edges[p];
      std::int32_t version = model.plane_version();
      unsigned candidates = candidates_of(p, edges_p, version);
      while (candidates != 0) {
        const int k = std::countr_zero(candidates);
        candidates &= candidates - 1;
        const std::int32_t q = static_cast<std::int32_t>(p + offsets[k]);
        if (!model.accepts(f, p, q)) {
          marked->push_back(q);
          labels[q] = -version;
          continue;
        }
        labels[q] = label;
        if (touched != nullptr) touched[q / kCellSide] = 1;
        model.add(f, q);
        assert(static_cast<std::size_t>(tail) < capacity);
        queue[tail++] = q;
        if (model.plane_version() != version) {
          // A new plane: earlier rejections among the remaining neighbours are stale.
          version = model.plane_version();
          const unsigned remaining = ~((2u << k) - 1u);
          candidates = candidates_of(p, edges_p, version) & remaining;
        }
      }
    }
    for (const std::int32_t q : *marked) labels[q] = std::max(labels[q], std::int32_t{0});
  } else {
    while (head < tail) {
      const std::int32_t p = queue[head++];
      unsigned mask = edges[p];
      while (mask != 0) {
        const int k = std::countr_zero(mask);
        mask &= mask - 1;
        const std::int32_t q = static_cast<std::int32_t>(p + offsets[k]);
        if (labels[q] != 0 || !model.accepts(f, p, q)) continue;
        labels[q] = label;
        if (touched != nullptr) touched[q / kCellSide] = 1;
        model.add(f, q);
        assert(static_cast<std::size_t>(tail) < capacity);
        queue[tail++] = q;
      }
    }
  }
  return tail;
}

/// Coarse level of `grow_regions`: complete cells in ascending curvature order seed regions that
/// grow over neighbouring cells the model accepts as units; each region then continues pixel by
/// pixel from the border of its cells. Raw labels continue from `label`. Needs scratch.cells
/// computed for this frame (`compute_cells`).
template <CellGrowingModel Model>
void grow_cells(const Frame& f, Model& model, Segmenter::Scratch& s, std::int32_t& label) {
  using namespace detail_engine;
  const int cols = s.cell_cols, rows = s.cell_rows;
  const auto& cells = s.cells;
  auto& cell_label = s.cell_label;
  // Ascending curvature, ties in index order (a stable sort of the cells in index order).
  s.cell_order.clear();
  s.cell_keys.clear();
  // Cells with missing vertices join regions but seed none: where a sensor drops pixels, the
  // surface is often one it measures poorly (dark, shiny, or small and curved, like a mug's
  // handle), and a region seeded there that stays small would keep the pixel seeds out.
  for (std::int32_t c = 0; c < cols * rows; ++c) {
    if (cells[c].complete && cells[c].stats.count == kCellVertices &&
        model.cell_seed_ok(cells[c])) {
      s.cell_order.push_back(c);
      s.cell_keys.push_back(detail::float_order_key(cells[c].curvature));
    }
  }
  detail::radix_sort_by_key(s.cell_order, s.cell_keys, s.sort_items, s.sort_keys);
  s.cell_queue.resize(static_cast<std::size_t>(cols) * rows);
  s.rejected.clear();
  std::int32_t* const cell_queue = s.cell_queue.data();
  std::int32_t* const queue = s.queue.data();
  const int step = f.pixel_stride;
  const std::ptrdiff_t down = step * f.stride;
  // A cell not grown as a unit has labelled vertices only where the pixel growth of a region
  // entered it. At lattice step 1, with a row stride that is a multiple of kCellSide (so that
  // each flag covers one row of one cell), that growth flags each such row it labels, and a
  // cell is free when its kCellSide flags are clear: the flags of the whole frame fit in cache,
  // unlike the labels of cells not yet visited.
  std::uint8_t* touched = nullptr;
  if (step == 1 && f.stride % kCellSide == 0) {
    s.cell_touched.assign(static_cast<std::size_t>(f.height) * f.stride / kCellSide + 1, 0);
    touched = s.cell_touched.data();
  }
  const auto is_free = [&](std::ptrdiff_t origin) {
    if (touched == nullptr) return cell_free(f, origin);
    const std::uint8_t* flag = touched + origin / kCellSide;
    const std::ptrdiff_t flag_row = f.stride / kCellSide;
    std::uint8_t any = 0;
    for (int j = 0; j < kCellSide; ++j) any |= flag[j * flag_row];
    return any == 0;
  };
  for (const std::int32_t seed : s.cell_order) {
    if (cell_label[seed] != 0) continue;
    const int su = seed % cols, sv = seed / cols;
    if (!is_free(cell_origin(f, su, sv))) {
      cell_label[seed] = -1;
      continue;
    }
    ++label;
    cell_label[seed] = label;
    label_cell(f, cell_origin(f, su, sv), label, cells[seed]);
    model.init_cell(cells[seed]);
    std::int32_t head = 0, tail = 0;
    cell_queue[tail++] = seed;
    while (head < tail) {
      const std::int32_t c = cell_queue[head++];
      const int cu = c % cols, cv = c / cols;
      const std::ptrdiff_t origin = cell_origin(f, cu, cv);
      for (int k = 0; k < 8; ++k) {
        const int nu = cu + kNeighbourDu[k], nv = cv + kNeighbourDv[k];
        if (nu < 0 || nv < 0 || nu >= cols || nv >= rows) continue;
        const std::int32_t n = nv * cols + nu;
        if (cell_label[n] != 0 || !cells[n].complete) continue;
        if (!cells_connected(f, origin, k) || !model.accepts_cell(cells[n])) continue;
        const std::ptrdiff_t n_origin = cell_origin(f, nu, nv);
        if (!is_free(n_origin)) {
          cell_label[n] = -1;
          continue;
        }
        cell_label[n] = label;
        label_cell(f, n_origin, label, cells[n]);
        model.add_cell(cells[n]);
        cell_queue[tail++] = n;
      }
    }
    // Continue pixel-wise from the border vertices of the region's cells that face a cell with
    // free vertices (not grown as a unit) or the image's partial border cells.
    std::int32_t ptail = 0;
    for (std::int32_t j = 0; j < tail; ++j) {
      const std::int32_t c = cell_queue[j];
      const int cu = c % cols, cv = c / cols;
      unsigned outside = 0;  // bit k: neighbour cell k is not in the region
      for (int k = 0; k < 8; ++k) {
        const int nu = cu + kNeighbourDu[k], nv = cv + kNeighbourDv[k];
        // A cell grown as a unit (by this or an earlier region) has no free vertex.
        const bool done =
            nu >= 0 && nv >= 0 && nu < cols && nv < rows && cell_label[nv * cols + nu] > 0;
        if (!done) outside |= 1u << k;
      }
      if (outside == 0) continue;
      const std::ptrdiff_t origin = cell_origin(f, cu, cv);
      for (const BorderVertex& b : kBorderVertices) {
        if ((b.touches & outside) != 0) {
          queue[ptail++] =
              static_cast<std::int32_t>(origin + b.row * down + std::ptrdiff_t{b.column} * step);
        }
      }
    }
    grow_pixels(f, model, label, queue, 0, ptail, s.queue.size(), &s.marked, touched);
    detail::append_with_headroom(s.rejected, s.marked.begin(), s.marked.end());
    s.regions.push_back(model.stats());
  }
}

/// Outer loop over the seeds (ascending curvature), inner loop over a flat processing queue.
/// A pixel is labelled when it is accepted, so it enters the queue at most once per frame.
/// Models with the cell interface are first grown over cells (`grow_cells`); the pixel seeds
/// then only start regions in what the cells left unlabelled. The pixel seeds are
/// scratch.seeds as the caller filled them (`collect_seeds`), or, given `seed_settings`, are
/// collected here after the coarse level (only the pixels it left unlabelled).
/// `after_cells()` runs between the coarse level and the pixel seeds.
template <RegionGrowingModel Model, class AfterCells = void (*)()>
void grow_regions(
    const Frame& f, Model& model, Segmenter::Scratch& s,
    const SegmentationSettings* seed_settings = nullptr, AfterCells&& after_cells = [] {}) {
  std::int32_t* const labels = f.labels;
  std::int32_t* const queue = s.queue.data();
  s.regions.clear();
  s.regions.emplace_back();  // raw label 0: none
  std::int32_t label = 0;
  if constexpr (CellGrowingModel<Model>) grow_cells(f, model, s, label);
  after_cells();
  if (seed_settings != nullptr) {
    // A model whose seed test is seed_passes lets the scan drop the seeds it would veto.
    if constexpr (requires { model.seed_veto(); }) {
      const SeedVeto veto = model.seed_veto();
      collect_seeds(f, *seed_settings, s, &veto);
    } else {
      collect_seeds(f, *seed_settings, s);
    }
  }
  for (const std::int32_t seed : s.seeds) {
    if (labels[seed] != 0) continue;
    if constexpr (requires { model.seed_ok(f, seed); }) {
      if (!model.seed_ok(f, seed)) continue;
    }
    ++label;
    labels[seed] = label;
    model.init(f, seed);
    queue[0] = seed;
    grow_pixels(f, model, label, queue, 0, 1, s.queue.size(), &s.marked);
    s.regions.push_back(model.stats());
  }
}

}  // namespace rangeseg::seg
