// Re-assignment of unlabelled points to adjacent planes: between the coarse level and the pixel
// seeds (reassign_before_seeds) and after small regions are dissolved (reassign_boundary); and
// the refinement of the borders between plane segments (refine_plane_boundaries).
// Contraction into fused multiply-adds is off, as in postprocess.cpp, so the distance tests
// round the same way whatever the build flags.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include "detail/headroom.hpp"
#include "segmentation/internal.hpp"

namespace rangeseg::seg {
namespace {

using detail::PlaneFit;

/// The in-image lattice neighbours of pixel (u, v) (bit k: direction k), whatever its mesh edges.
inline unsigned lattice_mask(const Frame& f, int u, int v) {
  const int step = f.pixel_stride;
  if (u >= step && v >= step && u + step < f.width && v + step < f.height) return 0xFFu;
  unsigned inside = 0;
  for (int k = 0; k < 8; ++k) {
    const int nu = u + step * kNeighbourDu[k], nv = v + step * kNeighbourDv[k];
    if (nu >= 0 && nv >= 0 && nu < f.width && nv < f.height) inside |= 1u << k;
  }
  return inside;
}

/// The neighbours a point is re-assigned over: its mesh 1-ring, plus (kAcrossCuts), for a valid
/// point, the rest of its 8 lattice neighbours inside the image. The mesh's jump gate compares
/// depths along the viewing ray, and on a surface seen at grazing incidence (70-90 deg) by a
/// sensor whose noise is far below the pixel footprint, consecutive samples lie several sigma
/// apart along the ray although they are on the surface within the noise, so the mesh cuts a
/// narrow strip of such a surface into single columns and leaves its outermost points isolated;
/// the plane test measures the distance perpendicular to the surface, which is the right test
/// for them (a point across a real depth step is far from the plane).
template <bool kAcrossCuts>
inline unsigned reassign_mask(const Frame& f, std::ptrdiff_t i, int u, int v) {
  const unsigned edges = f.edges[i];
  if (!kAcrossCuts || edges == 0xFFu || !std::isfinite(f.z[i])) return edges;
  return edges | lattice_mask(f, u, v);
}
template <bool kAcrossCuts>
inline unsigned reassign_mask(const Frame& f, std::ptrdiff_t i) {
  if (!kAcrossCuts || f.edges[i] == 0xFFu) return f.edges[i];
  return reassign_mask<kAcrossCuts>(f, i, static_cast<int>(i % f.stride),
                                    static_cast<int>(i / f.stride));
}

/// The point's normal is within the angle (cosine `cos_max_angle`) of the plane's, up to sign,
/// or the point has no normal.
inline bool normal_fits(const detail::PlaneFit& fit, const Frame& f, std::int32_t q,
                        double cos_max_angle) {
  const double dot = fit.normal[0] * f.nx[q] + fit.normal[1] * f.ny[q] + fit.normal[2] * f.nz[q];
  return std::isnan(dot) || std::fabs(dot) >= cos_max_angle;
}

/// The unlabelled points of rows [v_begin, v_end) that have a labelled re-assignment neighbour,
/// in scan order into `out`, flagged in `queued`; returns how many. `row_pixels`: one row.
template <bool kAcrossCuts>
std::size_t reassign_candidates(const Frame& f, int v_begin, int v_end, std::int32_t* row_pixels,
                                std::uint8_t* queued, std::int32_t* out) {
  std::size_t n = 0;
  const auto has_labelled_neighbour = [&](std::ptrdiff_t i, int u, int v) {
    unsigned mask = reassign_mask<kAcrossCuts>(f, i, u, v);
    while (mask != 0) {
      const int k = std::countr_zero(mask);
      mask &= mask - 1;
      if (f.labels[i + f.neighbour_offset[k]] != 0) return true;
    }
    return false;
  };
  const int step = f.pixel_stride;
  const auto consider = [&](std::ptrdiff_t row, int u, int v) {
    const std::ptrdiff_t i = row + u;
    const bool candidate = kAcrossCuts ? std::isfinite(f.z[i]) : f.edges[i] != 0;
    if (f.labels[i] == 0 && candidate && has_labelled_neighbour(i, u, v)) {
      queued[i] = 1;
      out[n++] = static_cast<std::int32_t>(i);
    }
  };
  // At stride 1 the inner pixels of inner rows are first screened a vector at a time: only an
  // unlabelled pixel with a labelled one among its 8 neighbours can be a candidate.
  const bool screen = step == 1 && f.width > 2;
  for (int v = v_begin; v < v_end; v += step) {
    const std::ptrdiff_t row = v * f.stride;
    int u = 0;
    if (screen && v > 0 && v + 1 < f.height) {
      consider(row, 0, v);
      int found = 0;
      u = unlabelled_border_pixels(f.labels + row - f.stride, f.labels + row,
                                   f.labels + row + f.stride, 1, f.width - 1, row_pixels, found);
      for (int j = 0; j < found; ++j) consider(row, row_pixels[j], v);
    }
    for (; u < f.width; u += step) consider(row, u, v);
  }
  return n;
}

/// The test of boundary re-assignment for one unlabelled candidate q: the adjacent plane (over
/// `reassign_mask` neighbours; planes are s.fits by label, `ok` ones only) it is closest to, if
/// within k sigma(z) of it and (unless kAcrossCuts) with its normal within
/// reassign_max_normal_angle of the plane's; 0 for none. `unlabelled` gets the direction bits of
/// q's unlabelled neighbours.
template <bool kAcrossCuts>
class ReassignTest {
 public:
  ReassignTest(const Frame& f, const SegmentationSettings& settings, const Segmenter::Scratch& s)
      : f_(f),
        s_(s),
        settings_(settings),
        k_(settings.max_distance_sigmas),
        cos_max_angle_(std::cos(settings.reassign_max_normal_angle)),
        block_first_(f.stride + 1),
        block_last_(f.pixel_stride == 1 ? (f.height - 1) * f.stride - 3 : -1) {}

  std::int32_t operator()(std::int32_t q, unsigned& unlabelled) const {
    const Frame& f = f_;
    const double x = f.x[q], y = f.y[q], z = f.z[q];
    std::int32_t best = 0;
    double best_distance = k_ * settings_.noise.sigma(z);
    unsigned mask = reassign_mask<kAcrossCuts>(f, q);
    unlabelled = 0;
#if defined(__SSE2__)
    // Nearly always the labelled neighbours carry one label: one test decides, as in the loop
    // below (which would repeat the same test for each of them). The 3 x 4 label block starting
    // at q - stride - 1 must lie inside the plane (lattice step 1).
    if (q >= block_first_ && q <= block_last_) {
      const NeighbourLabels around = single_neighbour_label(f.labels, f.stride, q, mask);
      if (around.single) {
        unlabelled = around.unlabelled;
        const detail::PlaneFit& fit = s_.fits[around.label];
        const double d = std::fabs(fit.distance(x, y, z));
        if (fit.ok && d <= best_distance &&
            (kAcrossCuts || normal_fits(fit, f, q, cos_max_angle_))) {
          best = around.label;
        }
        return best;
      }
    }
#endif
    while (mask != 0) {
      const int n = std::countr_zero(mask);
      mask &= mask - 1;
      const std::int32_t label = f.labels[q + f.neighbour_offset[n]];
      if (label == 0) unlabelled |= 1u << n;
      if (label == 0 || label == best || !s_.fits[label].ok) continue;
      const double d = std::fabs(s_.fits[label].distance(x, y, z));
      if (d <= best_distance &&
          (kAcrossCuts || normal_fits(s_.fits[label], f, q, cos_max_angle_))) {
        best_distance = d;
        best = label;
      }
    }
    return best;
  }

 private:
  const Frame& f_;
  const Segmenter::Scratch& s_;
  const SegmentationSettings& settings_;
  double k_, cos_max_angle_;
  std::ptrdiff_t block_first_, block_last_;
};

/// Candidates lie scattered along the borders of the frame, and a test reads seven planes at
/// each: the queue loops prefetch the point kAhead places ahead (~10 % of the re-assignment's
/// time on grabber_frame0).
constexpr std::size_t kAhead = 8;
inline void prefetch_point(const Frame& f, std::int32_t q) {
  __builtin_prefetch(f.labels + q);
  __builtin_prefetch(f.x + q);
  __builtin_prefetch(f.y + q);
  __builtin_prefetch(f.z + q);
  __builtin_prefetch(f.nx + q);
  __builtin_prefetch(f.ny + q);
  __builtin_prefetch(f.nz + q);
}

/// The re-assignment of the candidates ring[0, size) of s.queue (flagged in s.queued): each
/// unlabelled one joins the plane of `ReassignTest`, and newly labelled points make their
/// neighbours candidates in turn, so dissolved small regions that lie on an adjacent plane are
/// absorbed whole.
template <bool kAcrossCuts>
void reassign_queued(const Frame& f, const SegmentationSettings& settings, Segmenter::Scratch& s,
                     std::size_t size) {
  std::int32_t* const ring = s.queue.data();
  const std::size_t capacity = s.queue.size();
  std::size_t head = 0;
  const auto push = [&](std::int32_t i) {
    s.queued[i] = 1;
    std::size_t slot = head + size;
    if (slot >= capacity) slot -= capacity;
    ring[slot] = i;
    ++size;
  };
  const ReassignTest<kAcrossCuts> best_plane(f, settings, s);
  while (size > 0) {
    const std::int32_t q = ring[head];
    if (size > kAhead) {
      std::size_t ahead = head + kAhead;
      if (ahead >= capacity) ahead -= capacity;
      prefetch_point(f, ring[ahead]);
    }
    if (++head == capacity) head = 0;
    --size;
    s.queued[q] = 0;
    if (f.labels[q] != 0) continue;
    unsigned unlabelled = 0;  // neighbours to queue if q joins a segment
    const std::int32_t best = best_plane(q, unlabelled);
    if (best == 0) continue;
    f.labels[q] = best;
    s.regions[best].add(f.x[q], f.y[q], f.z[q]);
    while (unlabelled != 0) {
      const int n = std::countr_zero(unlabelled);
      unlabelled &= unlabelled - 1;
      const std::int32_t r = static_cast<std::int32_t>(q + f.neighbour_offset[n]);
      if (!s.queued[r] && (!kAcrossCuts || std::isfinite(f.z[r]))) push(r);
    }
  }
}

/// Unlabelled valid points next to a plane segment join the adjacent plane they are closest to
/// (`reassign_queued`, with propagation); the candidates are found by a scan of the frame.
template <bool kAcrossCuts>
void reassign_boundary_points(const Frame& f, const SegmentationSettings& settings,
                              Segmenter::Scratch& s) {
  const std::size_t pixels = static_cast<std::size_t>(f.stride) * f.height;
  // Every pixel queued is dequeued again (and its flag cleared) before reassign_queued returns.
  if (s.queued.size() != pixels) s.queued.assign(pixels, 0);
  std::int32_t* const ring = s.queue.data();
  std::size_t size = 0;
  // The first candidates: row bands scanned concurrently, each into the ring from its first
  // pixel on (a band has fewer candidates than pixels), then moved together in band order.
  const auto bands = static_cast<std::size_t>(band_count(s));
  ensure_band_buffers(s, f.width);
  for_each_band(s, f.height, f.pixel_stride, [&](int band, int v_begin, int v_end) {
    const std::size_t first = static_cast<std::size_t>(v_begin) * f.stride;
    const auto b = static_cast<std::size_t>(band);
    s.band_found[2 * b] = first;
    s.band_found[2 * b + 1] = reassign_candidates<kAcrossCuts>(
        f, v_begin, v_end, row_pixels_of(s, band), s.queued.data(), ring + first);
  });
  for (std::size_t band = 0; band < bands; ++band) {
    const std::int32_t* const found = ring + s.band_found[2 * band];
    const std::size_t n = s.band_found[2 * band + 1];
    if (found != ring + size) std::copy(found, found + n, ring + size);
    size += n;
  }
  reassign_queued<kAcrossCuts>(f, settings, s, size);
}

/// Rounds of refine_plane_boundaries: the planes are refitted after each, and a later round
/// tests only the points next to those that moved, so a border that growth put several points
/// off a shallow crease moves back a point per round.
constexpr int kBorderRounds = 8;

/// Directions 0..3 (right, down-right, down, down-left): every lattice neighbour pair once.
constexpr unsigned kForward = 0x0Fu;

/// Records the move of point `x` (segment root `from`) to segment root `to` if it lies closer
/// to `to`'s plane by more than the margin and within the growth test's bound of it.
void consider_move(const Frame& f, const SegmentationSettings& settings, Segmenter::Scratch& s,
                   std::int32_t x, std::int32_t from, std::int32_t to) {
  const detail::PlaneFit& a = s.fits[from];
  const detail::PlaneFit& b = s.fits[to];
  if (!a.ok || !b.ok || s.grazing_region[from] != 0 || s.grazing_region[to] != 0) return;
  const double px = f.x[x], py = f.y[x], pz = f.z[x];
  const double sigma = settings.noise.sigma(pz);
  const double da = std::fabs(a.distance(px, py, pz)), db = std::fabs(b.distance(px, py, pz));
  if (da - db > settings.boundary_refine_sigmas * sigma &&
      db <= settings.max_distance_sigmas * sigma) {
    s.boundary_moves.push_back({.pixel = x, .target = to, .distance = db});
  }
}

/// Both points of the mesh edges from point p in the directions `edges` whose ends lie in
/// different plane segments, each tested for the other's segment.
void consider_edges(const Frame& f, const SegmentationSettings& settings, Segmenter::Scratch& s,
                    std::int32_t p, unsigned edges) {
  const std::int32_t lp = f.labels[p];
  const std::int32_t a = lp > 0 ? s.root_of[lp] : 0;
  if (a == 0) return;
  while (edges != 0) {
    const int k = std::countr_zero(edges);
    edges &= edges - 1;
    const auto q = static_cast<std::int32_t>(p + f.neighbour_offset[k]);
    const std::int32_t lq = f.labels[q];
    const std::int32_t b = lq > 0 ? s.root_of[lq] : 0;
    if (b == 0 || b == a) continue;
    consider_move(f, settings, s, p, a, b);
    consider_move(f, settings, s, q, b, a);
  }
}

/// The moves of the first round: both points of every pair of lattice neighbours joined by a
/// mesh edge whose segments differ (from the borders merging found, unless a split changed
/// them).
void collect_border_moves(const Frame& f, const SegmentationSettings& settings,
                          Segmenter::Scratch& s) {
  s.boundary_moves.clear();
  const int step = f.pixel_stride;
  const auto pair_at = [&](std::ptrdiff_t p) {
    consider_edges(f, settings, s, static_cast<std::int32_t>(p), f.edges[p] & kForward);
  };
  if (s.border_regions == s.regions.size()) {
    // Merging found the borders, and merging keeps the raw labels; a split (which adds
    // regions) relabels pixels, and the frame is scanned again.
    for (int band = 0; band < band_count(s); ++band) {
      for (const std::int32_t p : s.band_border[static_cast<std::size_t>(band)]) pair_at(p);
    }
    return;
  }
  const bool vector_scan = step == 1 && f.width > 2;
  for (int v = 0; v + step < f.height; v += step) {
    const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(v) * f.stride;
    int u = 0;
    if (vector_scan) {
      // Only a labelled pixel whose label differs from a forward neighbour's starts a pair.
      pair_at(row);
      int found = 0;
      u = adjacency_pixels(f.labels + row, f.labels + row + f.stride, 1, f.width - 1,
                           s.row_pixels.data(), found);
      for (int j = 0; j < found; ++j) pair_at(row + s.row_pixels[j]);
    }
    for (; u < f.width; u += step) pair_at(row + u);
  }
}

/// The moves of a later round: only the points that moved in the last one and their mesh
/// neighbours have a new neighbouring segment.
void collect_moves_around(const Frame& f, const SegmentationSettings& settings,
                          Segmenter::Scratch& s) {
  s.boundary_moves.clear();
  for (const std::int32_t m : s.moved) consider_edges(f, settings, s, m, f.edges[m]);
}

/// Applies the collected moves (a point next to several segments goes to the closest plane;
/// all were decided on the labels and planes as they were) and refits the planes they changed;
/// the moved points into s.moved. Returns whether a point moved.
bool apply_border_moves(const Frame& f, Segmenter::Scratch& s) {
  s.moved.clear();
  if (s.boundary_moves.empty()) return false;
  std::sort(s.boundary_moves.begin(), s.boundary_moves.end(),
            [](const BoundaryMove& m, const BoundaryMove& n) {
              return m.pixel != n.pixel ? m.pixel < n.pixel : m.distance < n.distance;
            });
  std::int32_t last = -1;
  for (const BoundaryMove& m : s.boundary_moves) {
    if (m.pixel == last) continue;
    last = m.pixel;
    const std::int32_t from = s.root_of[f.labels[m.pixel]];
    if (s.regions[from].count <= 3) continue;  // a segment keeps a plane
    const double x = f.x[m.pixel], y = f.y[m.pixel], z = f.z[m.pixel];
    s.regions[from].remove(x, y, z);
    s.regions[m.target].add(x, y, z);
    f.labels[m.pixel] = m.target;
    s.refit[from] = s.refit[m.target] = 1;
    s.moved.push_back(m.pixel);
  }
  for (std::size_t r = 0; r < s.refit.size(); ++r) {
    if (s.refit[r] != 0) s.fits[r] = s.regions[r].fit();
    s.refit[r] = 0;
  }
  return !s.moved.empty();
}

}  // namespace

void reassign_before_seeds(const Frame& f, const SegmentationSettings& settings,
                           Segmenter::Scratch& s) {
  const auto region_count = static_cast<std::int32_t>(s.regions.size());  // incl. label 0
  detail::assign_with_headroom(s.fits, static_cast<std::size_t>(region_count), PlaneFit{});
  bool any = false;
  for (std::int32_t r = 1; r < region_count; ++r) {
    if (s.regions[r].count >= settings.min_region_size) {
      s.fits[r] = s.regions[r].fit();
      any = any || s.fits[r].ok;
    }
  }
  if (!any) return;
  // The unlabelled points on a region's mesh 1-ring are those its growth rejected: every free
  // mesh neighbour of a region point was tested, but for the inner points of cells grown as
  // units, whose neighbours are all labelled.
  const std::size_t pixels = static_cast<std::size_t>(f.stride) * f.height;
  if (s.queued.size() != pixels) s.queued.assign(pixels, 0);
  std::int32_t* const ring = s.queue.data();
  std::size_t size = 0;
  for (const std::int32_t q : s.rejected) {
    if (f.labels[q] != 0 || s.queued[q] != 0) continue;
    s.queued[q] = 1;
    ring[size++] = q;
  }
  // Every candidate is decided on the labels as they were before any joined, so the candidates
  // are split among the bands (each collects its joins), and the joins applied in order.
  const auto bands = static_cast<std::size_t>(band_count(s));
  if (s.band_joins.size() < bands) s.band_joins.resize(bands);
  const ReassignTest<false> best_plane(f, settings, s);
  for_each_band(s, static_cast<int>(size), 1, [&](int band, int begin, int end) {
    auto& joins = band == 0 ? s.joins : s.band_joins[static_cast<std::size_t>(band)];
    joins.clear();
    unsigned unlabelled = 0;
    for (int j = begin; j < end; ++j) {
      const std::int32_t q = ring[j];
      if (j + static_cast<int>(kAhead) < end) prefetch_point(f, ring[j + kAhead]);
      s.queued[q] = 0;
      const std::int32_t best = best_plane(q, unlabelled);
      if (best != 0) joins.emplace_back(q, best);
    }
  });
  for (std::size_t band = 0; band < bands; ++band) {
    for (const auto& [q, best] : band == 0 ? s.joins : s.band_joins[band]) {
      f.labels[q] = best;
      s.regions[best].add(f.x[q], f.y[q], f.z[q]);
    }
  }
}

void reassign_boundary(const Frame& f, const SegmentationSettings& settings,
                       Segmenter::Scratch& s) {
  if (settings.reassign_across_mesh_cuts) {
    reassign_boundary_points<true>(f, settings, s);
  } else {
    reassign_boundary_points<false>(f, settings, s);
  }
}

void refine_plane_boundaries(const Frame& f, const SegmentationSettings& settings,
                             Segmenter::Scratch& s) {
  const std::size_t regions = s.regions.size();
  detail::assign_with_headroom(s.root_of, regions, 0);
  for (std::size_t r = 1; r < regions && r < s.remap.size(); ++r) {
    const auto label = static_cast<std::int32_t>(r);
    if (s.remap[r] == label) s.root_of[r] = find_root(s.parent, label);
  }
  detail::assign_with_headroom(s.refit, regions, 0);
  s.row_pixels.resize(static_cast<std::size_t>(f.width));
  collect_border_moves(f, settings, s);
  for (int round = 1; apply_border_moves(f, s) && round < kBorderRounds; ++round) {
    collect_moves_around(f, settings, s);
  }
}

}  // namespace rangeseg::seg
