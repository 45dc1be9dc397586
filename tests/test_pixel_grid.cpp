// The pixel grid of a depth camera's valid points (find_pixel_grid, scatter_to_grid) and the
// pipeline's grid stages on it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <random>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/pixel_grid.hpp"
#include "rangeseg/synth.hpp"
#include "segmentation_test_util.hpp"

namespace rangeseg {
namespace {

using test::qvga_boxes_scene;
using test::shuffled;
using test::Unorganized;

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
constexpr int kWidth = 320, kLeft = 7, kTop = 10, kRight = 300;  // the crop below

bool same_float(float a, float b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

/// A 320 x 240 synthetic Kinect frame (fx = fy = 262.5, cx = 159.5, cy = 119.5) without a border
/// (columns < 7 or >= 300, rows < 10): its valid points span a 293 x 230 box from (7, 10).
OrganizedCloud cropped_frame(std::uint64_t seed) {
  OrganizedCloud cloud = qvga_boxes_scene(seed).cloud;
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if (u >= kLeft && u < kRight && v >= kTop) continue;
      cloud.x(u, v) = cloud.y(u, v) = cloud.z(u, v) = kNan;
    }
  }
  return cloud;
}

TEST(PixelGrid, FindsTheGridOfShuffledValidPointsAndScattersThemBack) {
  const OrganizedCloud frame = cropped_frame(1);
  const Unorganized u = shuffled(frame, 3);
  PixelGrid grid;
  ASSERT_TRUE(find_pixel_grid(u.cloud, grid));
  EXPECT_EQ(grid.width, kRight - kLeft);
  EXPECT_EQ(grid.height, 240 - kTop);
  EXPECT_NEAR(grid.fx, 262.5, 1e-3);
  EXPECT_NEAR(grid.fy, 262.5, 1e-3);
  EXPECT_NEAR(grid.cx, 159.5 - kLeft, 1e-2);
  EXPECT_NEAR(grid.cy, 119.5 - kTop, 1e-2);
  ASSERT_EQ(grid.pixel.size(), u.cloud.size());
  for (std::size_t i = 0; i < u.pixel.size(); ++i) {
    const int col = static_cast<int>(u.pixel[i] % kWidth) - kLeft;
    const int row = static_cast<int>(u.pixel[i] / kWidth) - kTop;
    ASSERT_EQ(grid.pixel[i], row * grid.width + col) << i;
  }
  OrganizedCloud out;
  scatter_to_grid(u.cloud, grid, out);
  ASSERT_EQ(out.width(), grid.width);
  ASSERT_EQ(out.height(), grid.height);
  EXPECT_EQ(out.has_label(), frame.has_label());
  for (int v = 0; v < out.height(); ++v) {
    for (int c = 0; c < out.width(); ++c) {
      ASSERT_TRUE(same_float(out.x(c, v), frame.x(c + kLeft, v + kTop)) &&
                  same_float(out.y(c, v), frame.y(c + kLeft, v + kTop)) &&
                  same_float(out.z(c, v), frame.z(c + kLeft, v + kTop)))
          << c << " " << v;
      if (out.has_label() && frame.valid(c + kLeft, v + kTop)) {
        ASSERT_EQ(out.label(c, v), frame.label(c + kLeft, v + kTop));
      }
    }
  }
  // Invalid points among the valid ones get no pixel.
  OrganizedCloud with_invalid(static_cast<int>(u.cloud.size()) + 2, 1);
  for (int i = 0; i < u.cloud.width(); ++i) {
    with_invalid.x(i + 1, 0) = u.cloud.x(i, 0);
    with_invalid.y(i + 1, 0) = u.cloud.y(i, 0);
    with_invalid.z(i + 1, 0) = u.cloud.z(i, 0);
  }
  ASSERT_TRUE(find_pixel_grid(with_invalid, grid));
  EXPECT_EQ(grid.pixel.front(), -1);
  EXPECT_EQ(grid.pixel.back(), -1);
  EXPECT_EQ(grid.width, kRight - kLeft);
}

// Open3D's and PCL's text files keep 6 significant digits (~5e-6 of x / z over a column, 0.002
// pixel here): the grid is still found, every point on its own pixel.
TEST(PixelGrid, PointsWrittenAsTextWithSixDigitsStayOnTheirPixels) {
  const OrganizedCloud frame = cropped_frame(2);
  Unorganized u = shuffled(frame, 5);
  char text[32];
  for (FloatPlane* plane : {&u.cloud.x, &u.cloud.y, &u.cloud.z}) {
    for (int i = 0; i < plane->width(); ++i) {
      std::snprintf(text, sizeof text, "%.6g", (*plane)(i, 0));
      (*plane)(i, 0) = std::strtof(text, nullptr);
    }
  }
  PixelGrid grid;
  ASSERT_TRUE(find_pixel_grid(u.cloud, grid));
  EXPECT_EQ(grid.width, kRight - kLeft);
  EXPECT_EQ(grid.height, 240 - kTop);
  EXPECT_NEAR(grid.fx, 262.5, 1e-2);
  for (std::size_t i = 0; i < u.pixel.size(); ++i) {
    const int col = static_cast<int>(u.pixel[i] % kWidth) - kLeft;
    const int row = static_cast<int>(u.pixel[i] / kWidth) - kTop;
    ASSERT_EQ(grid.pixel[i], row * grid.width + col) << i;
  }
}

TEST(PixelGrid, EveryOtherPixelIsAGridOfHalfTheFocalLength) {
  const OrganizedCloud half = downsample(cropped_frame(2), 2);
  PixelGrid grid;
  ASSERT_TRUE(find_pixel_grid(shuffled(half, 5).cloud, grid));
  EXPECT_NEAR(grid.fx, 131.25, 1e-3);
  EXPECT_NEAR(grid.fy, 131.25, 1e-3);
  EXPECT_EQ(grid.width, kRight / 2 - (kLeft + 1) / 2);  // the even columns 8..298
}

/// Whether find_pixel_grid finds a grid, checking that a failure leaves it empty.
bool found(const OrganizedCloud& cloud) {
  PixelGrid grid;
  grid.pixel.assign(3, 7);
  const bool ok = find_pixel_grid(cloud, grid);
  if (!ok) {
    EXPECT_FALSE(grid.found());
    EXPECT_TRUE(grid.pixel.empty());
  }
  return ok;
}

TEST(PixelGrid, CloudsOffAPixelGridAreNotFound) {
  const Unorganized u = shuffled(cropped_frame(3), 4);
  ASSERT_TRUE(found(u.cloud));
  std::mt19937 random(9);
  const auto modified = [&](auto change) {
    OrganizedCloud c = u.cloud;
    for (int i = 0; i < c.width(); ++i) change(c, i);
    return c;
  };
  // Sub-pixel positions (a stereo camera's matches): up to 0.3 pixel sideways.
  std::uniform_real_distribution<float> jitter(-0.3f, 0.3f);
  EXPECT_FALSE(found(modified(
      [&](OrganizedCloud& c, int i) { c.x(i, 0) += jitter(random) * c.z(i, 0) / 262.5f; })));
  // Turned by 5 degrees about the vertical axis (a cloud in another frame).
  const float cs = std::cos(0.0873f), sn = std::sin(0.0873f);
  EXPECT_FALSE(found(modified([&](OrganizedCloud& c, int i) {
    const float x = c.x(i, 0), z = c.z(i, 0);
    c.x(i, 0) = cs * x + sn * z;
    c.z(i, 0) = -sn * x + cs * z;
  })));
  // Thinned at random to half: the grid's mesh would miss most edges.
  std::bernoulli_distribution drop(0.5);
  EXPECT_FALSE(found(modified([&](OrganizedCloud& c, int i) {
    if (drop(random)) c.x(i, 0) = kNan;
  })));
  // One point 0.2 pixel off (the lattice is fitted to a sample of every 2nd point here, which
  // leaves it out; every point is checked against the lattice).
  ASSERT_GT(u.cloud.size(), 2u * 32768u);
  OrganizedCloud one_off = u.cloud;
  one_off.x(1, 0) += 0.2f * one_off.z(1, 0) / 262.5f;
  EXPECT_FALSE(found(one_off));
  // Two points on one pixel (the same view twice, or two frames merged): along one ray.
  OrganizedCloud twice = u.cloud;
  twice.x(1, 0) = u.cloud.x(0, 0) * 2;
  twice.y(1, 0) = u.cloud.y(0, 0) * 2;
  twice.z(1, 0) = u.cloud.z(0, 0) * 2;
  EXPECT_FALSE(found(twice));
  // A point behind the camera.
  OrganizedCloud behind = u.cloud;
  behind.z(5, 0) = -behind.z(5, 0);
  EXPECT_FALSE(found(behind));
  // Too few points, none at all.
  OrganizedCloud few(15, 1);
  for (int i = 0; i < 15; ++i) {
    const int col = i % 5, row = i / 5;
    few.x(i, 0) = static_cast<float>(col) / 500.0f;
    few.y(i, 0) = static_cast<float>(row) / 500.0f;
    few.z(i, 0) = 1.0f;
  }
  EXPECT_FALSE(found(few));
  EXPECT_FALSE(found(OrganizedCloud(4, 1)));
  EXPECT_FALSE(found(OrganizedCloud()));
}

TEST(PixelGrid, ALidarScanAndSparsePatchesAreNotAGrid) {
  // A 16-beam lidar's points: azimuth steps of 0.2 deg, x / z = tan(azimuth) is no lattice.
  OrganizedCloud lidar(16 * 300, 1);
  for (int beam = 0; beam < 16; ++beam) {
    for (int a = 0; a < 300; ++a) {
      const double el = (beam - 7.5) * 2.0 * test::kDeg, az = (a - 150) * 0.2 * test::kDeg;
      const int i = beam * 300 + a;
      lidar.x(i, 0) = static_cast<float>(5 * std::cos(el) * std::sin(az));
      lidar.y(i, 0) = static_cast<float>(5 * std::sin(el));
      lidar.z(i, 0) = static_cast<float>(5 * std::cos(el) * std::cos(az));
    }
  }
  EXPECT_FALSE(found(lidar));
  // Two 10 x 10 patches of one camera's pixels 5000 columns apart: a lattice, but the grid
  // would hold 250 pixels per point.
  OrganizedCloud patches(200, 1);
  for (int i = 0; i < 200; ++i) {
    const int col = (i % 10) + (i >= 100 ? 5000 : 0), row = (i / 10) % 10;
    patches.x(i, 0) = static_cast<float>(col) / 525.0f;
    patches.y(i, 0) = static_cast<float>(row) / 525.0f;
    patches.z(i, 0) = 1.0f;
  }
  EXPECT_FALSE(found(patches));
  // One of them alone is a grid.
  OrganizedCloud one(100, 1);
  for (int i = 0; i < 100; ++i) {
    one.x(i, 0) = patches.x(i, 0);
    one.y(i, 0) = patches.y(i, 0);
    one.z(i, 0) = 1.0f;
  }
  PixelGrid grid;
  ASSERT_TRUE(find_pixel_grid(one, grid));
  EXPECT_EQ(grid.width, 10);
  EXPECT_NEAR(grid.fx, 525.0, 1e-2);
}

TEST(PixelGrid, ScatterRejectsAGridOfAnotherCloud) {
  const Unorganized u = shuffled(cropped_frame(1), 3);
  PixelGrid grid;
  OrganizedCloud out;
  EXPECT_THROW(scatter_to_grid(u.cloud, grid, out), std::invalid_argument);
  ASSERT_TRUE(find_pixel_grid(u.cloud, grid));
  EXPECT_THROW(scatter_to_grid(OrganizedCloud(5, 1), grid, out), std::invalid_argument);
}

// The pipeline runs the grid stages on the restored grid and returns their results per point:
// the same as the grid stages on the restored cloud, pixel for pixel.
TEST(RestoredGrid, PipelineGivesTheGridStagesResultsPerPoint) {
  const Unorganized u = shuffled(cropped_frame(2), 6);
  OrganizedCloud input(static_cast<int>(u.cloud.size()) + 1, 1);  // and an invalid point last
  for (int i = 0; i < u.cloud.width(); ++i) {
    input.x(i, 0) = u.cloud.x(i, 0);
    input.y(i, 0) = u.cloud.y(i, 0);
    input.z(i, 0) = u.cloud.z(i, 0);
  }
  PipelineSettings settings = pipeline_preset("kinect");
  settings.segmentation.model = RegionModel::automatic;
  Pipeline points(settings), grid_pipeline(settings);
  points.process(input);
  const PixelGrid& grid = points.pixel_grid();
  ASSERT_TRUE(grid.found());
  EXPECT_EQ(points.rings().size(), 0u);
  EXPECT_EQ(points.mesh().width(), grid.width);
  EXPECT_GT(points.times().input, 0.0);
  OrganizedCloud restored;
  scatter_to_grid(input, grid, restored);
  grid_pipeline.process(restored, grid.fx);  // the grid's camera sets the smoothing's scale
  EXPECT_FALSE(grid_pipeline.pixel_grid().found());
  const Segmentation& a = points.segmentation();
  const Segmentation& b = grid_pipeline.segmentation();
  ASSERT_EQ(a.labels.width(), input.width());
  ASSERT_EQ(points.cloud().width(), input.width());
  ASSERT_EQ(points.normals().width(), input.width());
  ASSERT_EQ(points.raw_normals().width(), input.width());
  int labelled = 0;
  for (int i = 0; i < input.width(); ++i) {
    const std::int32_t p = grid.pixel[static_cast<std::size_t>(i)];
    if (p < 0) {
      EXPECT_EQ(a.labels(i, 0), 0);
      EXPECT_TRUE(std::isnan(points.normals().nx(i, 0)));
      EXPECT_TRUE(std::isnan(points.cloud().x(i, 0)));
      continue;
    }
    const int c = p % grid.width, v = p / grid.width;
    ASSERT_EQ(a.labels(i, 0), b.labels(c, v)) << i;
    labelled += a.labels(i, 0) > 0 ? 1 : 0;
    ASSERT_TRUE(same_float(points.cloud().x(i, 0), grid_pipeline.cloud().x(c, v)) &&
                same_float(points.cloud().z(i, 0), grid_pipeline.cloud().z(c, v)))
        << i;
    ASSERT_TRUE(
        same_float(points.normals().ny(i, 0), grid_pipeline.normals().ny(c, v)) &&
        same_float(points.raw_normals().nz(i, 0), grid_pipeline.raw_normals().nz(c, v)) &&
        same_float(points.normals().curvature(i, 0), grid_pipeline.normals().curvature(c, v)))
        << i;
  }
  EXPECT_GT(labelled, input.width() / 2);
  ASSERT_EQ(a.segments.size(), b.segments.size());
  EXPECT_GE(a.segments.size(), 5u);
  for (std::size_t s = 0; s < a.segments.size(); ++s) {
    EXPECT_EQ(a.segments[s].pixel_count, b.segments[s].pixel_count);
    EXPECT_EQ(a.segments[s].kind, b.segments[s].kind);
    EXPECT_EQ(a.segments[s].normal, b.segments[s].normal);
    EXPECT_EQ(a.segments[s].area_m2, b.segments[s].area_m2);
  }
  EXPECT_EQ(points.polygons().points3d, grid_pipeline.polygons().points3d);

  // An organized frame next forgets the grid; the points again find it.
  points.process(restored);
  EXPECT_FALSE(points.pixel_grid().found());
  points.process(input);
  EXPECT_TRUE(points.pixel_grid().found());
  // Every grid model runs on the restored grid; over rings incremental_plane is rejected.
  PipelineSettings incremental = pipeline_preset("kinect");
  incremental.segmentation.model = RegionModel::incremental_plane;
  Pipeline on_grid(incremental);
  on_grid.process(input);
  EXPECT_GE(on_grid.segmentation().segments.size(), 5u);
  incremental.restore_grid = false;
  Pipeline over_rings_incremental(incremental);
  EXPECT_THROW(over_rings_incremental.process(input), std::invalid_argument);
  // Rings when asked for, or when the viewpoint is not the camera's origin.
  PipelineSettings rings = settings;
  rings.restore_grid = false;
  Pipeline over_rings(rings);
  over_rings.process(input);
  EXPECT_FALSE(over_rings.pixel_grid().found());
  EXPECT_EQ(over_rings.rings().size(), input.size());
  rings.restore_grid = true;
  rings.rings.viewpoint = {0.0f, 0.0f, -0.1f};
  Pipeline moved(rings);
  moved.process(input);
  EXPECT_FALSE(moved.pixel_grid().found());
}

}  // namespace
}  // namespace rangeseg
