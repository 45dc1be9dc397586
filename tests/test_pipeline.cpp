// The frame pipeline: results equal the stage-by-stage calls, and no heap allocation per frame.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "rangeseg/pipeline.hpp"
#include "rangeseg/synth.hpp"

namespace {
std::atomic<long> g_allocations{0};
}  // namespace

// Counting allocator for this test binary: every operator new goes through here.
void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

using namespace rangeseg;

namespace {
// Quarter-VGA keeps the test quick (also under sanitizers); the code paths are the same.
synth::Rendering qvga(std::uint64_t seed) {
  const CameraIntrinsics camera{
      .fx = 262.5, .fy = 262.5, .cx = 159.5, .cy = 119.5, .width = 320, .height = 240};
  return synth::render(synth::random_scene(seed),
                       {.camera = camera, .noise = synth::Noise::kinect, .seed = seed});
}
}  // namespace

TEST(Pipeline, MatchesTheStagesCalledOneByOne) {
  const synth::Rendering r = qvga(5);
  PipelineSettings settings = pipeline_preset("kinect");
  Pipeline pipeline(settings);
  pipeline.process(r.cloud);

  const Mesh mesh = build_mesh(r.cloud, settings.mesh);
  const NormalMap normals = compute_normals(r.cloud, mesh, settings.normals);
  const SmoothedCloud smoothed = smooth(r.cloud, mesh, normals, settings.smoothing);
  const Segmentation seg = segment(smoothed.cloud, mesh, smoothed.normals, settings.segmentation);

  ASSERT_EQ(count_faces(pipeline.mesh()), count_faces(mesh));
  ASSERT_EQ(pipeline.segmentation().segments.size(), seg.segments.size());
  for (int v = 0; v < r.cloud.height(); ++v) {
    for (int u = 0; u < r.cloud.width(); ++u) {
      ASSERT_EQ(pipeline.segmentation().labels(u, v), seg.labels(u, v)) << u << "," << v;
    }
  }
  EXPECT_GT(pipeline.times().total, 0.0);
  EXPECT_GE(pipeline.times().total, pipeline.times().mesh + pipeline.times().segmentation);
}

TEST(Pipeline, NoAllocationPerFrameAfterTheFirst) {
  // Two different frames of the same size, alternating: buffers sized by the first must serve both.
  const synth::Rendering a = qvga(1);
  const synth::Rendering b = qvga(2);
  Pipeline pipeline(pipeline_preset("kinect"));
  for (int warmup = 0; warmup < 3; ++warmup) {
    pipeline.process(a.cloud);
    pipeline.process(b.cloud);
  }
  const long before = g_allocations.load();
  for (int frame = 0; frame < 4; ++frame) pipeline.process(frame % 2 == 0 ? a.cloud : b.cloud);
  EXPECT_EQ(g_allocations.load() - before, 0) << "heap allocations in 4 frames after warm-up";
  EXPECT_FALSE(pipeline.segmentation().segments.empty());
}

TEST(Pipeline, RejectsUnorganizedClouds) {
  Pipeline pipeline;
  EXPECT_THROW(pipeline.process(OrganizedCloud(100, 1)), std::invalid_argument);
  EXPECT_THROW(pipeline_preset("no-such-sensor"), std::invalid_argument);
}
