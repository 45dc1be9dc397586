// Segment tracks across frames: hand-made label images for each rule, and rendered scenes whose
// surfaces are known.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <set>
#include <stdexcept>
#include <vector>

#include "rangeseg/pipeline.hpp"
#include "rangeseg/synth.hpp"
#include "rangeseg/tracking.hpp"

using namespace rangeseg;

namespace {

struct Rect {
  int u0, v0, u1, v1;  ///< [u0, u1) x [v0, v1)
};

/// A 64 x 48 segmentation with one segment per rectangle (later ones drawn over earlier ones),
/// all planes facing the camera unless `normals` says otherwise.
Segmentation frame(const std::vector<Rect>& rects,
                   const std::vector<std::array<double, 3>>& normals = {}) {
  Segmentation s;
  s.labels.resize(64, 48, 0);
  for (std::size_t i = 0; i < rects.size(); ++i) {
    for (int v = rects[i].v0; v < rects[i].v1; ++v) {
      for (int u = rects[i].u0; u < rects[i].u1; ++u) s.labels(u, v) = static_cast<int>(i) + 1;
    }
  }
  s.segments.resize(rects.size());
  for (std::size_t i = 0; i < rects.size(); ++i) {
    Segment& seg = s.segments[i];
    seg.label = static_cast<int>(i) + 1;
    seg.normal = i < normals.size() ? normals[i] : std::array<double, 3>{0, 0, -1};
  }
  for (int v = 0; v < 48; ++v) {
    for (int u = 0; u < 64; ++u) {
      const int label = s.labels(u, v);
      if (label > 0) ++s.segments[static_cast<std::size_t>(label - 1)].pixel_count;
    }
  }
  return s;
}

std::vector<std::uint32_t> ids(const Segmentation& s) {
  std::vector<std::uint32_t> out;
  for (const Segment& seg : s.segments) out.push_back(seg.track_id);
  return out;
}

std::array<double, 3> tilted(double angle) { return {0, std::sin(angle), -std::cos(angle)}; }

}  // namespace

TEST(Tracking, TheFirstFrameGetsNewIdsAndTheSameFrameKeepsThem) {
  SegmentTracker tracker;
  Segmentation a = frame({{0, 0, 32, 48}, {32, 0, 64, 24}, {32, 24, 64, 48}});
  tracker.update(a);
  EXPECT_EQ(ids(a), (std::vector<std::uint32_t>{1, 2, 3}));
  Segmentation b = a;
  tracker.update(b);
  EXPECT_EQ(ids(b), ids(a));
}

TEST(Tracking, IdsFollowTheSurfacesWhenTheLabelsChangeOrder) {
  SegmentTracker tracker;
  Segmentation a = frame({{0, 0, 32, 48}, {32, 0, 64, 24}, {32, 24, 64, 48}});
  tracker.update(a);
  // The same regions, labelled in another order and moved by 3 pixels.
  Segmentation b = frame({{35, 24, 64, 48}, {3, 0, 35, 48}, {35, 0, 64, 24}});
  tracker.update(b);
  EXPECT_EQ(ids(b), (std::vector<std::uint32_t>{3, 1, 2}));
}

TEST(Tracking, ASegmentThatMovedMoreThanTheOverlapAllowsStartsANewTrack) {
  for (const auto& [shift, continues] : std::vector<std::pair<int, bool>>{{9, true}, {11, false}}) {
    SegmentTracker tracker({.min_overlap = 0.5});
    Segmentation a = frame({{10, 10, 30, 30}});  // 20 px wide
    tracker.update(a);
    Segmentation b = frame({{10 + shift, 10, 30 + shift, 30}});
    tracker.update(b);
    EXPECT_EQ(b.segments[0].track_id == a.segments[0].track_id, continues) << "shift " << shift;
  }
}

// A thin segment moving by more than its own width with the rest of the image finds its track
// once the image's shift, read off the large segment, is undone.
TEST(Tracking, AThinSegmentMovingWithTheImageKeepsItsTrack) {
  SegmentTracker tracker;
  Segmentation a = frame({{10, 10, 40, 40}, {50, 10, 53, 40}});
  tracker.update(a);
  Segmentation b = frame({{15, 8, 45, 38}, {55, 8, 58, 38}});  // 5 px right, 2 px up
  tracker.update(b);
  EXPECT_EQ(ids(b), ids(a));
  // A thin segment that moved against the image is a new one.
  Segmentation c = frame({{20, 8, 50, 38}, {52, 8, 55, 38}});
  tracker.update(c);
  EXPECT_EQ(c.segments[0].track_id, a.segments[0].track_id);
  EXPECT_NE(c.segments[1].track_id, a.segments[1].track_id);
}

TEST(Tracking, ASplitGoesOnInItsLargerPartAndAMergeInThePartSharingMore) {
  SegmentTracker tracker;
  Segmentation whole = frame({{0, 0, 64, 48}});
  tracker.update(whole);
  Segmentation split = frame({{0, 0, 24, 48}, {24, 0, 64, 48}});  // 24 and 40 columns
  tracker.update(split);
  EXPECT_EQ(split.segments[1].track_id, whole.segments[0].track_id);
  EXPECT_NE(split.segments[0].track_id, whole.segments[0].track_id);
  Segmentation merged = frame({{0, 0, 64, 48}});
  tracker.update(merged);
  EXPECT_EQ(merged.segments[0].track_id, split.segments[1].track_id);
}

TEST(Tracking, PlanesTurnedBeyondTheAngleOrSurfacesOfAnotherKindStartNewTracks) {
  SegmentTracker tracker({.max_normal_angle = 0.35});
  Segmentation a = frame({{0, 0, 32, 48}, {32, 0, 64, 48}}, {tilted(0), tilted(0)});
  tracker.update(a);
  Segmentation b = frame({{0, 0, 32, 48}, {32, 0, 64, 48}}, {tilted(0.30), tilted(0.40)});
  tracker.update(b);
  EXPECT_EQ(b.segments[0].track_id, a.segments[0].track_id);
  EXPECT_NE(b.segments[1].track_id, a.segments[1].track_id);

  Segmentation c = b;
  c.segments[0].kind = SurfaceKind::cylinder;
  tracker.update(c);
  EXPECT_NE(c.segments[0].track_id, b.segments[0].track_id);
  // Curved surfaces keep their track whatever their (fitted plane's) normal does, also when
  // the fit takes them for a sphere in one frame and a cylinder in the next.
  Segmentation d = c;
  d.segments[0].normal = tilted(1.2);
  d.segments[0].kind = SurfaceKind::sphere;
  tracker.update(d);
  EXPECT_EQ(d.segments[0].track_id, c.segments[0].track_id);
}

// A board put up before a wall, parallel to it, takes more of the wall's pixels than the wall
// keeps: the wall keeps its track, as the board lies 1.5 m before the wall's plane.
TEST(Tracking, ASurfaceBeforeAnotherOnItsPixelsStartsItsOwnTrack) {
  const auto at_depth = [](Segment& s, double z) {
    s.normal = {0, 0, -1};
    s.offset = z;  // the plane z = offset
    s.centroid = {0, 0, z};
  };
  SegmentTracker tracker({.max_distance = 0.1});
  Segmentation wall = frame({{0, 0, 64, 48}});
  at_depth(wall.segments[0], 3.0);
  tracker.update(wall);
  Segmentation both = frame({{0, 0, 40, 48}, {40, 0, 64, 48}});
  at_depth(both.segments[0], 1.5);  // the board, on 40 of the wall's 64 columns
  at_depth(both.segments[1], 3.05);
  tracker.update(both);
  EXPECT_NE(both.segments[0].track_id, wall.segments[0].track_id);
  EXPECT_EQ(both.segments[1].track_id, wall.segments[0].track_id);
}

TEST(Tracking, IdsAreNeverGivenTwiceAcrossResetsAndSizes) {
  SegmentTracker tracker;
  std::set<std::uint32_t> seen;
  Segmentation a = frame({{0, 0, 32, 48}, {32, 0, 64, 48}});
  tracker.update(a);
  tracker.reset();
  Segmentation b = a;
  tracker.update(b);
  Segmentation small;
  small.labels.resize(8, 8, 1);
  small.segments.resize(1);
  small.segments[0].label = 1;
  small.segments[0].pixel_count = 64;
  tracker.update(small);
  for (const Segmentation* s : {&a, &b, &small}) {
    for (const Segment& seg : s->segments) EXPECT_TRUE(seen.insert(seg.track_id).second);
  }
  EXPECT_EQ(seen.size(), 5U);
}

TEST(Tracking, InvalidLabelsThrowAndLeaveTheTrackerAsItWas) {
  SegmentTracker tracker;
  Segmentation a = frame({{0, 0, 32, 48}, {32, 0, 64, 48}});
  tracker.update(a);
  Segmentation bad = a;
  bad.labels(5, 7) = 3;  // no segment 3
  EXPECT_THROW(tracker.update(bad), std::invalid_argument);
  bad.labels(5, 7) = -1;
  EXPECT_THROW(tracker.update(bad), std::invalid_argument);
  Segmentation misnumbered = a;
  misnumbered.segments[1].label = 1;
  EXPECT_THROW(tracker.update(misnumbered), std::invalid_argument);
  Segmentation b = a;
  tracker.update(b);
  EXPECT_EQ(ids(b), ids(a));
  EXPECT_THROW(SegmentTracker({.min_overlap = 0}), std::invalid_argument);
  EXPECT_THROW(SegmentTracker({.min_overlap = 1.5}), std::invalid_argument);
  EXPECT_THROW(SegmentTracker({.max_normal_angle = -0.1}), std::invalid_argument);
  EXPECT_THROW(SegmentTracker({.max_normal_angle = NAN}), std::invalid_argument);
  EXPECT_THROW(SegmentTracker({.max_distance = -0.1}), std::invalid_argument);
  EXPECT_THROW(SegmentTracker({.max_distance = INFINITY}), std::invalid_argument);
  // The message keeps the value: "%f" would print 1.0000001 as 1.000000, a valid overlap.
  try {
    SegmentTracker({.min_overlap = 1.0000001});
    ADD_FAILURE() << "min_overlap 1.0000001 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("got 1.0000001"), std::string::npos) << e.what();
  }
}

// The runs are found 4 pixels at a time from bit masks of 64-pixel words: every pixel must be
// read wherever it lies (odd widths, runs across words, the scalar tail). A label outside the
// segments at any one pixel must throw, and a segment one pixel wide must continue.
TEST(Tracking, EveryPixelCountsWhateverTheWidth) {
  for (const int width : {1, 3, 5, 61, 64, 65, 66, 130, 203}) {
    Segmentation base;
    base.labels.resize(width, 3, 1);
    base.segments.resize(2);
    base.segments[0].label = 1;
    base.segments[1].label = 2;
    for (Segment& s : base.segments) s.normal = {0, 0, -1};
    for (int u = 0; u < width; ++u) {
      Segmentation column = base;
      for (int v = 0; v < 2; ++v) column.labels(u, v) = 2;  // row 2 stays segment 1
      column.segments[0].pixel_count = 3 * width - 2;
      column.segments[1].pixel_count = 2;
      SegmentTracker tracker;
      Segmentation first = column;
      tracker.update(first);
      Segmentation bad = column;
      bad.labels(u, 1) = 3;  // no segment 3
      EXPECT_THROW(tracker.update(bad), std::invalid_argument) << "width " << width << ", u " << u;
      Segmentation again = column;
      tracker.update(again);
      EXPECT_EQ(ids(again), ids(first)) << "width " << width << ", u " << u;
    }
  }
}

namespace {

/// Per ground-truth surface of `truth`, the segment covering at least 80 % of its pixels with
/// at least 80 % of its own pixels on it (a SegComp correct detection at T = 0.8), if any.
std::map<int, const Segment*> correct_detections(const synth::Rendering& truth,
                                                 const Segmentation& seg) {
  std::map<std::pair<int, int>, int> shared;
  std::map<int, int> truth_pixels, seg_pixels;
  for (int v = 0; v < truth.labels.height(); ++v) {
    for (int u = 0; u < truth.labels.width(); ++u) {
      const int t = truth.labels(u, v), s = seg.labels(u, v);
      if (t > 0) ++truth_pixels[t];
      if (s > 0) ++seg_pixels[s];
      if (t > 0 && s > 0) ++shared[{t, s}];
    }
  }
  std::map<int, const Segment*> out;
  for (const auto& [key, n] : shared) {
    if (n >= 0.8 * truth_pixels[key.first] && n >= 0.8 * seg_pixels[key.second]) {
      out[key.first] = &seg.segments[static_cast<std::size_t>(key.second - 1)];
    }
  }
  return out;
}

/// Turns the scene by `angle` [rad] about the camera's vertical axis (y): the camera turning
/// in place by -angle.
synth::Scene turned(synth::Scene scene, double angle) {
  const auto turn = [&](const synth::Vec3& p) -> synth::Vec3 {
    const double c = std::cos(angle), s = std::sin(angle);
    return {c * p[0] + s * p[2], p[1], -s * p[0] + c * p[2]};
  };
  if (scene.room) {
    scene.room->centre = turn(scene.room->centre);
    scene.room->yaw += angle;
  }
  for (auto& r : scene.rectangles) {
    r.centre = turn(r.centre);
    r.half_u = turn(r.half_u);
    r.half_v = turn(r.half_v);
  }
  for (auto& b : scene.boxes) {
    b.centre = turn(b.centre);
    b.orientation.yaw += angle;
  }
  for (auto& c : scene.cylinders) {
    c.base = turn(c.base);
    c.axis = turn(c.axis);
  }
  for (auto& sphere : scene.spheres) sphere.centre = turn(sphere.centre);
  return scene;
}

/// Surfaces of four frames that kept their ids (found correctly in two consecutive frames with
/// the same id) and that lost them.
struct Kept {
  int kept = 0, lost = 0;
};

/// Four frames of `scene` moved by `move(scene, render, frame)`, with Kinect noise (new noise
/// each frame); no surface may take another's id.
template <class Move>
Kept ids_kept_over_four_frames(const synth::Scene& scene, Move&& move) {
  PipelineSettings settings = pipeline_preset("kinect");
  settings.track = true;
  Pipeline pipeline(settings);
  std::map<int, std::uint32_t> id_of_surface;
  Kept out;
  for (int f = 0; f < 4; ++f) {
    synth::RenderSettings render{.noise = synth::Noise::kinect,
                                 .seed = static_cast<std::uint64_t>(10 + f)};
    const synth::Scene moved = move(scene, render, f);
    const synth::Rendering r = synth::render(moved, render);
    pipeline.process(r.cloud);
    const std::map<int, const Segment*> found = correct_detections(r, pipeline.segmentation());
    EXPECT_GE(found.size(), 6U) << "frame " << f;
    std::map<int, std::uint32_t> ids_now;
    for (const auto& [surface, segment] : found) {
      ids_now[surface] = segment->track_id;
      for (const auto& [other, id] : id_of_surface) {
        EXPECT_TRUE(other == surface || id != segment->track_id)
            << "surface " << surface << " took the track of surface " << other << " in frame " << f;
      }
      if (!id_of_surface.contains(surface)) continue;
      const bool same = segment->track_id == id_of_surface[surface];
      ++(same ? out.kept : out.lost);
      if (!same) {
        std::printf("surface %d (%s) lost its track in frame %d\n", surface,
                    r.surfaces[static_cast<std::size_t>(surface - 1)].name.c_str(), f);
      }
    }
    id_of_surface = ids_now;
    EXPECT_GT(pipeline.times().tracking, 0.0);
  }
  return out;
}

}  // namespace

// A camera panning by a few pixels per frame over a rendered scene: every surface keeps its id.
TEST(Tracking, SurfacesOfARenderedSceneKeepTheirIdsWhileTheCameraPans) {
  const Kept k = ids_kept_over_four_frames(
      synth::random_scene(4), [](const synth::Scene& scene, synth::RenderSettings& render, int f) {
        render.camera.cx += 6.0 * f;  // the image moves 6 px to the right per frame
        render.camera.cy -= 3.0 * f;
        return scene;
      });
  EXPECT_EQ(k.lost, 0);
  EXPECT_GE(k.kept, 18);  // 6 or more per pair of frames
}

// A camera turning in place. At 2 deg per frame (60 deg/s at 30 Hz) the walls 3-5 m away move
// by 0.1-0.17 m off their planes of the frame before, but not closer to the camera: every
// surface keeps its id. At 4 deg per frame (120 deg/s) the boxes also move by more than their
// width in the image (37 px): the image's shift, voted for by the pairs of segments that may be
// one surface, finds them (27 lost before the vote), but for a thin face near the image's
// edge, where a turn moves the image by a third more than at its centre.
TEST(Tracking, SurfacesOfARenderedSceneKeepTheirIdsWhileTheCameraTurns) {
  constexpr double kDegree = 3.14159265358979323846 / 180;
  for (const double degrees : {2.0, 4.0}) {
    const Kept k = ids_kept_over_four_frames(
        synth::random_scene(4), [&](const synth::Scene& scene, synth::RenderSettings&, int f) {
          return turned(scene, degrees * kDegree * f);
        });
    EXPECT_GE(k.kept, 18) << degrees << " deg";
    EXPECT_LE(k.lost, degrees == 2.0 ? 0 : 6) << degrees << " deg";  // 4 lost; 27 without the vote
  }
}

// A dropped sensor frame (no valid point, so no segment) between two frames changes no track.
TEST(Tracking, AFrameWithoutSegmentsLeavesTheTracksAsTheyWere) {
  SegmentTracker tracker;
  Segmentation a = frame({{0, 0, 32, 48}, {32, 0, 64, 48}});
  tracker.update(a);
  Segmentation blank;
  blank.labels.resize(64, 48, 0);
  Segmentation mislabelled = blank;
  mislabelled.labels(3, 4) = 1;  // no segment 1
  EXPECT_THROW(tracker.update(mislabelled), std::invalid_argument);
  tracker.update(blank);
  Segmentation b = frame({{0, 0, 30, 48}, {30, 0, 64, 48}});
  tracker.update(b);
  EXPECT_EQ(ids(b), ids(a));
}

// Tracks need frames on a pixel grid: a cloud over rings in between starts new tracks, and
// without `track` the ids stay 0.
TEST(Tracking, PipelineTracksOnlyWhenAskedAndRestartsAfterACloudOverRings) {
  const synth::Rendering r = synth::render(synth::random_scene(4), {.noise = synth::Noise::kinect});
  Pipeline untracked(pipeline_preset("kinect"));
  untracked.process(r.cloud);
  for (const Segment& s : untracked.segmentation().segments) EXPECT_EQ(s.track_id, 0U);

  PipelineSettings settings = pipeline_preset("kinect");
  settings.track = true;
  settings.restore_grid = false;
  Pipeline pipeline(settings);
  pipeline.process(r.cloud);
  const std::vector<std::uint32_t> first = ids(pipeline.segmentation());
  pipeline.process(r.cloud);
  EXPECT_EQ(ids(pipeline.segmentation()), first);
  OrganizedCloud points = valid_points(downsample(r.cloud, 8));
  pipeline.process(points);
  for (const Segment& s : pipeline.segmentation().segments) EXPECT_EQ(s.track_id, 0U);
  pipeline.process(r.cloud);
  for (const Segment& s : pipeline.segmentation().segments) EXPECT_GT(s.track_id, first.back());
  pipeline.reset_tracks();
  const std::uint32_t before = pipeline.segmentation().segments.front().track_id;
  pipeline.process(r.cloud);
  EXPECT_GT(pipeline.segmentation().segments.front().track_id, before);
}
