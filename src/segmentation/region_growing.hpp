// Internal: the region-growing engine of the paper (Sec. III-D), generic over the region model.
#pragma once

#include <bit>
#include <cassert>
#include <concepts>
#include <cstdint>

#include "segmentation/internal.hpp"

namespace rangeseg::seg {

/// What the engine needs from a region model. `init` starts a region at a seed pixel (already
/// added), `accepts(frame, from, candidate)` tests a mesh neighbour `candidate` of the region
/// point `from`, `add` adds an accepted pixel, `stats` gives the region's point statistics.
/// Models are plain structs; the engine is instantiated per model (no virtual call per point).
template <class M>
concept RegionGrowingModel = requires(M m, const M cm, const Frame& f, std::int32_t i) {
  m.init(f, i);
  { cm.accepts(f, i, i) } -> std::convertible_to<bool>;
  m.add(f, i);
  { cm.stats() } -> std::convertible_to<const detail::PlaneStats&>;
};

/// Outer loop over the seeds (ascending curvature), inner loop over a flat processing queue.
/// A pixel is labelled when it is accepted, so it enters the queue at most once per frame.
template <RegionGrowingModel Model>
void grow_regions(const Frame& f, Model& model, Segmenter::Scratch& s) {
  std::int32_t* const labels = f.labels;
  std::int32_t* const queue = s.queue.data();
  const std::uint8_t* const edges = f.edges;
  const auto offsets = f.neighbour_offset;
  s.regions.clear();
  s.regions.emplace_back();  // raw label 0: none
  std::int32_t label = 0;
  for (const std::int32_t seed : s.seeds) {
    if (labels[seed] != 0) continue;
    if constexpr (requires { model.seed_ok(f, seed); }) {
      if (!model.seed_ok(f, seed)) continue;
    }
    ++label;
    labels[seed] = label;
    model.init(f, seed);
    std::int32_t head = 0, tail = 0;
    queue[tail++] = seed;
    while (head < tail) {
      const std::int32_t p = queue[head++];
      unsigned mask = edges[p];
      while (mask != 0) {
        const int k = std::countr_zero(mask);
        mask &= mask - 1;
        const std::int32_t q = static_cast<std::int32_t>(p + offsets[k]);
        if (labels[q] != 0 || !model.accepts(f, p, q)) continue;
        labels[q] = label;
        model.add(f, q);
        assert(tail < static_cast<std::int32_t>(s.queue.size()));
        queue[tail++] = q;
      }
    }
    s.regions.push_back(model.stats());
  }
}

}  // namespace rangeseg::seg
