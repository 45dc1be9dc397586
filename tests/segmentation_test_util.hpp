// Helpers of the segmentation tests: ray-cast analytic scenes, the stages up to segmentation,
// and the invariants every segmentation must satisfy.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/synth.hpp"

namespace rangeseg::test {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kF = 525.0, kCx = 319.5, kCy = 239.5;

/// A sensor's pipeline settings for the tests of the rings: unorganized clouds run over rings
/// even where their points lie on a pixel grid, as the shuffled points of a rendering do.
inline PipelineSettings ring_preset(std::string_view sensor) {
  PipelineSettings settings = pipeline_preset(sensor);
  settings.restore_grid = false;
  return settings;
}

/// A 1-row (unorganized) cloud of the points, in their order.
inline OrganizedCloud row_cloud(const std::vector<std::array<double, 3>>& points) {
  OrganizedCloud cloud(static_cast<int>(points.size()), 1);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const int u = static_cast<int>(i);
    cloud.x(u, 0) = static_cast<float>(points[i][0]);
    cloud.y(u, 0) = static_cast<float>(points[i][1]);
    cloud.z(u, 0) = static_cast<float>(points[i][2]);
  }
  return cloud;
}

/// Ray-casts a depth function: `depth(a, b)` gives the depth t of the point t (a, b, 1) seen
/// through the pixel with ray slopes a = (u - cx) / f, b = (v - cy) / f (NaN = no point).
inline OrganizedCloud cast(int width, int height,
                           const std::function<double(double, double)>& depth) {
  OrganizedCloud cloud(width, height);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const double a = (u - kCx) / kF, b = (v - kCy) / kF;
      const double t = depth(a, b);
      if (!std::isfinite(t)) continue;
      cloud.x(u, v) = static_cast<float>(a * t);
      cloud.y(u, v) = static_cast<float>(b * t);
      cloud.z(u, v) = static_cast<float>(t);
    }
  }
  return cloud;
}

/// What the stages up to segmentation produce (`run`).
struct Stages {
  Mesh mesh;
  NormalMap normals;
  Segmentation seg;
};

inline Stages run(const OrganizedCloud& cloud, const SegmentationSettings& settings) {
  Stages p;
  p.mesh = build_mesh(cloud);
  p.normals = compute_normals(cloud, p.mesh);
  segment(cloud, p.mesh, p.normals, settings, p.seg);
  return p;
}

inline double angle_deg(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  const double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  return std::acos(std::clamp(d, -1.0, 1.0)) / kDeg;
}

/// Invariants of every model's labels and segments: labels 0..N on valid points only, segment i
/// has label i + 1 and as many pixels as carry it, segments by size descending, areas finite.
inline void expect_labels_name_segments(const OrganizedCloud& cloud, const Segmentation& seg,
                                        const std::string& what = {}) {
  ASSERT_EQ(seg.labels.width(), cloud.width()) << what;
  ASSERT_EQ(seg.labels.height(), cloud.height()) << what;
  std::vector<int> counts(seg.segments.size() + 1, 0);
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      const int l = seg.labels(u, v);
      ASSERT_GE(l, 0) << what;
      ASSERT_LE(l, static_cast<int>(seg.segments.size()))
          << what << ": label not compact at " << u << "," << v;
      if (l != 0) {
        ASSERT_TRUE(cloud.valid(u, v)) << what << ": invalid pixel labelled at " << u << "," << v;
      }
      ++counts[static_cast<std::size_t>(l)];
    }
  }
  for (std::size_t i = 0; i < seg.segments.size(); ++i) {
    const Segment& s = seg.segments[i];
    EXPECT_EQ(s.label, static_cast<int>(i + 1)) << what;
    EXPECT_EQ(s.pixel_count, counts[i + 1]) << what << ": segment " << s.label;
    if (i > 0) {
      EXPECT_LE(s.pixel_count, seg.segments[i - 1].pixel_count) << what;
    }
    EXPECT_TRUE(std::isfinite(s.area_m2) && s.area_m2 >= 0) << what << ": segment " << s.label;
  }
}

/// Invariants every plane segmentation must satisfy.
inline void expect_consistent(const OrganizedCloud& cloud, const Segmentation& seg,
                              const SegmentationSettings& settings) {
  expect_labels_name_segments(cloud, seg);
  for (std::size_t i = 0; i < seg.segments.size(); ++i) {
    const Segment& s = seg.segments[i];
    EXPECT_GE(2 * s.pixel_count, settings.min_region_size);  // below it only when wide (3D)
    const double norm = std::hypot(s.normal[0], s.normal[1], s.normal[2]);
    EXPECT_NEAR(norm, 1.0, 1e-9);
    EXPECT_GE(s.offset, 0.0);
    const double nc =
        s.normal[0] * s.centroid[0] + s.normal[1] * s.centroid[1] + s.normal[2] * s.centroid[2];
    EXPECT_NEAR(nc + s.offset, 0.0, 1e-9);  // the plane passes through the centroid
    EXPECT_GT(s.area_m2, 0.0);
    EXPECT_GE(s.rms_residual, 0.0);
  }
}

/// For a 640x480 frame of two faces meeting at a crease along the middle column (u = 319.5),
/// the left one's segment at (100, 240) and the right one's at (540, 240): the number of
/// pixels more than `margin` columns from the crease that carry the other side's segment.
inline int labelled_across_crease(const Segmentation& seg, double margin) {
  const int left = seg.labels(100, 240), right = seg.labels(540, 240);
  EXPECT_NE(left, 0);
  EXPECT_NE(right, 0);
  EXPECT_NE(left, right);
  int across = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      if (u < 319.5 - margin) across += seg.labels(u, v) == right;
      if (u > 319.5 + margin) across += seg.labels(u, v) == left;
    }
  }
  return across;
}

/// Two box fronts 3 m away meeting at a vertical crease on the optical axis, the left one
/// fronto-parallel, the right one turned by `degrees`; each 0.27 m wide and 0.36 m tall (47 x 63
/// pixels), before a wall at 4 m; Gaussian noise of `sigmas` sigma(z) along the ray.
inline OrganizedCloud two_fronts(double degrees, double sigmas, const SensorNoise& noise,
                                 std::uint32_t seed) {
  const double slope = std::tan(degrees * kDeg);
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  return cast(640, 480, [&](double a, double b) {
    double t = 4.0;
    if (std::fabs(b) <= 0.06 && std::fabs(a) <= 0.09) t = a <= 0 ? 3.0 : 3.0 / (1.0 - slope * a);
    return t + sigmas * noise.sigma(t) * unit(rng);
  });
}

/// The valid points of an organized cloud as a 1-row cloud in shuffled order; pixel[i] is the
/// grid index of point i.
struct Unorganized {
  OrganizedCloud cloud;
  std::vector<std::size_t> pixel;
};

inline Unorganized shuffled(const OrganizedCloud& grid, unsigned seed) {
  Unorganized out;
  out.cloud = shuffled_valid_points(grid, seed, &out.pixel);
  return out;
}

/// The 1-row labels on the grid the points came from (0 elsewhere).
inline LabelImage to_grid(const LabelImage& labels, const Unorganized& u, int width, int height) {
  LabelImage grid(width, height, 0);
  for (std::size_t i = 0; i < u.pixel.size(); ++i) {
    grid(static_cast<int>(u.pixel[i] % static_cast<std::size_t>(width)),
         static_cast<int>(u.pixel[i] / static_cast<std::size_t>(width))) =
        labels(static_cast<int>(i), 0);
  }
  return grid;
}

/// A floor 0.9 m below the camera and a back wall `wall_z` metres away (the room reaches 0.5 m
/// behind the camera), nothing else.
inline synth::Scene floor_and_wall(double wall_z) {
  synth::Scene scene;
  synth::Room room;
  room.half_extent = {6.0, 2.0, (wall_z + 0.5) / 2};
  room.centre = {0.0, 0.9 - 2.0, (wall_z - 0.5) / 2};
  room.left_wall = room.right_wall = false;
  scene.room = room;
  return scene;
}

/// A floor and back wall with a standing cylinder, a lying (tilted) cylinder and a sphere.
inline synth::Scene curved_scene() {
  synth::Scene scene = floor_and_wall(4.5);
  scene.cylinders.push_back(
      {.base = {-0.6, 0.9, 2.6}, .radius = 0.15, .height = 0.7, .name = "standing"});
  scene.cylinders.push_back({.base = {0.1, 0.78, 2.2},
                             .axis = {1.0, 0.0, 0.35},
                             .radius = 0.12,
                             .height = 0.6,
                             .name = "lying"});
  scene.spheres.push_back({.centre = {0.55, 0.9 - 0.2, 2.9}, .radius = 0.2, .name = "ball"});
  return scene;
}

/// A random box scene (synth::random_scene(seed)) with Kinect noise seen at 320 x 240 (about
/// 72,000 points): for tests of properties that do not depend on the size, a quarter of the
/// work of 640 x 480 (they also run under the sanitizers).
inline synth::Rendering qvga_boxes_scene(std::uint64_t seed) {
  constexpr CameraIntrinsics kQvga{
      .fx = 262.5, .fy = 262.5, .cx = 159.5, .cy = 119.5, .width = 320, .height = 240};
  return synth::render(
      synth::random_scene(seed),
      {.camera = kQvga, .noise = synth::Noise::kinect, .seed = seed, .min_surface_pixels = 250});
}

}  // namespace rangeseg::test
