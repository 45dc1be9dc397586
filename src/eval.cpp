// SegComp evaluation (Hoover et al. 1996): region classification, plane fits, angle differences.
#include "rangeseg/eval.hpp"
#include "detail/number_text.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unordered_set>

namespace rangeseg::eval {

namespace {

std::string size_string(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

std::uint64_t pair_key(std::int32_t a, std::int32_t b) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) |
         static_cast<std::uint32_t>(b);
}
std::int32_t key_first(std::uint64_t key) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(key >> 32));
}
std::int32_t key_second(std::uint64_t key) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(key));
}

/// O >= T P, with a relative slack far above double rounding (1e-16) but far below the step
/// between integer counts for any image size, so that T = 0.8 behaves like the exact fraction 4/5.
bool at_least_fraction(std::int64_t overlap, double tolerance, std::int64_t size) {
  return static_cast<double>(overlap) >= tolerance * static_cast<double>(size) * (1.0 - 1e-12);
}

constexpr std::int32_t kUnlabelled = 0;  // machine labels <= 0 are mapped to this

struct Overlap {
  std::int32_t gt;
  std::int32_t ms;
  std::int64_t pixels;
};

/// Open-addressing hash table from pair_key to a pixel count (linear probing, power-of-two
/// capacity, at most half full). Keys never equal kEmpty because GT labels are >= 0.
class PairCounter {
 public:
  PairCounter() : keys_(kInitialCapacity, kEmpty), counts_(kInitialCapacity, 0) {}

  void add(std::uint64_t key, std::int64_t count) {
    assert(key != kEmpty);
    std::size_t i = slot(key);
    while (keys_[i] != kEmpty && keys_[i] != key) i = (i + 1) & mask();
    if (keys_[i] == kEmpty) {
      keys_[i] = key;
      if (++size_ * 2 > keys_.size()) {
        counts_[i] += count;
        grow();
        return;
      }
    }
    counts_[i] += count;
  }

  std::vector<Overlap> sorted_overlaps() const {
    std::vector<std::pair<std::uint64_t, std::int64_t>> entries;
    entries.reserve(size_);
    for (std::size_t i = 0; i < keys_.size(); ++i) {
      if (keys_[i] != kEmpty) entries.emplace_back(keys_[i], counts_[i]);
    }
    std::sort(entries.begin(), entries.end());
    std::vector<Overlap> out;
    out.reserve(entries.size());
    for (const auto& [key, count] : entries) {
      out.push_back({key_first(key), key_second(key), count});
    }
    return out;
  }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  static constexpr std::size_t kInitialCapacity = 1024;

  std::size_t mask() const { return keys_.size() - 1; }
  std::size_t slot(std::uint64_t key) const {
    // Fibonacci hashing: the high bits of the product mix both labels.
    const int bits = std::countr_zero(keys_.size());
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> (64 - bits));
  }
  void grow() {
    std::vector<std::uint64_t> old_keys(keys_.size() * 2, kEmpty);
    std::vector<std::int64_t> old_counts(keys_.size() * 2, 0);
    old_keys.swap(keys_);
    old_counts.swap(counts_);
    for (std::size_t i = 0; i < old_keys.size(); ++i) {
      if (old_keys[i] == kEmpty) continue;
      std::size_t j = slot(old_keys[i]);
      while (keys_[j] != kEmpty) j = (j + 1) & mask();
      keys_[j] = old_keys[i];
      counts_[j] = old_counts[i];
    }
  }

  std::vector<std::uint64_t> keys_;
  std::vector<std::int64_t> counts_;
  std::size_t size_ = 0;
};

const RegionOutcome* find_label(const std::vector<RegionOutcome>& regions, int label) {
  auto it = std::lower_bound(regions.begin(), regions.end(), label,
                             [](const RegionOutcome& r, int l) { return r.label < l; });
  return (it != regions.end() && it->label == label) ? &*it : nullptr;
}

}  // namespace

const char* to_string(Outcome outcome) {
  switch (outcome) {
    case Outcome::correct:
      return "correct";
    case Outcome::over:
      return "over";
    case Outcome::under:
      return "under";
    case Outcome::missed:
      return "missed";
    case Outcome::noise:
      return "noise";
  }
  return "?";
}

const RegionOutcome* EvalResult::find_gt(int label) const { return find_label(gt, label); }
const RegionOutcome* EvalResult::find_ms(int label) const { return find_label(ms, label); }

EvalResult evaluate(const LabelImage& ground_truth, const LabelImage& machine,
                    const EvalSettings& settings) {
  if (ground_truth.width() != machine.width() || ground_truth.height() != machine.height()) {
    throw std::invalid_argument("eval::evaluate: ground truth is " +
                                size_string(ground_truth.width(), ground_truth.height()) +
                                " but machine segmentation is " +
                                size_string(machine.width(), machine.height()));
  }
  if (!(settings.tolerance > 0.5 && settings.tolerance <= 1.0)) {
    throw std::invalid_argument("eval::evaluate: tolerance must be in (0.5, 1], got " +
                                rangeseg::detail::number_text(settings.tolerance));
  }
  if (settings.min_gt_label < 0) {
    throw std::invalid_argument("eval::evaluate: min_gt_label must be >= 0, got " +
                                std::to_string(settings.min_gt_label));
  }
  const double T = settings.tolerance;
  const std::int32_t min_gt = settings.min_gt_label;
  const int width = ground_truth.width(), height = ground_truth.height();

  // Overlap table O_mn (machine label kUnlabelled included, so that P_n comes out of the same
  // table). Neighbouring pixels mostly share their label pair, so counts are accumulated in runs
  // and the table is touched once per run; it is a flat hash table, not a dense label x label
  // matrix, so any int32 labels work.
  PairCounter counter;
  std::vector<std::int32_t> ms_on_excluded;
  for (int y = 0; y < height; ++y) {
    const std::int32_t* g_row = ground_truth.row(y);
    const std::int32_t* m_row = machine.row(y);
    std::uint64_t run_key = 0;
    std::int64_t run_length = 0;
    std::int32_t last_excluded_ms = kUnlabelled;
    for (int x = 0; x < width; ++x) {
      const std::int32_t g = g_row[x];
      const std::int32_t m = m_row[x] > 0 ? m_row[x] : kUnlabelled;
      if (g < min_gt) {
        if (m != kUnlabelled && m != last_excluded_ms) ms_on_excluded.push_back(m);
        last_excluded_ms = m;
        continue;
      }
      const std::uint64_t key = pair_key(g, m);
      if (key != run_key || run_length == 0) {
        if (run_length > 0) counter.add(run_key, run_length);
        run_key = key;
        run_length = 0;
      }
      ++run_length;
    }
    if (run_length > 0) counter.add(run_key, run_length);
  }
  // Ascending (gt, ms): GT labels are >= 0, so pair_key preserves the order.
  std::vector<Overlap> overlaps = counter.sorted_overlaps();
  counter = {};

  EvalResult result;
  result.width = width;
  result.height = height;
  result.settings = settings;

  // GT regions, ascending label, with sizes P_n; overlaps with compact region indices.
  struct IndexedOverlap {
    int gi, mi;
    std::int64_t pixels;
  };
  std::vector<IndexedOverlap> indexed;
  std::vector<std::pair<std::int32_t, int>> ms_of_overlap;  // (MS label, index into `indexed`)
  for (const Overlap& o : overlaps) {
    if (result.gt.empty() || result.gt.back().label != o.gt) {
      result.gt.push_back({o.gt, 0, Outcome::missed, {}});
    }
    result.gt.back().pixels += o.pixels;
    if (o.ms == kUnlabelled) continue;
    ms_of_overlap.emplace_back(o.ms, static_cast<int>(indexed.size()));
    indexed.push_back({static_cast<int>(result.gt.size()) - 1, -1, o.pixels});
  }
  overlaps = {};
  // MS regions, ascending label, with sizes P_m.
  std::sort(ms_of_overlap.begin(), ms_of_overlap.end());
  for (const auto& [label, k] : ms_of_overlap) {
    if (result.ms.empty() || result.ms.back().label != label) {
      result.ms.push_back({label, 0, Outcome::noise, {}});
    }
    result.ms.back().pixels += indexed[k].pixels;
    indexed[k].mi = static_cast<int>(result.ms.size()) - 1;
  }
  const int n_gt = static_cast<int>(result.gt.size());
  const int n_ms = static_cast<int>(result.ms.size());

  // With T > 0.5 a region can lie "mostly inside" (O >= T P) at most one region of the other
  // segmentation; these two maps carry every classification below.
  std::vector<int> gt_containing_ms(n_ms, -1), ms_containing_gt(n_gt, -1);
  std::vector<std::int64_t> ms_inside_overlap(n_ms, 0), gt_inside_overlap(n_gt, 0);
  for (const IndexedOverlap& o : indexed) {
    if (at_least_fraction(o.pixels, T, result.ms[o.mi].pixels)) {
      assert(gt_containing_ms[o.mi] < 0);
      gt_containing_ms[o.mi] = o.gi;
      ms_inside_overlap[o.mi] = o.pixels;
    }
    if (at_least_fraction(o.pixels, T, result.gt[o.gi].pixels)) {
      assert(ms_containing_gt[o.gi] < 0);
      ms_containing_gt[o.gi] = o.mi;
      gt_inside_overlap[o.gi] = o.pixels;
    }
  }
  std::vector<bool> gt_done(n_gt, false), ms_done(n_ms, false);

  // 1. Correct detections: mutual containment.
  for (int gi = 0; gi < n_gt; ++gi) {
    const int mi = ms_containing_gt[gi];
    if (mi < 0 || gt_containing_ms[mi] != gi) continue;
    result.gt[gi].outcome = Outcome::correct;
    result.gt[gi].partners = {result.ms[mi].label};
    result.ms[mi].outcome = Outcome::correct;
    result.ms[mi].partners = {result.gt[gi].label};
    gt_done[gi] = ms_done[mi] = true;
    result.correct_pairs.emplace_back(result.gt[gi].label, result.ms[mi].label);
  }

  // 2. Over-segmentation: all still unclassified machine regions lying mostly inside R_n.
  {
    std::vector<std::pair<int, int>> pieces;  // (gi, mi), grouped by gi
    for (int mi = 0; mi < n_ms; ++mi) {
      if (!ms_done[mi] && gt_containing_ms[mi] >= 0 && !gt_done[gt_containing_ms[mi]]) {
        pieces.emplace_back(gt_containing_ms[mi], mi);
      }
    }
    std::sort(pieces.begin(), pieces.end());
    for (std::size_t begin = 0; begin < pieces.size();) {
      const int gi = pieces[begin].first;
      std::size_t end = begin;
      std::int64_t sum = 0;
      while (end < pieces.size() && pieces[end].first == gi) {
        sum += ms_inside_overlap[pieces[end++].second];
      }
      if (end - begin >= 2 && at_least_fraction(sum, T, result.gt[gi].pixels)) {
        result.gt[gi].outcome = Outcome::over;
        gt_done[gi] = true;
        for (std::size_t k = begin; k < end; ++k) {
          const int mi = pieces[k].second;
          result.gt[gi].partners.push_back(result.ms[mi].label);
          result.ms[mi].outcome = Outcome::over;
          result.ms[mi].partners = {result.gt[gi].label};
          ms_done[mi] = true;
        }
      }
      begin = end;
    }
  }

  // 3. Under-segmentation: all still unclassified GT regions lying mostly inside R_m.
  {
    std::vector<std::pair<int, int>> pieces;  // (mi, gi), grouped by mi
    for (int gi = 0; gi < n_gt; ++gi) {
      if (!gt_done[gi] && ms_containing_gt[gi] >= 0 && !ms_done[ms_containing_gt[gi]]) {
        pieces.emplace_back(ms_containing_gt[gi], gi);
      }
    }
    std::sort(pieces.begin(), pieces.end());
    for (std::size_t begin = 0; begin < pieces.size();) {
      const int mi = pieces[begin].first;
      std::size_t end = begin;
      std::int64_t sum = 0;
      while (end < pieces.size() && pieces[end].first == mi) {
        sum += gt_inside_overlap[pieces[end++].second];
      }
      if (end - begin >= 2 && at_least_fraction(sum, T, result.ms[mi].pixels)) {
        result.ms[mi].outcome = Outcome::under;
        ms_done[mi] = true;
        for (std::size_t k = begin; k < end; ++k) {
          const int gi = pieces[k].second;
          result.ms[mi].partners.push_back(result.gt[gi].label);
          result.gt[gi].outcome = Outcome::under;
          result.gt[gi].partners = {result.ms[mi].label};
          gt_done[gi] = true;
        }
      }
      begin = end;
    }
  }

  // 4. The rest: missed (GT) and noise (MS); regions were initialised to these.
  result.gt_regions = n_gt;
  result.ms_regions = n_ms;
  result.correct = static_cast<int>(result.correct_pairs.size());
  for (const RegionOutcome& r : result.gt) {
    if (r.outcome == Outcome::over) ++result.over;
    if (r.outcome == Outcome::missed) ++result.missed;
  }
  for (const RegionOutcome& r : result.ms) {
    if (r.outcome == Outcome::under) ++result.under;
    if (r.outcome == Outcome::noise) ++result.noise;
  }
  std::sort(ms_on_excluded.begin(), ms_on_excluded.end());
  ms_on_excluded.erase(std::unique(ms_on_excluded.begin(), ms_on_excluded.end()),
                       ms_on_excluded.end());
  for (std::int32_t m : ms_on_excluded) {
    if (!find_label(result.ms, m)) ++result.ms_regions_outside;
  }
  return result;
}

// ---------------------------------------------------------------------------------------------

namespace {

/// Moments about a label's first point, which keeps the covariance free of cancellation at
/// large depth.
struct Moments {
  std::int64_t n = 0;
  double ref[3] = {0, 0, 0};
  double s[3] = {0, 0, 0};
  double ss[6] = {0, 0, 0, 0, 0, 0};  // xx xy xz yy yz zz

  void add(double x, double y, double z) {
    if (n == 0) {
      ref[0] = x;
      ref[1] = y;
      ref[2] = z;
    }
    const double d0 = x - ref[0], d1 = y - ref[1], d2 = z - ref[2];
    ++n;
    s[0] += d0;
    s[1] += d1;
    s[2] += d2;
    ss[0] += d0 * d0;
    ss[1] += d0 * d1;
    ss[2] += d0 * d2;
    ss[3] += d1 * d1;
    ss[4] += d1 * d2;
    ss[5] += d2 * d2;
  }

  /// The least-squares plane, its normal facing the sensor origin; nullopt for fewer than 3
  /// points or points on (nearly) one line.
  std::optional<PlaneParams> fit() const {
    if (n < 3) return std::nullopt;
    const double inv_n = 1.0 / static_cast<double>(n);
    const Eigen::Vector3d mean(s[0] * inv_n, s[1] * inv_n, s[2] * inv_n);
    Eigen::Matrix3d cov;
    cov << ss[0], ss[1], ss[2], ss[1], ss[3], ss[4], ss[2], ss[4], ss[5];
    cov = cov * inv_n - mean * mean.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(cov);
    const Eigen::Vector3d& lambda = solver.eigenvalues();  // ascending
    if (!(lambda(2) > 0.0) || lambda(1) <= 1e-12 * lambda(2)) return std::nullopt;
    Eigen::Vector3d normal = solver.eigenvectors().col(0).normalized();
    const Eigen::Vector3d centroid = Eigen::Vector3d(ref[0], ref[1], ref[2]) + mean;
    double offset = -normal.dot(centroid);
    if (offset < 0.0) {
      normal = -normal;
      offset = -offset;
    }
    return PlaneParams{{normal(0), normal(1), normal(2)}, offset};
  }
};

/// A valid labelled pixel of a plane fit.
struct FitPoint {
  std::size_t pixel;  ///< y * width + x
  std::size_t slot;   ///< label - min_label
  double p[3];        ///< [m]
};

/// Sets kept[i] = 1 for the points in their label's largest 4-connected part among `points`
/// (ascending by pixel), 0 for the others.
void keep_largest_parts(int width, int height, std::size_t label_count,
                        const std::vector<FitPoint>& points, std::vector<std::uint8_t>& kept) {
  const auto w = static_cast<std::size_t>(width);
  const auto h = static_cast<std::size_t>(height);
  constexpr std::int32_t kNone = -1;
  std::vector<std::int32_t> at(w * h, kNone);  // pixel -> position in points
  for (std::size_t i = 0; i < points.size(); ++i) {
    at[points[i].pixel] = static_cast<std::int32_t>(i);
  }
  std::vector<std::int32_t> part(points.size(), kNone);
  std::vector<std::int64_t> part_size;
  std::vector<std::size_t> stack;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (part[i] != kNone) continue;
    const auto id = static_cast<std::int32_t>(part_size.size());
    std::int64_t size = 0;
    part[i] = id;
    stack.assign(1, i);
    while (!stack.empty()) {
      const std::size_t j = stack.back();
      stack.pop_back();
      ++size;
      const std::size_t q0 = points[j].pixel, x = q0 % w, y = q0 / w;
      const std::size_t next[4] = {x > 0 ? q0 - 1 : q0, x + 1 < w ? q0 + 1 : q0,
                                   y > 0 ? q0 - w : q0, y + 1 < h ? q0 + w : q0};
      for (const std::size_t q : next) {
        const std::int32_t k = at[q];
        if (k == kNone || part[static_cast<std::size_t>(k)] != kNone ||
            points[static_cast<std::size_t>(k)].slot != points[i].slot) {
          continue;
        }
        part[static_cast<std::size_t>(k)] = id;
        stack.push_back(static_cast<std::size_t>(k));
      }
    }
    part_size.push_back(size);
  }
  std::vector<std::int32_t> largest(label_count, kNone);  // per label its largest part
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::int32_t& best = largest[points[i].slot];
    if (best == kNone ||
        part_size[static_cast<std::size_t>(part[i])] > part_size[static_cast<std::size_t>(best)]) {
      best = part[i];
    }
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    kept[i] = static_cast<std::uint8_t>(largest[points[i].slot] == part[i]);
  }
}

/// The distances a robust refit keeps never go below this [m]: noise-free points lie on their
/// plane to float rounding, where the median distance is no measure of spread.
constexpr double kMinTrimDistance = 1e-4;
/// Refits of a robust fit at most; it stops earlier when the kept points no longer change.
constexpr int kMaxTrimRounds = 5;

}  // namespace

std::vector<std::optional<PlaneParams>> fit_planes(const OrganizedCloud& cloud,
                                                   const LabelImage& labels, int min_label,
                                                   double trim_sigmas) {
  require_consistent(cloud, "eval::fit_planes");
  if (cloud.width() != labels.width() || cloud.height() != labels.height()) {
    throw std::invalid_argument("eval::fit_planes: cloud is " +
                                size_string(cloud.width(), cloud.height()) + " but labels are " +
                                size_string(labels.width(), labels.height()));
  }
  if (min_label < 0) {
    throw std::invalid_argument("eval::fit_planes: min_label must be >= 0, got " +
                                std::to_string(min_label));
  }
  if (!(trim_sigmas >= 0.0) || !std::isfinite(trim_sigmas)) {
    throw std::invalid_argument("eval::fit_planes: trim_sigmas must be finite and >= 0, got " +
                                rangeseg::detail::number_text(trim_sigmas));
  }
  const int width = labels.width(), height = labels.height();
  std::int32_t max_label = -1;
  for (int y = 0; y < height; ++y) {
    const std::int32_t* row = labels.row(y);
    for (int x = 0; x < width; ++x) max_label = std::max(max_label, row[x]);
  }
  constexpr std::int32_t kMaxSupportedLabel = (1 << 24) - 1;
  if (max_label > kMaxSupportedLabel) {
    throw std::invalid_argument(
        "eval::fit_planes: label " + std::to_string(max_label) + " exceeds the supported maximum " +
        std::to_string(kMaxSupportedLabel) + " (the result is indexed by label)");
  }
  std::vector<std::optional<PlaneParams>> planes;
  if (max_label < min_label) return planes;
  planes.resize(static_cast<std::size_t>(max_label) + 1);
  const std::size_t label_count = static_cast<std::size_t>(max_label - min_label) + 1;

  // The points that enter the fit: labelled and valid (and, robust, near their label's plane).
  std::vector<FitPoint> points;
  for (int y = 0; y < height; ++y) {
    const std::int32_t* l_row = labels.row(y);
    const float* px = cloud.x.row(y);
    const float* py = cloud.y.row(y);
    const float* pz = cloud.z.row(y);
    for (int x = 0; x < width; ++x) {
      if (l_row[x] < min_label) continue;
      if (!std::isfinite(px[x]) || !std::isfinite(py[x]) || !std::isfinite(pz[x])) continue;
      points.push_back({static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                            static_cast<std::size_t>(x),
                        static_cast<std::size_t>(l_row[x] - min_label),
                        {px[x], py[x], pz[x]}});
    }
  }
  // A robust fit starts from each label's largest 4-connected part: a stray pixel far from its
  // region would otherwise pull the first plane through itself (a thin strip's plane turns about
  // the strip's axis), and then it lies near that plane.
  std::vector<std::uint8_t> kept(points.size(), 1);
  if (trim_sigmas > 0.0) keep_largest_parts(width, height, label_count, points, kept);
  std::vector<Moments> moments;
  const auto fit_kept = [&] {
    moments.assign(label_count, Moments{});
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (kept[i] != 0) moments[points[i].slot].add(points[i].p[0], points[i].p[1], points[i].p[2]);
    }
    for (std::size_t k = 0; k < label_count; ++k) {
      planes[k + static_cast<std::size_t>(min_label)] = moments[k].fit();
    }
  };
  fit_kept();
  if (trim_sigmas == 0.0) return planes;

  // Robust refits: the distances of every point of a label to its plane, grouped by label
  // (counting sort), give each label's median distance and so its bound.
  std::vector<double> distance(points.size(), 0.0);
  std::vector<std::size_t> first(label_count + 1, 0);
  for (const FitPoint& q : points) ++first[q.slot + 1];
  for (std::size_t k = 0; k < label_count; ++k) first[k + 1] += first[k];
  std::vector<std::size_t> fill(label_count);
  std::vector<double> grouped(points.size());
  std::vector<double> bound(label_count, 0.0);
  for (int round = 0; round < kMaxTrimRounds; ++round) {
    std::copy(first.begin(), first.end() - 1, fill.begin());
    for (std::size_t i = 0; i < points.size(); ++i) {
      const FitPoint& q = points[i];
      const std::optional<PlaneParams>& plane =
          planes[q.slot + static_cast<std::size_t>(min_label)];
      distance[i] = plane ? std::fabs(plane->normal[0] * q.p[0] + plane->normal[1] * q.p[1] +
                                      plane->normal[2] * q.p[2] + plane->offset)
                          : 0.0;
      grouped[fill[q.slot]++] = distance[i];
    }
    for (std::size_t k = 0; k < label_count; ++k) {
      const auto begin = grouped.begin() + static_cast<std::ptrdiff_t>(first[k]);
      const auto end = grouped.begin() + static_cast<std::ptrdiff_t>(first[k + 1]);
      if (begin == end) continue;
      const auto middle = begin + (end - begin) / 2;
      std::nth_element(begin, middle, end);
      bound[k] = std::max(kMinTrimDistance, trim_sigmas * 1.4826 * *middle);
    }
    bool changed = false;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const auto keep = static_cast<std::uint8_t>(distance[i] <= bound[points[i].slot]);
      changed = changed || keep != kept[i];
      kept[i] = keep;
    }
    if (!changed) break;
    fit_kept();
  }
  return planes;
}

// ---------------------------------------------------------------------------------------------

namespace {

const PlaneParams* plane_for(const std::vector<std::optional<PlaneParams>>& planes, int label) {
  if (label < 0 || static_cast<std::size_t>(label) >= planes.size()) return nullptr;
  const auto& p = planes[static_cast<std::size_t>(label)];
  return p ? &*p : nullptr;
}

/// Unit normal facing the sensor origin (offset >= 0).
std::array<double, 3> oriented_normal(const PlaneParams& plane, const char* which, int label) {
  const auto& n = plane.normal;
  const double length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  if (!(length > 0.0) || !std::isfinite(length) || !std::isfinite(plane.offset)) {
    throw std::invalid_argument(
        std::string("eval::angle_error: ") + which + " plane of label " + std::to_string(label) +
        " has normal (" + rangeseg::detail::number_text(n[0]) + ", " +
        rangeseg::detail::number_text(n[1]) + ", " + rangeseg::detail::number_text(n[2]) +
        ") and offset " + rangeseg::detail::number_text(plane.offset));
  }
  const double s = (plane.offset < 0.0 ? -1.0 : 1.0) / length;
  return {n[0] * s, n[1] * s, n[2] * s};
}

double angle_deg(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  const double c = std::clamp(a[0] * b[0] + a[1] * b[1] + a[2] * b[2], -1.0, 1.0);
  return std::acos(c) * 180.0 / std::numbers::pi;
}

}  // namespace

AngleStats angle_error(const EvalResult& result, const LabelImage& ground_truth,
                       const std::vector<std::optional<PlaneParams>>& gt_planes_by_label,
                       const std::vector<std::optional<PlaneParams>>& ms_planes_by_label,
                       const AngleSettings& settings) {
  if (ground_truth.width() != result.width || ground_truth.height() != result.height) {
    throw std::invalid_argument("eval::angle_error: ground truth is " +
                                size_string(ground_truth.width(), ground_truth.height()) +
                                " but the evaluation result is for " +
                                size_string(result.width, result.height));
  }
  if (settings.max_gap < 0) {
    throw std::invalid_argument("eval::angle_error: max_gap must be >= 0, got " +
                                std::to_string(settings.max_gap));
  }
  const std::int32_t min_gt = result.settings.min_gt_label;
  const int width = ground_truth.width(), height = ground_truth.height();
  const int max_step = settings.max_gap + 1;

  // Adjacent GT label pairs (a < b). Between the previous region pixel of a row / column and the
  // current one there are only excluded pixels, so the gap is the distance minus one.
  std::unordered_set<std::uint64_t> adjacent;
  std::uint64_t last_inserted = 0;
  bool inserted_any = false;
  const auto add_pair = [&](std::int32_t a, std::int32_t b) {
    const std::uint64_t key = pair_key(std::min(a, b), std::max(a, b));
    if (inserted_any && key == last_inserted) return;
    adjacent.insert(key);
    last_inserted = key;
    inserted_any = true;
  };
  std::vector<std::int32_t> column_label(static_cast<std::size_t>(width), 0);
  std::vector<int> column_y(static_cast<std::size_t>(width), -1);  // -1: no region pixel yet
  for (int y = 0; y < height; ++y) {
    const std::int32_t* row = ground_truth.row(y);
    std::int32_t row_label = 0;
    int row_x = -1;
    for (int x = 0; x < width; ++x) {
      const std::int32_t g = row[x];
      if (g < min_gt) continue;
      if (row_x >= 0 && row_label != g && x - row_x <= max_step) add_pair(row_label, g);
      row_label = g;
      row_x = x;
      if (column_y[x] >= 0 && column_label[x] != g && y - column_y[x] <= max_step) {
        add_pair(column_label[x], g);
      }
      column_label[x] = g;
      column_y[x] = y;
    }
  }
  std::vector<std::uint64_t> pairs(adjacent.begin(), adjacent.end());
  std::sort(pairs.begin(), pairs.end());

  const auto ms_partner = [&](std::int32_t gt_label) -> std::optional<int> {
    auto it = std::lower_bound(result.correct_pairs.begin(), result.correct_pairs.end(),
                               std::pair<int, int>{gt_label, std::numeric_limits<int>::min()});
    if (it != result.correct_pairs.end() && it->first == gt_label) return it->second;
    return std::nullopt;
  };

  AngleStats stats;
  double sum = 0.0, sum_sq = 0.0;
  for (std::uint64_t key : pairs) {
    const std::int32_t a = key_first(key), b = key_second(key);
    const std::optional<int> ma = ms_partner(a), mb = ms_partner(b);
    if (!ma || !mb) continue;
    const PlaneParams* ga = plane_for(gt_planes_by_label, a);
    const PlaneParams* gb = plane_for(gt_planes_by_label, b);
    const PlaneParams* pa = plane_for(ms_planes_by_label, *ma);
    const PlaneParams* pb = plane_for(ms_planes_by_label, *mb);
    if (!ga || !gb || !pa || !pb) {
      ++stats.skipped;
      continue;
    }
    const double gt_angle =
        angle_deg(oriented_normal(*ga, "ground-truth", a), oriented_normal(*gb, "ground-truth", b));
    const double ms_angle =
        angle_deg(oriented_normal(*pa, "machine", *ma), oriented_normal(*pb, "machine", *mb));
    const double diff = std::abs(gt_angle - ms_angle);
    sum += diff;
    sum_sq += diff * diff;
    ++stats.pairs;
  }
  if (stats.pairs > 0) {
    stats.mean_deg = sum / stats.pairs;
    stats.std_deg =
        std::sqrt(std::max(0.0, sum_sq / stats.pairs - stats.mean_deg * stats.mean_deg));
  }
  return stats;
}

// ---------------------------------------------------------------------------------------------

EvalSummary summarize(const std::vector<EvalResult>& results,
                      const std::vector<AngleStats>& angles) {
  if (!angles.empty() && angles.size() != results.size()) {
    throw std::invalid_argument("eval::summarize: " + std::to_string(results.size()) +
                                " results but " + std::to_string(angles.size()) +
                                " angle statistics (expected 0 or one per result)");
  }
  EvalSummary summary;
  summary.images = static_cast<int>(results.size());
  if (!results.empty()) {
    double gt = 0, correct = 0, over = 0, under = 0, missed = 0, noise = 0;
    for (const EvalResult& r : results) {
      gt += r.gt_regions;
      correct += r.correct;
      over += r.over;
      under += r.under;
      missed += r.missed;
      noise += r.noise;
    }
    const double n = static_cast<double>(results.size());
    summary.mean_gt = gt / n;
    summary.mean_correct = correct / n;
    summary.mean_over = over / n;
    summary.mean_under = under / n;
    summary.mean_missed = missed / n;
    summary.mean_noise = noise / n;
  }
  double sum = 0.0, sum_sq = 0.0;
  for (const AngleStats& a : angles) {
    if (a.pairs <= 0) continue;
    summary.angle_pairs += a.pairs;
    sum += a.pairs * a.mean_deg;
    sum_sq += a.pairs * (a.std_deg * a.std_deg + a.mean_deg * a.mean_deg);
  }
  if (summary.angle_pairs > 0) {
    summary.mean_angle_deg = sum / summary.angle_pairs;
    summary.std_angle_deg = std::sqrt(std::max(
        0.0, sum_sq / summary.angle_pairs - summary.mean_angle_deg * summary.mean_angle_deg));
  }
  return summary;
}

}  // namespace rangeseg::eval
