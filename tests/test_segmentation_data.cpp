// Tests of the segmentation on the synthetic renderer's ground truth and, when present, the
// SegComp ABW and OSD data.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "rangeseg/eval.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/rasterfile.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/smoothing.hpp"
#include "rangeseg/synth.hpp"
#include "segmentation_test_util.hpp"
#include "test_util.hpp"

namespace rangeseg {
namespace {

using namespace test;  // the segmentation test helpers

TEST(Segmentation, SyntheticKinectScenesDetectPlanes) {
  const SegmentationSettings settings = preset("kinect");
  int gt_total = 0, correct_total = 0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    // Planar regions of reasonable size: at least 1000 pixels (smaller ones get label 0).
    const synth::Rendering r =
        synth::render(synth::random_scene(seed),
                      {.noise = synth::Noise::kinect, .seed = seed, .min_surface_pixels = 1000});
    // Beyond ~3 m the disparity quantisation step (z^2 / (b f s) ~ 5 cm at 4 m) makes edges
    // between neighbouring terraces nearly parallel to the viewing ray; the default 12.5 deg
    // occlusion test would cut the mesh there, so a 3 deg one is used.
    const Mesh mesh = build_mesh(r.cloud, {.eps_theta = 0.05f});
    const NormalMap normals = compute_normals(r.cloud, mesh);
    OrganizedCloud smoothed;
    NormalMap smoothed_normals;
    smooth(r.cloud, mesh, normals, {}, smoothed, smoothed_normals);
    const Segmentation seg = segment(smoothed, mesh, smoothed_normals, settings);
    expect_consistent(smoothed, seg, settings);
    const eval::EvalResult e = eval::evaluate(r.labels, seg.labels, {.tolerance = 0.8});
    std::printf("random_scene(%llu): GT %d, correct %d, over %d, under %d, missed %d, noise %d\n",
                static_cast<unsigned long long>(seed), e.gt_regions, e.correct, e.over, e.under,
                e.missed, e.noise);
    gt_total += e.gt_regions;
    correct_total += e.correct;
  }
  std::printf("synthetic Kinect: %d of %d GT planes correct (%.1f%%)\n", correct_total, gt_total,
              100.0 * correct_total / gt_total);
  // Target 90%; reached 86% here (25 of 29, 2026-12-01).
  EXPECT_GE(correct_total, 0.7 * gt_total);
}

// --- SegComp ABW ---

TEST(Segmentation, SegCompAbw) {
  RANGESEG_REQUIRE_DATA("segcomp_abw/abw.test.0.range");
  const auto dir = data_file.parent_path();
  // The same settings as `rangeseg eval-segcomp` (pipeline_preset("abw"): no smoothing).
  const PipelineSettings pipeline = pipeline_preset("abw");
  ASSERT_FALSE(pipeline.smooth);
  const SegmentationSettings& settings = pipeline.segmentation;
  std::vector<eval::EvalResult> results;
  for (int i = 0; i < 10; ++i) {
    const std::string stem = (dir / ("abw.test." + std::to_string(i))).string();
    const OrganizedCloud cloud = io::read_abw_range(stem + ".range");
    const LabelImage gt = io::read_segcomp_gt(stem + ".gt-seg");
    const Mesh mesh = build_mesh(cloud, pipeline.mesh);
    const NormalMap normals = compute_normals(cloud, mesh, pipeline.normals);
    const Segmentation seg = segment(cloud, mesh, normals, settings);
    expect_consistent(cloud, seg, settings);
    const eval::EvalResult e =
        eval::evaluate(gt, seg.labels, {.tolerance = 0.8, .min_gt_label = 10});
    std::printf("abw.test.%d: GT %2d correct %2d over %d under %d missed %2d noise %2d\n", i,
                e.gt_regions, e.correct, e.over, e.under, e.missed, e.noise);
    results.push_back(e);
  }
  const eval::EvalSummary sum = eval::summarize(results);
  std::printf(
      "ABW mean: GT %.2f correct %.2f (%.1f%%) over %.2f under %.2f missed %.2f noise %.2f\n",
      sum.mean_gt, sum.mean_correct, 100.0 * sum.mean_correct / sum.mean_gt, sum.mean_over,
      sum.mean_under, sum.mean_missed, sum.mean_noise);
  // Target 85%, over + under <= 0.5, noise <= 2; reached 88.0% (over 0.1, under 0, noise 1.5)
  // since pieces of one plane merge when each lies on their union's plane within the plane's
  // measured residual, re-assignment also reaches points the mesh cut off (84.9%, over 0.6,
  // noise 3.2 before) and seeds may not touch a region (87.5%, over 0.2, noise 1.9 before).
  // Thresholds leave a little slack for cross-CPU rounding.
  EXPECT_GE(sum.mean_correct / sum.mean_gt, 0.87);
  EXPECT_LE(sum.mean_over + sum.mean_under, 0.3);
  EXPECT_LE(sum.mean_noise, 1.7);
}

// --- real Kinect frame with a labelled table ---

TEST(Segmentation, OsdTableIsOneSegment) {
  RANGESEG_REQUIRE_DATA("osd/test0.pcd");
  const OrganizedCloud cloud = io::read_pcd(data_file.string());
  ASSERT_TRUE(cloud.has_label());
  const Mesh mesh = build_mesh(cloud);
  const NormalMap normals = compute_normals(cloud, mesh);
  const SegmentationSettings settings = preset("kinect");
  const Segmentation seg = segment(cloud, mesh, normals, settings);
  expect_consistent(cloud, seg, settings);
  std::map<int, int> overlap;
  int table = 0;
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      const int gt = cloud.label(u, v);
      if (gt < 1 || gt > 9 || !cloud.valid(u, v)) continue;
      ++table;
      ++overlap[seg.labels(u, v)];
    }
  }
  ASSERT_GT(table, 0);
  int best = 0, best_label = 0;
  for (const auto& [label, count] : overlap) {
    if (label != 0 && count > best) {
      best = count;
      best_label = label;
    }
  }
  std::printf("OSD test0: table %d pixels, %.1f%% in segment %d\n", table, 100.0 * best / table,
              best_label);
  EXPECT_GE(best, 0.9 * table);
}

/// A point with an infinite coordinate is no point, as one with NaN is (a laser driver's "no
/// return", PCL's filters): every seventh column of a Kinect frame (its points only) set to inf
/// or to NaN gives the same segments, with smoothing. (The grazing-plane search took inf pixels for
/// unlabelled points: 2557 labels differed.)
TEST(Segmentation, InfinitePointsAreNoPointsAsNanOnes) {
  RANGESEG_REQUIRE_DATA("kinect/grabber_frame0.pcd");
  RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS();
  OrganizedCloud with_inf = io::read_pcd(data_file.string());
  for (BytePlane* plane : {&with_inf.r, &with_inf.g, &with_inf.b}) plane->clear();  // x y z only
  OrganizedCloud with_nan = with_inf;
  for (int v = 0; v < with_inf.height(); ++v) {
    for (int u = 0; u < with_inf.width(); u += 7) {
      for (FloatPlane* plane : {&with_inf.x, &with_inf.y, &with_inf.z}) (*plane)(u, v) = INFINITY;
      for (FloatPlane* plane : {&with_nan.x, &with_nan.y, &with_nan.z}) (*plane)(u, v) = NAN;
    }
  }
  Pipeline a(pipeline_preset("kinect")), b(pipeline_preset("kinect"));
  a.process(with_inf);
  b.process(with_nan);
  const LabelImage& la = a.segmentation().labels;
  const LabelImage& lb = b.segmentation().labels;
  int differ = 0;
  for (int v = 0; v < la.height(); ++v) {
    for (int u = 0; u < la.width(); ++u) differ += la(u, v) != lb(u, v) ? 1 : 0;
  }
  EXPECT_EQ(differ, 0);
  EXPECT_EQ(a.segmentation().segments.size(), b.segmentation().segments.size());
}

/// A plane found at grazing incidence spans more than one row and one column of the image: the
/// points of one scanner column (B604's last, 54 of them, once gave a segment with an arbitrary
/// normal and no area) lie in one plane with the rays, which leaves the plane's tilt open.
TEST(Segmentation, GrazingPlanesOfLaserScansSpanRowsAndColumns) {
  RANGESEG_REQUIRE_DATA("laser/B604.pcd");
  RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS();
  int grazing = 0;
  for (const char* name : {"laser/A601.pcd", "laser/B604.pcd"}) {
    const OrganizedCloud cloud =
        io::read_pcd((data_file.parent_path().parent_path() / name).string());
    Pipeline pipeline(pipeline_preset("laser"));
    pipeline.process(cloud);
    const Segmentation& seg = pipeline.segmentation();
    for (const Segment& segment : seg.segments) {
      if (!segment.grazing) continue;
      ++grazing;
      int u0 = cloud.width(), u1 = -1, v0 = cloud.height(), v1 = -1;
      for (int v = 0; v < cloud.height(); ++v) {
        for (int u = 0; u < cloud.width(); ++u) {
          if (seg.labels(u, v) != segment.label) continue;
          u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
        }
      }
      EXPECT_GT(u1, u0) << name << " segment " << segment.label;
      EXPECT_GT(v1, v0) << name << " segment " << segment.label;
      EXPECT_GT(segment.area_m2, 0.0) << name << " segment " << segment.label;
    }
  }
  EXPECT_GT(grazing, 0);  // the scans' floors are seen at grazing incidence
}

}  // namespace
}  // namespace rangeseg
