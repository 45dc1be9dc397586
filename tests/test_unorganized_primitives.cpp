// The auto model over k-nearest-neighbour rings (unorganized.hpp, segment with
// RegionModel::automatic): scenes with spheres and cylinders rendered, shuffled into unorganized
// clouds and segmented through Pipeline, scored on the grid against their analytic surfaces.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "rangeseg/eval.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/synth.hpp"
#include "rangeseg/unorganized.hpp"
#include "segmentation_test_util.hpp"
#include "test_util.hpp"

namespace rangeseg {
namespace {

struct RingRun {
  synth::Rendering r;
  test::Unorganized u;
  Segmentation seg;
  LabelImage grid;  ///< the segments' labels put back on the rendering's pixels
  /// Per segment: the sum of point_area over its points (the pipeline's cloud and rings) ...
  std::vector<double> point_areas;
  /// ... and the area of its polygon (-1 without one).
  std::vector<double> polygon_areas;
};

RingRun run(const synth::Scene& scene, synth::Noise noise, const char* preset, RegionModel model,
            std::uint64_t seed = 1) {
  RingRun out;
  out.r = synth::render(scene, {.noise = noise, .seed = seed});
  out.u = test::shuffled(out.r.cloud, static_cast<unsigned>(seed));
  PipelineSettings settings = test::ring_preset(preset);
  settings.segmentation.model = model;
  Pipeline pipeline(settings);
  pipeline.process(out.u.cloud);
  out.seg = pipeline.segmentation();
  out.point_areas.assign(out.seg.segments.size(), 0.0);
  for (int i = 0; i < out.u.cloud.width(); ++i) {
    const int l = out.seg.labels(i, 0);
    if (l > 0) {
      out.point_areas[static_cast<std::size_t>(l - 1)] +=
          point_area(pipeline.cloud(), pipeline.rings(), static_cast<std::size_t>(i));
    }
  }
  out.polygon_areas.assign(out.seg.segments.size(), -1.0);
  for (const SegmentPolygons& sp : pipeline.polygons().segments) {
    out.polygon_areas[static_cast<std::size_t>(sp.label - 1)] = sp.area;
  }
  out.grid = test::to_grid(out.seg.labels, out.u, out.r.cloud.width(), out.r.cloud.height());
  return out;
}

double axis_angle_deg(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  const double c = std::fabs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
  return std::acos(std::min(1.0, c)) / test::kDeg;
}

struct CurvedCount {
  int surfaces = 0;  ///< curved surfaces of at least 500 pixels
  int found = 0;     ///< of them, one segment of their kind within the tolerances
};

/// The curved surfaces of at least 500 pixels that are detected correctly (T = 0.8) by one
/// segment of their kind with radius and axis within the tolerances.
CurvedCount count_curved(const RingRun& run, double radius_tol, double axis_tol_deg) {
  const eval::EvalResult e = eval::evaluate(run.r.labels, run.grid, {.tolerance = 0.8});
  std::map<int, int> machine_of;
  for (const auto& [g, m] : e.correct_pairs) machine_of[g] = m;
  CurvedCount count;
  for (std::size_t k = 0; k < run.r.surfaces.size(); ++k) {
    const synth::Surface& s = run.r.surfaces[k];
    if (s.type == synth::SurfaceType::plane || run.r.pixel_counts[k] < 500) continue;
    ++count.surfaces;
    const auto it = machine_of.find(static_cast<int>(k + 1));
    if (it == machine_of.end()) {
      std::printf("  %-10s %6lld px: not one segment\n", s.name.c_str(),
                  static_cast<long long>(run.r.pixel_counts[k]));
      continue;
    }
    const Segment& seg = run.seg.segments[static_cast<std::size_t>(it->second - 1)];
    const bool sphere = s.type == synth::SurfaceType::sphere;
    const double axis_error = sphere ? 0.0 : axis_angle_deg(seg.axis, s.axis);
    std::printf("  %-10s %6lld px: kind %-8s radius %.4f (true %.4f), axis error %.2f deg\n",
                s.name.c_str(), static_cast<long long>(run.r.pixel_counts[k]), to_string(seg.kind),
                seg.radius, s.radius, axis_error);
    const bool kind_ok = seg.kind == (sphere ? SurfaceKind::sphere : SurfaceKind::cylinder) &&
                         seg.model == RegionModel::automatic;
    count.found += kind_ok && std::fabs(seg.radius - s.radius) <= radius_tol * s.radius &&
                   axis_error <= axis_tol_deg;
  }
  return count;
}

/// Labels name their segments, sorted by size, with positive areas (the sum of point_area over
/// their points, but on planes seen at grazing incidence: the primitive pass joins and relabels
/// segments, and their areas are summed again) and, for spheres and cylinders, their
/// parameters.
void check_segments(const RingRun& r) {
  test::expect_labels_name_segments(r.u.cloud, r.seg);
  for (std::size_t j = 0; j < r.seg.segments.size(); ++j) {
    const Segment& s = r.seg.segments[j];
    EXPECT_EQ(s.label, static_cast<int>(j) + 1);
    if (j > 0) {
      EXPECT_LE(s.pixel_count, r.seg.segments[j - 1].pixel_count) << s.label;
    }
    EXPECT_GT(s.area_m2, 0.0) << s.label;
    if (s.kind == SurfaceKind::sphere || s.kind == SurfaceKind::cylinder) {
      EXPECT_GT(s.radius, 0.0) << s.label;
      EXPECT_GT(s.surface_rms, 0.0) << s.label;
    }
  }
  // The primitive pass joins and relabels segments; their areas are summed again. A plane found
  // seen at grazing incidence counts each point's patch of the plane, not its ring's (a line).
  // A plane with a polygon takes the polygon's area (the union of the points' footprints).
  for (std::size_t j = 0; j < r.point_areas.size(); ++j) {
    if (r.seg.segments[j].kind == SurfaceKind::plane && r.polygon_areas[j] >= 0) {
      EXPECT_EQ(r.seg.segments[j].area_m2, r.polygon_areas[j]) << j + 1;
      continue;
    }
    if (r.seg.segments[j].grazing) {
      EXPECT_GT(r.seg.segments[j].area_m2, r.point_areas[j]) << j + 1;
      continue;
    }
    EXPECT_NEAR(r.seg.segments[j].area_m2, r.point_areas[j], 1e-9 * r.point_areas[j]) << j + 1;
  }
}

TEST(RingAutoModel, NoiseFreeCurvedSurfacesAreOneSegmentEach) {
  // 54 s under ASan; the ring auto model's paths run there in the pipeline's allocation test.
  RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS();
  const RingRun r = run(test::curved_scene(), synth::Noise::none, "ideal", RegionModel::automatic);
  const CurvedCount c = count_curved(r, 0.01, 1.0);
  EXPECT_EQ(c.surfaces, 3);  // two cylinder sides and a ball
  EXPECT_EQ(c.found, c.surfaces);
  check_segments(r);
}

TEST(RingAutoModel, KinectNoiseCurvedSurfacesWithinFivePercentAndThreeDegrees) {
  RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS();
  CurvedCount total;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const RingRun r =
        run(test::curved_scene(), synth::Noise::kinect, "kinect", RegionModel::automatic, seed);
    const CurvedCount c = count_curved(r, 0.05, 3.0);
    EXPECT_EQ(c.surfaces, 3);
    total.found += c.found;
    total.surfaces += c.surfaces;
    check_segments(r);
  }
  std::printf("  Kinect noise: %d of %d curved surfaces one segment within 5 %% and 3 deg\n",
              total.found, total.surfaces);
  // Measured 7 of 9 (2026-12-05; 8 before the re-assignment moved ahead of merging, which over
  // the mixed scenes 1-32 finds 55 of 89 curved surfaces against 53): the standing cylinder of
  // seeds 1 and 2 is not one segment (seed 1's: the plane split cuts it into facets that join
  // as two cylinders).
  EXPECT_GE(total.found, 7);
}

TEST(RingAutoModel, PlaneModelCutsTheCurvedSurfacesIntoFacets) {
  RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS();
  // What the auto model adds: with planes only, no curved surface is one segment.
  const RingRun r = run(test::curved_scene(), synth::Noise::kinect, "kinect", RegionModel::plane);
  const eval::EvalResult e = eval::evaluate(r.r.labels, r.grid, {.tolerance = 0.8});
  int curved_correct = 0;
  for (const auto& [g, m] : e.correct_pairs) {
    curved_correct +=
        r.r.surfaces[static_cast<std::size_t>(g - 1)].type != synth::SurfaceType::plane;
  }
  EXPECT_LE(curved_correct, 1);
  for (const Segment& s : r.seg.segments) EXPECT_EQ(s.kind, SurfaceKind::plane);
}

TEST(RingAutoModel, BoxScenesKeepTheirPlanes) {
  RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS();
  // A scene without curved surfaces: no segment is labelled sphere or cylinder, and the plane
  // segments score as with the plane model.
  constexpr std::uint64_t kSeed = 1;
  const synth::Scene scene = synth::random_scene(kSeed);
  const RingRun automatic =
      run(scene, synth::Noise::kinect, "kinect", RegionModel::automatic, kSeed);
  const RingRun planes = run(scene, synth::Noise::kinect, "kinect", RegionModel::plane, kSeed);
  test::expect_labels_name_segments(automatic.u.cloud, automatic.seg);
  for (const Segment& s : automatic.seg.segments) {
    EXPECT_TRUE(s.kind == SurfaceKind::plane || s.kind == SurfaceKind::smooth)
        << "segment " << s.label << ": " << to_string(s.kind);
  }
  const int a = eval::evaluate(automatic.r.labels, automatic.grid, {.tolerance = 0.8}).correct;
  const int p = eval::evaluate(planes.r.labels, planes.grid, {.tolerance = 0.8}).correct;
  std::printf("  boxes %llu: auto %d, plane %d correct\n", static_cast<unsigned long long>(kSeed),
              a, p);
  EXPECT_GE(a, p - 1);
}

}  // namespace
}  // namespace rangeseg
