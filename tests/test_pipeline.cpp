// The frame pipeline: results equal the stage-by-stage calls, and no heap allocation per frame
// (segment tracking included).
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <limits>
#include <new>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "polygon_test_util.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/synth.hpp"
#include "segmentation_test_util.hpp"

namespace {
std::atomic<long> g_allocations{0};
/// The allocation (by g_allocations' count) that fails with std::bad_alloc, as if memory had run
/// out there; -1: none.
std::atomic<long> g_fail_allocation{-1};

void fail_if_asked(long count) {
  if (count == g_fail_allocation.load(std::memory_order_relaxed)) throw std::bad_alloc();
}
}  // namespace

// Counting allocator for this test binary: every operator new goes through here.
void* operator new(std::size_t size) {
  fail_if_asked(g_allocations.fetch_add(1, std::memory_order_relaxed) + 1);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
// Image planes and row buffers are cache-line aligned: count those too.
void* operator new(std::size_t size, std::align_val_t alignment) {
  fail_if_asked(g_allocations.fetch_add(1, std::memory_order_relaxed) + 1);
  const auto a = static_cast<std::size_t>(alignment);
  const std::size_t rounded = (std::max<std::size_t>(size, 1) + a - 1) / a * a;
  if (void* p = std::aligned_alloc(a, rounded)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

using namespace rangeseg;
using rangeseg::test::expect_identical_polygons;

namespace {
// Quarter-VGA keeps the test quick (also under sanitizers); the code paths are the same.
constexpr CameraIntrinsics kQvgaCamera{
    .fx = 262.5, .fy = 262.5, .cx = 159.5, .cy = 119.5, .width = 320, .height = 240};
synth::Rendering qvga(std::uint64_t seed) {
  return synth::render(synth::random_scene(seed),
                       {.camera = kQvgaCamera, .noise = synth::Noise::kinect, .seed = seed});
}
}  // namespace

TEST(Pipeline, MinimumSegmentSizeIsASolidAngle) {
  SegmentationSettings kinect = preset("kinect");
  EXPECT_EQ(min_region_size_for(kinect, 525.0), 200);
  EXPECT_EQ(min_region_size_for(kinect, 262.5), 50);
  EXPECT_EQ(min_region_size_for(kinect, 1050.0), 200) << "a finer camera keeps the count";
  EXPECT_EQ(min_region_size_for(kinect, 0.0), 200) << "unknown camera";
  EXPECT_EQ(min_region_size_for(kinect, 131.25), 49) << "a pixel seed's window, not 12.5";
  kinect.seed_clearance = 0;
  EXPECT_EQ(min_region_size_for(kinect, 1.0), 1) << "never below 1";
  kinect.seed_clearance = 3;
  kinect.min_region_size = 20;
  EXPECT_EQ(min_region_size_for(kinect, 262.5), 20) << "not above the size given";
  EXPECT_EQ(min_region_size_for(kinect, 131.25), 20);
  kinect.min_region_size = 200;
  kinect.min_region_fx = 0;
  EXPECT_EQ(min_region_size_for(kinect, 262.5), 200) << "the frame's own pixels";
  EXPECT_EQ(min_region_size_for(preset("laser"), 262.5), 50) << "a scanner's grid";

  // A 9 x 9 cm square 40 cm in front of a wall at 2 m: 18 x 18 pixels at 640x480, 9 x 9 at
  // 320x240, below the 200 pixels of the preset there but above its 50.
  const auto square_segment_pixels = [](int scale, double min_region_fx, int pixel_stride = 1) {
    const CameraIntrinsics camera{.fx = 525.0 / scale,
                                  .fy = 525.0 / scale,
                                  .cx = 319.5 / scale,
                                  .cy = 239.5 / scale,
                                  .width = 640 / scale,
                                  .height = 480 / scale};
    FloatPlane depth(camera.width, camera.height);
    const int side = 18 / scale, u0 = 400 / scale, v0 = 100 / scale;
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        const bool square = u >= u0 && u < u0 + side && v >= v0 && v < v0 + side;
        depth(u, v) = square ? 1.6f : 2.0f;
      }
    }
    PipelineSettings settings = pipeline_preset("ideal");
    settings.segmentation.min_region_size = 200;
    settings.segmentation.min_region_fx = min_region_fx;
    settings.mesh.pixel_stride = pixel_stride;
    Pipeline pipeline(settings);
    pipeline.process(depth.view(), camera);
    // The square's centre, on the mesh's lattice (off it no pixel has a label).
    const int u = (u0 + side / 2) / pixel_stride * pixel_stride;
    const int v = (v0 + side / 2) / pixel_stride * pixel_stride;
    const int label = pipeline.segmentation().labels(u, v);
    return label > 0 ? pipeline.segmentation().segments[label - 1].pixel_count : 0;
  };
  EXPECT_GE(square_segment_pixels(1, 525.0), 16 * 16);
  EXPECT_GE(square_segment_pixels(2, 525.0), 8 * 8) << "50 pixels at 320x240";
  EXPECT_EQ(square_segment_pixels(2, 0.0), 0) << "200 of the frame's own pixels";
  // Every 2nd pixel of the 640x480 frame: regions count 9 x 9 lattice vertices, as at 320x240.
  EXPECT_GE(square_segment_pixels(1, 525.0, 2), 8 * 8) << "50 lattice vertices";
  EXPECT_EQ(square_segment_pixels(1, 0.0, 2), 0) << "200 lattice vertices";
}

TEST(Pipeline, MatchesTheStagesCalledOneByOne) {
  const synth::Rendering r = qvga(5);
  PipelineSettings settings = pipeline_preset("kinect");
  // The free function knows no camera; the pipeline would fit it to the points.
  settings.smoothing.pixel_angle = static_cast<float>(1.0 / kQvgaCamera.fx);
  Pipeline pipeline(settings);
  pipeline.process(r.cloud);

  const Mesh mesh = build_mesh(r.cloud, settings.mesh);
  const NormalMap normals = compute_normals(r.cloud, mesh, settings.normals);
  const SmoothedCloud smoothed = smooth(r.cloud, mesh, normals, settings.smoothing);
  // Nor does it scale the minimum segment size to the camera's resolution.
  SegmentationSettings at_qvga = settings.segmentation;
  at_qvga.min_region_size = min_region_size_for(at_qvga, kQvgaCamera.fx);
  ASSERT_EQ(at_qvga.min_region_size, 50);
  const Segmentation seg = segment(smoothed.cloud, mesh, smoothed.normals, at_qvga);

  // The pipeline closes the cells of grazing planes in its mesh after segmentation.
  Mesh closed = mesh;
  close_grazing_cells(seg, closed);
  ASSERT_EQ(count_faces(pipeline.mesh()), count_faces(closed));
  ASSERT_EQ(pipeline.segmentation().segments.size(), seg.segments.size());
  for (int v = 0; v < r.cloud.height(); ++v) {
    for (int u = 0; u < r.cloud.width(); ++u) {
      ASSERT_EQ(pipeline.segmentation().labels(u, v), seg.labels(u, v)) << u << "," << v;
    }
  }
  EXPECT_GT(pipeline.times().total, 0.0);
  EXPECT_GE(pipeline.times().total, pipeline.times().mesh + pipeline.times().segmentation);
}

/// Every field of two segmentations and polygon sets, bit for bit.
void expect_same_output(const Pipeline& a, const Pipeline& b, const std::string& what) {
  const Segmentation& sa = a.segmentation();
  const Segmentation& sb = b.segmentation();
  ASSERT_EQ(sa.segments.size(), sb.segments.size()) << what;
  for (int v = 0; v < sa.labels.height(); ++v) {
    ASSERT_EQ(
        std::memcmp(sa.labels.row(v), sb.labels.row(v), sizeof(std::int32_t) * sa.labels.width()),
        0)
        << what << " row " << v;
  }
  for (std::size_t i = 0; i < sa.segments.size(); ++i) {
    const Segment &x = sa.segments[i], &y = sb.segments[i];
    const auto fields = [](const Segment& g) {
      return std::tuple(g.label, g.model, g.pixel_count, g.area_m2, g.centroid, g.normal, g.offset,
                        g.rms_residual, g.kind, g.surface_rms, g.centre, g.axis, g.radius, g.extent,
                        g.grazing);
    };
    EXPECT_TRUE(fields(x) == fields(y))
        << what << " segment " << x.label << ": radius " << x.radius << " / " << y.radius;
  }
  expect_identical_polygons(a.polygons(), b.polygons(), what);
}

TEST(Pipeline, ReusedOverFramesOfOtherSizesGivesWhatAFreshOneGives) {
  // One pipeline, frames of changing size and content (with spheres and cylinders), against a
  // new pipeline per frame: no buffer or segment may carry anything over from an earlier frame.
  const auto scene = [](std::uint64_t seed, int width, int height) {
    const double f = 0.82 * width;
    const CameraIntrinsics camera{
        .fx = f, .fy = f, .cx = width / 2.0, .cy = height / 2.0, .width = width, .height = height};
    return synth::render(synth::random_scene(seed, true),
                         {.camera = camera, .noise = synth::Noise::kinect, .seed = seed})
        .cloud;
  };
  const std::vector<OrganizedCloud> frames = {scene(1, 320, 240), scene(2, 160, 120),
                                              scene(3, 333, 251), scene(4, 320, 240),
                                              scene(1, 320, 240)};
  for (const RegionModel model : {RegionModel::plane, RegionModel::smooth,
                                  RegionModel::incremental_plane, RegionModel::automatic}) {
    for (const int threads : {1, 2}) {
      PipelineSettings settings = pipeline_preset("kinect");
      settings.segmentation.model = model;
      settings.threads = threads;
      Pipeline reused(settings);
      for (std::size_t k = 0; k < frames.size(); ++k) {
        reused.process(frames[k]);
        Pipeline fresh(settings);
        fresh.process(frames[k]);
        expect_same_output(reused, fresh,
                           std::string(to_string(model)) + ", " + std::to_string(threads) +
                               " threads, frame " + std::to_string(k));
      }
    }
  }
}

/// The first of the random QVGA scenes 3.. whose segmentation the split of regions one plane does
/// not explain changes (SegmentationSettings::split_residual_factor), so that its code runs.
synth::Rendering qvga_with_a_split() {
  for (std::uint64_t seed = 3; seed < 20; ++seed) {
    synth::Rendering r = qvga(seed);
    PipelineSettings settings = pipeline_preset("kinect");
    Pipeline with(settings);
    settings.segmentation.split_residual_factor = 0;
    Pipeline without(settings);
    with.process(r.cloud);
    without.process(r.cloud);
    if (with.segmentation().segments.size() != without.segmentation().segments.size()) return r;
  }
  ADD_FAILURE() << "no random QVGA scene in which a region is split";
  return qvga(3);
}

// A frame that runs out of memory at any of its allocations throws std::bad_alloc and leaves
// the pipeline able to run the next frame as a new pipeline would (before, a stage that failed
// midway left buffers whose sizes disagreed, and the next frame could crash in the polygons).
// Every allocation of a first frame, and of a larger frame after it, fails once in turn.
TEST(Pipeline, AFrameThatRunsOutOfMemoryLeavesThePipelineAsGoodAsNew) {
  constexpr CameraIntrinsics kSmall{
      .fx = 131.25, .fy = 131.25, .cx = 79.5, .cy = 59.5, .width = 160, .height = 120};
  const OrganizedCloud small =
      synth::render(synth::random_scene(4),
                    {.camera = kSmall, .noise = synth::Noise::kinect, .seed = 4})
          .cloud;
  const OrganizedCloud& large = qvga(5).cloud;
  PipelineSettings settings = pipeline_preset("kinect");
  settings.track = true;
  Pipeline fresh(settings);
  fresh.process(large);
  const Segmentation expected = fresh.segmentation();
  const PolygonSet expected_polygons = fresh.polygons();
  ASSERT_GT(expected.segments.size(), 3U);
  const auto same_labels = [](const LabelImage& a, const LabelImage& b) {
    if (a.width() != b.width() || a.height() != b.height()) return false;
    for (int v = 0; v < a.height(); ++v) {
      if (!std::equal(a.row(v), a.row(v) + a.width(), b.row(v))) return false;
    }
    return true;
  };
  for (const bool warm : {false, true}) {
    // The allocations of the frame that fails, counted once without a failure.
    Pipeline counting(settings);
    if (warm) counting.process(small);
    const long first = g_allocations.load();
    counting.process(large);
    const long allocations = g_allocations.load() - first;
    ASSERT_GT(allocations, 20);
    int failed = 0;
    for (long k = 1; k <= allocations; ++k) {
      Pipeline pipeline(settings);
      if (warm) pipeline.process(small);
      g_fail_allocation = g_allocations.load() + k;
      try {
        pipeline.process(large);
      } catch (const std::bad_alloc&) {
        ++failed;
      }
      g_fail_allocation = -1;
      pipeline.process(large);
      const std::string at = (warm ? "after a smaller frame, " : "first frame, ") +
                             std::string("allocation ") + std::to_string(k);
      ASSERT_EQ(pipeline.segmentation().segments.size(), expected.segments.size()) << at;
      ASSERT_TRUE(same_labels(pipeline.segmentation().labels, expected.labels)) << at;
      expect_identical_polygons(pipeline.polygons(), expected_polygons, at);
    }
    EXPECT_EQ(failed, allocations) << "every allocation of the frame was made to fail once";
  }
}

TEST(Pipeline, NoAllocationPerFrameAfterTheFirst) {
  // Three different frames of the same size in turn (one with a region that is split): buffers
  // sized by the first must serve all.
  const synth::Rendering a = qvga(1);
  const synth::Rendering b = qvga(2);
  const synth::Rendering c = qvga_with_a_split();
  const auto frame_of = [&](int i) -> const OrganizedCloud& {
    return i % 3 == 0 ? a.cloud : i % 3 == 1 ? b.cloud : c.cloud;
  };
  for (const int threads : {1, 2}) {
    PipelineSettings settings = pipeline_preset("kinect");
    settings.threads = threads;
    settings.segmentation.growth_bands = threads;
    settings.track = true;
    Pipeline pipeline(settings);
    for (int warmup = 0; warmup < 9; ++warmup) pipeline.process(frame_of(warmup));
    const long before = g_allocations.load();
    for (int frame = 0; frame < 6; ++frame) pipeline.process(frame_of(frame));
    EXPECT_EQ(g_allocations.load() - before, 0)
        << "heap allocations in 6 frames after warm-up, " << threads << " threads";
    EXPECT_FALSE(pipeline.segmentation().segments.empty());
  }
}

// The auto model fits hundreds of candidate spheres and cylinders a frame, and unorganized
// clouds add the k-d tree and the passes over rings: their buffers too are sized by the first
// frames. (nanoflann takes the tree's nodes from its own pool through malloc, not operator new:
// 8 KB blocks, freed and taken again at each build.)
TEST(Pipeline, AutoModelAndUnorganizedFramesAllocateNothingAfterWarmUp) {
  const auto render = [](std::uint64_t seed, const CameraIntrinsics& camera) {
    return synth::render(synth::random_scene(seed, true),
                         {.camera = camera, .noise = synth::Noise::kinect, .seed = seed})
        .cloud;
  };
  // Unorganized frames at 160 x 120 keep the test quick under sanitizers.
  constexpr CameraIntrinsics kQqvga{
      .fx = 131.25, .fy = 131.25, .cx = 79.5, .cy = 59.5, .width = 160, .height = 120};
  std::vector<OrganizedCloud> grids, points;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    grids.push_back(render(seed, kQvgaCamera));
    points.push_back(shuffled_valid_points(render(seed, kQqvga), seed));
  }
  // The shuffled points of a rendering lie on its pixel grid (whose bounding box changes from
  // frame to frame): both the rings and the restored grid.
  struct Case {
    const std::vector<OrganizedCloud>* frames;
    RegionModel model;
    int threads;
    bool restore_grid;
    const char* what;
  };
  for (const Case& c :
       {Case{&grids, RegionModel::automatic, 1, true, "grid, auto, 1 thread"},
        Case{&grids, RegionModel::automatic, 2, true, "grid, auto, 2 threads"},
        Case{&points, RegionModel::plane, 1, false, "unorganized, plane"},
        Case{&points, RegionModel::automatic, 1, false, "unorganized, auto"},
        Case{&points, RegionModel::automatic, 1, true, "unorganized on its pixel grid, auto"},
        Case{&points, RegionModel::plane, 2, true, "unorganized on its pixel grid, 2 threads"}}) {
    PipelineSettings settings = pipeline_preset("kinect");
    settings.segmentation.model = c.model;
    settings.threads = c.threads;
    settings.restore_grid = c.restore_grid;
    Pipeline pipeline(settings);
    for (int warmup = 0; warmup < 3; ++warmup) pipeline.process((*c.frames)[warmup % 3]);
    int curved = 0;
    const long before = g_allocations.load();
    // In another order than the warm-up: buffers that trade places (double buffers) end a
    // frame in either role, so each must have grown to the largest set either role has seen.
    for (const int frame : {2, 0, 1, 1, 2, 0}) {
      pipeline.process((*c.frames)[static_cast<std::size_t>(frame)]);
      for (const Segment& g : pipeline.segmentation().segments) {
        curved += g.kind == SurfaceKind::sphere || g.kind == SurfaceKind::cylinder;
      }
    }
    EXPECT_EQ(g_allocations.load() - before, 0) << c.what;
    EXPECT_EQ(pipeline.pixel_grid().found(), c.frames == &points && c.restore_grid) << c.what;
    // The fits ran: these scenes have spheres and cylinders (too small at 160 x 120 for the
    // grid's primitive pass).
    if (c.model == RegionModel::automatic && (c.frames == &grids || !c.restore_grid)) {
      EXPECT_GT(curved, 0) << c.what;
    }
  }
}

// A camera loop: depth images (millimetres, and metres as float) in, one pipeline, nothing
// allocated after the first frame, and the depth-to-points conversion into a reused cloud.
TEST(Pipeline, DepthImageFramesAllocateNothingAfterTheFirst) {
  const DepthImage a = cloud_to_depth(qvga(1).cloud, 0.001);
  const DepthImage b = cloud_to_depth(qvga(2).cloud, 0.001);
  FloatPlane metres(a.width(), a.height());
  for (int v = 0; v < a.height(); ++v) {
    for (int u = 0; u < a.width(); ++u) {
      metres(u, v) = a(u, v) == 0 ? std::numeric_limits<float>::quiet_NaN() : 0.001f * a(u, v);
    }
  }
  for (const int threads : {1, 2}) {
    PipelineSettings settings = pipeline_preset("kinect");
    settings.threads = threads;
    settings.track = true;
    Pipeline pipeline(settings);
    for (int warmup = 0; warmup < 4; ++warmup) {
      pipeline.process((warmup % 2 == 0 ? a : b).view(), kQvgaCamera, 0.001);
      pipeline.process(metres.view(), kQvgaCamera);
    }
    const long before = g_allocations.load();
    for (int frame = 0; frame < 4; ++frame) {
      pipeline.process((frame % 2 == 0 ? a : b).view(), kQvgaCamera, 0.001);
      pipeline.process(metres.view(), kQvgaCamera);
    }
    EXPECT_EQ(g_allocations.load() - before, 0) << threads << " threads";
    EXPECT_FALSE(pipeline.segmentation().segments.empty());
    EXPECT_GT(pipeline.times().input, 0.0);
    EXPECT_GE(pipeline.times().total, pipeline.times().input + pipeline.times().segmentation);
  }
  OrganizedCloud cloud;
  depth_to_cloud(a.view(), kQvgaCamera, 0.001, cloud);
  const long before = g_allocations.load();
  depth_to_cloud(b.view(), kQvgaCamera, 0.001, cloud);
  depth_to_cloud(metres.view(), kQvgaCamera, cloud);
  EXPECT_EQ(g_allocations.load() - before, 0);
}

template <class T>
bool same_bits(const Plane<T>& a, const Plane<T>& b) {
  if (a.width() != b.width() || a.height() != b.height()) return false;
  for (int v = 0; v < a.height(); ++v) {
    if (std::memcmp(a.row(v), b.row(v), sizeof(T) * static_cast<std::size_t>(a.width())) != 0) {
      return false;
    }
  }
  return true;
}

/// Every output of a threaded frame equals the single-threaded one bit for bit, for 2 and 3
/// threads (uneven bands) and both the smoothed and the raw path (the latter grown in 3 growth
/// bands).
TEST(Pipeline, ThreadsInsideAFrameGiveIdenticalResults) {
  const synth::Rendering scene = qvga(3);
  for (const bool smooth : {true, false}) {
    PipelineSettings settings = pipeline_preset("kinect");
    settings.smooth = smooth;
    settings.segmentation.growth_bands = smooth ? 1 : 3;  // 3 bands on 2 and 3 threads
    settings.smoothing.iterations = 2;
    Pipeline reference(settings);
    reference.process(scene.cloud);
    for (const int threads : {2, 3}) {
      settings.threads = threads;
      Pipeline threaded(settings);
      threaded.process(scene.cloud);
      const std::string what =
          std::to_string(threads) + " threads, smooth " + std::to_string(smooth);
      EXPECT_TRUE(same_bits(threaded.mesh().edges, reference.mesh().edges)) << what;
      EXPECT_TRUE(same_bits(threaded.mesh().faces, reference.mesh().faces)) << what;
      EXPECT_TRUE(same_bits(threaded.raw_normals().nz, reference.raw_normals().nz)) << what;
      EXPECT_TRUE(same_bits(threaded.raw_normals().curvature, reference.raw_normals().curvature))
          << what;
      EXPECT_TRUE(same_bits(threaded.cloud().x, reference.cloud().x)) << what;
      EXPECT_TRUE(same_bits(threaded.cloud().z, reference.cloud().z)) << what;
      EXPECT_TRUE(same_bits(threaded.normals().nx, reference.normals().nx)) << what;
      EXPECT_TRUE(same_bits(threaded.normals().ny, reference.normals().ny)) << what;
      EXPECT_TRUE(same_bits(threaded.segmentation().labels, reference.segmentation().labels))
          << what;
      ASSERT_EQ(threaded.segmentation().segments.size(), reference.segmentation().segments.size());
      ASSERT_FALSE(reference.segmentation().segments.empty());
      // Areas are summed alongside the polygons with threads: the same sums.
      for (std::size_t j = 0; j < reference.segmentation().segments.size(); ++j) {
        const double area = reference.segmentation().segments[j].area_m2;
        EXPECT_GT(area, 0.0) << what << " segment " << j;
        EXPECT_EQ(std::bit_cast<std::uint64_t>(threaded.segmentation().segments[j].area_m2),
                  std::bit_cast<std::uint64_t>(area))
            << what << " segment " << j;
      }
      expect_identical_polygons(threaded.polygons(), reference.polygons(), what);
    }
  }
}

/// A depth image gives bit for bit what its cloud gives, for raw units and metres, with one and
/// two threads; pixels without a measurement (0; NaN, infinite or <= 0 metres) are no points.
TEST(Pipeline, DepthImagesGiveWhatTheirCloudsGive) {
  const DepthImage depth = cloud_to_depth(qvga(4).cloud, 0.001);
  FloatPlane metres(depth.width(), depth.height());
  for (int v = 0; v < depth.height(); ++v) {
    for (int u = 0; u < depth.width(); ++u) {
      metres(u, v) = depth(u, v) == 0 ? 0.0f : 0.001f * depth(u, v);
    }
  }
  const float odd[] = {std::numeric_limits<float>::quiet_NaN(),
                       std::numeric_limits<float>::infinity(), -1.0f, 0.0f};
  for (int k = 0; k < 4; ++k) metres(10 + k, 20) = odd[k];
  const OrganizedCloud from_raw = depth_to_cloud(depth.view(), kQvgaCamera, 0.001);
  OrganizedCloud from_metres;
  depth_to_cloud(metres.view(), kQvgaCamera, from_metres);
  for (int k = 0; k < 4; ++k) EXPECT_FALSE(from_metres.valid(10 + k, 20)) << k;
  EXPECT_EQ(from_raw.count_valid(),
            from_metres.count_valid() + 4 -
                static_cast<std::size_t>(std::count_if(depth.row(20) + 10, depth.row(20) + 14,
                                                       [](std::uint16_t d) { return d == 0; })));
  for (const int threads : {1, 2}) {
    PipelineSettings settings = pipeline_preset("kinect");
    settings.threads = threads;
    Pipeline from_depth(settings), from_cloud(settings);
    from_depth.process(depth.view(), kQvgaCamera, 0.001);
    from_cloud.process(from_raw, kQvgaCamera.fx);
    EXPECT_TRUE(same_bits(from_depth.cloud().z, from_cloud.cloud().z)) << threads;
    EXPECT_TRUE(same_bits(from_depth.segmentation().labels, from_cloud.segmentation().labels));
    from_depth.process(metres.view(), kQvgaCamera);
    from_cloud.process(from_metres, kQvgaCamera.fx);
    EXPECT_TRUE(same_bits(from_depth.segmentation().labels, from_cloud.segmentation().labels));
    EXPECT_TRUE(same_bits(from_depth.cloud().x, from_cloud.cloud().x));
  }
  Pipeline pipeline;
  EXPECT_THROW(pipeline.process(depth.view(), kQvgaCamera, 0.0), std::invalid_argument);
  EXPECT_THROW(pipeline.process(depth.view(), CameraIntrinsics{.fx = 0}, 0.001),
               std::invalid_argument);
  EXPECT_THROW(pipeline.process(metres.view(), CameraIntrinsics{.fx = NAN}), std::invalid_argument);
  // A driver's buffer wrapped wrongly: a stride shorter than a row, or no data.
  EXPECT_THROW(
      pipeline.process(View<const std::uint16_t>{depth.row(0), 320, 240, 100}, kQvgaCamera, 0.001),
      std::invalid_argument);
  EXPECT_THROW(pipeline.process(View<const float>{nullptr, 320, 240, 320}, kQvgaCamera),
               std::invalid_argument);
  // A negative width names the view, not an internal buffer.
  try {
    pipeline.process(View<const std::uint16_t>{depth.row(0), -64, 48, 320}, kQvgaCamera, 0.001);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("depth image needs at least 1 column and 2 rows, got -64"),
              std::string::npos)
        << e.what();
  }
  OrganizedCloud cloud;
  EXPECT_THROW(depth_to_cloud(View<const float>{nullptr, 4, 4, 4}, kQvgaCamera, cloud),
               std::invalid_argument);
  // Intrinsics stated for another image size, and one row (which would run as an unorganized
  // cloud over rings).
  CameraIntrinsics vga = kQvgaCamera;
  vga.width = 640;
  vga.height = 480;
  EXPECT_THROW(pipeline.process(depth.view(), vga, 0.001), std::invalid_argument);
  EXPECT_THROW(depth_to_cloud(metres.view(), vga, cloud), std::invalid_argument);
  CameraIntrinsics any_size = vga;
  any_size.width = any_size.height = 0;
  EXPECT_NO_THROW(depth_to_cloud(metres.view(), any_size, cloud));
  EXPECT_THROW(pipeline.process(View<const std::uint16_t>{depth.row(0), 320, 1, 320}, any_size),
               std::invalid_argument);
}

/// A depth image rejected for its intrinsics leaves the last frame's results as they were, also
/// when it has another size: without smoothing, cloud() is the pipeline's own points of the
/// last image, which the rejected one must not have resized.
TEST(Pipeline, ARejectedDepthImageLeavesTheLastFramesResults) {
  const DepthImage depth = cloud_to_depth(qvga(4).cloud, 0.001);
  PipelineSettings settings = pipeline_preset("kinect");
  settings.smooth = false;
  Pipeline pipeline(settings);
  pipeline.process(depth.view(), kQvgaCamera, 0.001);
  const OrganizedCloud before = pipeline.cloud();
  const LabelImage labels = pipeline.segmentation().labels;
  ASSERT_GT(pipeline.segmentation().segments.size(), 0u);
  const DepthImage smaller(160, 120, 1000);
  CameraIntrinsics qvga_only = kQvgaCamera;
  qvga_only.width = 320;
  qvga_only.height = 240;
  for (const bool resized : {true, false}) {
    const DepthImage& rejected = resized ? smaller : depth;
    EXPECT_THROW(pipeline.process(rejected.view(), resized ? qvga_only : kQvgaCamera, 0.0),
                 std::invalid_argument);
    ASSERT_EQ(pipeline.cloud().width(), 320) << resized;
    ASSERT_EQ(pipeline.cloud().height(), 240) << resized;
    EXPECT_TRUE(same_bits(pipeline.cloud().z, before.z)) << resized;
    EXPECT_TRUE(same_bits(pipeline.segmentation().labels, labels)) << resized;
  }
}

// The smoothing's scale follows the camera: a depth image's fx sets the pixel angle (here
// twice the Kinect's at quarter VGA), as the settings or process's camera_fx do; a cloud alone
// takes the camera fitted to its points, and a grid that is no pinhole camera's a Kinect's at VGA.
TEST(Pipeline, PixelAngleFollowsTheCamera) {
  const DepthImage depth = cloud_to_depth(qvga(6).cloud, 0.001);
  const OrganizedCloud cloud = depth_to_cloud(depth.view(), kQvgaCamera, 0.001);
  Pipeline from_depth(pipeline_preset("kinect")), unknown(pipeline_preset("kinect"));
  from_depth.process(depth.view(), kQvgaCamera, 0.001);
  unknown.process(cloud);
  PipelineSettings stated = pipeline_preset("kinect");
  stated.smoothing.pixel_angle = static_cast<float>(1.0 / kQvgaCamera.fx);
  Pipeline with_angle(stated);
  with_angle.process(cloud);
  EXPECT_TRUE(same_bits(from_depth.cloud().z, with_angle.cloud().z));
  // The fitted fx is the camera's to float rounding: the same segments, points within 1 um.
  EXPECT_TRUE(same_bits(from_depth.segmentation().labels, unknown.segmentation().labels));
  double largest = 0;
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if (!cloud.valid(u, v)) continue;
      largest = std::max(largest, std::fabs(static_cast<double>(from_depth.cloud().z(u, v)) -
                                            unknown.cloud().z(u, v)));
    }
  }
  EXPECT_LT(largest, 1e-6);
  stated.smoothing.pixel_angle = kDefaultPixelAngle;
  Pipeline kinect_angle(stated);
  kinect_angle.process(cloud);
  EXPECT_FALSE(same_bits(from_depth.cloud().z, kinect_angle.cloud().z));
  // Settings that state an angle win over the camera.
  const OrganizedCloud at_kinect_angle = kinect_angle.cloud();
  kinect_angle.process(depth.view(), kQvgaCamera, 0.001);
  EXPECT_TRUE(same_bits(at_kinect_angle.z, kinect_angle.cloud().z));
  // Points that no pinhole camera explains (x stretched by up to 2 % towards the right edge, as
  // an uncorrected lens or a scanner's grid) take kDefaultPixelAngle; the next cloud forgets
  // the depth image's camera.
  OrganizedCloud stretched = cloud;
  for (int v = 0; v < stretched.height(); ++v) {
    for (int u = 0; u < stretched.width(); ++u) {
      stretched.x(u, v) *= 1.0f + 0.02f * static_cast<float>(u) / stretched.width();
    }
  }
  Pipeline stretched_kinect(stated);
  stretched_kinect.process(stretched);
  from_depth.process(stretched);
  EXPECT_TRUE(same_bits(stretched_kinect.cloud().z, from_depth.cloud().z));
  EXPECT_THROW(from_depth.process(cloud, -1.0), std::invalid_argument);
  EXPECT_THROW(from_depth.process(cloud, NAN), std::invalid_argument);
  EXPECT_THROW(Pipeline({.smoothing = {.pixel_angle = -0.01f}}), std::invalid_argument);
}

// The pipeline's own smoothed points fed back as the next frame give what a copy of them gives
// (the smoothing writes the buffer it would read).
TEST(Pipeline, ItsOwnCloudFedBackIsACopysFrame) {
  const OrganizedCloud cloud = qvga(7).cloud;
  Pipeline pipeline(pipeline_preset("kinect")), reference(pipeline_preset("kinect"));
  pipeline.process(cloud);
  const OrganizedCloud copy = pipeline.cloud();
  reference.process(copy);
  pipeline.process(pipeline.cloud());
  EXPECT_TRUE(same_bits(pipeline.cloud().z, reference.cloud().z));
  EXPECT_TRUE(same_bits(pipeline.segmentation().labels, reference.segmentation().labels));
}

// Without smoothing, cloud() is the frame's points: for a depth image the pipeline's own, which
// a moved pipeline still gives.
TEST(Pipeline, MovedPipelineKeepsItsDepthFramesPoints) {
  const DepthImage depth = cloud_to_depth(qvga(5).cloud, 0.001);
  PipelineSettings settings = pipeline_preset("kinect");
  settings.smooth = false;
  Pipeline first(settings);
  EXPECT_EQ(first.cloud().size(), 0u);  // before any frame
  first.process(depth.view(), kQvgaCamera, 0.001);
  const OrganizedCloud expected = depth_to_cloud(depth.view(), kQvgaCamera, 0.001);
  const Pipeline moved(std::move(first));
  ASSERT_EQ(moved.cloud().width(), 320);
  ASSERT_EQ(moved.cloud().height(), 240);
  EXPECT_TRUE(same_bits(moved.cloud().z, expected.z));
}

/// A frame without segments tells why when its input is the cause, and what to change: no
/// valid point; valid pixels on every k-th row or column (which rows and columns to mesh); a
/// camera so coarse that its pixels lie beyond the mesh's edge bound (a bound that joins them).
/// Points that leave no face themselves (noise, random dropouts) get no such word.
TEST(Pipeline, SaysWhyAFrameHasNoSegments) {
  const OrganizedCloud frame = qvga(2).cloud;
  Pipeline pipeline(pipeline_preset("kinect"));
  pipeline.process(frame);
  ASSERT_FALSE(pipeline.segmentation().segments.empty());
  EXPECT_EQ(pipeline.why_no_segments(), "");
  const auto contains = [](const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
  };
  const auto rows_from = [&](int first) {
    OrganizedCloud rows = frame;
    for (int v = 0; v < rows.height(); ++v) {
      if (v % 2 == first) continue;
      for (int u = 0; u < rows.width(); ++u) rows.z(u, v) = NAN;
    }
    return rows;
  };
  const OrganizedCloud even = rows_from(0), odd = rows_from(1);
  pipeline.process(even);
  EXPECT_TRUE(pipeline.segmentation().segments.empty());
  std::string why = pipeline.why_no_segments();
  EXPECT_TRUE(contains(why, "the mesh joins hardly any of the points (0 faces")) << why;
  EXPECT_TRUE(contains(why, "every 2nd row from row 0: mesh those (NumPy: points[0::2, 0::1])"))
      << why;
  EXPECT_TRUE(contains(why, "\"pixel_stride\": 2")) << why;
  PipelineSettings stride2 = pipeline_preset("kinect");
  stride2.mesh.pixel_stride = 2;
  Pipeline every_other(stride2);
  every_other.process(even);
  EXPECT_FALSE(every_other.segmentation().segments.empty());  // the hint helps
  // Odd rows: a lattice from row 0 misses them all, whatever its step.
  every_other.process(odd);
  why = every_other.why_no_segments();
  EXPECT_TRUE(contains(why, "every 2nd row from row 1: mesh those (NumPy: points[1::2, 0::1])"))
      << why;
  EXPECT_FALSE(contains(why, "pixel_stride")) << why;

  // A plane at 1.5 m whose points lie 6 cm apart (a camera of fx 25 px): beyond the kinect
  // preset's edge bound there, 4-5 cm; the bound the message proposes joins them.
  OrganizedCloud coarse(32, 24);
  for (int v = 0; v < 24; ++v) {
    for (int u = 0; u < 32; ++u) {
      coarse.x(u, v) = 0.06f * (static_cast<float>(u) - 15.5f);
      coarse.y(u, v) = 0.06f * (static_cast<float>(v) - 11.5f);
      coarse.z(u, v) = 1.5f;
    }
  }
  pipeline.process(coarse);
  EXPECT_TRUE(pipeline.segmentation().segments.empty());
  why = pipeline.why_no_segments();
  EXPECT_TRUE(contains(why, "beyond the mesh's edge bound there")) << why;
  const std::size_t at = why.find("to about ");
  ASSERT_NE(at, std::string::npos) << why;
  PipelineSettings raised = pipeline_preset("kinect");
  raised.mesh.max_edge_b = std::stof(why.substr(at + 9));
  Pipeline joined(raised);
  joined.process(coarse);
  EXPECT_EQ(joined.segmentation().segments.size(), 1u);

  // Depth noise of metres, and 90 % random dropouts: no face for reasons of the points.
  std::mt19937 rng(5);
  OrganizedCloud noise = frame, dropouts = frame;
  std::uniform_real_distribution<float> depth(0.5f, 5.0f), unit(0.0f, 1.0f);
  for (int v = 0; v < frame.height(); ++v) {
    for (int u = 0; u < frame.width(); ++u) {
      if (!frame.valid(u, v)) continue;
      const float scale = depth(rng) / frame.z(u, v);
      noise.x(u, v) *= scale;
      noise.y(u, v) *= scale;
      noise.z(u, v) *= scale;
      if (unit(rng) < 0.9f) dropouts.z(u, v) = NAN;
    }
  }
  pipeline.process(noise);
  EXPECT_TRUE(pipeline.segmentation().segments.empty());
  EXPECT_EQ(pipeline.why_no_segments(), "");
  pipeline.process(dropouts);
  ASSERT_TRUE(pipeline.segmentation().segments.empty());
  why = pipeline.why_no_segments();
  EXPECT_TRUE(contains(why, "neighbouring pixels seldom both hold a point")) << why;
  EXPECT_FALSE(contains(why, "pixel_stride")) << why;
  EXPECT_FALSE(contains(why, "NumPy")) << why;

  OrganizedCloud none = frame;
  none.z.fill(NAN);
  pipeline.process(none);
  EXPECT_TRUE(contains(pipeline.why_no_segments(), "the cloud has no point"));

  PipelineSettings off = pipeline_preset("kinect");
  off.segment = false;
  Pipeline no_segmentation(off);
  no_segmentation.process(even);
  EXPECT_EQ(no_segmentation.why_no_segments(), "");
}

TEST(Pipeline, RejectsInvalidThreadCounts) {
  EXPECT_THROW(Pipeline({.threads = 0}), std::invalid_argument);
  EXPECT_THROW(Pipeline({.threads = 257}), std::invalid_argument);
  EXPECT_THROW(ThreadPool(0), std::invalid_argument);
}

// Settings of every stage are checked when the pipeline is made, before any frame.
TEST(Pipeline, RejectsInvalidStageSettingsBeforeAnyFrame) {
  EXPECT_NO_THROW(validate(PipelineSettings{}));
  PipelineSettings mesh;
  mesh.mesh.pixel_stride = 0;
  PipelineSettings smoothing;
  smoothing.smoothing.iterations = -1;
  PipelineSettings segmentation;
  segmentation.segmentation.min_region_size = 0;
  PipelineSettings rings;
  rings.rings.k = 0;
  PipelineSettings polygon;  // these two were only refused at the first frame
  polygon.polygon.simplify_tolerance = -1;
  PipelineSettings normals;
  normals.normals.viewpoint[1] = NAN;
  for (const PipelineSettings& s : {mesh, smoothing, segmentation, rings, polygon, normals}) {
    EXPECT_THROW(validate(s), std::invalid_argument);
    EXPECT_THROW(Pipeline{s}, std::invalid_argument);
  }
  try {
    validate(segmentation);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("min_region_size"), std::string::npos) << e.what();
  }
  EXPECT_THROW(validate(MeshSettings{.eps_theta = 2.0f}), std::invalid_argument);
  EXPECT_THROW(validate(SegmentationSettings{.max_normal_angle = -1}), std::invalid_argument);
}

TEST(Pipeline, UnorganizedCloudsTakeTheRingPathWithoutTheIncrementalPlaneModel) {
  const OrganizedCloud empty(100, 1);  // no valid point: no segment
  Pipeline pipeline;
  pipeline.process(empty);
  EXPECT_TRUE(pipeline.segmentation().segments.empty());
  EXPECT_EQ(pipeline.rings().size(), 100u);
  EXPECT_EQ(pipeline.mesh().width(), 0);
  PipelineSettings automatic;
  automatic.segmentation.model = RegionModel::automatic;
  Pipeline auto_pipeline(automatic);
  auto_pipeline.process(empty);
  EXPECT_TRUE(auto_pipeline.segmentation().segments.empty());
  PipelineSettings incremental;
  incremental.segmentation.model = RegionModel::incremental_plane;
  Pipeline incremental_pipeline(incremental);
  EXPECT_THROW(incremental_pipeline.process(empty), std::invalid_argument);
  PipelineSettings bad_rings;
  bad_rings.rings.k = 1;
  EXPECT_THROW(Pipeline{bad_rings}, std::invalid_argument);
  EXPECT_THROW(pipeline_preset("no-such-sensor"), std::invalid_argument);
}

TEST(Pipeline, NonFinitePointsAreNoPoints) {
  // Points with an infinite coordinate (1 % of a synthetic Kinect frame, in every variant) are
  // invalid (OrganizedCloud::valid) and must be treated like NaN ones by every stage: never
  // labelled, and every segment's sums, area and pixel count finite and consistent.
  synth::Rendering r = qvga(3);
  OrganizedCloud& cloud = r.cloud;
  const float inf = std::numeric_limits<float>::infinity();
  int damaged = 0;
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      const int kind = (u * 7 + v * 13) % 101;
      if (kind > 3 || !cloud.valid(u, v)) continue;
      ++damaged;
      if (kind == 0) cloud.z(u, v) = inf;
      if (kind == 1) cloud.z(u, v) = -inf;
      if (kind == 2) cloud.x(u, v) = inf;
      if (kind == 3) cloud.y(u, v) = -inf;
    }
  }
  ASSERT_GT(damaged, 2000);
  for (const RegionModel model : {RegionModel::plane, RegionModel::smooth,
                                  RegionModel::incremental_plane, RegionModel::automatic}) {
    PipelineSettings settings = pipeline_preset("kinect");
    settings.segmentation.model = model;
    Pipeline pipeline(settings);
    pipeline.process(cloud);
    const Segmentation& seg = pipeline.segmentation();
    ASSERT_GT(seg.segments.size(), 2u) << to_string(model);
    test::expect_labels_name_segments(cloud, seg, to_string(model));
    for (const Segment& s : seg.segments) {
      EXPECT_GT(s.area_m2, 0) << to_string(model) << " " << s.label;
      EXPECT_TRUE(std::isfinite(s.rms_residual) && std::isfinite(s.offset)) << to_string(model);
    }
    for (const auto& p : pipeline.polygons().points3d) {
      ASSERT_TRUE(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]));
    }
  }
}

TEST(Pipeline, DamagedScenesWithRandomSettingsKeepTheInvariants) {
  // Small synthetic scenes, damaged (dropped pixels, rows and columns, infinite or far outlying
  // coordinates, NaN x), through random valid settings of every stage, model, preset and thread
  // count: no stage may throw or crash (the sanitizer build runs this too), labels name segments
  // whose pixel counts and order agree, areas are finite, polygon loops index valid points.
  std::mt19937_64 rng(20261203);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const char* presets[] = {"kinect", "abw", "laser", "perceptron", "ideal"};
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int run = 0; run < 24; ++run) {
    const int width = 48 + static_cast<int>(rng() % 260),
              height = 32 + static_cast<int>(rng() % 200);
    const double f = 0.8 * width;
    synth::RenderSettings render{.camera = {.fx = f,
                                            .fy = f,
                                            .cx = width / 2.0,
                                            .cy = height / 2.0,
                                            .width = width,
                                            .height = height},
                                 .noise = run % 3 == 0 ? synth::Noise::none : synth::Noise::kinect,
                                 .seed = rng()};
    OrganizedCloud cloud =
        synth::render(synth::random_scene(rng() % 100, run % 2 == 1), render).cloud;
    const int damage = run % 6;
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        const double p = uniform(rng);
        if ((damage == 1 && p < 0.3) || (damage == 2 && (v % 7 == 0 || u % 11 == 0))) {
          cloud.x(u, v) = cloud.y(u, v) = cloud.z(u, v) = nan;
        } else if (damage == 3 && p < 0.02) {
          (p < 0.01 ? cloud.z(u, v) : cloud.x(u, v)) = p < 0.005 ? -inf : inf;
        } else if (damage == 4 && p < 0.01) {
          cloud.x(u, v) *= 100;
          cloud.y(u, v) *= 100;
          cloud.z(u, v) *= 100;
        } else if (damage == 5 && p < 0.05) {
          cloud.x(u, v) = nan;
        }
      }
    }
    PipelineSettings settings = pipeline_preset(presets[rng() % std::size(presets)]);
    settings.threads = 1 + static_cast<int>(rng() % 3);
    settings.mesh.type = static_cast<MeshType>(rng() % 4);
    settings.mesh.pixel_stride = uniform(rng) < 0.7 ? 1 : 1 + static_cast<int>(rng() % 3);
    settings.smooth = uniform(rng) < 0.8;
    settings.smoothing.iterations = static_cast<int>(rng() % 4);
    settings.smoothing.recompute_normals = uniform(rng) < 0.3;
    SegmentationSettings& s = settings.segmentation;
    s.model = static_cast<RegionModel>(rng() % 4);
    s.growth_bands = 1 + static_cast<int>(rng() % 5);
    s.coarse_cells = uniform(rng) < 0.8;
    s.min_region_size = 1 + static_cast<int>(rng() % 400);
    s.seed_clearance = static_cast<int>(rng() % 5);
    s.reassign_across_mesh_cuts = uniform(rng) < 0.3;
    s.merge_planes = uniform(rng) < 0.9;
    s.reassign_boundary = uniform(rng) < 0.9;
    s.boundary_refine_sigmas = uniform(rng) < 0.8 ? 3 * uniform(rng) : 0;
    s.split_residual_factor = 1 + 4 * uniform(rng);
    settings.polygon.planes_only = uniform(rng) < 0.5;
    settings.polygon.min_loop_pixels = 20 * uniform(rng);
    const std::string what = "run " + std::to_string(run) + " " + std::to_string(width) + "x" +
                             std::to_string(height) + " model " + to_string(s.model);
    Pipeline pipeline(settings);
    for (int frame = 0; frame < 2; ++frame) {
      ASSERT_NO_THROW(pipeline.process(cloud)) << what;
      test::expect_labels_name_segments(cloud, pipeline.segmentation(), what);
      const PolygonSet& polygons = pipeline.polygons();
      for (const PolygonLoop& loop : polygons.loops) {
        ASSERT_GE(loop.count, 3) << what;
        ASSERT_LE(static_cast<std::size_t>(loop.first + loop.count), polygons.points3d.size())
            << what;
        ASSERT_TRUE(!loop.is_hole ||
                    (loop.parent >= 0 && loop.parent < static_cast<int>(polygons.loops.size())))
            << what;
      }
    }
  }
}

namespace rangeseg {
namespace {

/// The segment of `result` holding most pixels of the largest segment of `reference` (same
/// size): the same surface in two renderings of one scene.
const Segment& same_surface(const Segmentation& result, const Segmentation& reference) {
  std::vector<int> hits(result.segments.size() + 1, 0);
  for (int v = 0; v < reference.labels.height(); ++v) {
    for (int u = 0; u < reference.labels.width(); ++u) {
      if (reference.labels(u, v) == 1) ++hits[static_cast<std::size_t>(result.labels(u, v))];
    }
  }
  hits[0] = 0;
  const auto best = std::max_element(hits.begin(), hits.end()) - hits.begin();
  return result.segments.at(static_cast<std::size_t>(best) - 1);
}

TEST(Pipeline, PlaneAreasAreTheirPolygonsAndNotInflatedByNoise) {
  // The demo scene's back wall at 4-6 m: Kinect noise there (2.5-7 cm) tilts the mesh faces.
  const synth::Scene scene = synth::demo_scene();
  const OrganizedCloud noise_free = synth::render(scene, {.noise = synth::Noise::none}).cloud;
  const OrganizedCloud kinect = synth::render(scene, {.noise = synth::Noise::kinect}).cloud;
  Pipeline clean, noisy;
  clean.process(noise_free);
  noisy.process(kinect);
  const Segment& truth = clean.segmentation().segments.at(0);
  const Segment& wall = same_surface(noisy.segmentation(), clean.segmentation());
  ASSERT_EQ(wall.kind, SurfaceKind::plane);
  // Every plane's area is its polygon's.
  for (const SegmentPolygons& sp : noisy.polygons().segments) {
    const Segment& s = noisy.segmentation().segments[static_cast<std::size_t>(sp.label - 1)];
    if (s.kind == SurfaceKind::plane) {
      EXPECT_EQ(s.area_m2, sp.area) << s.label;
    }
  }
  EXPECT_NEAR(wall.area_m2, truth.area_m2, 0.03 * truth.area_m2);
  // The mesh faces it replaces sum to much more there.
  Segmentation faces = noisy.segmentation();
  Segmenter().compute_areas(noisy.cloud(), noisy.mesh(), faces);
  const double face_area = faces.segments[static_cast<std::size_t>(wall.label - 1)].area_m2;
  EXPECT_GT(face_area, 1.1 * truth.area_m2) << "the faces are no longer tilted by the noise?";
  // A plane the polygon settings skip keeps the faces' sum.
  PipelineSettings skip_small;
  skip_small.polygon.min_segment_pixels = 2000;
  Pipeline some_polygons(skip_small);
  some_polygons.process(kinect);
  const Segmentation& some = some_polygons.segmentation();
  Segmentation some_faces = some;
  Segmenter().compute_areas(some_polygons.cloud(), some_polygons.mesh(), some_faces);
  int skipped = 0;
  for (const Segment& s : some.segments) {
    const std::size_t j = static_cast<std::size_t>(s.label - 1);
    if (s.pixel_count >= 2000) continue;
    ++skipped;
    EXPECT_GT(s.area_m2, 0.0) << s.label;
    EXPECT_EQ(s.area_m2, some_faces.segments[j].area_m2) << s.label;
  }
  EXPECT_GT(skipped, 0);
  // Without polygons the area is the faces' sum.
  Pipeline no_polygons({.polygons = false});
  no_polygons.process(kinect);
  EXPECT_EQ(same_surface(no_polygons.segmentation(), clean.segmentation()).area_m2, face_area);
}

TEST(Pipeline, PointsOfGrazingPlanesWithoutFacesTakeThePlanesNormal) {
  // The demo scene's Kinect rendering has planes found at grazing incidence, where the mesh
  // has few faces and most 1-ring normals are NaN.
  const OrganizedCloud kinect =
      synth::render(synth::demo_scene(), {.noise = synth::Noise::kinect}).cloud;
  for (const bool smooth : {true, false}) {
    Pipeline pipeline({.smooth = smooth});
    pipeline.process(kinect);
    const Segmentation& seg = pipeline.segmentation();
    const NormalMap& normals = pipeline.normals();
    int grazing_points = 0, filled = 0;
    for (int v = 0; v < seg.labels.height(); ++v) {
      for (int u = 0; u < seg.labels.width(); ++u) {
        const std::int32_t l = seg.labels(u, v);
        if (l == 0) continue;
        const Segment& s = seg.segments[static_cast<std::size_t>(l - 1)];
        if (!s.grazing) continue;
        ++grazing_points;
        const std::array<float, 3> n{normals.nx(u, v), normals.ny(u, v), normals.nz(u, v)};
        ASSERT_TRUE(std::isfinite(n[0]) && std::isfinite(n[1]) && std::isfinite(n[2]))
            << u << "," << v << " smooth " << smooth;
        ASSERT_TRUE(std::isfinite(normals.curvature(u, v)));
        if (n[0] == static_cast<float>(s.normal[0]) && n[1] == static_cast<float>(s.normal[1]) &&
            n[2] == static_cast<float>(s.normal[2])) {
          ++filled;
          EXPECT_EQ(normals.curvature(u, v), 0.0f);
        }
      }
    }
    EXPECT_GT(grazing_points, 1000) << "smooth " << smooth;
    EXPECT_GT(filled, 100) << "smooth " << smooth;  // points without a face
  }
}

}  // namespace
}  // namespace rangeseg
