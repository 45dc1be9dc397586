// Tests of the grazing-plane search: surfaces seen a few degrees off the rays (table tops).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/smoothing.hpp"
#include "segmentation_frame_util.hpp"
#include "segmentation_test_util.hpp"

namespace rangeseg {
namespace {

using namespace test;  // the segmentation test helpers

/// A table top 0.3 m below the sensor, 2-3 m away (seen at 6-8.5 deg), with its front face and
/// a wall at 4 m, Kinect noise along the ray and one smoothing pass, as the pipeline runs. The
/// top's rows lie 4-7 cm apart in depth against 1-1.5 cm of noise, so its 1-ring normals are off
/// by tens of degrees and growth leaves it in unlabelled fragments; the grazing-plane search
/// fits it whole. The top is 1 m wide and 0.6 m deep (0.6 m^2).
struct GrazingTop {
  double coverage = 0;             ///< share of the top's valid pixels in its best segment
  std::array<double, 3> normal{};  ///< that segment's normal
  double area = 0;                 ///< its area_m2 [m^2]
  double open_area = 0;            ///< its area over the mesh's own faces (compute_areas) [m^2]
  bool grazing = false;
  /// Summed |difference| of every segment's area_m2 and its area over the mesh that
  /// close_grazing_cells closed [m^2].
  double closed_mismatch = 0;
};

GrazingTop grazing_top(const SegmentationSettings& settings) {
  constexpr double kTop = 0.2, kFront = 2.4, kBack = 3.0, kHalfWidth = 0.5;
  std::mt19937 rng(29);
  std::normal_distribution<double> unit(0.0, 1.0);
  const SegmentationSettings kinect = preset("kinect");
  LabelImage truth(640, 480);
  const OrganizedCloud raw = cast(640, 480, [&](double a, double b) {
    double t = 4.0;  // wall
    int label = 0;
    if (b > 0 && std::abs(a) * kTop / b <= kHalfWidth) {
      const double on_top = kTop / b;  // depth where the ray meets the plane y = kTop
      if (on_top >= kFront && on_top <= kBack) {
        t = on_top;
        label = 1;
      } else if (on_top < kFront && b * kFront <= 0.8 && std::abs(a) * kFront <= kHalfWidth) {
        t = kFront;  // the front face, down to 0.8 m below the sensor
      }
    }
    const int u = static_cast<int>(std::lround(a * kF + kCx));
    const int v = static_cast<int>(std::lround(b * kF + kCy));
    truth(u, v) = label;
    return t + kinect.noise.sigma(t) * unit(rng);
  });
  const Mesh mesh = build_mesh(raw);
  OrganizedCloud points;
  NormalMap normals;
  smooth(raw, mesh, compute_normals(raw, mesh), {.iterations = 1}, points, normals);
  Segmentation seg = segment(points, mesh, normals, settings);
  expect_consistent(points, seg, settings);
  std::map<int, int> hits;
  int top_pixels = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      if (truth(u, v) != 1) continue;
      ++top_pixels;
      if (seg.labels(u, v) != 0) ++hits[seg.labels(u, v)];
    }
  }
  EXPECT_GT(top_pixels, 1500);
  std::pair<int, int> best{0, 0};
  for (const auto& [label, count] : hits) {
    if (count > best.second) best = {label, count};
  }
  GrazingTop out;
  if (best.first == 0) return out;
  const Segment& top = seg.segments[static_cast<std::size_t>(best.first - 1)];
  out.coverage = static_cast<double>(best.second) / top_pixels;
  out.normal = top.normal;
  out.area = top.area_m2;
  out.grazing = top.grazing;
  Segmentation areas = seg;
  Segmenter segmenter;
  segmenter.compute_areas(points, mesh, areas);
  out.open_area = areas.segments[static_cast<std::size_t>(best.first - 1)].area_m2;
  Mesh closed = mesh;
  close_grazing_cells(seg, closed);
  // The closed mesh stays a mesh: every edge is known at both ends.
  for (int v = 1; v + 1 < 480; ++v) {
    for (int u = 1; u + 1 < 640; ++u) {
      for (int k = 0; k < 8; ++k) {
        const int back =
            (closed.edges(u + kNeighbourDu[k], v + kNeighbourDv[k]) >> ((k + 4) % 8)) & 1;
        EXPECT_EQ((closed.edges(u, v) >> k) & 1, back) << u << "," << v << " direction " << k;
      }
    }
  }
  segmenter.compute_areas(points, closed, areas);
  for (std::size_t j = 0; j < seg.segments.size(); ++j) {
    out.closed_mismatch += std::abs(seg.segments[j].area_m2 - areas.segments[j].area_m2);
  }
  return out;
}

TEST(Segmentation, TableTopSeenAtGrazingIncidenceIsOneSegment) {
  const SegmentationSettings kinect = preset("kinect");
  const GrazingTop top = grazing_top(kinect);
  EXPECT_GT(top.coverage, 0.9);
  EXPECT_LT(angle_deg(top.normal, {0.0, -1.0, 0.0}), 1.0);
  // The mesh has few faces there; the area counts the top's cells closed, as the mesh that
  // close_grazing_cells closes does.
  EXPECT_TRUE(top.grazing);
  EXPECT_LT(top.open_area, 0.2 * 0.6);
  EXPECT_NEAR(top.area, 0.6, 0.2 * 0.6);  // less a rim of half a pixel: 9 rows deep
  EXPECT_LT(top.closed_mismatch, 1e-9);
  SegmentationSettings off = kinect;
  off.grazing_min_angle = 0;  // without the search, growth leaves the top in fragments
  EXPECT_LT(grazing_top(off).coverage, 0.5);
}

/// A box 2-2.6 m away, noise-free, with the sensor's noise model set to 0.5 mm: its top (0.3 m
/// below the sensor, 6.6-8.5 deg to the rays) and its side (0.35 m to the left, 7.7-10 deg) lose
/// their mesh faces, as the angle test cuts edges that steep and the noise no longer explains the
/// depth steps. Both are left to the grazing-plane search as one unlabelled component, joined at
/// the box's edge, whose least-squares plane is neither. The search starts from the best sampled
/// plane, takes the top or the side, and searches the rest again: both become segments.
TEST(Segmentation, GrazingTopAndSideOfOneComponentAreTwoSegments) {
  constexpr double kTop = 0.3, kSide = -0.35, kFar = -0.9, kBottom = 0.8;
  constexpr double kFront = 2.0, kBack = 2.6;
  LabelImage truth(640, 480);  // 1 top, 2 side
  const OrganizedCloud cloud = cast(640, 480, [&](double a, double b) {
    double t = 4.0;  // wall
    int label = 0;
    const auto hit = [&](double depth, int surface) {
      if (depth < t) t = depth, label = surface;
    };
    if (a * kFront >= kFar && a * kFront <= kSide && b * kFront >= kTop && b * kFront <= kBottom) {
      hit(kFront, 0);
    }
    if (b > 0) {
      const double on_top = kTop / b;
      if (on_top >= kFront && on_top <= kBack && a * on_top >= kFar && a * on_top <= kSide) {
        hit(on_top, 1);
      }
    }
    if (a < 0) {
      const double on_side = kSide / a;
      if (on_side >= kFront && on_side <= kBack && b * on_side >= kTop && b * on_side <= kBottom) {
        hit(on_side, 2);
      }
    }
    truth(static_cast<int>(std::lround(a * kF + kCx)),
          static_cast<int>(std::lround(b * kF + kCy))) = label;
    return t;
  });
  const SensorNoise exact{.a = 0.0005, .b = 0.0, .z0 = 0.0};
  SegmentationSettings settings = preset("kinect");
  settings.noise = exact;
  Stages p;
  p.mesh = build_mesh(cloud, {.noise = exact});
  p.normals = compute_normals(cloud, p.mesh);
  segment(cloud, p.mesh, p.normals, settings, p.seg);
  expect_consistent(cloud, p.seg, settings);
  const std::array<std::array<double, 3>, 2> normals{{{0.0, -1.0, 0.0}, {1.0, 0.0, 0.0}}};
  for (int surface = 1; surface <= 2; ++surface) {
    std::map<int, int> hits;
    int pixels = 0;
    for (int v = 0; v < 480; ++v) {
      for (int u = 0; u < 640; ++u) {
        if (truth(u, v) != surface) continue;
        ++pixels;
        ++hits[p.seg.labels(u, v)];
      }
    }
    ASSERT_GT(pixels, 1500) << "surface " << surface;
    const auto best = std::max_element(
        hits.begin(), hits.end(), [](const auto& x, const auto& y) { return x.second < y.second; });
    ASSERT_NE(best->first, 0) << "surface " << surface << " left unlabelled";
    EXPECT_GT(best->second, 0.9 * pixels) << "surface " << surface;
    const Segment& segment = p.seg.segments[static_cast<std::size_t>(best->first - 1)];
    EXPECT_TRUE(segment.grazing) << "surface " << surface;
    const std::array<double, 3> n = normals[static_cast<std::size_t>(surface - 1)];
    const std::array<double, 3> flipped{-n[0], -n[1], -n[2]};
    EXPECT_LT(std::min(angle_deg(segment.normal, n), angle_deg(segment.normal, flipped)), 0.5)
        << "surface " << surface;
  }
}

/// Mixed pixels along a depth step (a laser scanner's veil): 10 columns between a plate at 1.5 m
/// and a wall at 3 m whose depths step evenly from one to the other. They lie on one plane, but
/// it runs within 1.5 deg of the viewing rays (0.15 m per column against a 3 mm footprint), as a
/// surface through the sensor would: no segment. With a lower grazing_min_angle they become one.
TEST(Segmentation, VeilAlongADepthStepIsNoGrazingPlane) {
  const OrganizedCloud cloud = cast(640, 480, [&](double a, double) {
    const double u = a * kF + kCx;
    if (u < 300) return 1.5;
    if (u >= 310) return 3.0;
    return 1.5 + 1.5 * (u - 299.5) / 11.0;
  });
  SegmentationSettings settings = preset("kinect");
  const Stages p = run(cloud, settings);
  expect_consistent(cloud, p.seg, settings);
  EXPECT_EQ(p.seg.segments.size(), 2u);
  for (int v = 0; v < 480; v += 7) {
    for (int u = 301; u < 309; ++u) EXPECT_EQ(p.seg.labels(u, v), 0) << u << "," << v;
  }
  settings.grazing_min_angle = 0.2 * kDeg;
  const Stages q = run(cloud, settings);
  EXPECT_EQ(q.seg.segments.size(), 3u);
  EXPECT_NE(q.seg.labels(305, 240), 0);
}

/// A patch of the plane 0.7 m below the sensor, 2.2-3.4 m away (12-18 deg to the rays),
/// noise-free, the Kinect preset's sigma(z), left unlabelled in a frame whose other points are
/// one region, and the grazing-plane search run on it (the segmentation's internals). Returns
/// the share of the patch's points in the one grazing plane found (0 for none), and its normal.
struct PatchResult {
  int pixels = 0;
  double share = 0;
  std::array<double, 3> normal{};
};

PatchResult grazing_patch(int columns, double z_near, double z_far) {
  FrameOf t(cast(640, 480, [](double, double b) {
    const double on_plane = b > 0 ? 0.7 / b : 0.0;
    return on_plane >= 2.2 && on_plane <= 3.4 ? on_plane : 5.0;
  }));
  const SegmentationSettings settings = preset("kinect");
  Segmenter::Scratch s;
  s.regions.assign(2, {});
  PatchResult out;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const double z = t.cloud.z(u, v);
      const std::int32_t i = t.at(u, v);
      if (u >= 316 && u < 316 + columns && z >= z_near && z <= z_far) {
        ++out.pixels;
        continue;
      }
      t.f.labels[i] = 1;
      s.regions[1].add(t.cloud.x(u, v), t.cloud.y(u, v), z);
    }
  }
  s.fits = {{}, s.regions[1].fit()};
  s.parent = s.remap = {0, 1};
  s.grazing_region = {0, 0};
  seg::find_grazing_planes(t.f, settings, s, seg::pixel_footprint(t.f, s));
  EXPECT_LT(out.pixels, settings.min_region_size);
  if (s.regions.size() == 2) return out;
  EXPECT_EQ(s.regions.size(), 3u);
  EXPECT_EQ(s.grazing_region[2], 1);
  out.share = static_cast<double>(s.regions[2].count) / out.pixels;
  out.normal = s.fits[2].normal;
  return out;
}

/// A patch of 8 columns and 15 rows (120 points: below min_region_size, and 5 cm across, too
/// narrow for wide_enough) covers what ~550 points facing the sensor would: a grazing plane. A
/// strip of 2 columns and ~60 rows (~120 points, 1 cm across) does not become one: a plane
/// through it edge-on would fit its points within sigma(z) sin(grazing_max_angle) (1.8 cm
/// across at most) as well.
TEST(Segmentation, SmallGrazingPatchCountsItsFrontalAreaUnlessItIsAStrip) {
  const PatchResult patch = grazing_patch(8, 2.9, 3.3);
  EXPECT_GT(patch.pixels, 100);
  EXPECT_GT(patch.share, 0.95);
  EXPECT_LT(angle_deg(patch.normal, {0.0, -1.0, 0.0}), 0.5);
  const PatchResult strip = grazing_patch(2, 2.2, 3.4);
  EXPECT_GT(strip.pixels, 100);
  EXPECT_EQ(strip.share, 0.0);
}

/// A 16-beam spinning lidar's organized scan (16 rows 2 deg apart from -15 to +15 deg, 900
/// columns over 360 deg) in the middle of a 20 x 15 m room, 1.7 m above its floor, with 1 cm of
/// range noise; points in the lidar's frame (x forward, y left, z up), or turned upside down
/// (y and z negated, an exact rotation). Truth: 1 floor, 2 walls.
OrganizedCloud lidar_room(bool upside_down, LabelImage& truth) {
  constexpr int kRows = 16, kColumns = 900;
  constexpr double kFloor = -1.7, kHalfX = 10.0, kHalfY = 7.5;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.01);
  OrganizedCloud cloud(kColumns, kRows);
  truth.resize(kColumns, kRows, 0);
  for (int v = 0; v < kRows; ++v) {
    const double elevation = (15.0 - 2.0 * v) * std::numbers::pi / 180.0;
    for (int u = 0; u < kColumns; ++u) {
      const double azimuth = 2.0 * std::numbers::pi * u / kColumns;
      const double d[3] = {std::cos(elevation) * std::cos(azimuth),
                           std::cos(elevation) * std::sin(azimuth), std::sin(elevation)};
      double t = std::numeric_limits<double>::infinity();
      int label = 0;
      if (d[2] < 0) t = kFloor / d[2], label = 1;
      for (const double wall : {std::abs(d[0]) > 0 ? kHalfX / std::abs(d[0]) : t,
                                std::abs(d[1]) > 0 ? kHalfY / std::abs(d[1]) : t}) {
        if (wall < t) t = wall, label = 2;
      }
      t += noise(rng);
      const double sign = upside_down ? -1.0 : 1.0;
      cloud.x(u, v) = static_cast<float>(t * d[0]);
      cloud.y(u, v) = static_cast<float>(sign * t * d[1]);
      cloud.z(u, v) = static_cast<float>(sign * t * d[2]);
      truth(u, v) = label;
    }
  }
  return cloud;
}

// The floor round a spinning lidar is seen at 2-15 deg from 6 m on: its rows lie metres apart,
// so the grazing-plane search finds it. It took only points with z > 0 and bounded neighbours
// by z, which in the lidar's own frame is the height: 1 % of the floor was labelled there, all
// of it upside down; and the plane's angle to the rays at its centroid, below the sensor, read
// head-on. Ranges and the angle over its points give one floor in either frame.
TEST(Segmentation, FloorRoundASpinningLidarIsOneSegmentInAnyFrame) {
  LabelImage truth;
  const OrganizedCloud up = lidar_room(false, truth);
  const OrganizedCloud down = lidar_room(true, truth);
  Pipeline a(pipeline_preset("laser")), b(pipeline_preset("laser"));
  a.process(up);
  b.process(down);
  std::map<int, int> floor_labels;
  std::map<std::pair<int, int>, int> pairs;  // (label up, label down) -> pixels
  int floor = 0;
  for (int v = 0; v < truth.height(); ++v) {
    for (int u = 0; u < truth.width(); ++u) {
      ++pairs[{a.segmentation().labels(u, v), b.segmentation().labels(u, v)}];
      if (truth(u, v) != 1) continue;
      ++floor;
      ++floor_labels[a.segmentation().labels(u, v)];
    }
  }
  // The same segments but where the rounding of the turned coordinates (in eigen solvers, sums)
  // tips a tie: one pixel of 14400 here. (Segments of equal size may swap their labels.)
  std::map<int, int> most;  // per label up, the pixels of its commonest label down
  for (const auto& [labels, count] : pairs) {
    most[labels.first] = std::max(most[labels.first], count);
  }
  int same = 0;
  for (const auto& [label, count] : most) same += count;
  EXPECT_LE(truth.width() * truth.height() - same, truth.width() * truth.height() / 1000);
  ASSERT_GT(floor, 2000);
  std::pair<int, int> best{0, 0};
  for (const auto& [label, count] : floor_labels) {
    if (label != 0 && count > best.second) best = {label, count};
  }
  ASSERT_NE(best.first, 0) << "the floor is unlabelled";
  EXPECT_GT(best.second, 0.9 * floor);
  const Segment& segment = a.segmentation().segments[static_cast<std::size_t>(best.first - 1)];
  EXPECT_LT(angle_deg(segment.normal, {0.0, 0.0, 1.0}), 1.0);
  EXPECT_NEAR(segment.offset, 1.7, 0.02);
}

/// The columns of `cloud` in [first, last).
OrganizedCloud columns(const OrganizedCloud& cloud, int first, int last) {
  OrganizedCloud out(last - first, cloud.height());
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = first; u < last; ++u) {
      out.x(u - first, v) = cloud.x(u, v);
      out.y(u - first, v) = cloud.y(u, v);
      out.z(u - first, v) = cloud.z(u, v);
    }
  }
  return out;
}

// A spinning lidar's columns go once round: the first and the last are neighbours, which the
// grid's mesh does not join. The wall at x = +10 m spans azimuths -36.9 to +36.9 deg, across
// that seam; it came out as two segments of about half its pixels each.
TEST(Segmentation, AWallAcrossASpinningLidarsColumnSeamIsOneSegment) {
  LabelImage truth;
  const OrganizedCloud room = lidar_room(false, truth);
  for (const char* model : {"plane", "auto"}) {
    PipelineSettings settings = pipeline_preset("laser");
    settings.segmentation.model = region_model_from_string(model);
    Pipeline pipeline(settings);
    pipeline.process(room);
    std::map<int, int> wall_labels;
    int wall = 0;
    for (int v = 0; v < truth.height(); ++v) {
      for (int u = 0; u < truth.width(); ++u) {
        if (truth(u, v) != 2 || !(room.x(u, v) > 9.5f)) continue;
        ++wall;
        ++wall_labels[pipeline.segmentation().labels(u, v)];
      }
    }
    ASSERT_GT(wall, 500) << model;
    int best = 0;
    for (const auto& [label, count] : wall_labels) {
      if (label != 0) best = std::max(best, count);
    }
    EXPECT_GT(best, 0.9 * wall) << model << ": the wall is cut at the seam";
  }
  // Which grids wrap: the whole turn, with or without the first column, but not three quarters
  // of it, a half, or a camera's field of view.
  EXPECT_TRUE(seg::columns_wrap(FrameOf(room).f));
  EXPECT_TRUE(seg::columns_wrap(FrameOf(columns(room, 1, 900)).f));
  EXPECT_FALSE(seg::columns_wrap(FrameOf(columns(room, 0, 675)).f));
  EXPECT_FALSE(seg::columns_wrap(FrameOf(columns(room, 100, 550)).f));
  EXPECT_FALSE(seg::columns_wrap(FrameOf(cast(640, 480, [](double, double) { return 2.0; })).f));
}

}  // namespace
}  // namespace rangeseg
