// Segmentation entry points: validation, seed ordering, and dispatch to the region models.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "detail/bad_setting.hpp"
#include "detail/headroom.hpp"
#include "detail/segment_labels.hpp"
#include "segmentation/internal.hpp"
#include "segmentation/primitive_internal.hpp"

namespace rangeseg {
namespace {

void require_size(const char* what, int width, int height, const OrganizedCloud& cloud) {
  if (width != cloud.width() || height != cloud.height()) {
    std::ostringstream msg;
    msg << "segment: " << what << " is " << width << "x" << height << " but the cloud is "
        << cloud.width() << "x" << cloud.height();
    throw std::invalid_argument(msg.str());
  }
}

/// Region growing and re-assignment follow the mesh edges without bounds checks, so an edge that
/// leaves the image (a mesh not built for this cloud's size or stride) is rejected here. Only
/// pixels within one lattice step of the border can have such an edge.
void require_edges_inside(const Mesh& mesh) {
  const int width = mesh.width(), height = mesh.height(), step = mesh.pixel_stride;
  const auto check = [&](int u, int v) {
    const unsigned edges = mesh.edges(u, v);
    for (int k = 0; k < 8; ++k) {
      if ((edges >> k & 1u) == 0) continue;
      const long nu = u + static_cast<long>(step) * kNeighbourDu[static_cast<std::size_t>(k)];
      const long nv = v + static_cast<long>(step) * kNeighbourDv[static_cast<std::size_t>(k)];
      if (nu < 0 || nv < 0 || nu >= width || nv >= height) {
        std::ostringstream msg;
        msg << "segment: the mesh has an edge from pixel (" << u << ", " << v << ") to (" << nu
            << ", " << nv << "), outside the " << width << "x" << height << " image (pixel_stride "
            << step << "); was it built for this cloud?";
        throw std::invalid_argument(msg.str());
      }
    }
  };
  for (int v = 0; v < height; ++v) {
    if (v < step || v >= height - step) {
      for (int u = 0; u < width; ++u) check(u, v);
      continue;
    }
    for (int u = 0; u < std::min(step, width); ++u) check(u, v);
    for (int u = std::max(width - step, step); u < width; ++u) check(u, v);
  }
}

template <class T>
void require(bool ok, const char* field, T value, const char* condition) {
  if (!ok) detail::throw_bad_setting("SegmentationSettings", field, value, condition);
}

}  // namespace

namespace seg {

void validate(const SegmentationSettings& s) {
  constexpr double pi = 3.14159265358979323846;
  require(s.model <= RegionModel::automatic, "model", static_cast<int>(s.model),
          "a RegionModel (plane, smooth, incremental_plane or automatic)");
  detail::require_noise(s.noise, "SegmentationSettings");
  require(s.max_normal_angle > 0 && s.max_normal_angle <= pi, "max_normal_angle",
          s.max_normal_angle, "in (0, pi] rad");
  require(s.max_distance_sigmas > 0 && std::isfinite(s.max_distance_sigmas), "max_distance_sigmas",
          s.max_distance_sigmas, "finite and > 0");
  require(s.split_residual_factor >= 0 && std::isfinite(s.split_residual_factor),
          "split_residual_factor", s.split_residual_factor, "finite and >= 0");
  require(s.boundary_refine_sigmas >= 0 && std::isfinite(s.boundary_refine_sigmas),
          "boundary_refine_sigmas", s.boundary_refine_sigmas, "finite and >= 0");
  require(s.grazing_min_angle >= 0 && s.grazing_min_angle < pi / 2, "grazing_min_angle",
          s.grazing_min_angle, "in [0, pi / 2) rad");
  require(s.grazing_max_angle >= s.grazing_min_angle && s.grazing_max_angle < pi / 2,
          "grazing_max_angle", s.grazing_max_angle, "in [grazing_min_angle, pi / 2) rad");
  require(s.normal_noise_sigmas >= 0 && std::isfinite(s.normal_noise_sigmas), "normal_noise_sigmas",
          s.normal_noise_sigmas, "finite and >= 0");
  require(s.min_normal_angle >= 0 && s.min_normal_angle <= pi, "min_normal_angle",
          s.min_normal_angle, "in [0, pi] rad");
  require(s.max_smooth_angle > 0 && s.max_smooth_angle <= pi, "max_smooth_angle",
          s.max_smooth_angle, "in (0, pi] rad");
  require(s.max_curvature > 0, "max_curvature", s.max_curvature, "> 0");
  require(s.max_seed_curvature > 0, "max_seed_curvature", s.max_seed_curvature, "> 0");
  require(s.min_region_size >= 1, "min_region_size", s.min_region_size, ">= 1");
  require(s.min_region_fx >= 0 && std::isfinite(s.min_region_fx), "min_region_fx", s.min_region_fx,
          "finite and >= 0 pixels");
  require(s.seed_clearance >= 0 && s.seed_clearance <= 32, "seed_clearance", s.seed_clearance,
          "in [0, 32] lattice steps");
  require(s.growth_bands >= 1 && s.growth_bands <= 64, "growth_bands", s.growth_bands,
          "in [1, 64]");
  require(s.merge_angle > 0 && s.merge_angle <= pi, "merge_angle", s.merge_angle, "in (0, pi] rad");
  require(s.merge_rms_sigmas >= 0 && std::isfinite(s.merge_rms_sigmas), "merge_rms_sigmas",
          s.merge_rms_sigmas, "finite and >= 0");
  require(s.merge_rms_max_angle >= 0 && s.merge_rms_max_angle <= pi, "merge_rms_max_angle",
          s.merge_rms_max_angle, "in [0, pi] rad");
  require(s.reassign_max_normal_angle >= 0 && s.reassign_max_normal_angle <= pi,
          "reassign_max_normal_angle", s.reassign_max_normal_angle, "in [0, pi] rad");
  require(s.merge_distance_sigmas > 0 && std::isfinite(s.merge_distance_sigmas),
          "merge_distance_sigmas", s.merge_distance_sigmas, "finite and > 0");
}

}  // namespace seg

namespace {

/// Seed order key: the bits of a non-negative float are monotone in its value, so the exponent
/// and top 6 mantissa bits give 64 buckets per octave (a piecewise-linear log2) without a log.
constexpr int kSeedBuckets = 2048;
constexpr float kSeedKeyFloor = 1e-3f;  // [1/m]; all smaller curvatures share bucket 0

inline std::uint32_t float_key(float c) { return std::bit_cast<std::uint32_t>(c) >> 17; }

}  // namespace

namespace seg {

namespace {

/// Bits of the labelled pixels of rows [row_begin, row_end) (stride 1), `words` 64-bit words a
/// row, pixel u of a row in bit u % 64 of word u / 64.
void labelled_bits(const Frame& f, int row_begin, int row_end, int words, std::uint64_t* bits) {
  for (int v = row_begin; v < row_end; ++v) {
    const std::int32_t* labels = f.labels + static_cast<std::ptrdiff_t>(v) * f.stride;
    std::uint64_t* out = bits + static_cast<std::ptrdiff_t>(v - row_begin) * words;
    std::fill(out, out + words, 0);
    int u = 0;
#if defined(__SSE2__)
    const __m128i zero = _mm_setzero_si128();
    for (; u + 4 <= f.width; u += 4) {
      const __m128i l = _mm_loadu_si128(reinterpret_cast<const __m128i*>(labels + u));
      const auto free =
          static_cast<std::uint64_t>(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(l, zero))));
      out[u / 64] |= (free ^ 15u) << (u % 64);  // u % 4 == 0: the four bits share a word
    }
#endif
    for (; u < f.width; ++u) {
      out[u / 64] |= static_cast<std::uint64_t>(labels[u] != 0) << (u % 64);
    }
  }
}

/// The seed candidates of lattice rows [v_begin, v_end) (pixel rows, multiples of the lattice
/// step) into pixel / key_of in scan order, counted per bucket; returns how many. `bits`:
/// scratch for labelled_bits of the rows within veto->clearance of the band (step 1).
std::size_t scan_seed_rows(const Frame& f, float max_curvature, const SeedVeto* veto, int v_begin,
                           int v_end, std::int32_t* pixel, std::uint16_t* key_of,
                           std::int32_t* count, std::vector<std::uint64_t>& bits) {
  const std::uint32_t floor_key = float_key(kSeedKeyFloor);
  const int step = f.pixel_stride;
  std::size_t n = 0;
  const auto add = [&](std::ptrdiff_t i) {
    const std::uint32_t key = float_key(std::fabs(f.curvature[i]));
    const std::uint32_t bucket =
        key <= floor_key ? 0u : std::min<std::uint32_t>(key - floor_key, kSeedBuckets - 1);
    ++count[bucket];
    pixel[n] = static_cast<std::int32_t>(i);
    key_of[n] = static_cast<std::uint16_t>(bucket);
    ++n;
  };
  // A seed needs a point and a normal; NaN curvature fails the comparison.
  const auto valid = [&](std::ptrdiff_t i) {
    return f.curvature[i] <= max_curvature && std::isfinite(f.nz[i]) && std::isfinite(f.z[i]);
  };
  if (step != 1) {
    for (int v = v_begin; v < v_end; v += step) {
      for (int u = 0; u < f.width; u += step) {
        const std::ptrdiff_t i = v * f.stride + u;
        if (f.labels[i] == 0 && valid(i) &&
            (veto == nullptr || seed_passes(f, static_cast<std::int32_t>(i), *veto))) {
          add(i);
        }
      }
    }
    return n;
  }
  // Most pixels are labelled by the coarse level, or lie within the clearance of one: those are
  // found from bit masks of the labels (a row's mask ORed over the rows within the clearance,
  // then widened by it along the row) before any other plane is read.
  const int r = veto != nullptr ? veto->clearance : 0;
  const int words = (f.width + 63) / 64;
  const int row_begin = std::max(0, v_begin - r), row_end = std::min(f.height, v_end + r);
  bits.resize(static_cast<std::size_t>(row_end - row_begin + 2) * words);
  labelled_bits(f, row_begin, row_end, words, bits.data());
  std::uint64_t* const near =
      bits.data() + static_cast<std::ptrdiff_t>(row_end - row_begin) * words;
  std::uint64_t* const wide = near + words;
  const std::uint64_t last_word =
      f.width % 64 == 0 ? ~std::uint64_t{0} : (std::uint64_t{1} << (f.width % 64)) - 1;
  for (int v = v_begin; v < v_end; ++v) {
    const int first = std::max(row_begin, v - r), last = std::min(row_end - 1, v + r);
    std::copy_n(bits.data() + static_cast<std::ptrdiff_t>(first - row_begin) * words, words, near);
    for (int t = first + 1; t <= last; ++t) {
      const std::uint64_t* row = bits.data() + static_cast<std::ptrdiff_t>(t - row_begin) * words;
      for (int w = 0; w < words; ++w) near[w] |= row[w];
    }
    for (int w = 0; w < words; ++w) {
      std::uint64_t m = near[w];
      const std::uint64_t before = w > 0 ? near[w - 1] : 0, after = w + 1 < words ? near[w + 1] : 0;
      for (int d = 1; d <= r; ++d) {
        m |= near[w] << d | before >> (64 - d) | near[w] >> d | after << (64 - d);
      }
      wide[w] = m;
    }
    const std::ptrdiff_t row = v * f.stride;
    for (int w = 0; w < words; ++w) {
      std::uint64_t free = ~wide[w] & (w + 1 == words ? last_word : ~std::uint64_t{0});
      while (free != 0) {
        const std::ptrdiff_t i = row + std::ptrdiff_t{64} * w + std::countr_zero(free);
        free &= free - 1;
        // The labels within the clearance are all 0, so seed_passes reduces to the ring normals.
        if (valid(i) &&
            (veto == nullptr || seed_ring_ok(f, static_cast<std::int32_t>(i), veto->ring_cos))) {
          add(i);
        }
      }
    }
  }
  return n;
}

}  // namespace

// Row bands are scanned concurrently, each into its own slice of the candidate arrays (at most
// one candidate per lattice vertex) with its own bucket counts; the seeds of a bucket are placed
// band after band, so the order is the single-threaded scan order whatever the band count.
void collect_seeds(const Frame& f, const SegmentationSettings& settings, Segmenter::Scratch& s,
                   const SeedVeto* veto) {
  float max_curvature = static_cast<float>(std::fmin(settings.max_seed_curvature, 3e38));
  if (settings.model == RegionModel::smooth) {
    max_curvature = std::fmin(max_curvature, static_cast<float>(settings.max_curvature));
  }
  const int step = f.pixel_stride;
  const std::size_t lattice_width = (f.width + step - 1) / step;
  // Written by index: push_back costs a quarter of the scan. The buffers only grow, so the zero
  // fill of resize is paid once per Segmenter.
  const std::size_t lattice = lattice_width * ((f.height + step - 1) / step);
  if (s.candidate_pixel.size() < lattice) {
    s.candidate_pixel.resize(lattice);
    s.candidate_key.resize(lattice);
  }
  const auto bands = static_cast<std::size_t>(band_count(s));
  s.band_seed_counts.assign(bands * kSeedBuckets, 0);
  s.band_found.assign(bands * 2, 0);  // per band: first lattice vertex, candidates found
  if (s.band_label_bits.size() < bands) s.band_label_bits.resize(bands);
  for_each_band(s, f.height, step, [&](int band, int v_begin, int v_end) {
    const std::size_t first = static_cast<std::size_t>(v_begin / step) * lattice_width;
    const auto b = static_cast<std::size_t>(band);
    s.band_found[2 * b] = first;
    s.band_found[2 * b + 1] =
        scan_seed_rows(f, max_curvature, veto, v_begin, v_end, s.candidate_pixel.data() + first,
                       s.candidate_key.data() + first, s.band_seed_counts.data() + b * kSeedBuckets,
                       s.band_label_bits[b]);
  });
  // bucket_start: where each bucket begins; then band_seed_counts: where each band's part does.
  s.bucket_start.assign(kSeedBuckets + 1, 0);
  for (int b = 0; b < kSeedBuckets; ++b) {
    std::int32_t at = s.bucket_start[b];
    for (std::size_t band = 0; band < bands; ++band) {
      std::int32_t& count = s.band_seed_counts[band * kSeedBuckets + b];
      const std::int32_t c = count;
      count = at;
      at += c;
    }
    s.bucket_start[b + 1] = at;
  }
  detail::resize_with_headroom(s.seeds, static_cast<std::size_t>(s.bucket_start[kSeedBuckets]));
  for_each_band(s, static_cast<int>(bands), 1, [&](int, int band_begin, int band_end) {
    for (auto band = static_cast<std::size_t>(band_begin);
         band < static_cast<std::size_t>(band_end); ++band) {
      std::int32_t* const next = s.band_seed_counts.data() + band * kSeedBuckets;
      const std::size_t first = s.band_found[2 * band], n = s.band_found[2 * band + 1];
      const std::int32_t* const pixel = s.candidate_pixel.data() + first;
      const std::uint16_t* const key_of = s.candidate_key.data() + first;
      for (std::size_t j = 0; j < n; ++j) s.seeds[next[key_of[j]]++] = pixel[j];
    }
  });
}

Frame make_frame(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
                 LabelImage& labels) {
  Frame f;
  f.x = cloud.x.row(0);
  f.y = cloud.y.row(0);
  f.z = cloud.z.row(0);
  f.nx = normals.nx.row(0);
  f.ny = normals.ny.row(0);
  f.nz = normals.nz.row(0);
  f.curvature = normals.curvature.row(0);
  f.edges = mesh.edges.row(0);
  f.faces = mesh.faces.row(0);
  f.labels = labels.row(0);
  f.width = cloud.width();
  f.height = cloud.height();
  f.stride = cloud.z.stride();
  f.pixel_stride = mesh.pixel_stride;
  for (const std::ptrdiff_t stride :
       {cloud.x.stride(), cloud.y.stride(), normals.nx.stride(), normals.ny.stride(),
        normals.nz.stride(), normals.curvature.stride(), mesh.edges.stride(), mesh.faces.stride(),
        labels.stride()}) {
    if (stride != f.stride) {
      throw std::invalid_argument("segment: planes of equal width have different row strides (" +
                                  std::to_string(stride) + " vs " + std::to_string(f.stride) + ")");
    }
  }
  for (int k = 0; k < 8; ++k) {
    f.neighbour_offset[k] = static_cast<std::ptrdiff_t>(f.pixel_stride) *
                            (kNeighbourDv[k] * f.stride + kNeighbourDu[k]);
  }
  return f;
}

}  // namespace seg

Segmenter::Segmenter() : scratch_(std::make_unique<Scratch>()) {}
Segmenter::~Segmenter() = default;
Segmenter::Segmenter(Segmenter&&) noexcept = default;
Segmenter& Segmenter::operator=(Segmenter&&) noexcept = default;

void Segmenter::segment(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
                        const SegmentationSettings& settings, Segmentation& out) {
  run(cloud, mesh, normals, settings, out, nullptr);
}

void Segmenter::segment(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
                        const SegmentationSettings& settings, Segmentation& out, ThreadPool& pool) {
  run(cloud, mesh, normals, settings, out, pool.threads() > 1 ? &pool : nullptr);
}

void Segmenter::run(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
                    const SegmentationSettings& settings, Segmentation& out, ThreadPool* pool) {
  require_organized(cloud, "segment");
  require_size("the mesh", mesh.width(), mesh.height(), cloud);
  require_size("the mesh faces", mesh.faces.width(), mesh.faces.height(), cloud);
  require_size("the normal map (nz)", normals.nz.width(), normals.nz.height(), cloud);
  require_size("the normal map (nx)", normals.nx.width(), normals.nx.height(), cloud);
  require_size("the normal map (ny)", normals.ny.width(), normals.ny.height(), cloud);
  require_size("the curvature plane", normals.curvature.width(), normals.curvature.height(), cloud);
  if (mesh.pixel_stride < 1) {
    throw std::invalid_argument(
        "segment: mesh.pixel_stride = " + std::to_string(mesh.pixel_stride) + " must be >= 1");
  }
  require_edges_inside(mesh);
  seg::validate(settings);
  if (!scratch_) scratch_ = std::make_unique<Scratch>();

  if (out.labels.width() != cloud.width() || out.labels.height() != cloud.height()) {
    out.labels.resize(cloud.width(), cloud.height(), 0);
  } else if (pool != nullptr) {
    // A frame's worth of zeros is a fifth of a millisecond's memory traffic on one core.
    pool->for_each_band(cloud.height(), 1, [&](int, int v_begin, int v_end) {
      if (v_begin < v_end) {
        std::fill(out.labels.row(v_begin), out.labels.row(v_end - 1) + out.labels.stride(), 0);
      }
    });
  } else {
    out.labels.fill(0);
  }
  seg::Frame f = seg::make_frame(cloud, mesh, normals, out.labels);
  f.columns_wrap = seg::columns_wrap(f);

  Scratch& s = *scratch_;
  // The pool is only borrowed for this call.
  struct PoolGuard {
    Scratch& s;
    ~PoolGuard() { s.pool = nullptr; }
  } const guard{s};
  s.pool = pool;
  // Its passes dispatch bands with serial work between them.
  std::optional<ThreadPool::KeepAwake> awake;
  if (pool != nullptr) awake.emplace(*pool);
  s.queue.resize(static_cast<std::size_t>(f.stride) * f.height);
  s.growth_rows.clear();  // growing in bands sets them (grow_planes)
  // The plane model collects its pixel seeds itself, after growing over cells.
  const bool cell_seeds =
      settings.model == RegionModel::plane || settings.model == RegionModel::automatic;
  if (!cell_seeds) seg::collect_seeds(f, settings, s);
  if (settings.model == RegionModel::plane || settings.model == RegionModel::automatic) {
    seg::grow_planes(f, settings, s);
  } else if (settings.model == RegionModel::incremental_plane) {
    seg::grow_incremental_planes(f, settings, s);
  } else {
    seg::grow_smooth(f, settings, s);
  }
  if (settings.model == RegionModel::plane || settings.model == RegionModel::smooth) {
    seg::postprocess(f, settings, s, out);
  } else {
    // Both post-process their regions as planes (merging, boundary re-assignment).
    SegmentationSettings as_planes = settings;
    as_planes.model = RegionModel::plane;
    // The auto model's plane facets may be pieces of one curved surface, where a border point
    // lies closer to the neighbouring facet's plane without being on another surface.
    if (settings.model == RegionModel::automatic) as_planes.boundary_refine_sigmas = 0;
    seg::postprocess(f, as_planes, s, out);
    if (settings.model == RegionModel::incremental_plane) {
      for (Segment& segment : out.segments) segment.model = settings.model;
    }
  }
  std::int32_t tentative_from = 0;
  if (settings.model == RegionModel::automatic) {
    // The plane segments' point statistics, for the primitive pass (in label order).
    s.segment_stats.clear();
    for (const std::int32_t r : s.order) s.segment_stats.push_back(s.regions[r]);
    tentative_from = seg::grow_smooth_leftovers(f, settings, s, out);
  }
  if (settings.compute_area) {
    // Areas count the cells of grazing segments closed, as close_grazing_cells closes them.
    if (std::any_of(out.segments.begin(), out.segments.end(),
                    [](const Segment& g) { return g.grazing; })) {
      const std::size_t size = static_cast<std::size_t>(f.stride) * f.height;
      s.closed_faces.assign(f.faces, f.faces + size);
      seg::close_grazing_faces(f.labels, f.stride, f.width, f.height, f.pixel_stride,
                               mesh.type == MeshType::quad, out.segments, s.closed_faces.data(),
                               nullptr);
      seg::Frame closed = f;
      closed.faces = s.closed_faces.data();
      seg::segment_areas(closed, s, out.segments);
    } else {
      seg::segment_areas(f, s, out.segments);
    }
  }
  if (settings.model == RegionModel::automatic) {
    seg::fit_primitives(f, settings, out, s.primitive,
                        {.tentative_from = tentative_from,
                         .normal_noise_c = s.normal_noise_c,
                         .segment_stats = s.segment_stats});
  } else {
    const SurfaceKind kind =
        settings.model == RegionModel::smooth ? SurfaceKind::smooth : SurfaceKind::plane;
    for (Segment& segment : out.segments) {
      segment.kind = kind;
      segment.surface_rms = segment.rms_residual;
    }
  }
}

void Segmenter::compute_areas(const OrganizedCloud& cloud, const Mesh& mesh, Segmentation& out) {
  require_size("the mesh", mesh.width(), mesh.height(), cloud);
  require_size("the label image", out.labels.width(), out.labels.height(), cloud);
  if (mesh.pixel_stride < 1) {
    throw std::invalid_argument("compute_areas: mesh.pixel_stride = " +
                                std::to_string(mesh.pixel_stride) + " must be >= 1");
  }
  // Labels index the per-segment sums: each must name a segment.
  detail::require_labels_name_segments(out, "compute_areas");
  if (!scratch_) scratch_ = std::make_unique<Scratch>();
  seg::Frame f;
  f.x = cloud.x.row(0);
  f.y = cloud.y.row(0);
  f.z = cloud.z.row(0);
  f.faces = mesh.faces.row(0);
  f.labels = out.labels.row(0);
  f.width = cloud.width();
  f.height = cloud.height();
  f.stride = cloud.z.stride();
  f.pixel_stride = mesh.pixel_stride;
  for (const std::ptrdiff_t stride :
       {cloud.x.stride(), cloud.y.stride(), mesh.faces.stride(), out.labels.stride()}) {
    if (stride != f.stride) {
      throw std::invalid_argument(
          "compute_areas: planes of equal width have different row "
          "strides (" +
          std::to_string(stride) + " vs " + std::to_string(f.stride) + ")");
    }
  }
  seg::segment_areas(f, *scratch_, out.segments);
}

void validate(const SegmentationSettings& settings) { seg::validate(settings); }

int min_region_size_for(const SegmentationSettings& settings, double camera_fx) {
  if (!(settings.min_region_fx > 0) || !(camera_fx > 0) || !std::isfinite(camera_fx)) {
    return settings.min_region_size;
  }
  // A finer camera keeps the count: more pixels of one surface only make its fit surer.
  const double ratio = std::min(camera_fx / settings.min_region_fx, 1.0);
  const double scaled = std::round(settings.min_region_size * ratio * ratio);
  // A region no larger than a pixel seed's window is mostly the band its borders blur.
  const int window = (2 * settings.seed_clearance + 1) * (2 * settings.seed_clearance + 1);
  const double floor = std::min(settings.min_region_size, window);
  // A bound far beyond any frame's pixel count, so that the cast cannot overflow.
  return static_cast<int>(std::clamp(scaled, std::max(floor, 1.0), 1e9));
}

void segment(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
             const SegmentationSettings& settings, Segmentation& out) {
  Segmenter segmenter;
  segmenter.segment(cloud, mesh, normals, settings, out);
}

}  // namespace rangeseg
