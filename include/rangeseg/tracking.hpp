// Segment ids that persist from frame to frame of a depth stream.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "rangeseg/image.hpp"
#include "rangeseg/segmentation.hpp"

namespace rangeseg {

/// Settings of SegmentTracker. The defaults suit a hand-held or robot-mounted camera at 15-30
/// frames per second.
struct TrackingSettings {
  /// A segment continues one of the frame before only if at least this fraction of the smaller
  /// of the two lies on the pixels of both (0..1], default 0.5: between two frames a segment may
  /// move by up to half of its own extent across the image.
  double min_overlap = 0.5;
  /// ... and, when both are planes, only if their normals are at most this far apart [rad],
  /// default 0.35 (20 deg): far more than a frame's turn of a camera whose segments still
  /// overlap (min_overlap; a few degrees per frame), while the table and a box top beside it at
  /// the same place in the image stay apart from a wall.
  double max_normal_angle = 0.35;
  /// ... and only if the segment's centroid lies at most this far from the plane fitted to the
  /// previous one, or the distances of the two fitted planes from the camera differ by at most
  /// this [m], default 0.1: a camera moving at up to 3 m/s at 30 Hz (turning in place moves a
  /// far centroid off the previous plane, but changes no such distance), while a board put up
  /// before a wall, or a new scene after a cut, starts its own track.
  double max_distance = 0.1;
};

/// Throws std::invalid_argument naming the field and its value unless 0 < min_overlap <= 1,
/// 0 <= max_normal_angle <= pi and max_distance >= 0 (finite).
void validate(const TrackingSettings& settings);

/// Gives the segments of consecutive frames ids that stay the same while a surface stays in
/// view (Segment::track_id), so that a consumer of a stream sees the table as track 1 frame
/// after frame although its label (1..N by size) may change. Matching is by shared pixels, so
/// the frames must come from one camera, in order. It keeps the previous frame's labels; after
/// the first frame of a given size it allocates nothing (unless a frame has more pairs of
/// overlapping segments than any before). Not thread-safe.
class SegmentTracker {
 public:
  /// Throws std::invalid_argument for invalid settings (`validate`).
  explicit SegmentTracker(const TrackingSettings& settings = {});

  /// Sets Segment::track_id of every segment of `segmentation` to the id of the segment of the
  /// previous frame that it continues, or to a new id (ids count up from 1 and are never given
  /// twice). A segment continues a previous one when both are planes or both are not (a
  /// curved surface may be fitted as a cylinder in one frame and a sphere in the next), the
  /// normals of two planes are within `max_normal_angle`, its centroid is within
  /// `max_distance` of the previous one's fitted plane or their fitted planes' distances from
  /// the camera differ by at most that, and they share at least `min_overlap`
  /// of the smaller one's pixels (counted once as they lie, and once more for segments
  /// without a match with the image's shift between the frames undone). A track continues in one
  /// segment at most: of the pairs that qualify, those sharing the most pixels are taken first, so
  /// a segment split in two goes on in its larger part, and of two merged the one sharing more
  /// pixels goes on. A frame of another size than the previous one (or the first) starts new
  /// tracks; a frame without segments (a dropped or blank sensor frame) changes nothing, so the
  /// next frame continues the one before it. Throws std::invalid_argument when a label lies
  /// outside [0, segments.size()] or segments[i].label is not i + 1; the tracker is then as
  /// before the call.
  void update(Segmentation& segmentation);

  /// Forgets the previous frame: the next `update` starts new tracks (with new ids).
  void reset();

  const TrackingSettings& settings() const { return settings_; }

 private:
  /// Where a segment lies in the image [pixels].
  struct Footprint {
    double sum_u = 0, sum_v = 0;
    int pixels = 0;
    int min_u = 0, max_u = 0, min_v = 0, max_v = 0;
  };
  struct Track {
    std::uint32_t id = 0;
    int pixels = 0;
    bool plane = false;
    std::array<double, 3> normal{};  ///< of the fitted plane (every segment has one)
    double offset = 0;
    Footprint footprint;
  };
  struct Pair {
    std::uint32_t shared = 0;
    std::int32_t previous = 0, current = 0;  ///< labels
  };

  /// Checks the labels; with `count` also counts the pixels shared with the previous frame.
  void measure_footprints(const LabelImage& labels, int segments, bool count);
  void clear_shared();
  /// Counts for the labels of the current frame that are `open_` only.
  void count_shared_pixels(const LabelImage& labels, int du, int dv);
  void add_shared(std::uint64_t key, std::uint32_t count);
  /// Whether `now` may continue `before` by their kinds and planes (not by their pixels).
  bool may_continue(const Track& before, const Segment& now) const;
  void add_candidates(const Segmentation& segmentation);
  std::array<int, 2> image_motion(const Segmentation& segmentation, int width, int height);

  TrackingSettings settings_;
  double min_cos_;  ///< cos(settings_.max_normal_angle)
  LabelImage previous_labels_;
  std::vector<Track> previous_;  ///< per label - 1 of previous_labels_
  /// Open-addressing table of (previous << 32 | current) -> shared pixels; key 0 = empty.
  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> counts_;
  std::size_t pairs_ = 0;
  std::vector<Footprint> footprints_;    ///< per label of the current frame (0 unused)
  std::vector<std::uint64_t> run_bits_;  ///< a row's run starts
  std::vector<Pair> candidates_;
  std::vector<std::array<double, 3>> motions_;  ///< du, dv and weight of a pair's proposal
  std::vector<std::uint8_t> taken_;             ///< per previous label - 1: its track continues
  std::vector<std::uint8_t> open_;              ///< per current label: no candidate pair yet
  std::vector<std::uint8_t> open_rows_;         ///< per row: an open segment lies on it
  std::uint32_t next_id_ = 1;
};

}  // namespace rangeseg
