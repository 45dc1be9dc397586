// Internal: the data shared by the segmentation stages (engine, models, post-processing).
#pragma once

#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "detail/plane_stats.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/segmentation.hpp"

namespace rangeseg::seg {

/// Throws std::invalid_argument naming the field and its value for invalid settings.
void validate(const SegmentationSettings& s);

/// Flat views of every per-pixel input plane. All planes have the same width and therefore the
/// same row stride, so one index i = v * stride + u addresses all of them.
struct Frame {
  const float* x = nullptr;
  const float* y = nullptr;
  const float* z = nullptr;
  const float* nx = nullptr;
  const float* ny = nullptr;
  const float* nz = nullptr;
  const float* curvature = nullptr;
  const std::uint8_t* edges = nullptr;
  const std::uint8_t* faces = nullptr;  ///< face_bits per cell (top-left pixel)
  std::int32_t* labels = nullptr;
  int width = 0, height = 0;
  std::ptrdiff_t stride = 0;  ///< [elements]
  int pixel_stride = 1;       ///< mesh lattice step s
  /// Index offset of the 8 mesh neighbour directions (kNeighbourDu/Dv, scaled by s).
  std::array<std::ptrdiff_t, 8> neighbour_offset{};
  /// Only the primitive pass (fit_primitives) and the plane split (split_unexplained_planes)
  /// read a frame of k-nearest-neighbour rings: one row of points, each neighbouring
  /// ring_neighbours[i * ring_k, i * ring_k + ring_count[i]) instead of its mesh edges, with
  /// sigma a function of the range from the origin, not of z (noise_depth).
  const std::int32_t* ring_neighbours = nullptr;
  const std::uint8_t* ring_count = nullptr;
  int ring_k = 0;
  /// The first and last lattice columns are neighbours (columns_wrap): merging and the
  /// primitive pass join segments across that seam.
  bool columns_wrap = false;
};

/// Whether the first and last lattice columns of a grid frame are neighbours, as in a spinning
/// lidar's organized scan whose columns go once round the sensor: in most rows where the two
/// seam pixels and their inner neighbours are valid, the angle between the seam pixels' rays
/// (from the origin, the sensor) is at most 2.5 times the larger angle between a seam pixel and
/// its inner neighbour (a column may be missing at the seam; up to 64 rows tested). A camera's
/// first and last columns lie its field of view apart. False for a frame of rings and for fewer
/// than 3 lattice columns.
bool columns_wrap(const Frame& f);

/// The index of the last lattice column's pixel in row 0 (width - 1 rounded down to the lattice).
inline int last_lattice_column(const Frame& f) {
  return (f.width - 1) / f.pixel_stride * f.pixel_stride;
}

/// Whether the seam between pixels `last` (last lattice column) and `first` (first column) of
/// one row is no larger a step than the steps beside it: both valid, and its length within three
/// times the larger of the two pixels' distances to their valid inner neighbours (room for a
/// column missing at the seam), as a mesh edge would join them. Otherwise the seam is a cut
/// there (a depth step).
bool column_seam_linked(const Frame& f, std::ptrdiff_t last, std::ptrdiff_t first);

/// Calls fn(q) for the neighbours q of point i: its ring in a frame of rings, else its mesh
/// neighbours in `directions` (bit k: direction k; 0x05: right and down only).
template <class Fn>
void for_each_neighbour(const Frame& f, std::ptrdiff_t i, unsigned directions, Fn&& fn) {
  if (f.ring_neighbours != nullptr) {
    const std::int32_t* ring = f.ring_neighbours + i * f.ring_k;
    for (int j = 0; j < f.ring_count[i]; ++j) fn(std::ptrdiff_t{ring[j]});
    return;
  }
  unsigned mask = f.edges[i] & directions;
  while (mask != 0) {
    const int k = std::countr_zero(mask);
    mask &= mask - 1;
    fn(i + f.neighbour_offset[k]);
  }
}

/// The argument of the noise model sigma at point p: its z on the grid, its distance from the
/// origin in a frame of rings (`by_range`; unorganized clouds need not have z along the view,
/// and the stages over rings take sigma of the range).
inline double noise_depth(const std::array<double, 3>& p, bool by_range) {
  return by_range ? std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) : p[2];
}

/// Direction bits (kNeighbourDu/Dv order) of the 3 x 3 block around a pixel, from 3 bits per
/// row (columns -1, 0, +1) of the rows above, at and below it: index up | mid << 3 | down << 6.
inline constexpr auto kBlockDirections = [] {
  std::array<std::uint8_t, 512> table{};
  for (unsigned i = 0; i < 512; ++i) {
    const unsigned up = i & 7u, mid = (i >> 3) & 7u, down = (i >> 6) & 7u;
    unsigned d = 0;
    for (int k = 0; k < 8; ++k) {
      const unsigned row = kNeighbourDv[k] < 0 ? up : kNeighbourDv[k] > 0 ? down : mid;
      d |= ((row >> (kNeighbourDu[k] + 1)) & 1u) << k;
    }
    table[i] = static_cast<std::uint8_t>(d);
  }
  return table;
}();

#if defined(__SSE2__)
struct NeighbourLabels {
  std::int32_t label = 0;   ///< the one label of the labelled neighbours (0: none)
  unsigned unlabelled = 0;  ///< direction bits of the unlabelled neighbours
  bool single = false;      ///< all labelled neighbours carry `label` (or there are none)
};

/// The labels of the neighbours of pixel q in `directions` (bit k: direction k, lattice step 1),
/// from three vector loads of the 3 x 4 block starting at q - stride - 1, which must lie inside
/// the label plane.
inline NeighbourLabels single_neighbour_label(const std::int32_t* labels, std::ptrdiff_t stride,
                                              std::ptrdiff_t q, unsigned directions) {
  const std::int32_t* const left = labels + q - 1;
  const __m128i up = _mm_loadu_si128(reinterpret_cast<const __m128i*>(left - stride));
  const __m128i mid = _mm_loadu_si128(reinterpret_cast<const __m128i*>(left));
  const __m128i down = _mm_loadu_si128(reinterpret_cast<const __m128i*>(left + stride));
  const auto bits_of = [](__m128i a, __m128i b, __m128i c, __m128i value) {
    const auto bits = [&](__m128i row) {
      return static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(row, value)))) &
             7u;
    };
    return static_cast<unsigned>(kBlockDirections[bits(a) | bits(b) << 3 | bits(c) << 6]);
  };
  NeighbourLabels out;
  out.unlabelled = bits_of(up, mid, down, _mm_setzero_si128()) & directions;
  const unsigned labelled = directions & ~out.unlabelled;
  if (labelled == 0) {
    out.single = true;
    return out;
  }
  const int first = std::countr_zero(labelled);
  const std::ptrdiff_t offset = kNeighbourDv[first] * stride + kNeighbourDu[first];
  out.label = labels[q + offset];
  out.single = (labelled & ~bits_of(up, mid, down, _mm_set1_epi32(out.label))) == 0;
  return out;
}
#endif

/// Side of the square cells of the coarse growing level [lattice steps] (8 x 8 vertices).
inline constexpr int kCellSide = 8;

/// One part of a region being split (split_unexplained_planes): its raw label, its points in
/// the region's pixel list while splitting, and its plane.
struct SplitPart {
  std::int32_t label = 0;
  std::size_t begin = 0, end = 0;
  detail::PlaneStats stats;
  detail::PlaneFit fit;
  bool splittable = true;
};

/// At most this many of a cell's kCellSide^2 vertices may lack a point or normal for the cell to
/// be grown as a unit: sensors drop single pixels (speckle, 0.5 % in the synthetic Kinect
/// model, where 28 % of the cells miss at least one and 0.01 % more than four), and a cell's
/// plane is still measured from 60 of its 64 points.
inline constexpr int kCellMaxMissing = 4;
inline constexpr std::int64_t kCellVertices = std::int64_t{kCellSide} * kCellSide;

/// A vertex that counts in its cell's statistics (point, normal and curvature present), and
/// only such a vertex is labelled when its cell joins a region as a unit: the two must agree,
/// or a region's point count would differ from its labelled pixels. (With the library's own
/// normals the three go together; a caller's NormalMap need not.)
inline bool cell_vertex_valid(const Frame& f, std::ptrdiff_t p) {
  return f.z[p] == f.z[p] && f.nz[p] == f.nz[p] && f.curvature[p] <= 3e38f;
}

/// Statistics of one kCellSide x kCellSide cell of mesh vertices, for growing whole cells at a
/// time (cf. CAPE / PEAC). `complete` cells have every vertex valid (point and normal), or all
/// but at most kCellMaxMissing, and every mesh edge between horizontally and vertically adjacent
/// valid vertices inside the cell, so the cell is one piece of surface; only complete cells are
/// grown as units. Their vertices without one stay unlabelled (`cell_vertex_valid`).
struct Cell {
  detail::PlaneStats stats;          ///< points [m] (stats.count: the valid vertices)
  double snx = 0, sny = 0, snz = 0;  ///< sum of the vertex normals
  float curvature = 0;               ///< sum of the vertex curvatures [1/m]
  bool complete = false;
};

/// A border point of a plane segment that lies closer to an adjacent segment's plane
/// (refine_plane_boundaries).
struct BoundaryMove {
  std::int32_t pixel = 0;
  std::int32_t target = 0;  ///< root label of the segment it moves to
  double distance = 0;      ///< to the target's plane [m]
};

/// Buffers of the primitive pass of RegionModel::automatic (primitive_model.cpp).
struct PrimitiveScratch;
struct PrimitiveScratchDeleter {
  void operator()(PrimitiveScratch* p) const;
};
using PrimitiveScratchPtr = std::unique_ptr<PrimitiveScratch, PrimitiveScratchDeleter>;

}  // namespace rangeseg::seg

namespace rangeseg {

struct Segmenter::Scratch {
  // seeds
  std::vector<std::int32_t> candidate_pixel;
  std::vector<std::uint16_t> candidate_key;
  std::vector<std::int32_t> bucket_start;
  std::vector<std::int32_t> seeds;
  // region growing
  std::vector<std::int32_t> queue;
  std::vector<std::int32_t> marked;    ///< pixels rejected by a region (grow_pixels)
  std::vector<std::int32_t> rejected;  ///< `marked` of all regions of the cell level
  std::vector<std::pair<std::int32_t, std::int32_t>> joins;  ///< (pixel, label) re-assignments
  // refine_plane_boundaries
  std::vector<std::int32_t> root_of;              ///< per raw label its segment's root, 0 = none
  std::vector<seg::BoundaryMove> boundary_moves;  ///< candidate moves of a round
  std::vector<std::uint8_t> refit;                ///< per raw label: its plane changed this round
  std::vector<std::int32_t> moved;                ///< points moved in the last round
  std::vector<detail::PlaneStats> regions;        ///< per raw region label; [0] unused
  std::vector<detail::PlaneStats> segment_stats;  ///< per segment after post-processing (auto)
  /// The primitive pass's buffers (auto model), made on its first frame.
  seg::PrimitiveScratchPtr primitive;
  // coarse level (models with a cell interface)
  std::vector<seg::Cell> cells;  ///< row-major, cell_cols x cell_rows
  int cell_cols = 0, cell_rows = 0;
  std::vector<std::int32_t> cell_label;  ///< raw label of a cell grown as a unit; -1 = broken
  std::vector<std::int32_t> cell_order;
  std::vector<std::uint32_t> cell_keys;  ///< detail::float_order_key of cell_order's curvatures
  std::vector<std::int32_t> sort_items;  ///< radix sort scratch
  std::vector<std::uint32_t> sort_keys;  ///< radix sort scratch
  std::vector<std::int32_t> cell_queue;
  /// One flag per run of kCellSide pixels of a row (byte p / kCellSide for pixel p), set when
  /// the coarse level's pixel growth labels one of them (grow_cells, lattice step 1): a cell is
  /// free when the flags of its rows are clear, without reading its labels.
  std::vector<std::uint8_t> cell_touched;
  std::vector<double> cell_normal_noise;  ///< per complete cell (normal_noise_constant)
  /// The frame's normal noise constant c (sigma_n(z) = c sigma(z) / z), 0 when not measured.
  double normal_noise_c = 0;
  detail::CacheLineVector<float> cell_sums;  ///< per-column sums of one cell row (cells.cpp)
  std::vector<std::uint8_t> cell_complete;   ///< per cell of one cell row (cells.cpp)
  // post-processing
  std::vector<detail::PlaneFit> fits;
  std::vector<std::int32_t> parent;       ///< union-find over raw labels
  std::vector<std::int32_t> seam_parent;  ///< union-find of the pieces a band seam cut apart
  std::vector<std::int64_t> seam_count;   ///< per seam_parent root: its group's pixels
  std::vector<std::uint8_t> seam_kept;    ///< per raw label: kept for its group (1), dropped (2)
  std::vector<std::uint64_t> adjacency;
  std::vector<std::uint64_t> adjacency_table;  ///< scratch of detail::sort_distinct
  std::vector<std::int32_t> remap;
  std::vector<std::int32_t> compact;
  std::vector<std::uint8_t> queued;
  std::vector<double> area;
  detail::CacheLineVector<float> cell_area;  ///< twice the mesh area of each cell of one row
  std::vector<std::int32_t> row_pixels;      ///< columns of one row picked by a vector scan
  std::vector<std::int32_t> order;
  std::vector<double> quantile_values;  ///< values of a median or tercile (post-processing)
  // splitting (split_unexplained_planes)
  std::vector<std::int32_t> split_slot;              ///< per raw label: candidate index or -1
  std::vector<std::int32_t> split_candidates;        ///< raw labels of the regions to try
  std::vector<double> split_reference;               ///< per candidate: the others' lower tercile
  std::vector<std::size_t> split_start, split_fill;  ///< per candidate: its points in split_pixels
  std::vector<std::int32_t> split_pixels;
  std::vector<std::int32_t> split_samples;  ///< the subsample of a two-plane fit
  std::vector<double> split_xyzw;           ///< per sample: x, y, z, 1 / sigma(z)^2
  std::vector<std::uint8_t> split_side;     ///< per sample: which plane
  std::vector<std::int32_t> split_pieces;   ///< mesh-connected pieces, flood-filled
  std::vector<std::size_t> split_piece_start;
  std::vector<seg::SplitPart> split_parts;
  // grazing planes (find_grazing_planes)
  std::vector<std::int32_t> grazing_pixels;  ///< the unlabelled points visited, by component
  std::vector<std::int32_t> grazing_starts;  ///< points to collect components from (search_from)
  std::vector<double> grazing_points;        ///< per point of one component (try_plane)
  std::vector<std::uint8_t> grazing_region;  ///< per raw label: holds a grazing plane's points
  std::vector<std::uint8_t> closed_faces;    ///< the mesh faces with grazing cells closed
  // threads: the pool of the current call (null: one thread) and per-band buffers of bands 1..
  ThreadPool* pool = nullptr;
  std::vector<detail::CacheLineVector<float>> band_cell_sums;
  std::vector<std::vector<std::uint8_t>> band_cell_complete;
  std::vector<std::vector<std::int32_t>> band_row_pixels;
  std::vector<std::vector<std::uint64_t>> band_adjacency;
  /// Per band: the pixels that start a pair of plane regions joined by a mesh edge, as merging
  /// found them (adjacent_pairs), and how many regions there were then.
  std::vector<std::vector<std::int32_t>> band_border;
  std::size_t border_regions = 0;
  std::vector<std::int32_t> band_seed_counts;               ///< kSeedBuckets per band
  std::vector<std::vector<std::uint64_t>> band_label_bits;  ///< seed scan's label masks per band
  std::vector<std::size_t> band_found;                      ///< items each band found
  std::vector<std::vector<std::pair<std::int32_t, std::int32_t>>> band_joins;  ///< `joins`
  // growth bands (SegmentationSettings::growth_bands): first row of each band and the frame's
  // height; each band's own scratch, whose `edges` is a copy of the band's mesh edges without
  // those crossing a seam.
  std::vector<int> growth_rows;
  std::vector<seg::Frame> band_frames;
  std::vector<std::unique_ptr<Scratch>> growth;
  std::vector<std::uint8_t> edges;
};

}  // namespace rangeseg

namespace rangeseg::seg {

/// Number of row bands the passes over the frame are split into (scratch.pool's threads, or 1).
inline int band_count(const Segmenter::Scratch& s) {
  return s.pool != nullptr ? s.pool->threads() : 1;
}

/// Calls fn(band, row_begin, row_end) for band_count(s) disjoint bands covering [0, rows)
/// (concurrently on scratch.pool, or as one band on this thread); band starts but the first are
/// multiples of `align`.
template <class F>
void for_each_band(Segmenter::Scratch& s, int rows, int align, F&& fn) {
  if (s.pool != nullptr) {
    s.pool->for_each_band(rows, align, fn);
  } else {
    fn(0, 0, rows);
  }
}

/// Whether `seed` may start a region: it has mesh neighbours, none of them is labelled, and all
/// their normals are within the angle whose cosine is `cos_angle` of the seed's normal (NaN
/// normals fail). A region started from a normal that its neighbours contradict would follow
/// noise, and noisy areas would spawn one region per pixel. A pixel next to a region is one that
/// region rejected: seeds there start slivers along region boundaries, which keep two pieces of
/// one surface from being adjacent when they are merged; such pixels are left to boundary
/// re-assignment.
inline bool seed_ring_ok(const Frame& f, std::int32_t seed, float cos_angle) {
  const float nx = f.nx[seed], ny = f.ny[seed], nz = f.nz[seed];
  unsigned mask = f.edges[seed];
  if (mask == 0) return false;
  while (mask != 0) {
    const int k = std::countr_zero(mask);
    mask &= mask - 1;
    const std::ptrdiff_t q = seed + f.neighbour_offset[k];
    if (f.labels[q] != 0) return false;
    if (!(nx * f.nx[q] + ny * f.ny[q] + nz * f.nz[q] >= cos_angle)) return false;
  }
  return true;
}

/// Whether every pixel within `radius` lattice steps of `seed` (Chebyshev distance, inside the
/// image) is unlabelled (labels >= 0).
inline bool seed_clear(const Frame& f, std::int32_t seed, int radius) {
  if (radius <= 0) return true;
  const int step = f.pixel_stride;
  const int u = static_cast<int>(seed % f.stride), v = static_cast<int>(seed / f.stride);
  const int u0 = std::max(u - radius * step, u % step), v0 = std::max(v - radius * step, v % step);
  const int u1 = std::min(u + radius * step, f.width - 1),
            v1 = std::min(v + radius * step, f.height - 1);
  std::int32_t any = 0;
  for (int r = v0; r <= v1; r += step) {
    const std::int32_t* row = f.labels + static_cast<std::ptrdiff_t>(r) * f.stride;
    for (int c = u0; c <= u1; c += step) any |= row[c];
    if (any != 0) return false;
  }
  return true;
}

/// What a pixel seed must pass beyond the scan's own tests (see seed_ring_ok and seed_clear).
struct SeedVeto {
  float ring_cos = -1;  ///< seed_ring_ok's cosine
  int clearance = 0;    ///< seed_clear's radius [lattice steps]
};
inline bool seed_passes(const Frame& f, std::int32_t seed, const SeedVeto& veto) {
  return seed_ring_ok(f, seed, veto.ring_cos) && seed_clear(f, seed, veto.clearance);
}

/// Sets a segment's pixel count, centroid and least-squares plane (normal, offset, RMS) from its
/// point statistics. Collinear points (a one-pixel strip) have no plane: the plane facing the
/// sensor through the centroid is reported instead.
void set_plane_fields(const detail::PlaneStats& stats, Segment& segment);

/// Flat views of the cloud, mesh, normal and label planes (all of the cloud's size, checked by
/// the caller); throws std::invalid_argument when their row strides differ.
Frame make_frame(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
                 LabelImage& labels);

/// Fills scratch.seeds with the unlabelled seed pixels in ascending curvature order (counting
/// sort). Given `veto`, only pixels that pass seed_passes(frame, pixel, *veto) now: labels
/// only appear while regions grow, so a pixel failing it now fails it for good.
void collect_seeds(const Frame& frame, const SegmentationSettings& settings,
                   Segmenter::Scratch& scratch, const SeedVeto* veto = nullptr);

/// Fills scratch.cells (cell_cols x cell_rows cells of kCellSide x kCellSide lattice vertices
/// covering the image from the top-left; a partial last column/row of cells is left out) and
/// resets scratch.cell_label to 0.
void compute_cells(const Frame& frame, Segmenter::Scratch& scratch);

/// Splits the frame into growth bands (see SegmentationSettings::growth_bands): equal shares of
/// the whole cell rows, the last band also taking the rows below the last cell row. Fills
/// scratch.growth_rows and makes a scratch per band; returns the number of bands.
int plan_growth_bands(const Frame& frame, int requested, Segmenter::Scratch& scratch);

/// The frame of rows [growth_rows[band], growth_rows[band + 1]), whose mesh edges (copied into
/// the band's scratch) end at the seams: growth in one band neither reads nor writes another.
Frame growth_band_frame(const Frame& frame, Segmenter::Scratch& scratch, int band);

/// After every band grew its regions (raw labels 1..R_b in its rows, statistics in its
/// scratch's regions): scratch.regions holds them all in band order and the labels are made
/// unique by offsetting each band's by the regions of the bands above it. The regions a seam
/// cut are joined later, by merging and re-assignment over the whole frame.
void join_growth_bands(const Frame& frame, Segmenter::Scratch& scratch);

/// Grows regions from the seeds; writes raw labels 1..R into frame.labels and their point
/// statistics into scratch.regions[1..R].
void grow_planes(const Frame& frame, const SegmentationSettings& settings,
                 Segmenter::Scratch& scratch);
void grow_smooth(const Frame& frame, const SegmentationSettings& settings,
                 Segmenter::Scratch& scratch);
/// After plane post-processing (labels 1..N = out.segments): regions of surface continuity
/// over the unlabelled pixels; those of at least min_region_size pixels are appended to `out`
/// as segments N+1.. (plane fields from their points), the rest stay unlabelled.
/// Then the remaining mesh-connected patches of unlabelled points of at least min_region_size
/// pixels are appended as tentative segments; returns the number of segments before them.
std::int32_t grow_smooth_leftovers(const Frame& frame, const SegmentationSettings& settings,
                                   Segmenter::Scratch& scratch, Segmentation& out);

/// Columns u in [begin, end) of a label row (stride 1; `row` and `below` readable from begin - 1
/// to end) whose label is not 0 and differs from a forward neighbour's (right, down-left, down,
/// down-right), into `out` in ascending order (`found` of them); returns the column up to which
/// the row was scanned (the caller does the rest). Vectorised for the CPU.
int adjacency_pixels(const std::int32_t* row, const std::int32_t* below, int begin, int end,
                     std::int32_t* out, int& found);

/// Columns u in [begin, end) of a label row (stride 1; `above`, `row` and `below` readable from
/// begin - 1 to end) that are unlabelled with a labelled pixel among their 8 neighbours, into
/// `out` in ascending order (`found` of them); returns the column up to which the row was
/// scanned (the caller does the rest). Vectorised for the CPU.
int unlabelled_border_pixels(const std::int32_t* above, const std::int32_t* row,
                             const std::int32_t* below, int begin, int end, std::int32_t* out,
                             int& found);

/// Per-band buffers of the row scans: band 0 uses scratch.row_pixels, band b > 0
/// band_row_pixels[b], each one row long; band_found holds two numbers per band.
void ensure_band_buffers(Segmenter::Scratch& scratch, int width);

/// The one-row buffer of band `band` (see ensure_band_buffers).
std::int32_t* row_pixels_of(Segmenter::Scratch& scratch, int band);

/// Segment::area_m2 of every segment (label j + 1 for segments[j]; every label of the frame at
/// most segments.size()): a third of each triangle's area and a quarter of each quad's per
/// labelled corner.
void segment_areas(const Frame& frame, Segmenter::Scratch& scratch, std::vector<Segment>& segments);

/// Between the coarse level and the pixel seeds of the plane model: each unlabelled valid point
/// on the mesh 1-ring of a region of at least min_region_size pixels joins the closest such
/// region's least-squares plane when within max_distance_sigmas sigma(z) of it, with its normal
/// within reassign_max_normal_angle of the plane's (the test of boundary re-assignment, over
/// mesh edges only whatever reassign_across_mesh_cuts). Unlike the final re-assignment, points
/// that join do not make their neighbours candidates. The growth test bounds the normal far
/// tighter, so in noisy data (Kinect at a few metres) it leaves scattered points inside and
/// around every large plane, which would otherwise seed hundreds of tiny regions that
/// post-processing dissolves and re-assigns to the same plane; without propagation the points
/// of a small real face next to a large plane keep all but the crease for their own seeds.
void reassign_before_seeds(const Frame& frame, const SegmentationSettings& settings,
                           Segmenter::Scratch& scratch);

/// After small regions are dissolved: unlabelled valid points next to a plane segment join the
/// adjacent plane they are closest to, within max_distance_sigmas sigma(z) (and, over mesh edges,
/// with the normal within reassign_max_normal_angle), and points that join make their
/// neighbours candidates in turn; over mesh edges, or all lattice neighbours when
/// reassign_across_mesh_cuts. Needs scratch.fits of the kept regions.
void reassign_boundary(const Frame& frame, const SegmentationSettings& settings,
                       Segmenter::Scratch& scratch);

/// After merging and splitting: points on the border of two plane segments (a mesh edge between
/// them) move to the other segment when closer to its plane by more than
/// boundary_refine_sigmas sigma(z) (see SegmentationSettings); up to 8 rounds, the moved segments'
/// statistics updated and their planes refitted. Needs the union-find parents, fits and kept
/// regions (remap) of post-processing.
void refine_plane_boundaries(const Frame& frame, const SegmentationSettings& settings,
                             Segmenter::Scratch& scratch);

/// Root of `a` in the union-find forest `parent` (with path halving).
inline std::int32_t find_root(std::vector<std::int32_t>& parent, std::int32_t a) {
  while (parent[a] != a) {
    parent[a] = parent[parent[a]];
    a = parent[a];
  }
  return a;
}

/// Whether post-processing merges two adjacent plane segments (statistics and fits of each):
/// their planes agree, or one plane explains their union within the noise (see
/// SegmentationSettings::merge_angle .. merge_rms_max_angle). On true, the union's statistics
/// and fit are stored where given. `by_range`: sigma of the distance from the origin, not of z
/// (noise_depth).
bool planes_merge(const detail::PlaneStats& sa, const detail::PlaneFit& a,
                  const detail::PlaneStats& sb, const detail::PlaneFit& b,
                  const SegmentationSettings& settings, detail::PlaneStats* merged = nullptr,
                  detail::PlaneFit* merged_fit = nullptr, bool by_range = false);

/// `settings` with the sensor noise model scaled by `ratio`, a frame's measured RMS residual /
/// sigma(z) of good planes, clamped to [0.05, 1]: smoothed points fit far below the sensor's
/// sigma(z), and merge tests at that level tell a step of a few sigma from one plane.
SegmentationSettings with_measured_noise(const SegmentationSettings& settings, double ratio);

/// After merging (raw labels, union-find in scratch.parent): a plane segment whose RMS residual /
/// sigma(z) exceeds split_residual_factor times the lower tercile of the other segments' is cut
/// into up to four planes (two-plane k-means while a part is still that far off), and the parts
/// that merging would join at the frame's noise level are joined again. New parts are appended
/// as raw regions (scratch.regions, fits, parent, remap). `references`, when given: per raw
/// region the RMS / sigma that stands for its noise instead of the other segments' tercile.
void split_unexplained_planes(const Frame& frame, const SegmentationSettings& settings,
                              Segmenter::Scratch& scratch, std::span<const double> references = {});

/// After boundary re-assignment (raw labels): plane regions of the unlabelled points of surfaces
/// seen at grazing incidence (SegmentationSettings::grazing_min_angle), appended as raw regions
/// (scratch.regions, fits, parent, remap). `footprint`: pixel_footprint of the frame.
void find_grazing_planes(const Frame& frame, const SegmentationSettings& settings,
                         Segmenter::Scratch& scratch, double footprint);

/// A point of a grazing-plane fit: x, y, z [m], sigma along its ray [m], 1 / |p| [1/m].
inline constexpr std::size_t kGrazingPointSize = 5;

/// The robust plane fit of find_grazing_planes over `n` points (kGrazingPointSize doubles
/// each): from the grazing plane with most support among the least-squares plane and sampled
/// triples, refitted to its inliers over shrinking bounds. Returns the plane when it is
/// grazing_min_angle..grazing_max_angle off the viewing ray at its centroid, with an RMS
/// residual of at most sigma sin(grazing_max_angle) and inliers covering the area of
/// min_region_size points facing the sensor (min_region_size times the sine of its angle to the
/// rays; at least half min_region_size), or half as many and wide_enough with `footprint`;
/// otherwise a fit that is not ok. `by_range`: sigma and the footprints at the centroid's
/// range, not its z (rings).
detail::PlaneFit fit_grazing_plane(const double* points, std::size_t n,
                                   const SegmentationSettings& settings, double footprint,
                                   bool by_range);

/// Whether point `p` of a grazing-plane fit lies within `sigmas` of its noise perpendicular to
/// the plane `fit`: sigma along the ray times the sine of the ray's angle to the plane, floored
/// at `sin_max` = sin(grazing_max_angle).
bool within_grazing_plane(const detail::PlaneFit& fit, const double* p, double sigmas,
                          double sin_max);

/// close_grazing_cells on flat planes of one row stride: the faces (and, unless `edges` is null,
/// the edges) of every lattice cell whose four corners carry the label of one `grazing` segment
/// (labels 1..segments.size() or 0). `quads`: MeshType::quad.
void close_grazing_faces(const std::int32_t* labels, std::ptrdiff_t stride, int width, int height,
                         int step, bool quads, const std::vector<Segment>& segments,
                         std::uint8_t* faces, std::uint8_t* edges);

/// The angle one lattice step subtends [rad]: the median over three rows of the distance between
/// horizontally adjacent valid points divided by their range (0 without such points), so that
/// a length at range r is that many pixel footprints when divided by footprint * r. `vertical`:
/// over three columns, between vertically adjacent points (a spinning lidar's beams lie several
/// times further apart than its columns).
double pixel_footprint(const Frame& frame, Segmenter::Scratch& scratch, bool vertical = false);

/// A region of at least half min_region_size pixels that, in 3D, is at least
/// sqrt(2 min_region_size) pixel footprints wide in its narrower in-plane direction (the
/// square root of 12 times the middle covariance eigenvalue): a face seen obliquely covers
/// fewer pixels than a frontal one of its size, and this one has at least twice the frontal area
/// of the smallest segment; crease slivers and specks are narrow. The footprints are those at
/// the centroid's range.
bool wide_enough(const detail::PlaneStats& stats, int min_region_size, double footprint);

/// Refit, merge, small-region removal, boundary re-assignment, compaction and the Segment list
/// (areas 0: see segment_areas).
void postprocess(const Frame& frame, const SegmentationSettings& settings,
                 Segmenter::Scratch& scratch, Segmentation& out);

}  // namespace rangeseg::seg
