// Tests of growth bands (region growing in horizontal bands, pieces joined across seams).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/thread_pool.hpp"
#include "segmentation_test_util.hpp"

namespace rangeseg {
namespace {

using namespace test;  // the segmentation test helpers

/// Growth bands cut every region that crosses a seam; merging over the whole frame joins the
/// pieces again. A noisy floor-like plane crossing all three seams of 4 bands is one segment as
/// large as without bands, and a crease across the seams still splits the frame where it runs
/// (noise of half the Kinect preset's sigma(z) along the ray, no smoothing).
TEST(Segmentation, GrowthBandSeamsAreJoinedButCreasesAreNot) {
  SegmentationSettings settings = preset("kinect");
  std::mt19937 rng(7);
  std::normal_distribution<double> unit(0.0, 1.0);
  const auto noisy = [&](const std::function<double(double, double)>& depth) {
    return cast(640, 480, [&](double a, double b) {
      const double t = depth(a, b);
      return t + 0.5 * settings.noise.sigma(t) * unit(rng);
    });
  };
  // A plane tilted 40 deg about the x axis, 1.5 m away at the image centre.
  const double tilt = std::tan(40 * kDeg);
  const OrganizedCloud floor = noisy([tilt](double, double b) { return 1.5 / (1.0 - tilt * b); });
  const Stages whole = run(floor, settings);
  settings.growth_bands = 4;
  const Stages banded = run(floor, settings);
  expect_consistent(floor, banded.seg, settings);
  ASSERT_EQ(whole.seg.segments.size(), 1u);
  ASSERT_EQ(banded.seg.segments.size(), 1u);
  EXPECT_GT(banded.seg.segments[0].pixel_count, 0.95 * 640 * 480);
  EXPECT_NEAR(banded.seg.segments[0].pixel_count, whole.seg.segments[0].pixel_count,
              0.002 * 640 * 480);
  EXPECT_LT(angle_deg(banded.seg.segments[0].normal, whole.seg.segments[0].normal), 0.05);

  // Two planes at 1.2 m meeting at a 30 deg crease along the column u = 320.
  const double slope = std::tan(30 * kDeg);
  const OrganizedCloud crease =
      noisy([slope](double a, double) { return a <= 0 ? 1.2 : 1.2 / (1.0 - slope * a); });
  const Stages q = run(crease, settings);
  expect_consistent(crease, q.seg, settings);
  ASSERT_EQ(q.seg.segments.size(), 2u);
  for (const int v : {20, 130, 240, 350, 460}) {
    EXPECT_EQ(q.seg.labels(100, v), q.seg.labels(100, 20)) << v;
    EXPECT_EQ(q.seg.labels(540, v), q.seg.labels(540, 20)) << v;
  }
  EXPECT_NE(q.seg.labels(100, 20), q.seg.labels(540, 20));
  EXPECT_NE(q.seg.labels(100, 20), 0);
  EXPECT_NE(q.seg.labels(540, 20), 0);
}

/// A surface that a band seam cuts into pieces, each below min_region_size (and too narrow to
/// be kept as a wide face), is kept as with one band: the pieces count together. Here an
/// 18 x 18 pixel square 1 m in front of a wall at 2 m, its centre on the seam of 2 bands at row
/// 240: 162 pixels above and below, against a minimum of 200. (Before, both were removed before
/// merging could join them.)
TEST(Segmentation, SurfaceCutByASeamIsKeptWhenItsPiecesAreSmall) {
  const OrganizedCloud cloud = cast(640, 480, [](double a, double b) {
    const double u = a * kF + kCx, v = b * kF + kCy;
    return (u >= 311 && u < 329 && v >= 231 && v < 249) ? 1.0 : 2.0;
  });
  SegmentationSettings settings = preset("kinect");
  ASSERT_EQ(settings.min_region_size, 200);
  for (const int bands : {1, 2}) {
    settings.growth_bands = bands;
    const Stages p = run(cloud, settings);
    expect_consistent(cloud, p.seg, settings);
    ASSERT_EQ(p.seg.segments.size(), 2u) << bands << " bands";
    const Segment& square = p.seg.segments[1];
    EXPECT_GE(square.pixel_count, 17 * 17) << bands << " bands";
    EXPECT_NEAR(square.offset, 1.0, 1e-3) << bands << " bands";
    EXPECT_EQ(p.seg.labels(320, 235), square.label) << bands << " bands";
    EXPECT_EQ(p.seg.labels(320, 245), square.label) << bands << " bands";
  }
}

/// A band is at least 4 cell rows tall: more bands than that allows give the largest count
/// that fits (7 at 240 rows = 30 cell rows; 3 at 241 rows with mesh stride 2 = 15 cell rows of
/// lattice rows, the last band taking the partial cell row; 1 at 48 rows), and the results with
/// a thread pool equal those without (bands are split among the threads, never the other way
/// round).
TEST(Segmentation, GrowthBandsAreClampedAndIndependentOfThreads) {
  const auto boxes = [](double a, double b) {
    return a < -0.1 ? 1.2 : (b > 0.05 ? 1.0 / (0.8 + 0.4 * b) : 1.6 - 0.5 * a);
  };
  struct Case {
    int height, stride, bands;
  };
  for (const Case c : {Case{240, 1, 7}, Case{241, 2, 3}, Case{48, 1, 1}}) {
    const OrganizedCloud cloud = cast(320, c.height, boxes);
    const Mesh mesh = build_mesh(cloud, {.pixel_stride = c.stride});
    const NormalMap normals = compute_normals(cloud, mesh);
    SegmentationSettings settings = preset("kinect");
    settings.growth_bands = c.bands;
    const Segmentation expected = segment(cloud, mesh, normals, settings);
    expect_consistent(cloud, expected, settings);
    ASSERT_GE(expected.segments.size(), 2u) << c.height;
    settings.growth_bands = 64;
    for (const int threads : {1, 2, 3}) {
      Segmenter segmenter;
      ThreadPool pool(threads);
      Segmentation out;
      segmenter.segment(cloud, mesh, normals, settings, out, pool);
      ASSERT_EQ(out.segments.size(), expected.segments.size()) << c.height << " " << threads;
      for (int v = 0; v < c.height; ++v) {
        for (int u = 0; u < 320; ++u) {
          ASSERT_EQ(out.labels(u, v), expected.labels(u, v))
              << u << "," << v << " " << c.height << " " << threads;
        }
      }
    }
  }
}

/// Growth bands on frames of many shapes (thin, tiny, odd heights, mesh strides 1-3, holes):
/// never a crash, and the same segmentation with and without threads.
TEST(Segmentation, GrowthBandsOnAnyFrameShape) {
  std::mt19937 rng(5);
  for (const int height : {2, 31, 32, 33, 63, 97, 130}) {
    for (const int width : {2, 3, 40}) {
      for (const int stride : {1, 2, 3}) {
        std::uniform_real_distribution<double> hole(0.0, 1.0);
        const OrganizedCloud cloud = cast(width, height, [&](double a, double b) {
          return hole(rng) < 0.05 ? NAN : (b > 0.0 ? 1.0 + 0.3 * a : 1.5);
        });
        const Mesh mesh = build_mesh(cloud, {.pixel_stride = stride});
        const NormalMap normals = compute_normals(cloud, mesh);
        SegmentationSettings settings = preset("kinect");
        settings.min_region_size = 4;
        settings.growth_bands = 64;
        const Segmentation one = segment(cloud, mesh, normals, settings);
        expect_consistent(cloud, one, settings);
        ThreadPool pool(2);
        Segmenter segmenter;
        Segmentation two;
        segmenter.segment(cloud, mesh, normals, settings, two, pool);
        ASSERT_EQ(two.segments.size(), one.segments.size()) << width << "x" << height;
        for (int v = 0; v < height; ++v) {
          for (int u = 0; u < width; ++u) ASSERT_EQ(two.labels(u, v), one.labels(u, v));
        }
      }
    }
  }
}

}  // namespace
}  // namespace rangeseg
