// Moving images, meshes and pipelines: a moved-from object is empty and can be reused, and a
// moved pipeline's results are its own. A pipeline called from two threads at once refuses the
// second call.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "rangeseg/pipeline.hpp"
#include "segmentation_test_util.hpp"

namespace rangeseg {
namespace {

using test::cast;

/// A plane 2 m away with a box in front of it, 320 x 240 (large enough for threads).
OrganizedCloud scene() {
  return cast(320, 240, [](double a, double b) {
    return std::abs(a) < 0.15 && std::abs(b) < 0.1 ? 1.5 : 2.0;
  });
}

TEST(Moves, AMovedFromPlaneOrCloudIsEmptyAndReusable) {
  OrganizedCloud a = scene();
  const OrganizedCloud b(std::move(a));
  EXPECT_EQ(b.width(), 320);
  EXPECT_EQ(a.width(), 0);  // NOLINT(bugprone-use-after-move): what a move leaves is the test
  EXPECT_EQ(a.height(), 0);
  EXPECT_TRUE(a.empty());
  EXPECT_EQ(a.count_valid(), 0u);
  a.resize(8, 4);
  EXPECT_EQ(a.z.width(), 8);
  a.z(7, 3) = 1.0f;

  LabelImage labels(5, 5, 3);
  LabelImage other(2, 2, 1);
  other = std::move(labels);
  EXPECT_EQ(other.width(), 5);
  EXPECT_EQ(other(4, 4), 3);
  EXPECT_EQ(labels.width(), 0);  // NOLINT(bugprone-use-after-move)
  EXPECT_EQ(labels.stride(), 0);

  // A moved-from mesh is an output buffer like any other.
  Mesh mesh = build_mesh(b);
  const Mesh kept = std::move(mesh);
  build_mesh(b, {}, mesh);  // NOLINT(bugprone-use-after-move)
  EXPECT_EQ(mesh.faces.width(), 320);
  EXPECT_EQ(mesh.faces.height(), 240);
  EXPECT_GT(kept.faces.width(), 0);
}

/// A moved-from pipeline processes the next frame as a new one would, with and without threads,
/// and the pipeline it moved into keeps its results.
TEST(Moves, AMovedFromPipelineProcessesTheNextFrame) {
  const OrganizedCloud cloud = scene();
  for (const int threads : {1, 2}) {
    Pipeline fresh({.threads = threads});
    fresh.process(cloud);
    Pipeline p({.threads = threads});
    p.process(cloud);
    const Pipeline q(std::move(p));
    EXPECT_EQ(q.segmentation().segments.size(), fresh.segmentation().segments.size());
    p.process(cloud);  // NOLINT(bugprone-use-after-move)
    ASSERT_EQ(p.segmentation().segments.size(), fresh.segmentation().segments.size()) << threads;
    for (int v = 0; v < cloud.height(); ++v) {
      for (int u = 0; u < cloud.width(); ++u) {
        ASSERT_EQ(p.segmentation().labels(u, v), fresh.segmentation().labels(u, v))
            << u << "," << v;
      }
    }
  }
}

/// cloud() of a frame whose input was the pipeline's own points (a depth image's points fed
/// back, or the smoothed points fed back) is the moved pipeline's, not the old object's.
TEST(Moves, AMovedPipelineKeepsTheCloudOfAFedBackFrame) {
  std::vector<float> depth(std::size_t{160} * 120, 2.0f);
  const CameraIntrinsics camera{
      .fx = 131.25, .fy = 131.25, .cx = 79.5, .cy = 59.5, .width = 160, .height = 120};
  for (const bool smooth : {false, true}) {
    Pipeline p({.smooth = smooth});
    p.process(View<const float>{depth.data(), 160, 120, 160}, camera);
    p.process(p.cloud());
    const float z = p.cloud().z(80, 60);
    Pipeline q(std::move(p));
    p = Pipeline({.smooth = smooth});  // NOLINT(bugprone-use-after-move): the old storage is gone
    const OrganizedCloud other = scene();
    p.process(other);
    ASSERT_EQ(q.cloud().width(), 160) << smooth;
    EXPECT_FLOAT_EQ(q.cloud().z(80, 60), z) << smooth;
    EXPECT_NEAR(q.cloud().z(80, 60), 2.0f, 0.01f) << smooth;
  }
}

/// Two threads calling one pipeline: a call made while the other thread's runs throws
/// std::logic_error and leaves that frame alone; the pipeline then gives a new one's results.
TEST(Moves, APipelineRefusesACallWhileAnotherThreadsRuns) {
  const OrganizedCloud cloud = scene();
  Pipeline fresh;
  fresh.process(cloud);
  Pipeline shared;
  std::atomic<int> refused{0}, done{0};
  const auto call = [&] {
    // Until one call of either thread has been refused, at most 200 calls a thread.
    for (int i = 0; i < 200 && refused.load() == 0; ++i) {
      try {
        shared.process(cloud);
        ++done;
      } catch (const std::logic_error& e) {
        EXPECT_NE(std::string(e.what()).find("another thread"), std::string::npos) << e.what();
        ++refused;
      }
    }
  };
  std::thread other(call);
  call();
  other.join();
  EXPECT_GE(refused.load(), 1);
  EXPECT_GE(done.load(), 1);
  shared.process(cloud);
  ASSERT_EQ(shared.segmentation().segments.size(), fresh.segmentation().segments.size());
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      ASSERT_EQ(shared.segmentation().labels(u, v), fresh.segmentation().labels(u, v));
    }
  }
}

}  // namespace
}  // namespace rangeseg
