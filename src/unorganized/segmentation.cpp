// Stage 4 over k-nearest-neighbour rings: region growing, merging and re-assignment.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "detail/plane_stats.hpp"
#include "detail/radix_sort.hpp"
#include "rangeseg/unorganized.hpp"
#include "segmentation/internal.hpp"
#include "unorganized/internal.hpp"
#include "unorganized/region_growing.hpp"

namespace rangeseg::unorganized {

void label_stats(const Points& pts, const std::vector<std::int32_t>& labels, std::int32_t count,
                 std::vector<detail::PlaneStats>& stats) {
  stats.assign(static_cast<std::size_t>(count) + 1, detail::PlaneStats{});
  for (std::size_t i = 0; i < labels.size(); ++i) {
    if (labels[i] <= 0) continue;
    const float* p = pts.point(i);
    stats[static_cast<std::size_t>(labels[i])].add(p[0], p[1], p[2]);
  }
}

void collect_seeds(const PointRings& rings, const Points& pts, const SegmentationSettings& s,
                   bool planes, const std::vector<std::int32_t>& labels, RingBuffers::Impl& b) {
  std::vector<std::int32_t>& seeds = b.seeds;
  std::vector<std::uint32_t>& keys = b.seed_keys;
  seeds.clear();
  keys.clear();
  for (std::size_t i = 0; i < labels.size(); ++i) {
    const float c = pts.curvature[i];
    if (labels[i] != 0 || rings.count[i] == 0 || !pts.has_normal(i)) continue;
    if (!(c <= s.max_seed_curvature) || (!planes && !(c <= s.max_curvature))) continue;
    seeds.push_back(static_cast<std::int32_t>(i));
    keys.push_back(detail::float_order_key(c));
  }
  // Stable, and the seeds were collected in point order: ties stay in point order.
  detail::radix_sort_by_key(seeds, keys, b.seeds_tmp, b.seed_keys_tmp);
}

namespace {

/// The plane region model of the grid (plane_model.cpp) without its cell level: running sums
/// of points and normals; the plane is the mean normal through the centroid, from 8 points the
/// PCA normal, refreshed whenever the region has grown by half.
class PlaneRegion {
 public:
  PlaneRegion(const Points& pts, const SegmentationSettings& s)
      : pts_(pts), k_(static_cast<float>(s.max_distance_sigmas)) {}

  void init(std::size_t seed) {
    stats_.clear();
    sn_[0] = sn_[1] = sn_[2] = 0;
    next_refresh_ = 0;
    add(seed);
  }
  bool accepts(std::size_t /*from*/, std::size_t q) const {
    const float* m = pts_.normal(q);
    const float dot = n_[0] * m[0] + n_[1] * m[1] + n_[2] * m[2];
    if (!(dot >= pts_.cos_angle[q])) return false;  // also rejects NaN normals
    const float* p = pts_.point(q);
    return std::fabs(n_[0] * p[0] + n_[1] * p[1] + n_[2] * p[2] + d_) <= k_ * pts_.sigma[q];
  }
  void add(std::size_t q) {
    const float* p = pts_.point(q);
    const float* m = pts_.normal(q);
    stats_.add(p[0], p[1], p[2]);
    for (int c = 0; c < 3; ++c) sn_[c] += m[c];
    if (stats_.count >= next_refresh_) refresh();
  }

 private:
  static constexpr std::int64_t kPcaMinPoints = 8;

  void refresh() {
    double n[3] = {sn_[0], sn_[1], sn_[2]};
    const double norm = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (norm > 0) {
      for (double& c : n) c /= norm;
    }
    if (stats_.count >= kPcaMinPoints) {
      const detail::PlaneFit fit = stats_.fit();
      if (fit.ok) {
        const double sign =
            fit.normal[0] * n[0] + fit.normal[1] * n[1] + fit.normal[2] * n[2] < 0 ? -1.0 : 1.0;
        for (int c = 0; c < 3; ++c) n[c] = sign * fit.normal[c];
      }
    }
    const auto mean = stats_.mean();
    for (int c = 0; c < 3; ++c) n_[c] = static_cast<float>(n[c]);
    d_ = static_cast<float>(-(n[0] * mean[0] + n[1] * mean[1] + n[2] * mean[2]));
    next_refresh_ =
        stats_.count < kPcaMinPoints ? stats_.count + 1 : stats_.count + stats_.count / 2;
  }

  const Points& pts_;
  float k_;
  detail::PlaneStats stats_;
  double sn_[3] = {0, 0, 0};
  float n_[3] = {0, 0, 1};
  float d_ = 0;
  std::int64_t next_refresh_ = 0;
};

void drop_small(std::vector<std::int32_t>& labels, const std::vector<detail::PlaneStats>& stats,
                int min_size) {
  for (std::int32_t& l : labels) {
    if (l > 0 && stats[static_cast<std::size_t>(l)].count < min_size) l = 0;
  }
}

/// The angle between a point and its nearest ring neighbour as seen from the origin [rad]: the
/// median over every 4th point with a ring of that distance divided by the point's range; 0
/// for fewer than 16 such points. The rings' counterpart of the grid's pixel footprint.
double ring_footprint(const PointRings& rings, const Points& pts, std::vector<double>& steps) {
  steps.clear();
  for (std::size_t i = 0; i < rings.count.size(); i += 4) {
    if (rings.count[i] == 0) continue;
    const float* p = pts.point(i);
    const float* q = pts.point(static_cast<std::size_t>(rings.ring(i)[0]));
    const double r = std::sqrt(double{p[0]} * p[0] + double{p[1]} * p[1] + double{p[2]} * p[2]);
    if (r > 0) steps.push_back(std::sqrt(double{squared_distance(p, q)}) / r);
  }
  if (steps.size() < 16) return 0;
  const auto middle = steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2);
  std::nth_element(steps.begin(), middle, steps.end());
  return *middle;
}

double sigma_at(const SensorNoise& noise, const std::array<double, 3>& c) {
  return noise.sigma(std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]));
}

/// Adjacent plane segments are merged by the grid's test (seg::planes_merge, with sigma of the
/// range): their planes agree, or one plane explains their union within the noise (union-find
/// over the ring adjacency, refitted after every union, until nothing changes).
void merge_planes(const PointRings& rings, const SegmentationSettings& s,
                  std::vector<std::int32_t>& labels, std::vector<detail::PlaneStats>& stats,
                  RingBuffers::Impl& buffers) {
  // Adjacent: joined by a ring edge, or both in the ring of one unlabelled point (a border
  // one point wide, as growth leaves between the terraces of range quantisation).
  std::vector<std::uint64_t>& pairs = buffers.pairs;
  pairs.clear();
  const auto add_pair = [&](std::int32_t x, std::int32_t y) {
    if (x <= 0 || y <= 0 || x == y) return;
    const auto lo = static_cast<std::uint64_t>(std::min(x, y));
    const auto hi = static_cast<std::uint64_t>(std::max(x, y));
    pairs.push_back(lo << 32 | hi);
  };
  for (std::size_t i = 0; i < labels.size(); ++i) {
    const std::int32_t a = labels[i];
    const auto ring = rings.ring(i);
    for (std::size_t j = 0; j < ring.size(); ++j) {
      const std::int32_t b = labels[static_cast<std::size_t>(ring[j])];
      if (a > 0) {
        add_pair(a, b);
        continue;
      }
      for (std::size_t t = j + 1; t < ring.size(); ++t) {
        add_pair(b, labels[static_cast<std::size_t>(ring[t])]);
      }
    }
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  std::vector<std::int32_t>& parent = buffers.parent;
  parent.resize(stats.size());
  buffers.grazing.resize(stats.size(), 0);
  std::iota(parent.begin(), parent.end(), 0);
  const auto find = [&](std::int32_t x) {
    while (parent[static_cast<std::size_t>(x)] != x) {
      parent[static_cast<std::size_t>(x)] =
          parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(x)])];
      x = parent[static_cast<std::size_t>(x)];
    }
    return x;
  };
  for (bool changed = true; changed;) {
    changed = false;
    for (const std::uint64_t pair : pairs) {
      const std::int32_t a = find(static_cast<std::int32_t>(pair >> 32));
      const std::int32_t b = find(static_cast<std::int32_t>(pair & 0xffffffffu));
      if (a == b) continue;
      detail::PlaneStats& sa = stats[static_cast<std::size_t>(a)];
      detail::PlaneStats& sb = stats[static_cast<std::size_t>(b)];
      const detail::PlaneFit fa = sa.fit();
      const detail::PlaneFit fb = sb.fit();
      detail::PlaneStats merged;
      if (!fa.ok || !fb.ok ||
          !seg::planes_merge(sa, fa, sb, fb, s, &merged, nullptr, /*by_range=*/true)) {
        continue;
      }
      const std::int32_t keep = std::min(a, b), gone = std::max(a, b);
      parent[static_cast<std::size_t>(gone)] = keep;
      buffers.grazing[static_cast<std::size_t>(keep)] |=
          buffers.grazing[static_cast<std::size_t>(gone)];
      stats[static_cast<std::size_t>(keep)] = merged;
      stats[static_cast<std::size_t>(gone)].clear();
      changed = true;
    }
  }
  for (std::int32_t& l : labels) {
    if (l > 0) l = find(l);
  }
}

/// The grid's splitting of plane segments that one plane does not explain
/// (seg::split_unexplained_planes) over the rings, after merging: raw labels and their
/// statistics (roots only); parts split off get new raw labels, appended to `stats`. A
/// segment's noise reference is what its own rings show, not the frame's other segments (whose
/// RMS / sigma differ from surface to surface in a sparse scan): the RMS distance of its ring
/// neighbours in the segment from each point's tangent plane, / sqrt 2 (both points are noisy),
/// in units of sigma(r) at its centroid. A segment flagged against it is one that a single
/// plane explains much worse than its points' neighbourhoods do.
void split_planes(const PointRings& rings, const Points& pts, const SegmentationSettings& s,
                  std::vector<std::int32_t>& labels, std::vector<detail::PlaneStats>& stats,
                  RingBuffers::Impl& b) {
  if (!(s.split_residual_factor > 0)) return;
  const std::size_t n = stats.size();
  std::vector<double>& sums = b.local_sums;
  std::vector<std::int64_t>& counts = b.counts;
  sums.assign(n, 0.0);
  counts.assign(n, 0);
  for (std::size_t i = 0; i < labels.size(); ++i) {
    const std::int32_t l = labels[i];
    if (l <= 0 || !pts.has_normal(i)) continue;
    const float* p = pts.point(i);
    const float* m = pts.normal(i);
    for (const std::int32_t jj : rings.ring(i)) {
      const auto j = static_cast<std::size_t>(jj);
      if (labels[j] != l) continue;
      const float* q = pts.point(j);
      const double d = double{m[0]} * (q[0] - p[0]) + double{m[1]} * (q[1] - p[1]) +
                       double{m[2]} * (q[2] - p[2]);
      sums[static_cast<std::size_t>(l)] += d * d;
      counts[static_cast<std::size_t>(l)] += 1;
    }
  }
  if (!b.split) b.split = std::make_unique<Segmenter::Scratch>();
  Segmenter::Scratch& scratch = *b.split;
  scratch.regions = stats;
  scratch.fits.assign(n, detail::PlaneFit{});
  scratch.parent.resize(n);
  std::iota(scratch.parent.begin(), scratch.parent.end(), 0);
  scratch.remap.assign(n, 0);
  scratch.grazing_region.assign(b.grazing.begin(), b.grazing.end());
  scratch.grazing_region.resize(n, 0);
  std::vector<double>& references = b.references;
  references.assign(n, 0.0);
  for (std::size_t r = 1; r < n; ++r) {
    if (stats[r].count < s.min_region_size || counts[r] == 0) continue;
    scratch.remap[r] = static_cast<std::int32_t>(r);
    scratch.fits[r] = stats[r].fit();
    const double local = std::sqrt(sums[r] / static_cast<double>(counts[r]) / 2.0);
    references[r] = local / sigma_at(s.noise, scratch.fits[r].centroid);
  }
  const seg::Frame f = ring_frame(rings, pts, pts.n, labels.data(), b.planar);
  seg::split_unexplained_planes(f, s, scratch, references);
  stats = scratch.regions;
  b.grazing.assign(scratch.grazing_region.begin(), scratch.grazing_region.end());
}

/// Rounds of `reassign`: a hole that growth left in a noisy far surface fills from its border
/// inwards, one ring per round (as the grid's border refinement, up to 8 rounds).
constexpr int kReassignRounds = 8;

/// Unlabelled points with a plane segment in their ring join the closest such plane within
/// max_distance_sigmas sigma(r) and reassign_max_normal_angle, widened like the growth test's
/// angle where the ring's normals are noisier; repeated on the points next to those that
/// joined (the planes are not refitted between rounds).
void reassign(const PointRings& rings, const Points& pts, const SegmentationSettings& s,
              std::vector<std::int32_t>& labels, const std::vector<detail::PlaneStats>& stats,
              RingBuffers::Impl& b) {
  std::vector<detail::PlaneFit>& fits = b.fits;
  fits.assign(stats.size(), detail::PlaneFit{});
  for (std::size_t l = 1; l < stats.size(); ++l) {
    if (stats[l].count > 0) fits[l] = stats[l].fit();
  }
  const double cos_normal = std::cos(s.reassign_max_normal_angle);
  const std::vector<float>& cos_noise = pts.cos_angle;
  std::vector<std::pair<std::size_t, std::int32_t>>& moves = b.moves;
  for (int round = 0; round < kReassignRounds; ++round) {
    moves.clear();
    for (std::size_t i = 0; i < labels.size(); ++i) {
      if (labels[i] != 0 || rings.count[i] == 0) continue;
      const float* p = pts.point(i);
      const float* n = pts.normal(i);
      double best = s.max_distance_sigmas * pts.sigma[i];
      std::int32_t choice = 0;
      for (const std::int32_t j : rings.ring(i)) {
        const std::int32_t l = labels[static_cast<std::size_t>(j)];
        if (l <= 0 || !fits[static_cast<std::size_t>(l)].ok) continue;
        const detail::PlaneFit& f = fits[static_cast<std::size_t>(l)];
        if (pts.has_normal(i) &&
            std::fabs(f.normal[0] * n[0] + f.normal[1] * n[1] + f.normal[2] * n[2]) <
                std::min(cos_normal, double{cos_noise[i]})) {
          continue;
        }
        const double distance = std::fabs(f.distance(p[0], p[1], p[2]));
        if (distance <= best) {
          best = distance;
          choice = l;
        }
      }
      if (choice != 0) moves.emplace_back(i, choice);
    }
    for (const auto& [i, l] : moves) labels[i] = l;
    if (moves.empty()) break;
  }
}

/// Rounds of `refine_borders`, as on the grid.
constexpr int kBorderRounds = 8;

/// The grid's refinement of the borders between plane segments (seg::refine_plane_boundaries)
/// over the rings: a point of a plane segment with a ring neighbour in another one moves to that
/// segment when it lies closer to its plane by more than boundary_refine_sigmas sigma(r) and
/// within max_distance_sigmas sigma(r) of it (to the closest such plane). The planes are
/// refitted after each round, and a later round tests the points that moved and their rings.
/// Growth gives the points near a crease to whichever region reaches them first, and with Kinect
/// noise a region can grow a few points past a shallow crease onto the next face.
void refine_borders(const PointRings& rings, const Points& pts, const SegmentationSettings& s,
                    std::vector<std::int32_t>& labels, std::vector<detail::PlaneStats>& stats,
                    RingBuffers::Impl& b) {
  std::vector<detail::PlaneFit>& fits = b.fits;
  fits.assign(stats.size(), detail::PlaneFit{});
  for (std::size_t l = 1; l < stats.size(); ++l) {
    if (stats[l].count > 0) fits[l] = stats[l].fit();
  }
  std::vector<BorderMove>& moves = b.border_moves;
  std::vector<std::int32_t>& moved = b.moved;
  b.refit.assign(stats.size(), 0);
  b.grazing.resize(stats.size(), 0);
  // As on the grid, not across the border of a plane found seen at grazing incidence: the
  // distances there are along its noisy rays.
  const auto grazing = [&](std::int32_t l) { return b.grazing[static_cast<std::size_t>(l)] != 0; };
  const auto consider = [&](std::size_t i) {
    const std::int32_t from = labels[i];
    if (from <= 0 || !fits[static_cast<std::size_t>(from)].ok || grazing(from)) return;
    const float* p = pts.point(i);
    const double sigma = pts.sigma[i];
    const double own = std::fabs(fits[static_cast<std::size_t>(from)].distance(p[0], p[1], p[2]));
    for (const std::int32_t j : rings.ring(i)) {
      const std::int32_t to = labels[static_cast<std::size_t>(j)];
      if (to <= 0 || to == from || !fits[static_cast<std::size_t>(to)].ok || grazing(to)) continue;
      const double other = std::fabs(fits[static_cast<std::size_t>(to)].distance(p[0], p[1], p[2]));
      if (own - other > s.boundary_refine_sigmas * sigma &&
          other <= s.max_distance_sigmas * sigma) {
        moves.push_back({static_cast<std::int32_t>(i), to, other});
      }
    }
  };
  moves.clear();
  for (std::size_t i = 0; i < labels.size(); ++i) consider(i);
  for (int round = 0; round < kBorderRounds && !moves.empty(); ++round) {
    std::sort(moves.begin(), moves.end(), [](const BorderMove& m, const BorderMove& n) {
      return m.point != n.point ? m.point < n.point : m.distance < n.distance;
    });
    moved.clear();
    std::int32_t last = -1;
    for (const BorderMove& m : moves) {
      if (m.point == last) continue;
      last = m.point;
      const auto i = static_cast<std::size_t>(m.point);
      const auto from = static_cast<std::size_t>(labels[i]);
      if (stats[from].count <= 3) continue;  // a segment keeps a plane
      const float* p = pts.point(i);
      stats[from].remove(p[0], p[1], p[2]);
      stats[static_cast<std::size_t>(m.target)].add(p[0], p[1], p[2]);
      labels[i] = m.target;
      b.refit[from] = b.refit[static_cast<std::size_t>(m.target)] = 1;
      moved.push_back(m.point);
    }
    for (std::size_t l = 1; l < stats.size(); ++l) {
      if (b.refit[l] != 0) fits[l] = stats[l].fit();
      b.refit[l] = 0;
    }
    moves.clear();
    for (const std::int32_t m : moved) {
      consider(static_cast<std::size_t>(m));
      for (const std::int32_t j : rings.ring(static_cast<std::size_t>(m))) {
        consider(static_cast<std::size_t>(j));
      }
    }
  }
}

}  // namespace
}  // namespace rangeseg::unorganized

namespace rangeseg {

using unorganized::at;
using unorganized::collect_seeds;
using unorganized::drop_small;
using unorganized::find_grazing_planes;
using unorganized::fit_ring_primitives;
using unorganized::grow;
using unorganized::grow_leftovers;
using unorganized::label_stats;
using unorganized::merge_planes;
using unorganized::PlaneRegion;
using unorganized::Points;
using unorganized::reassign;
using unorganized::refine_borders;
using unorganized::ring_footprint;
using unorganized::sample_area;
using unorganized::SmoothRegion;
using unorganized::split_planes;

void segment(const OrganizedCloud& cloud, const PointRings& rings, const NormalMap& normals,
             const SegmentationSettings& settings, Segmentation& out) {
  RingBuffers buffers;
  segment(cloud, rings, normals, settings, out, buffers);
}

void segment(const OrganizedCloud& cloud, const PointRings& rings, const NormalMap& normals,
             const SegmentationSettings& settings, Segmentation& out, RingBuffers& buffers) {
  seg::validate(settings);
  const bool automatic = settings.model == RegionModel::automatic;
  const bool planes = settings.model == RegionModel::plane || automatic;
  if (!planes && settings.model != RegionModel::smooth) {
    throw std::invalid_argument(std::string("segment: model ") + to_string(settings.model) +
                                " is not available for unorganized clouds (plane, smooth or auto)");
  }
  unorganized::require_rings_match(cloud, rings, &normals, "segment");
  if (normals.curvature.width() != cloud.width() || normals.curvature.height() != cloud.height()) {
    throw std::invalid_argument("segment: the normals have no curvature of the cloud's size");
  }
  RingBuffers::Impl& b = buffers.impl();
  const Points pts(b, cloud, rings, normals, settings);
  const std::size_t count = cloud.size();
  std::vector<std::int32_t>& labels = b.labels;
  labels.assign(count, 0);
  b.grazing.clear();
  std::vector<std::int32_t>& seeds = b.seeds;
  collect_seeds(rings, pts, settings, planes, labels, b);
  std::int32_t raw = 0;
  if (planes) {
    PlaneRegion model(pts, settings);
    raw = grow(rings, pts, seeds, model, labels, b.queue);
  } else {
    SmoothRegion model(pts, settings);
    raw = grow(rings, pts, seeds, model, labels, b.queue);
  }
  std::vector<detail::PlaneStats>& stats = b.stats;
  label_stats(pts, labels, raw, stats);
  // As on the grid, with the plane model a region below min_region_size is kept when it is wide
  // enough (a far or oblique face); other regions, and those of `auto`, need min_region_size.
  const double footprint =
      settings.model == RegionModel::plane ? ring_footprint(rings, pts, b.noise_samples) : 0;
  const auto kept = [&](const detail::PlaneStats& st) {
    return st.count >= settings.min_region_size ||
           seg::wide_enough(st, settings.min_region_size, footprint);
  };
  std::vector<std::uint8_t>& keep = b.keep;  // per raw label (wide_enough is an eigen-solve)
  keep.assign(stats.size(), 0);
  for (std::size_t l = 1; l < stats.size(); ++l) keep[l] = kept(stats[l]) ? 1 : 0;
  for (std::int32_t& l : labels) {
    if (l > 0 && keep[static_cast<std::size_t>(l)] == 0) l = 0;
  }
  if (planes) {
    for (std::size_t l = 1; l < stats.size(); ++l) {
      if (keep[l] == 0) stats[l].clear();
    }
    // As on the grid, the unlabelled points join adjacent planes before merging: two pieces of
    // one surface that growth left apart (a noisy far surface, a surface seen at grazing
    // incidence) then touch and merge; and again after splitting, around the new parts.
    const auto reassign_and_count = [&] {
      if (!settings.reassign_boundary) return;
      reassign(rings, pts, settings, labels, stats, b);
      label_stats(pts, labels, raw, stats);
    };
    reassign_and_count();
    // As on the grid, planes seen at grazing incidence among the points still unlabelled.
    find_grazing_planes(rings, pts, settings,
                        footprint > 0 ? footprint : ring_footprint(rings, pts, b.noise_samples),
                        labels, stats, b);
    raw = static_cast<std::int32_t>(stats.size()) - 1;
    if (settings.merge_planes) {
      merge_planes(rings, settings, labels, stats, b);
      split_planes(rings, pts, settings, labels, stats, b);
      raw = static_cast<std::int32_t>(stats.size()) - 1;
      // Not for `auto`, whose plane facets may be pieces of one curved surface (as on the grid).
      if (settings.boundary_refine_sigmas > 0 && !automatic) {
        refine_borders(rings, pts, settings, labels, stats, b);
      }
      reassign_and_count();
    }
  }
  // Final labels 1..N by point count, descending (ties: the earlier raw label first).
  std::vector<std::int32_t>& order = b.order;
  order.clear();
  for (std::int32_t l = 1; l <= raw; ++l) {
    if (kept(stats[static_cast<std::size_t>(l)])) order.push_back(l);
  }
  std::sort(order.begin(), order.end(), [&](std::int32_t x, std::int32_t y) {
    const std::int64_t cx = stats[static_cast<std::size_t>(x)].count;
    const std::int64_t cy = stats[static_cast<std::size_t>(y)].count;
    return cx > cy || (cx == cy && x < y);
  });
  std::int32_t tentative_from = 0;
  if (automatic) {
    // The primitive pass's labels: the plane segments, the smooth and then the tentative
    // leftovers, each in the order grown.
    const std::int32_t first = raw + 1;
    tentative_from = grow_leftovers(rings, pts, settings, labels, b, raw);
    label_stats(pts, labels, raw, stats);
    drop_small(labels, stats, settings.min_region_size);
    std::int32_t kept = static_cast<std::int32_t>(order.size());
    for (std::int32_t l = first; l <= raw; ++l) {
      if (stats[static_cast<std::size_t>(l)].count < settings.min_region_size) continue;
      order.push_back(l);
      if (l <= tentative_from) kept = static_cast<std::int32_t>(order.size());
    }
    tentative_from = kept;
  }
  std::vector<std::int32_t>& final_label = b.final_label;
  final_label.assign(static_cast<std::size_t>(raw) + 1, 0);
  for (std::size_t j = 0; j < order.size(); ++j) {
    final_label[static_cast<std::size_t>(order[j])] = static_cast<std::int32_t>(j) + 1;
  }
  out.labels.resize(cloud.width(), cloud.height(), 0);
  out.segments.assign(order.size(), Segment{});
  for (std::size_t i = 0; i < count; ++i) {
    at(out.labels, i) = labels[i] > 0 ? final_label[static_cast<std::size_t>(labels[i])] : 0;
  }
  for (std::size_t j = 0; j < order.size(); ++j) {
    Segment& sgm = out.segments[j];
    seg::set_plane_fields(stats[static_cast<std::size_t>(order[j])], sgm);
    sgm.label = static_cast<int>(j) + 1;
    sgm.model = automatic ? RegionModel::plane : settings.model;
    sgm.kind = planes ? SurfaceKind::plane : SurfaceKind::smooth;
    sgm.surface_rms = sgm.rms_residual;
    const auto raw_label = static_cast<std::size_t>(order[j]);
    sgm.grazing = raw_label < b.grazing.size() && b.grazing[raw_label] != 0;
  }
  // `auto` sums them after its primitive pass, which joins and relabels segments.
  if (settings.compute_area && !automatic) {
    for (std::size_t i = 0; i < count; ++i) {
      const std::int32_t l = at(out.labels, i);
      if (l <= 0) continue;
      Segment& sgm = out.segments[static_cast<std::size_t>(l - 1)];
      sgm.area_m2 += sample_area(cloud, rings, i, sgm, b.grazing_spacing);
    }
  }
  if (automatic) fit_ring_primitives(cloud, rings, pts, settings, tentative_from, b, out);
}

}  // namespace rangeseg
