#include "rangeseg/tracking.hpp"
#include "detail/number_text.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace rangeseg {
namespace {

constexpr std::uint64_t kEmpty = 0;  // labels are >= 1, so no pair has key 0

std::uint64_t pair_key(std::int32_t previous, std::int32_t current) {
  return static_cast<std::uint64_t>(previous) << 32 | static_cast<std::uint32_t>(current);
}

std::size_t slot_of(std::uint64_t key, std::size_t mask) {
  return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ULL) >> 32) & mask;
}

/// Sets bit u (of word u / 64) of `bits` where a run starts: u == 0, or a[u] != a[u - 1], or
/// (when b is given) b[u] != b[u - 1]; n >= 1, `bits` holds (n + 63) / 64 words. Labels come in
/// runs of ~20-100 pixels: finding their ends four at a time, then bit by bit, spares the
/// branch a pixel-by-pixel scan mispredicts at the end of every run.
void mark_run_starts(const std::int32_t* a, const std::int32_t* b, int n, std::uint64_t* bits) {
  std::fill(bits, bits + (n + 63) / 64, 0);
  bits[0] = 1;
  int u = 1;
#if defined(__SSE2__)
  const auto load = [](const std::int32_t* p) {
    return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p));
  };
  for (; u + 4 <= n; u += 4) {
    __m128i same = _mm_cmpeq_epi32(load(a + u), load(a + u - 1));
    if (b != nullptr) same = _mm_and_si128(same, _mm_cmpeq_epi32(load(b + u), load(b + u - 1)));
    const auto starts = static_cast<std::uint64_t>(_mm_movemask_ps(_mm_castsi128_ps(same)) ^ 15);
    bits[u / 64] |= starts << (u % 64);
    if (u % 64 > 60) bits[u / 64 + 1] |= starts >> (64 - u % 64);
  }
#endif
  for (; u < n; ++u) {
    const bool start = a[u] != a[u - 1] || (b != nullptr && b[u] != b[u - 1]);
    bits[u / 64] |= static_cast<std::uint64_t>(start) << (u % 64);
  }
}

/// Calls run(begin, end) for each run that mark_run_starts marked in `bits`, in order.
template <class Run>
void for_each_run(const std::uint64_t* bits, int n, Run&& run) {
  int begin = 0;
  for (int w = 0; w < (n + 63) / 64; ++w) {
    for (std::uint64_t m = bits[w]; m != 0; m &= m - 1) {
      const int u = w * 64 + std::countr_zero(m);
      if (u > 0) run(begin, u);
      begin = u;
    }
  }
  run(begin, n);
}

[[noreturn]] void bad_label(std::int32_t label, int u, int v, int segments) {
  throw std::invalid_argument("SegmentTracker::update: label " + std::to_string(label) +
                              " at pixel (" + std::to_string(u) + ", " + std::to_string(v) +
                              ") is outside [0, " + std::to_string(segments) + "]");
}

}  // namespace

void validate(const TrackingSettings& settings) {
  if (!(settings.min_overlap > 0 && settings.min_overlap <= 1)) {
    throw std::invalid_argument("TrackingSettings::min_overlap must be in (0, 1], got " +
                                rangeseg::detail::number_text(settings.min_overlap));
  }
  if (!(settings.max_normal_angle >= 0 && settings.max_normal_angle <= std::numbers::pi)) {
    throw std::invalid_argument("TrackingSettings::max_normal_angle must be in [0, pi] rad, got " +
                                rangeseg::detail::number_text(settings.max_normal_angle));
  }
  if (!(settings.max_distance >= 0 && std::isfinite(settings.max_distance))) {
    throw std::invalid_argument("TrackingSettings::max_distance must be finite and >= 0 m, got " +
                                rangeseg::detail::number_text(settings.max_distance));
  }
}

SegmentTracker::SegmentTracker(const TrackingSettings& settings)
    : settings_(settings), min_cos_(std::cos(settings.max_normal_angle)) {
  validate(settings_);
}

void SegmentTracker::reset() {
  previous_labels_.resize(0, 0);
  previous_.clear();
}

void SegmentTracker::add_shared(std::uint64_t key, std::uint32_t count) {
  std::size_t mask = keys_.size() - 1;
  for (std::size_t s = slot_of(key, mask);; s = (s + 1) & mask) {
    if (keys_[s] == key) {
      counts_[s] += count;
      return;
    }
    if (keys_[s] != kEmpty) continue;
    keys_[s] = key;
    counts_[s] = count;
    if (2 * ++pairs_ <= keys_.size()) return;
    // More than half full: twice the size (allocates only for more pairs than ever before).
    std::vector<std::uint64_t> keys(2 * keys_.size(), kEmpty);
    std::vector<std::uint32_t> counts(keys.size(), 0);
    mask = keys.size() - 1;
    for (std::size_t i = 0; i < keys_.size(); ++i) {
      if (keys_[i] == kEmpty) continue;
      std::size_t t = slot_of(keys_[i], mask);
      while (keys[t] != kEmpty) t = (t + 1) & mask;
      keys[t] = keys_[i];
      counts[t] = counts_[i];
    }
    keys_.swap(keys);
    counts_.swap(counts);
    return;
  }
}

void SegmentTracker::measure_footprints(const LabelImage& labels, int segments, bool count) {
  footprints_.assign(static_cast<std::size_t>(segments) + 1, Footprint{});
  if (count) clear_shared();
  const int width = labels.width();
  if (width == 0) return;
  run_bits_.resize(static_cast<std::size_t>(width + 63) / 64);
  for (int v = 0; v < labels.height(); ++v) {
    const std::int32_t* current = labels.row(v);
    const std::int32_t* previous = count ? previous_labels_.row(v) : nullptr;
    // Runs of one pair (current, previous): each goes to its footprint and the table at once.
    mark_run_starts(current, previous, width, run_bits_.data());
    for_each_run(run_bits_.data(), width, [&](int begin, int end) {
      const std::int32_t c = current[begin];
      if (c < 0 || c > segments) bad_label(c, begin, v, segments);
      if (c == 0) return;
      Footprint& f = footprints_[static_cast<std::size_t>(c)];
      const int n = end - begin;
      if (f.pixels == 0) f = {0, 0, 0, begin, end - 1, v, v};
      f.sum_u += 0.5 * (begin + end - 1) * n;
      f.sum_v += static_cast<double>(v) * n;
      f.pixels += n;
      f.min_u = std::min(f.min_u, begin);
      f.max_u = std::max(f.max_u, end - 1);
      f.max_v = v;
      if (count && previous[begin] != 0) {
        add_shared(pair_key(previous[begin], c), static_cast<std::uint32_t>(n));
      }
    });
  }
}

void SegmentTracker::clear_shared() {
  if (keys_.empty()) {
    keys_.assign(1024, kEmpty);
    counts_.assign(keys_.size(), 0);
  } else {
    std::fill(keys_.begin(), keys_.end(), kEmpty);
  }
  pairs_ = 0;
}

void SegmentTracker::count_shared_pixels(const LabelImage& labels, int du, int dv) {
  clear_shared();
  // Pixel (u, v) now against pixel (u - du, v - dv) of the frame before.
  const int u0 = std::max(0, du), u1 = std::min(labels.width(), labels.width() + du);
  const int n = u1 - u0;
  // Only the rows of the open segments: most of a frame's segments found their tracks in the
  // first count (the PrimeSense frames: 30 of 34-36).
  open_rows_.assign(static_cast<std::size_t>(labels.height()), 0);
  for (std::size_t c = 1; c < open_.size(); ++c) {
    const Footprint& f = footprints_[c];
    if (open_[c] == 0 || f.pixels == 0) continue;
    std::fill(open_rows_.begin() + f.min_v, open_rows_.begin() + f.max_v + 1, 1);
  }
  for (int v = std::max(0, dv); v < std::min(labels.height(), labels.height() + dv); ++v) {
    if (open_rows_[static_cast<std::size_t>(v)] == 0) continue;
    const std::int32_t* current = labels.row(v) + u0;
    const std::int32_t* previous = previous_labels_.row(v - dv) - du + u0;
    mark_run_starts(current, previous, n, run_bits_.data());
    for_each_run(run_bits_.data(), n, [&](int begin, int end) {
      const std::int32_t c = current[begin], p = previous[begin];
      if (c == 0 || p == 0 || open_[static_cast<std::size_t>(c)] == 0) return;
      add_shared(pair_key(p, c), static_cast<std::uint32_t>(end - begin));
    });
  }
}

bool SegmentTracker::may_continue(const Track& before, const Segment& now) const {
  if (before.plane != is_plane(now)) return false;
  const auto dot = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  };
  if (before.plane && dot(before.normal, now.normal) < min_cos_) return false;
  // Near the previous plane, or at its distance from the camera: a camera turning in place
  // moves the centroid off the previous plane (a wall 3 m away, a turn of 4 deg: 0.2 m) but
  // keeps the distance, while a fitted normal a few degrees off changes the distance (|c| times
  // the angle) and keeps the centroid near the plane. (A fit's normal may point either way:
  // its distance is |offset|.)
  const double off_plane = std::abs(dot(before.normal, now.centroid) + before.offset);
  const double nearer = std::abs(std::abs(now.offset) - std::abs(before.offset));
  return std::min(off_plane, nearer) <= settings_.max_distance;
}

void SegmentTracker::add_candidates(const Segmentation& segmentation) {
  for (std::size_t s = 0; s < keys_.size(); ++s) {
    if (keys_[s] == kEmpty) continue;
    const auto p = static_cast<std::int32_t>(keys_[s] >> 32);
    const auto c = static_cast<std::int32_t>(keys_[s] & 0xffffffffU);
    const Track& before = previous_[static_cast<std::size_t>(p - 1)];
    const Segment& now = segmentation.segments[static_cast<std::size_t>(c - 1)];
    if (static_cast<double>(counts_[s]) <
            settings_.min_overlap * std::min(before.pixels, now.pixel_count) ||
        !may_continue(before, now)) {
      continue;
    }
    candidates_.push_back({counts_[s], p, c});
  }
}

std::array<int, 2> SegmentTracker::image_motion(const Segmentation& segmentation, int width,
                                                int height) {
  // The shift of the image between the frames, voted for by the pairs of segments, one of each
  // frame, that may be one surface (may_continue, sizes within a factor 2), whether or not they
  // share pixels: a camera turning by a few degrees moves small segments by more than their
  // width (4 deg: 37 px at 525 px focal length). Each pair proposes the shift of its centroids,
  // weighted by the smaller segment's pixels; the shift is that of the proposals within kNear
  // pixels of the best supported one (weighted medians), when there are two or more. Segments that
  // touch the image's border are left out: cut by it, they move less than the image.
  constexpr double kNear = 3;          // [pixels]
  constexpr std::size_t kVoters = 96;  // the heaviest proposals (a frame has tens of segments)
  const auto inside = [&](const Footprint& f) {
    return f.pixels > 0 && f.min_u > 0 && f.min_v > 0 && f.max_u < width - 1 &&
           f.max_v < height - 1;
  };
  motions_.clear();
  for (std::size_t p = 0; p < previous_.size(); ++p) {
    const Track& before = previous_[p];
    if (!inside(before.footprint)) continue;
    for (std::size_t c = 0; c < segmentation.segments.size(); ++c) {
      const Footprint& now = footprints_[c + 1];
      if (!inside(now) ||
          2 * std::min(before.pixels, now.pixels) < std::max(before.pixels, now.pixels)) {
        continue;
      }
      if (!may_continue(before, segmentation.segments[c])) continue;
      const Footprint& was = before.footprint;
      motions_.push_back({now.sum_u / now.pixels - was.sum_u / was.pixels,
                          now.sum_v / now.pixels - was.sum_v / was.pixels,
                          static_cast<double>(std::min(before.pixels, now.pixels))});
    }
  }
  if (motions_.empty()) return {0, 0};
  const auto heavier = [](const auto& x, const auto& y) { return x[2] > y[2]; };
  if (motions_.size() > kVoters) {
    std::nth_element(motions_.begin(), motions_.begin() + kVoters, motions_.end(), heavier);
    motions_.resize(kVoters);
  }
  const auto near = [&](const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return std::abs(a[0] - b[0]) <= kNear && std::abs(a[1] - b[1]) <= kNear;
  };
  std::size_t best = 0;
  double best_support = -1;
  for (std::size_t i = 0; i < motions_.size(); ++i) {
    double support = 0;
    for (const auto& m : motions_) support += near(motions_[i], m) ? m[2] : 0;
    if (support > best_support) {
      best_support = support;
      best = i;
    }
  }
  const std::array<double, 3> centre = motions_[best];
  const auto last = std::partition(motions_.begin(), motions_.end(),
                                   [&](const auto& m) { return near(centre, m); });
  // One pair alone is a segment that moved, not the image: it would vote for its own track.
  if (last - motions_.begin() < 2) return {0, 0};
  std::array<int, 2> shift{0, 0};
  for (std::size_t axis = 0; axis < 2; ++axis) {
    std::sort(motions_.begin(), last,
              [axis](const auto& x, const auto& y) { return x[axis] < y[axis]; });
    double total = 0, below = 0;
    for (auto m = motions_.begin(); m != last; ++m) total += (*m)[2];
    for (auto m = motions_.begin(); m != last; ++m) {
      below += (*m)[2];
      if (2 * below < total) continue;
      shift[axis] = static_cast<int>(std::lround((*m)[axis]));
      break;
    }
  }
  return shift;
}

void SegmentTracker::update(Segmentation& segmentation) {
  std::vector<Segment>& segments = segmentation.segments;
  const int n = static_cast<int>(segments.size());
  for (int i = 0; i < n; ++i) {
    if (segments[static_cast<std::size_t>(i)].label != i + 1) {
      throw std::invalid_argument("SegmentTracker::update: segments[" + std::to_string(i) +
                                  "].label is " +
                                  std::to_string(segments[static_cast<std::size_t>(i)].label) +
                                  ", expected " + std::to_string(i + 1));
    }
  }
  const LabelImage& labels = segmentation.labels;
  // A frame without segments (a dropped or blank sensor frame) leaves the tracks as they were:
  // the next frame continues the one before it. Its labels must all be 0 still.
  if (n == 0) {
    for (int v = 0; v < labels.height(); ++v) {
      const std::int32_t* row = labels.row(v);
      const std::int32_t* const label =
          std::find_if(row, row + labels.width(), [](std::int32_t l) { return l != 0; });
      if (label != row + labels.width()) bad_label(*label, static_cast<int>(label - row), v, 0);
    }
    return;
  }
  const bool same_size = !previous_.empty() && previous_labels_.width() == labels.width() &&
                         previous_labels_.height() == labels.height();
  measure_footprints(labels, n, same_size);

  // The pairs that may continue a track: first pixel by pixel, then with the image's shift
  // between the frames undone, so that a small segment moving by more than its own width
  // still finds its track. Most shared pixels first.
  candidates_.clear();
  if (same_size) {
    add_candidates(segmentation);  // measure_footprints counted the shared pixels
    // The second count is for the segments without a candidate yet.
    open_.assign(segments.size() + 1, 1);
    for (const Pair& pair : candidates_) open_[static_cast<std::size_t>(pair.current)] = 0;
    const auto [du, dv] = image_motion(segmentation, labels.width(), labels.height());
    // A shift of one pixel, which noise in the centroids gives too, changes little.
    if (std::max(std::abs(du), std::abs(dv)) >= 2 && std::abs(du) < labels.width() &&
        std::abs(dv) < labels.height()) {
      count_shared_pixels(labels, du, dv);
      add_candidates(segmentation);
    }
  }
  std::sort(candidates_.begin(), candidates_.end(), [](const Pair& a, const Pair& b) {
    if (a.shared != b.shared) return a.shared > b.shared;
    return a.previous != b.previous ? a.previous < b.previous : a.current < b.current;
  });

  for (Segment& s : segments) s.track_id = 0;
  taken_.assign(previous_.size(), 0);
  for (const Pair& pair : candidates_) {
    Segment& now = segments[static_cast<std::size_t>(pair.current - 1)];
    std::uint8_t& taken = taken_[static_cast<std::size_t>(pair.previous - 1)];
    if (taken != 0 || now.track_id != 0) continue;
    taken = 1;
    now.track_id = previous_[static_cast<std::size_t>(pair.previous - 1)].id;
  }
  for (Segment& s : segments) {
    if (s.track_id == 0) s.track_id = next_id_++;
  }

  // This frame is the next one's previous frame.
  if (previous_labels_.width() != labels.width() || previous_labels_.height() != labels.height()) {
    previous_labels_.resize(labels.width(), labels.height());
  }
  for (int v = 0; v < labels.height(); ++v) {
    std::copy_n(labels.row(v), labels.width(), previous_labels_.row(v));
  }
  previous_.resize(segments.size());
  for (std::size_t i = 0; i < segments.size(); ++i) {
    const Segment& s = segments[i];
    previous_[i] = {s.track_id, s.pixel_count, is_plane(s), s.normal, s.offset, footprints_[i + 1]};
  }
}

}  // namespace rangeseg
