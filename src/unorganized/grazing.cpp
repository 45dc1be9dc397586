// Plane segments of surfaces seen at grazing incidence over k-nearest-neighbour rings: the grid's
// search (segmentation/grazing.cpp) with neighbours by viewing direction among the unlabelled
// points instead of lattice neighbours. On such a surface the rings' veil test cuts the edges
// between consecutive scan lines (they lie nearly along the ray), so growth leaves it in strips.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "detail/plane_stats.hpp"
#include "segmentation/internal.hpp"
#include "unorganized/internal.hpp"
#include "unorganized/kd_tree.hpp"
#include "unorganized/region_growing.hpp"

namespace rangeseg::unorganized {
namespace {

/// Neighbours by direction searched per candidate point.
constexpr int kLinks = 8;
/// Candidates whose directions are further apart than this many footprints are not linked: the
/// lattice's 4- and 8-neighbours are 1 and sqrt 2 footprints apart, a gap in the data more.
constexpr double kMaxLinkFootprints = 2.5;

using State = GrazingState;

class GrazingSearch {
 public:
  GrazingSearch(const Points& pts, const SegmentationSettings& s, double footprint,
                std::vector<std::int32_t>& labels, std::vector<detail::PlaneStats>& stats,
                RingBuffers::Impl& b)
      : pts_(pts),
        s_(s),
        footprint_(footprint),
        inv_tan_min_(1.0 / std::tan(s.grazing_min_angle)),
        sin_max_(std::sin(s.grazing_max_angle)),
        labels_(labels),
        stats_(stats),
        b_(b) {}

  void run(const PointRings& rings) {
    std::vector<std::int32_t>& candidates = b_.grazing_candidates;
    std::vector<double>& range = b_.grazing_range;
    candidates.clear();
    range.clear();
    for (std::size_t i = 0; i < labels_.size(); ++i) {
      if (labels_[i] != 0 || rings.count[i] == 0) continue;
      const float* p = pts_.point(i);
      const double r = std::sqrt(double{p[0]} * p[0] + double{p[1]} * p[1] + double{p[2]} * p[2]);
      if (!(r > 0)) continue;  // no viewing direction
      candidates.push_back(static_cast<std::int32_t>(i));
      range.push_back(r);
    }
    if (2 * static_cast<std::int64_t>(candidates.size()) < s_.min_region_size) return;
    link_candidates();
    std::vector<State>& state = b_.grazing_state;
    state.assign(candidates.size(), State::free);
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      if (state[c] == State::free) search_from(c);
    }
  }

 private:
  /// The directions from the origin of the candidates (ranges in grazing_range); the undirected
  /// links between candidates among each one's kLinks nearest by direction (as CSR: link_first,
  /// links) whose ranges differ by no more than a surface at grazing_min_angle to the rays,
  /// plus the noise of both, explains.
  void link_candidates() {
    const std::vector<std::int32_t>& candidates = b_.grazing_candidates;
    const std::size_t m = candidates.size();
    const std::vector<double>& range = b_.grazing_range;
    std::vector<float>& directions = b_.grazing_directions;
    directions.resize(3 * m);
    for (std::size_t c = 0; c < m; ++c) {
      const float* p = pts_.point(static_cast<std::size_t>(candidates[c]));
      for (int d = 0; d < 3; ++d) directions[3 * c + d] = static_cast<float>(p[d] / range[c]);
    }
    if (!b_.grazing_tree) b_.grazing_tree.reset(new RingTree);
    b_.grazing_tree->data = PackedCloud{directions.data(), m};
    b_.grazing_tree->tree.buildIndex();
    const Tree& tree = b_.grazing_tree->tree;
    std::vector<std::uint64_t>& pairs = b_.grazing_pairs;
    pairs.clear();
    const double max_chord = kMaxLinkFootprints * footprint_;
    std::array<std::uint32_t, kLinks + 1> index{};
    std::array<float, kLinks + 1> distance2{};
    for (std::size_t c = 0; c < m; ++c) {
      nanoflann::KNNResultSet<float, std::uint32_t, std::uint32_t> result(kLinks + 1);
      result.init(index.data(), distance2.data());
      tree.findNeighbors(result, &directions[3 * c], nanoflann::SearchParams());
      for (std::uint32_t j = 0; j < result.size(); ++j) {
        const std::size_t d = index[j];
        if (d == c) continue;
        const double chord = std::sqrt(double{distance2[j]});
        if (!(chord <= max_chord)) continue;
        const double r = std::min(range[c], range[d]);
        const double bound = chord * r * inv_tan_min_ +
                             s_.max_distance_sigmas * std::numbers::sqrt2 * s_.noise.sigma(r);
        if (!(std::abs(range[c] - range[d]) <= bound)) continue;
        pairs.push_back(static_cast<std::uint64_t>(c) << 32 | d);
        pairs.push_back(static_cast<std::uint64_t>(d) << 32 | c);
      }
    }
    // Grouped by their first point (a counting sort keeps the search's order).
    std::vector<std::int32_t>& first = b_.grazing_link_first;
    std::vector<std::int32_t>& links = b_.grazing_links;
    first.assign(m + 1, 0);
    for (const std::uint64_t pair : pairs) ++first[(pair >> 32) + 1];
    for (std::size_t c = 0; c < m; ++c) first[c + 1] += first[c];
    links.resize(pairs.size());
    std::vector<std::int32_t>& cursor = b_.grazing_cursor;
    cursor.assign(first.begin(), first.end() - 1);
    for (const std::uint64_t pair : pairs) {
      links[static_cast<std::size_t>(cursor[pair >> 32]++)] =
          static_cast<std::int32_t>(pair & 0xffffffffu);
    }
  }

  bool free(std::size_t c) const {
    return b_.grazing_state[c] == State::free &&
           labels_[static_cast<std::size_t>(b_.grazing_candidates[c])] == 0;
  }

  /// The component of `start` and, each time a plane is taken from one, the components of the
  /// rest of its points: a component may hold two grazing surfaces (a box's top and its side).
  void search_from(std::size_t start) {
    std::vector<std::int32_t>& starts = b_.grazing_starts;
    std::vector<std::int32_t>& component = b_.grazing_component;
    starts.assign(1, static_cast<std::int32_t>(start));
    while (!starts.empty()) {
      const auto c = static_cast<std::size_t>(starts.back());
      starts.pop_back();
      if (!free(c)) continue;
      collect_component(c);
      if (2 * static_cast<std::int64_t>(component.size()) < s_.min_region_size || !try_plane()) {
        continue;
      }
      for (const std::int32_t k : component) {
        if (labels_[static_cast<std::size_t>(b_.grazing_candidates[k])] != 0) continue;
        b_.grazing_state[static_cast<std::size_t>(k)] = State::free;
        starts.push_back(k);
      }
    }
  }

  /// The free candidates connected to `start` over links, into grazing_component, visited.
  void collect_component(std::size_t start) {
    std::vector<std::int32_t>& component = b_.grazing_component;
    std::vector<State>& state = b_.grazing_state;
    component.assign(1, static_cast<std::int32_t>(start));
    state[start] = State::visited;
    for (std::size_t k = 0; k < component.size(); ++k) {
      const auto c = static_cast<std::size_t>(component[k]);
      for (std::int32_t l = b_.grazing_link_first[c]; l < b_.grazing_link_first[c + 1]; ++l) {
        const auto d = static_cast<std::size_t>(b_.grazing_links[static_cast<std::size_t>(l)]);
        if (!free(d)) continue;
        state[d] = State::visited;
        component.push_back(static_cast<std::int32_t>(d));
      }
    }
  }

  /// The grid's robust fit (seg::fit_grazing_plane) of the component; a grazing plane that
  /// explains enough of it becomes a new raw label (returns whether one did).
  bool try_plane() {
    const std::vector<std::int32_t>& component = b_.grazing_component;
    std::vector<double>& points = b_.grazing_points;
    points.resize(seg::kGrazingPointSize * component.size());
    for (std::size_t k = 0; k < component.size(); ++k) {
      const auto c = static_cast<std::size_t>(component[k]);
      const auto i = static_cast<std::size_t>(b_.grazing_candidates[c]);
      const float* p = pts_.point(i);
      double* q = &points[seg::kGrazingPointSize * k];
      q[0] = p[0];
      q[1] = p[1];
      q[2] = p[2];
      q[3] = pts_.sigma[i];
      q[4] = 1.0 / b_.grazing_range[c];
    }
    const detail::PlaneFit fit =
        seg::fit_grazing_plane(points.data(), component.size(), s_, footprint_, /*by_range=*/true);
    if (!fit.ok) return false;
    const auto label = static_cast<std::int32_t>(stats_.size());
    detail::PlaneStats kept;
    for (std::size_t k = 0; k < component.size(); ++k) {
      const double* q = &points[seg::kGrazingPointSize * k];
      if (!seg::within_grazing_plane(fit, q, s_.max_distance_sigmas, sin_max_)) continue;
      const auto c = static_cast<std::size_t>(component[k]);
      labels_[static_cast<std::size_t>(b_.grazing_candidates[c])] = label;
      kept.add(q[0], q[1], q[2]);
    }
    if (2 * kept.count < s_.min_region_size) {  // the last refit moved the plane
      for (const std::int32_t c : component) {
        std::int32_t& l = labels_[static_cast<std::size_t>(b_.grazing_candidates[c])];
        if (l == label) l = 0;
      }
      return false;
    }
    stats_.push_back(kept);
    b_.grazing.resize(stats_.size(), 0);
    b_.grazing[static_cast<std::size_t>(label)] = 1;
    return true;
  }

  const Points& pts_;
  const SegmentationSettings& s_;
  double footprint_, inv_tan_min_, sin_max_;
  std::vector<std::int32_t>& labels_;
  std::vector<detail::PlaneStats>& stats_;
  RingBuffers::Impl& b_;
};

}  // namespace

void find_grazing_planes(const PointRings& rings, const Points& pts, const SegmentationSettings& s,
                         double footprint, std::vector<std::int32_t>& labels,
                         std::vector<detail::PlaneStats>& stats, RingBuffers::Impl& b) {
  b.grazing.assign(stats.size(), 0);
  b.grazing_spacing = footprint;
  if (!(s.grazing_min_angle > 0) || !(footprint > 0)) return;
  GrazingSearch(pts, s, footprint, labels, stats, b).run(rings);
}

double sample_area(const OrganizedCloud& cloud, const PointRings& rings, std::size_t i,
                   const Segment& s, double spacing) {
  if (!s.grazing || !(spacing > 0)) return point_area(cloud, rings, i);
  const double x = at(cloud.x, i), y = at(cloud.y, i), z = at(cloud.z, i);
  const double r2 = x * x + y * y + z * z;
  const double sine = std::abs(s.normal[0] * x + s.normal[1] * y + s.normal[2] * z) / std::sqrt(r2);
  return spacing * spacing * r2 / std::max(sine, kMinGrazingSine);
}

}  // namespace rangeseg::unorganized
