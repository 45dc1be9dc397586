// The spatial order Pipeline runs the stages over rings in (unorganized/order.hpp): a
// permutation with the valid points first and neighbours close together, the moves into it and
// back, and results of the pipeline that do not depend on the order of the input points.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iterator>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "rangeseg/pipeline.hpp"
#include "rangeseg/synth.hpp"
#include "segmentation_test_util.hpp"
#include "test_util.hpp"
#include "unorganized/order.hpp"

namespace rangeseg {
namespace {

using test::qvga_boxes_scene;
using test::shuffled;
using test::Unorganized;

bool same_float(float a, float b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

/// The points of `cloud` (height 1) with an invalid point after every `every`-th one.
OrganizedCloud with_invalid_points(const OrganizedCloud& cloud, int every) {
  const int n = cloud.width();
  OrganizedCloud out(n + n / every, 1);
  int o = 0;
  for (int i = 0; i < n; ++i) {
    out.x(o, 0) = cloud.x(i, 0);
    out.y(o, 0) = cloud.y(i, 0);
    out.z(o, 0) = cloud.z(i, 0);
    ++o;
    if ((i + 1) % every == 0) ++o;  // stays NaN
  }
  return out;
}

/// Mean distance between the directions of consecutive points of `order` (valid ones).
double mean_step(const OrganizedCloud& cloud, const std::vector<std::int32_t>& order) {
  const auto direction = [&](std::int32_t i, double* d) {
    const double x = cloud.x(i, 0), y = cloud.y(i, 0), z = cloud.z(i, 0);
    const double r = std::sqrt(x * x + y * y + z * z);
    d[0] = x / r;
    d[1] = y / r;
    d[2] = z / r;
  };
  double sum = 0;
  int steps = 0;
  for (std::size_t t = 1; t < order.size(); ++t) {
    if (!cloud.valid(order[t - 1], 0) || !cloud.valid(order[t], 0)) continue;
    double a[3], b[3];
    direction(order[t - 1], a);
    direction(order[t], b);
    sum += std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                     (a[2] - b[2]) * (a[2] - b[2]));
    ++steps;
  }
  return sum / steps;
}

TEST(SpatialOrder, ValidPointsFirstNeighboursCloseInvalidOnesLastInInputOrder) {
  const synth::Rendering r = qvga_boxes_scene(5);
  const OrganizedCloud cloud = with_invalid_points(shuffled(r.cloud, 5).cloud, 7);
  unorganized::SpatialOrder o;
  unorganized::spatial_order(cloud, RingSettings{}, o);
  ASSERT_EQ(o.order.size(), cloud.size());
  std::vector<std::int32_t> sorted = o.order;
  std::sort(sorted.begin(), sorted.end());
  std::vector<std::int32_t> all(cloud.size());
  std::iota(all.begin(), all.end(), 0);
  EXPECT_EQ(sorted, all) << "not a permutation";
  const std::size_t valid = cloud.count_valid();
  ASSERT_LT(valid, cloud.size());
  for (std::size_t t = 0; t < cloud.size(); ++t) {
    ASSERT_EQ(cloud.valid(o.order[t], 0), t < valid) << "at " << t;
    if (t > valid) {
      ASSERT_LT(o.order[t - 1], o.order[t]) << "invalid points out of input order";
    }
  }
  // Pixels 1 / 262.5 rad apart: consecutive points in input order are a third of the field of
  // view apart on average, in the spatial order a few pixels.
  std::vector<std::int32_t> input(cloud.size());
  std::iota(input.begin(), input.end(), 0);
  const double pixel = 1.0 / 262.5, spatial = mean_step(cloud, o.order);
  const double shuffled_step = mean_step(cloud, input);
  std::printf("  mean step between consecutive points: input order %.1f px, spatial %.2f px\n",
              shuffled_step / pixel, spatial / pixel);
  EXPECT_LT(spatial, 3 * pixel);
  EXPECT_GT(shuffled_step, 50 * pixel);

  // By 3D distance the order is over the positions; both are permutations of the valid points.
  unorganized::SpatialOrder by_distance;
  unorganized::spatial_order(cloud, RingSettings{.by_direction = false}, by_distance);
  std::vector<std::int32_t> first_valid(by_distance.order.begin(),
                                        by_distance.order.begin() + static_cast<long>(valid));
  std::vector<std::int32_t> expected(o.order.begin(), o.order.begin() + static_cast<long>(valid));
  std::sort(first_valid.begin(), first_valid.end());
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(first_valid, expected);
}

TEST(SpatialOrder, GatherAndBackRestoreEveryPlane) {
  const synth::Rendering r = qvga_boxes_scene(6);
  OrganizedCloud cloud = with_invalid_points(shuffled(r.cloud, 6).cloud, 5);
  cloud.add_intensity();
  cloud.add_label();
  for (int i = 0; i < cloud.width(); ++i) {
    cloud.intensity(i, 0) = static_cast<float>(i);
    cloud.label(i, 0) = i;
  }
  unorganized::SpatialOrder o;
  unorganized::spatial_order(cloud, RingSettings{}, o);
  OrganizedCloud ordered;
  unorganized::gather(cloud, o.order, ordered);
  ASSERT_EQ(ordered.width(), cloud.width());
  EXPECT_FALSE(ordered.has_rgb());
  for (std::size_t t = 0; t < o.order.size(); ++t) {
    const auto i = o.order[t];
    ASSERT_EQ(ordered.label(static_cast<int>(t), 0), i);
    ASSERT_TRUE(same_float(ordered.z(static_cast<int>(t), 0), cloud.z(i, 0)));
  }
  unorganized::to_input_order(ordered.intensity, o, o.floats);
  unorganized::to_input_order(ordered.label, o, o.ints);
  for (int i = 0; i < cloud.width(); ++i) {
    ASSERT_EQ(ordered.label(i, 0), i);
    ASSERT_EQ(ordered.intensity(i, 0), static_cast<float>(i));
  }
  // Rings in the order point at the same points once back in input order.
  const PointRings rings = build_rings(ordered);
  PointRings back;
  unorganized::rings_to_input_order(rings, o, back);
  const PointRings direct = build_rings(cloud);
  ASSERT_EQ(back.size(), direct.size());
  std::size_t differing = 0;
  for (std::size_t i = 0; i < back.size(); ++i) {
    const auto a = back.ring(i), b = direct.ring(i);
    std::vector<std::int32_t> sa(a.begin(), a.end()), sb(b.begin(), b.end());
    std::sort(sa.begin(), sa.end());
    std::sort(sb.begin(), sb.end());
    differing += sa != sb ? 1 : 0;
  }
  // Neighbours at equal distance may be taken in another order where a ring is cut at k.
  EXPECT_LT(differing, back.size() / 1000) << differing << " of " << back.size();
}

// The stages run in the spatial order, which depends on the points alone: two shuffles of a
// rendering give the same rings, normals, smoothed points and labels point for point, and the
// same segments and polygons.
// Finite coordinates of any size: the extent of the box can exceed the float range (found by
// fuzz_pipeline: the cell index was NaN, converted to an integer).
TEST(SpatialOrder, ExtremeCoordinatesGiveAPermutation) {
  const float big = std::numeric_limits<float>::max();
  const float values[] = {-big, big, 0.0f, 1.0f, -1e-30f, 3e38f, -3e38f, 1e20f};
  OrganizedCloud cloud(static_cast<int>(std::size(values)), 1);
  for (int i = 0; i < cloud.width(); ++i) {
    cloud.x(i, 0) = values[static_cast<std::size_t>(i)];
    cloud.y(i, 0) = values[static_cast<std::size_t>(cloud.width() - 1 - i)];
    cloud.z(i, 0) = 1.0f;
  }
  for (const bool by_direction : {true, false}) {
    unorganized::SpatialOrder o;
    unorganized::spatial_order(cloud, RingSettings{.by_direction = by_direction}, o);
    std::vector<std::int32_t> sorted = o.order;
    std::sort(sorted.begin(), sorted.end());
    std::vector<std::int32_t> all(cloud.size());
    std::iota(all.begin(), all.end(), 0);
    EXPECT_EQ(sorted, all) << by_direction;
  }
  Pipeline pipeline(test::ring_preset("kinect"));
  EXPECT_NO_THROW(pipeline.process(cloud));
}

TEST(RingPipeline, AnyOrderOfThePointsGivesTheSameResults) {
  const synth::Rendering r = qvga_boxes_scene(1);
  PipelineSettings settings = test::ring_preset("kinect");
  settings.segmentation.model = RegionModel::automatic;
  Pipeline a(settings), b(settings);
  const Unorganized ua = shuffled(r.cloud, 100), ub = shuffled(r.cloud, 101);
  a.process(ua.cloud);
  b.process(ub.cloud);
  std::vector<std::int32_t> in_b(r.cloud.size(), -1);
  for (std::size_t j = 0; j < ub.pixel.size(); ++j) in_b[ub.pixel[j]] = static_cast<int>(j);
  std::size_t checked = 0;
  for (std::size_t i = 0; i < ua.pixel.size(); ++i) {
    const int ia = static_cast<int>(i), ib = in_b[ua.pixel[i]];
    ASSERT_GE(ib, 0);
    ASSERT_EQ(a.segmentation().labels(ia, 0), b.segmentation().labels(ib, 0)) << i;
    ASSERT_TRUE(same_float(a.cloud().x(ia, 0), b.cloud().x(ib, 0)) &&
                same_float(a.cloud().z(ia, 0), b.cloud().z(ib, 0)))
        << i;
    ASSERT_TRUE(same_float(a.normals().nx(ia, 0), b.normals().nx(ib, 0)) &&
                same_float(a.normals().nz(ia, 0), b.normals().nz(ib, 0)) &&
                same_float(a.raw_normals().ny(ia, 0), b.raw_normals().ny(ib, 0)))
        << i;
    const auto ring_a = a.rings().ring(i);
    const auto ring_b = b.rings().ring(static_cast<std::size_t>(ib));
    ASSERT_EQ(ring_a.size(), ring_b.size()) << i;
    for (std::size_t m = 0; m < ring_a.size(); ++m) {
      ASSERT_EQ(ua.pixel[static_cast<std::size_t>(ring_a[m])],
                ub.pixel[static_cast<std::size_t>(ring_b[m])])
          << i;
    }
    ++checked;
  }
  EXPECT_EQ(checked, r.cloud.count_valid());
  const auto& sa = a.segmentation().segments;
  const auto& sb = b.segmentation().segments;
  ASSERT_EQ(sa.size(), sb.size());
  EXPECT_GE(sa.size(), 5u);
  for (std::size_t s = 0; s < sa.size(); ++s) {
    EXPECT_EQ(sa[s].pixel_count, sb[s].pixel_count);
    EXPECT_EQ(sa[s].kind, sb[s].kind);
    EXPECT_EQ(sa[s].centroid, sb[s].centroid);
    EXPECT_EQ(sa[s].normal, sb[s].normal);
  }
  EXPECT_EQ(a.polygons().points3d, b.polygons().points3d);
}

TEST(RingPipeline, CloudsWithoutEnoughValidPointsGiveEmptyResultsInInputOrder) {
  Pipeline pipeline(test::ring_preset("kinect"));
  OrganizedCloud nan_only(5, 1);
  pipeline.process(nan_only);
  EXPECT_EQ(pipeline.segmentation().labels.width(), 5);
  EXPECT_TRUE(pipeline.segmentation().segments.empty());
  EXPECT_EQ(pipeline.rings().size(), 5u);
  OrganizedCloud few(6, 1);  // three valid points between invalid ones
  for (int i = 1; i < 6; i += 2) {
    few.x(i, 0) = 0.1f * static_cast<float>(i);
    few.y(i, 0) = 0.0f;
    few.z(i, 0) = 1.0f;
  }
  pipeline.process(few);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(pipeline.segmentation().labels(i, 0), 0);
    EXPECT_EQ(pipeline.cloud().valid(i, 0), i % 2 == 1) << i;
    EXPECT_EQ(pipeline.rings().count[static_cast<std::size_t>(i)] > 0, i % 2 == 1) << i;
  }
  for (const std::int32_t j : pipeline.rings().ring(1)) EXPECT_TRUE(j == 3 || j == 5) << j;
  const OrganizedCloud empty(0, 1);
  try {
    pipeline.process(empty);
    EXPECT_EQ(pipeline.segmentation().labels.width(), 0);
  } catch (const std::invalid_argument& e) {
    std::printf("  empty cloud: %s\n", e.what());
  }
}

// Points on one viewing ray share their key by direction; among 200000 of them (each given
// twice, alternately) the copies are found by sorting, not pair by pair, and each original is
// the first of its equal points in input order.
TEST(SpatialOrder, CopiesAmongManyPointsOnOneRay) {
  constexpr int n = 100000;
  OrganizedCloud ray(2 * n, 1);
  for (int i = 0; i < 2 * n; ++i) {
    const float t = 1.0f + 1e-4f * static_cast<float>(i / 2);
    ray.x(i, 0) = 0.5f * t;
    ray.y(i, 0) = 0.25f * t;
    ray.z(i, 0) = t;
  }
  unorganized::SpatialOrder o;
  unorganized::spatial_order(ray, RingSettings{}, o);
  ASSERT_EQ(o.copies.size(), static_cast<std::size_t>(n));
  EXPECT_EQ(o.order.size(), static_cast<std::size_t>(n));
  for (std::size_t c = 0; c < o.copies.size(); ++c) {
    ASSERT_EQ(o.copies[c] % 2, 1) << c;
    ASSERT_EQ(o.copied[c], o.copies[c] - 1) << c;
  }
  for (const std::int32_t i : o.order) ASSERT_EQ(i % 2, 0);
}

// A merged or tiled cloud's exact copies of points: the stages run on the distinct points, and
// each copy takes its original's results, so that the copies change nothing.
TEST(RingPipeline, ExactCopiesOfPointsTakeTheirOriginalsResults) {
  const synth::Rendering r = qvga_boxes_scene(4);
  const Unorganized u = shuffled(r.cloud, 4);
  const int n = u.cloud.width();
  // Every point three times: the cloud, then the cloud twice more.
  OrganizedCloud tripled(3 * n, 1);
  for (int i = 0; i < 3 * n; ++i) {
    tripled.x(i, 0) = u.cloud.x(i % n, 0);
    tripled.y(i, 0) = u.cloud.y(i % n, 0);
    tripled.z(i, 0) = u.cloud.z(i % n, 0);
  }
  unorganized::SpatialOrder o;
  unorganized::spatial_order(tripled, RingSettings{}, o);
  EXPECT_EQ(o.order.size(), static_cast<std::size_t>(n));
  EXPECT_EQ(o.copies.size(), static_cast<std::size_t>(2 * n));
  for (std::size_t c = 0; c < o.copies.size(); ++c) {
    ASSERT_EQ(o.copied[c], o.copies[c] % n) << c;
  }

  PipelineSettings settings = test::ring_preset("kinect");
  settings.restore_grid = false;
  Pipeline single(settings), copies(settings);
  single.process(u.cloud);
  copies.process(tripled);
  const auto& a = single.segmentation();
  const auto& b = copies.segmentation();
  ASSERT_EQ(b.labels.width(), 3 * n);
  ASSERT_GE(a.segments.size(), 5u);
  ASSERT_EQ(a.segments.size(), b.segments.size());
  for (int i = 0; i < 3 * n; ++i) {
    ASSERT_EQ(b.labels(i, 0), a.labels(i % n, 0)) << i;
    ASSERT_TRUE(same_float(copies.cloud().z(i, 0), single.cloud().z(i % n, 0))) << i;
    ASSERT_TRUE(same_float(copies.normals().nx(i, 0), single.normals().nx(i % n, 0))) << i;
    ASSERT_EQ(copies.rings().count[static_cast<std::size_t>(i)],
              single.rings().count[static_cast<std::size_t>(i % n)]);
  }
  for (std::size_t s = 0; s < a.segments.size(); ++s) {
    EXPECT_EQ(3 * a.segments[s].pixel_count, b.segments[s].pixel_count);  // as the labels
    EXPECT_EQ(a.segments[s].area_m2, b.segments[s].area_m2);
  }
  // A copy's ring is its original's: no edge of length 0.
  for (const std::int32_t j : copies.rings().ring(static_cast<std::size_t>(n))) {
    EXPECT_LT(j, n) << "a ring holds a copy";
    EXPECT_NE(j, 0) << "a copy's ring holds its original";
  }
}

}  // namespace
}  // namespace rangeseg
