// Tests of the sphere / cylinder fits against analytic ground truth, and of the `automatic`
// and `incremental_plane` region models on rendered scenes (Hoover evaluation).
#include "rangeseg/primitives.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "rangeseg/eval.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/synth.hpp"
#include "segmentation_test_util.hpp"
#include "test_util.hpp"

namespace rangeseg {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

double dot(const Point3& a, const Point3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Point3 normalized(const Point3& a) {
  const double n = std::sqrt(dot(a, a));
  return {a[0] / n, a[1] / n, a[2] / n};
}
double axis_angle_deg(const Point3& a, const Point3& b) {
  return std::acos(std::min(1.0, std::fabs(dot(normalized(a), normalized(b))))) / kDeg;
}

/// Distance from point p to the line through q with unit direction d.
double line_distance(const Point3& p, const Point3& q, const Point3& d) {
  const Point3 w{p[0] - q[0], p[1] - q[1], p[2] - q[2]};
  const double t = dot(w, d);
  const Point3 r{w[0] - t * d[0], w[1] - t * d[1], w[2] - t * d[2]};
  return std::sqrt(dot(r, r));
}

/// Moves p along its viewing ray by Gaussian depth noise of the Kinect model's sigma(z), and
/// tilts the normal by Gaussian noise of `normal_sigma` [rad] per component.
void add_noise(std::vector<Point3>& points, std::vector<Point3>& normals, double normal_sigma,
               std::mt19937_64& rng) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  const SensorNoise noise;
  for (std::size_t i = 0; i < points.size(); ++i) {
    Point3& p = points[i];
    const double dz = noise.sigma(p[2]) * gauss(rng);
    const double s = (p[2] + dz) / p[2];
    p = {p[0] * s, p[1] * s, p[2] * s};
    Point3& n = normals[i];
    n = normalized({n[0] + normal_sigma * gauss(rng), n[1] + normal_sigma * gauss(rng),
                    n[2] + normal_sigma * gauss(rng)});
  }
}

/// The part of a sphere visible from the origin (front cap), sampled on a grid of directions.
void sample_sphere(const Point3& c, double r, int n, std::vector<Point3>& points,
                   std::vector<Point3>& normals) {
  const Point3 towards_camera = normalized({-c[0], -c[1], -c[2]});
  // Orthonormal basis around the direction to the camera.
  Point3 e1 = normalized({towards_camera[2], 0.0, -towards_camera[0]});
  const Point3 e2{towards_camera[1] * e1[2] - towards_camera[2] * e1[1],
                  towards_camera[2] * e1[0] - towards_camera[0] * e1[2],
                  towards_camera[0] * e1[1] - towards_camera[1] * e1[0]};
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double a = (2.0 * i / (n - 1) - 1.0) * 0.9, b = (2.0 * j / (n - 1) - 1.0) * 0.9;
      if (a * a + b * b > 0.81) continue;
      const double h = std::sqrt(1.0 - a * a - b * b);
      const Point3 nrm{a * e1[0] + b * e2[0] + h * towards_camera[0],
                       a * e1[1] + b * e2[1] + h * towards_camera[1],
                       a * e1[2] + b * e2[2] + h * towards_camera[2]};
      points.push_back({c[0] + r * nrm[0], c[1] + r * nrm[1], c[2] + r * nrm[2]});
      normals.push_back(nrm);
    }
  }
}

/// A cylinder side between angles -span/2 .. span/2 around the direction to the camera.
void sample_cylinder(const Point3& base, const Point3& axis_in, double r, double height,
                     double span, int n, std::vector<Point3>& points,
                     std::vector<Point3>& normals) {
  const Point3 axis = normalized(axis_in);
  Point3 to_camera{-base[0], -base[1], -base[2]};
  const double t = dot(to_camera, axis);
  to_camera = normalized(
      {to_camera[0] - t * axis[0], to_camera[1] - t * axis[1], to_camera[2] - t * axis[2]});
  const Point3 side{axis[1] * to_camera[2] - axis[2] * to_camera[1],
                    axis[2] * to_camera[0] - axis[0] * to_camera[2],
                    axis[0] * to_camera[1] - axis[1] * to_camera[0]};
  for (int i = 0; i < n; ++i) {
    const double phi = (static_cast<double>(i) / (n - 1) - 0.5) * span;
    const Point3 nrm{std::cos(phi) * to_camera[0] + std::sin(phi) * side[0],
                     std::cos(phi) * to_camera[1] + std::sin(phi) * side[1],
                     std::cos(phi) * to_camera[2] + std::sin(phi) * side[2]};
    for (int j = 0; j < n; ++j) {
      const double h = height * j / (n - 1);
      points.push_back({base[0] + h * axis[0] + r * nrm[0], base[1] + h * axis[1] + r * nrm[1],
                        base[2] + h * axis[2] + r * nrm[2]});
      normals.push_back(nrm);
    }
  }
}

TEST(FitSphere, ExactOnNoiseFreeCap) {
  std::vector<Point3> points, normals;
  sample_sphere({0.3, -0.2, 2.5}, 0.15, 40, points, normals);
  const SphereFit fit = fit_sphere(points, normals);
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.radius, 0.15, 1e-9);
  EXPECT_NEAR(fit.centre[0], 0.3, 1e-9);
  EXPECT_NEAR(fit.centre[1], -0.2, 1e-9);
  EXPECT_NEAR(fit.centre[2], 2.5, 1e-9);
  EXPECT_LT(fit.rms, 1e-9);
}

TEST(FitSphere, WorksWithoutNormalsAndRejectsBadInput) {
  std::vector<Point3> points, normals;
  sample_sphere({-0.4, 0.1, 1.5}, 0.3, 30, points, normals);
  std::vector<Point3> no_normals(points.size(), {NAN, NAN, NAN});
  const SphereFit fit = fit_sphere(points, no_normals);
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.radius, 0.3, 1e-7);
  EXPECT_FALSE(fit_sphere(std::span(points).first(3), std::span(normals).first(3)).ok);
  EXPECT_THROW(fit_sphere(points, std::span(normals).first(5)), std::invalid_argument);
}

TEST(FitCylinder, ExactOnNoiseFreeSide) {
  for (const Point3 axis : {Point3{0, -1, 0}, Point3{0.3, -1, 0.2}, Point3{1, 0.1, 0.4}}) {
    std::vector<Point3> points, normals;
    const Point3 base{0.2, 0.5, 2.8};
    sample_cylinder(base, axis, 0.12, 0.6, 150 * kDeg, 40, points, normals);
    const CylinderFit fit = fit_cylinder(points, normals);
    ASSERT_TRUE(fit.ok);
    EXPECT_NEAR(fit.radius, 0.12, 1e-8);
    EXPECT_LT(axis_angle_deg(fit.axis, axis), 1e-6);
    EXPECT_LT(line_distance(base, fit.axis_point, fit.axis), 1e-8);
    EXPECT_NEAR(fit.extent, 0.6, 1e-8);
    EXPECT_LE(fit.axis[1], 0.0);  // points up
    EXPECT_LT(fit.rms, 1e-8);
  }
}

TEST(FitCylinder, NarrowStripAndBadInput) {
  // A 40 degree strip: the normals alone barely fix the axis; the refinement must.
  std::vector<Point3> points, normals;
  sample_cylinder({0.0, 0.3, 2.0}, {0.1, -1, 0}, 0.2, 0.5, 40 * kDeg, 30, points, normals);
  const CylinderFit fit = fit_cylinder(points, normals);
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.radius, 0.2, 1e-6);
  EXPECT_LT(axis_angle_deg(fit.axis, {0.1, -1, 0}), 1e-4);
  EXPECT_THROW(fit_cylinder(points, std::span(normals).first(5)), std::invalid_argument);
  EXPECT_FALSE(fit_cylinder(std::span(points).first(4), std::span(normals).first(4)).ok);
}

/// A segment takes some points of the surface beside it along its border (a lid's rim on a
/// cylinder, a table under a ball): 2 % of the points, 2-5 cm off the surface, with normals of
/// their own surface. The fits drop them (beyond 10 robust standard deviations of the
/// least-squares fit) and stay exact; least squares over all points (outlier_refits = 0) misses
/// the radius by more than 0.5 % (cylinder) and 1 % (sphere).
TEST(FitPrimitives, AFewPointsOfAnotherSurfaceDoNotMoveTheFit) {
  std::vector<Point3> points, normals;
  const Point3 base{0.2, 0.5, 2.8}, axis{0.0, -1.0, 0.0};
  sample_cylinder(base, axis, 0.12, 0.6, 150 * kDeg, 40, points, normals);
  const std::size_t lid = points.size() / 50;
  // The lid at the top (y = 0.5 - 0.6): points 2-5 cm inside the rim, facing up.
  for (std::size_t k = 0; k < lid; ++k) {
    const double phi = -0.6 + 1.2 * static_cast<double>(k) / static_cast<double>(lid);
    const double rho = 0.12 - 0.02 - 0.03 * static_cast<double>(k % 4) / 3.0;
    points.push_back({base[0] + rho * std::sin(phi), -0.1, base[2] - rho * std::cos(phi)});
    normals.push_back({0.0, -1.0, 0.0});
  }
  const CylinderFit cylinder = fit_cylinder(points, normals);
  ASSERT_TRUE(cylinder.ok);
  EXPECT_NEAR(cylinder.radius, 0.12, 1e-6);
  EXPECT_LT(axis_angle_deg(cylinder.axis, axis), 1e-4);
  EXPECT_LT(line_distance(base, cylinder.axis_point, cylinder.axis), 1e-6);
  // Its RMS is over all points, outliers included (what the segment's points do).
  EXPECT_GT(cylinder.rms, 0.002);
  const CylinderFit plain = fit_cylinder(points, normals, {.outlier_refits = 0});
  ASSERT_TRUE(plain.ok);
  EXPECT_GT(std::fabs(plain.radius - 0.12), 0.005 * 0.12);

  points.clear();
  normals.clear();
  const Point3 centre{0.3, -0.2, 2.5};
  sample_sphere(centre, 0.15, 40, points, normals);
  const std::size_t floor = points.size() / 50;
  // The floor under the ball (y = centre + 0.16), seen from above its lowest point.
  for (std::size_t k = 0; k < floor; ++k) {
    const double x = -0.05 + 0.1 * static_cast<double>(k) / static_cast<double>(floor);
    points.push_back({centre[0] + x, centre[1] + 0.16, centre[2] - 0.05 - 0.02 * (k % 3)});
    normals.push_back({0.0, -1.0, 0.0});
  }
  const SphereFit sphere = fit_sphere(points, normals);
  ASSERT_TRUE(sphere.ok);
  EXPECT_NEAR(sphere.radius, 0.15, 1e-6);
  EXPECT_NEAR(sphere.centre[1], -0.2, 1e-6);
  const SphereFit plain_sphere = fit_sphere(points, normals, {.outlier_refits = 0});
  ASSERT_TRUE(plain_sphere.ok);
  EXPECT_GT(std::fabs(plain_sphere.radius - 0.15), 0.01 * 0.15);
}

TEST(FitPrimitives, KinectNoiseWithinFivePercentAndThreeDegrees) {
  // 1.8 - 2.6 m (sigma 4 - 10 mm). Farther away a 15 cm cap's radius trades off against its
  // centre's depth: at 3.2 m (sigma 16 mm) single draws miss by ~7%.
  std::mt19937_64 rng(42);
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<Point3> points, normals;
    sample_sphere({0.2 * trial - 0.4, 0.1, 1.8 + 0.2 * trial}, 0.15, 45, points, normals);
    add_noise(points, normals, 0.1, rng);
    const SphereFit sphere = fit_sphere(points, normals);
    ASSERT_TRUE(sphere.ok);
    EXPECT_NEAR(sphere.radius, 0.15, 0.05 * 0.15) << "trial " << trial;

    points.clear();
    normals.clear();
    const Point3 axis{0.05 * trial, -1.0, 0.0};
    sample_cylinder({0.1, 0.4, 1.8 + 0.3 * trial}, axis, 0.12, 0.6, 150 * kDeg, 30, points,
                    normals);
    add_noise(points, normals, 0.1, rng);
    const CylinderFit cyl = fit_cylinder(points, normals);
    ASSERT_TRUE(cyl.ok);
    EXPECT_NEAR(cyl.radius, 0.12, 0.05 * 0.12) << "trial " << trial;
    EXPECT_LT(axis_angle_deg(cyl.axis, axis), 3.0) << "trial " << trial;
  }
}

// --- region models on rendered scenes ---

using test::curved_scene;
using test::floor_and_wall;

struct SceneRun {
  synth::Rendering r;
  Segmentation seg;
};

SceneRun run(const synth::Scene& scene, synth::Noise noise, RegionModel model,
             std::uint64_t seed = 1, const char* sensor = "kinect") {
  SceneRun out;
  out.r = synth::render(scene, {.noise = noise, .seed = seed});
  PipelineSettings settings = pipeline_preset(sensor);
  settings.segmentation.model = model;
  settings.polygons = false;
  Pipeline pipeline(settings);
  pipeline.process(out.r.cloud);
  out.seg = pipeline.segmentation();
  return out;
}

/// The machine segment with the largest overlap with GT label `gt`.
int best_segment(const SceneRun& run, int gt) {
  std::map<int, int> overlap;
  for (int v = 0; v < run.r.labels.height(); ++v) {
    for (int u = 0; u < run.r.labels.width(); ++u) {
      if (run.r.labels(u, v) == gt && run.seg.labels(u, v) != 0) ++overlap[run.seg.labels(u, v)];
    }
  }
  int best = 0, count = 0;
  for (const auto& [label, c] : overlap) {
    if (c > count) best = label, count = c;
  }
  return best;
}

/// Each curved surface of at least 500 pixels (or only the one named `only`) is one segment of
/// its kind, radius and axis within the tolerances.
void check_curved(const SceneRun& run, double radius_tol, double axis_tol_deg,
                  const std::string& only = {}) {
  for (std::size_t k = 0; k < run.r.surfaces.size(); ++k) {
    const synth::Surface& s = run.r.surfaces[k];
    if (s.type == synth::SurfaceType::plane || run.r.pixel_counts[k] < 500) continue;
    if (!only.empty() && s.name != only) continue;
    const int gt = static_cast<int>(k + 1);
    const int label = best_segment(run, gt);
    ASSERT_NE(label, 0) << s.name;
    const Segment& seg = run.seg.segments[static_cast<std::size_t>(label - 1)];
    std::printf("%-20s kind %-8s radius %.4f (true %.4f) rms %.4f\n", s.name.c_str(),
                to_string(seg.kind), seg.radius, s.radius, seg.surface_rms);
    if (s.type == synth::SurfaceType::sphere) {
      EXPECT_EQ(seg.kind, SurfaceKind::sphere) << s.name;
    } else {
      EXPECT_EQ(seg.kind, SurfaceKind::cylinder) << s.name;
      std::printf("   axis error %.3f deg\n", axis_angle_deg(seg.axis, s.axis));
      EXPECT_LT(axis_angle_deg(seg.axis, s.axis), axis_tol_deg) << s.name;
    }
    EXPECT_NEAR(seg.radius, s.radius, radius_tol * s.radius) << s.name;
  }
  // One segment per visible curved surface: correct detections at T = 0.8.
  const eval::EvalResult e = eval::evaluate(run.r.labels, run.seg.labels, {.tolerance = 0.8});
  for (const eval::RegionOutcome& o : e.gt) {
    const synth::Surface& s = run.r.surfaces[static_cast<std::size_t>(o.label - 1)];
    if (!only.empty() && s.name != only) continue;
    if (s.type != synth::SurfaceType::plane && o.pixels >= 500) {
      EXPECT_EQ(o.outcome, eval::Outcome::correct) << s.name << " " << eval::to_string(o.outcome);
    }
  }
}

TEST(AutoModel, NoiseFreeCurvedSurfacesAreOneSegmentEach) {
  const SceneRun r = run(curved_scene(), synth::Noise::none, RegionModel::automatic);
  check_curved(r, 0.01, 1.0);
}

TEST(AutoModel, NoiseFreeFarSphereWhosePlaneFacetsAreAllSmall) {
  // Without noise the normal test lets a plane facet bend by a few degrees only: on the ball of
  // this scene (r = 0.24 m at 3 m) every facet stays under min_region_size, so the plane model
  // leaves it unlabelled, and region growing by surface continuity must recover it.
  const SceneRun r = run(synth::random_scene(1, true), synth::Noise::none, RegionModel::automatic);
  check_curved(r, 0.01, 1.0);
}

TEST(AutoModel, KinectNoiseCurvedSurfaces) {
  for (std::uint64_t seed : {1, 2}) {
    const SceneRun r = run(curved_scene(), synth::Noise::kinect, RegionModel::automatic, seed);
    check_curved(r, 0.05, 3.0);
  }
}

/// A ball (r = 0.24 m, 4.7 m away) seen with Kinect noise (sigma 3.6 cm there): plane
/// segmentation cuts it into two facets whose normals are 60-80 deg apart, each fitting a plane
/// within the noise, while their union is one sphere within the noise; a pair test limited to
/// 60 deg between facets never tried it (`rangeseg synth --scene mixed --seed 2`).
TEST(AutoModel, KinectNoiseFarBallIsOneSphere) {
  synth::Scene scene = floor_and_wall(6.0);
  scene.spheres.push_back({.centre = {-0.8, 0.9 - 0.24, 4.7}, .radius = 0.24, .name = "ball"});
  for (std::uint64_t seed : {1, 2, 3}) {
    const SceneRun r = run(scene, synth::Noise::kinect, RegionModel::automatic, seed);
    check_curved(r, 0.05, 3.0);
  }
}

/// A small ball (r = 0.11 m) 4 m away with Kinect noise (sigma 2.6 cm there): its 1-ring normals
/// scatter by ~19 deg on average, so the plane model cuts it into facets below min_region_size
/// and growing by surface continuity (8 deg between neighbours) stops at once; only the patch
/// of unlabelled points it leaves, tested as a sphere against that normal noise, recovers it
/// (`rangeseg synth --scene mixed --seed 13`).
TEST(AutoModel, KinectNoiseSmallFarBallLeftUnlabelledIsOneSphere) {
  synth::Scene scene = floor_and_wall(6.0);
  scene.spheres.push_back({.centre = {1.0, 0.9 - 0.11, 4.0}, .radius = 0.11, .name = "ball"});
  for (std::uint64_t seed : {1, 2, 3}) {
    const SceneRun r = run(scene, synth::Noise::kinect, RegionModel::automatic, seed);
    check_curved(r, 0.05, 3.0);
  }
}

/// Labels and segments agree (pixel counts, labels 1..N by size) on a plane at 2 m with half its
/// pixels dropped at random: it falls into many small pieces, and the patches that the auto model
/// keeps after the plane segments (their labels follow the plane segments') can be larger than
/// the smallest plane segments, so the final relabelling by size must move them even when no
/// segment was joined or dropped and no point re-assigned.
TEST(AutoModel, LabelsAndSegmentsAgreeOnFragmentedInput) {
  OrganizedCloud cloud(341, 260);
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      std::uint32_t h =
          static_cast<std::uint32_t>(u) * 73856093u ^ static_cast<std::uint32_t>(v) * 19349663u;
      h *= 2654435761u;
      if ((h >> 16 & 1u) != 0) continue;
      const float z = 2.0f;
      cloud.x(u, v) = static_cast<float>((u - 170) * z / 500.0f);
      cloud.y(u, v) = static_cast<float>((v - 130) * z / 500.0f);
      cloud.z(u, v) = z;
    }
  }
  // With the laser preset's low noise the pieces stay many small segments (the Kinect preset's
  // smoothing joins them into a few).
  for (const char* sensor : {"laser", "kinect"}) {
    PipelineSettings settings = pipeline_preset(sensor);
    settings.segmentation.model = RegionModel::automatic;
    settings.polygons = false;
    Pipeline pipeline(settings);
    pipeline.process(cloud);
    const Segmentation& seg = pipeline.segmentation();
    if (std::string(sensor) == "laser") {
      EXPECT_GT(seg.segments.size(), 10u);
    }
    test::expect_labels_name_segments(cloud, seg, sensor);
  }
}

/// A standing cylinder (r = 0.17 m) 3.4 m away, noise-free: its plane facets face directions
/// 30 deg and more apart, too far for merging to join them, yet their union sags from one plane
/// by less than a third of the Kinect's sigma there (18 mm), so the flatness gate of the curved
/// merge alone would leave it in facets (`rangeseg synth --scene mixed --seed 4 --noise none`).
TEST(AutoModel, NoiseFreeSmallFarCylinderIsOneSegment) {
  synth::Scene scene = floor_and_wall(5.0);
  scene.cylinders.push_back(
      {.base = {-0.65, 0.9, 3.43}, .radius = 0.17, .height = 0.25, .name = "small far"});
  const SceneRun r = run(scene, synth::Noise::none, RegionModel::automatic);
  check_curved(r, 0.01, 1.0);
}

/// Noise-free mixed scene 8 (`rangeseg synth --scene mixed --seed 8 --noise none`): the plane
/// model cuts its standing cylinder into facets, and the pair of facets tested first joins
/// neither; the cylinder is one segment only when that pair is tested again after each side has
/// grown by its other neighbours.
TEST(AutoModel, CylinderWhoseFacetsJoinInTwoStepsIsOneSegment) {
  const SceneRun r = run(synth::random_scene(8, true), synth::Noise::none, RegionModel::automatic);
  check_curved(r, 0.01, 1.0);
}

/// Noise-free mixed scene 2 (`rangeseg synth --scene mixed --seed 2 --noise none`, segmented
/// with `--preset ideal`: sigma 0.5 mm, no smoothing): with a 0.5 mm noise model the plane model
/// cuts the standing cylinder into narrow facets; two of them together cover too short an arc to be
/// told from a plane, so the cylinder is put together from its wider side facets inwards, over more
/// than two passes of the pair tests.
TEST(AutoModel, LowNoiseCylinderJoinsOverSeveralPasses) {
  const SceneRun r =
      run(synth::random_scene(2, true), synth::Noise::none, RegionModel::automatic, 1, "ideal");
  check_curved(r, 0.01, 1.0);
}

/// Noise-free mixed scene 7, as above: the cylinder's facets end up in two cylinder segments
/// separated by a column of points that no facet's plane took; they become neighbours only
/// when those points are re-assigned to the curved segments, and are then joined.
TEST(AutoModel, LowNoiseCylinderPartsJoinAcrossReassignedPoints) {
  const SceneRun r =
      run(synth::random_scene(7, true), synth::Noise::none, RegionModel::automatic, 1, "ideal");
  check_curved(r, 0.01, 1.0);
}

/// Noise-free mixed scene 6, as above: plane facets of a cylinder are cut off from its curved
/// part by such a column, and join it only once the points are re-assigned to the cylinder.
TEST(AutoModel, LowNoiseFacetsJoinCylinderAcrossReassignedPoints) {
  const SceneRun r =
      run(synth::random_scene(6, true), synth::Noise::none, RegionModel::automatic, 1, "ideal");
  check_curved(r, 0.01, 1.0);
}

/// Noise-free mixed scenes 1 and 5, as above: every facet of a cylinder is ~10 deg wide, so no
/// pair of them covers the arc a curved fit needs to be told from a plane, and there is no
/// wider facet to start from; three neighbouring facets together do.
TEST(AutoModel, LowNoiseCylinderOfNarrowFacetsJoinsInThrees) {
  for (const std::uint64_t seed : {1, 5}) {
    const SceneRun r = run(synth::random_scene(seed, true), synth::Noise::none,
                           RegionModel::automatic, 1, "ideal");
    check_curved(r, 0.01, 1.0);
  }
}

/// Noise-free mixed scene 3, as above: the facets that join the cylinder after re-assignment
/// leave the next facet beyond another such column, so re-assignment and joining repeat until
/// nothing joins.
TEST(AutoModel, LowNoiseReassignmentAndJoiningRepeat) {
  const SceneRun r =
      run(synth::random_scene(3, true), synth::Noise::none, RegionModel::automatic, 1, "ideal");
  check_curved(r, 0.01, 1.0, "cylinder0/side");
}

/// The same scene's second cylinder: its facets join into two halves (2594 and 2138 px) only
/// after re-assignment, when the merge passes are over; the facet pairs along which the halves
/// meet must then be tested again.
TEST(AutoModel, LowNoiseCylinderHalvesGrownAfterReassignmentJoin) {
  const SceneRun r =
      run(synth::random_scene(3, true), synth::Noise::none, RegionModel::automatic, 1, "ideal");
  check_curved(r, 0.01, 1.0, "cylinder1/side");
}

/// Noise-free box scenes 2, 3 and 8 (`rangeseg synth --scene boxes --seed N --noise none`): the
/// `ideal` preset, whose noise model matches such data, finds box faces that the Kinect preset
/// merges or loses (13 against 11 of 13 regions, 7 against 6 of 7, 17 against 16 of 17).
TEST(IdealPreset, NoiseFreeBoxScenesBeatTheKinectPreset) {
  int ideal_total = 0, kinect_total = 0;
  for (const std::uint64_t seed : {2, 3, 8}) {
    const synth::Scene scene = synth::random_scene(seed, false);
    const SceneRun ideal = run(scene, synth::Noise::none, RegionModel::plane, seed, "ideal");
    const SceneRun kinect = run(scene, synth::Noise::none, RegionModel::plane, seed, "kinect");
    const eval::EvalResult ei =
        eval::evaluate(ideal.r.labels, ideal.seg.labels, {.tolerance = 0.8});
    const eval::EvalResult ek =
        eval::evaluate(kinect.r.labels, kinect.seg.labels, {.tolerance = 0.8});
    std::printf("seed %d: ideal %d, kinect %d of %d, noise regions %d / %d\n",
                static_cast<int>(seed), ei.correct, ek.correct, ei.gt_regions, ei.noise, ek.noise);
    EXPECT_GT(ei.correct, ek.correct) << "seed " << seed;
    EXPECT_EQ(ei.noise, 0) << "seed " << seed;
    ideal_total += ei.correct;
    kinect_total += ek.correct;
  }
  EXPECT_GE(ideal_total, kinect_total + 4);
}

double correct_fraction(bool curved, RegionModel model, int seeds, bool print) {
  int correct = 0, total = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    const SceneRun r = run(synth::random_scene(seed, curved), synth::Noise::kinect, model, seed);
    const eval::EvalResult e = eval::evaluate(r.r.labels, r.seg.labels, {.tolerance = 0.8});
    correct += e.correct;
    total += e.gt_regions;
    if (print) {
      for (const eval::RegionOutcome& o : e.gt) {
        if (o.outcome != eval::Outcome::correct) {
          std::printf("seed %d: %s %s (%lld px)\n", seed,
                      r.r.surfaces[static_cast<std::size_t>(o.label - 1)].name.c_str(),
                      eval::to_string(o.outcome), static_cast<long long>(o.pixels));
        }
      }
    }
  }
  return static_cast<double>(correct) / total;
}

TEST(AutoModel, DISABLED_CompareWithPlanes) {
  for (const synth::Noise noise : {synth::Noise::none, synth::Noise::kinect}) {
    for (int seed = 1; seed <= 8; ++seed) {
      const SceneRun a = run(synth::random_scene(seed, true), noise, RegionModel::automatic, seed);
      const SceneRun p = run(synth::random_scene(seed, true), noise, RegionModel::plane, seed);
      const eval::EvalResult ea = eval::evaluate(a.r.labels, a.seg.labels, {.tolerance = 0.8});
      const eval::EvalResult ep = eval::evaluate(p.r.labels, p.seg.labels, {.tolerance = 0.8});
      std::printf("noise %d seed %d: auto %d/%d plane %d/%d\n", static_cast<int>(noise), seed,
                  ea.correct, ea.gt_regions, ep.correct, ep.gt_regions);
      for (std::size_t k = 0; k < ea.gt.size(); ++k) {
        if (ea.gt[k].outcome != ep.gt[k].outcome) {
          std::printf("   %-16s auto %-8s plane %-8s (%lld px)\n",
                      a.r.surfaces[static_cast<std::size_t>(ea.gt[k].label - 1)].name.c_str(),
                      eval::to_string(ea.gt[k].outcome), eval::to_string(ep.gt[k].outcome),
                      static_cast<long long>(ea.gt[k].pixels));
        }
      }
    }
  }
}

TEST(AutoModel, MixedScenesHoover) {
  // Seeds 1-3 of `rangeseg synth --scene mixed`, Kinect noise, every visible surface counted
  // (also the small box tops and cylinder caps that the plane model misses). Measured: auto
  // 21/41, plane 16/41; over seeds 1-8 auto 71/125, plane 56/125 (noise-free: 77 vs 60).
  const double automatic = correct_fraction(true, RegionModel::automatic, 3, false);
  const double planes = correct_fraction(true, RegionModel::plane, 3, false);
  std::printf("mixed scenes, T = 0.8: auto %.3f, plane %.3f correct\n", automatic, planes);
  EXPECT_GE(automatic, 0.45);
  EXPECT_GE(automatic, planes + 0.08);
}

TEST(AutoModel, PlaneOnlyScenesNoWorseThanPlanes) {
  for (int seed = 1; seed <= 2; ++seed) {
    const SceneRun a =
        run(synth::random_scene(seed, false), synth::Noise::kinect, RegionModel::automatic, seed);
    const SceneRun p =
        run(synth::random_scene(seed, false), synth::Noise::kinect, RegionModel::plane, seed);
    const eval::EvalResult ea = eval::evaluate(a.r.labels, a.seg.labels, {.tolerance = 0.8});
    const eval::EvalResult ep = eval::evaluate(p.r.labels, p.seg.labels, {.tolerance = 0.8});
    EXPECT_GE(ea.correct, ep.correct) << "seed " << seed;
    int curved = 0;
    for (const Segment& s : a.seg.segments) curved += s.kind != SurfaceKind::plane;
    EXPECT_EQ(curved, 0) << "seed " << seed;
  }
}

TEST(IncrementalPlaneModel, TiltedPlaneIsOneSegment) {
  for (const synth::Noise noise : {synth::Noise::none, synth::Noise::kinect}) {
    const SceneRun r = run(synth::plane_scene(2.5, 0.5), noise, RegionModel::incremental_plane);
    ASSERT_FALSE(r.seg.segments.empty());
    const Segment& s = r.seg.segments[0];
    EXPECT_EQ(s.model, RegionModel::incremental_plane);
    EXPECT_EQ(s.kind, SurfaceKind::plane);
    EXPECT_GE(s.pixel_count, 0.95 * static_cast<double>(r.r.cloud.count_valid()));
    const synth::Surface& gt = r.r.surfaces[0];
    EXPECT_LT(axis_angle_deg(s.normal, gt.normal), 0.5);
  }
}

TEST(IncrementalPlaneModel, BoxScenesComparableToPlanes) {
  int correct_incremental = 0, correct_planes = 0;
  for (int seed = 1; seed <= 2; ++seed) {
    const SceneRun i = run(synth::random_scene(seed, false), synth::Noise::kinect,
                           RegionModel::incremental_plane, seed);
    const SceneRun p =
        run(synth::random_scene(seed, false), synth::Noise::kinect, RegionModel::plane, seed);
    correct_incremental += eval::evaluate(i.r.labels, i.seg.labels, {.tolerance = 0.8}).correct;
    correct_planes += eval::evaluate(p.r.labels, p.seg.labels, {.tolerance = 0.8}).correct;
  }
  std::printf("box scenes 1-2: incremental %d, plane %d correct\n", correct_incremental,
              correct_planes);
  EXPECT_GE(correct_incremental, correct_planes - 2);
}

struct PartCover {
  int pixels = 0;
  double best_fraction = 0;  ///< of the part's pixels in its best segment
  int pieces = 0;            ///< segments holding >= 10% of the part
  SurfaceKind kind = SurfaceKind::plane;
};

/// Per OSD ground-truth object part (labels >= 20), how the segmentation covers it.
std::map<int, PartCover> cover_parts(const OrganizedCloud& cloud, RegionModel model) {
  PipelineSettings settings = pipeline_preset("kinect");
  settings.segmentation.model = model;
  settings.polygons = false;
  Pipeline pipeline(settings);
  pipeline.process(cloud);
  const Segmentation& seg = pipeline.segmentation();
  std::map<int, std::map<int, int>> overlap;
  std::map<int, PartCover> parts;
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      const int gt = cloud.label(u, v);
      if (gt < 20 || !cloud.valid(u, v)) continue;
      ++parts[gt].pixels;
      ++overlap[gt][seg.labels(u, v)];
    }
  }
  for (auto& [gt, part] : parts) {
    int best = 0;
    for (const auto& [label, count] : overlap[gt]) {
      if (label == 0) continue;
      if (count >= 0.1 * part.pixels) ++part.pieces;
      if (count > best) {
        best = count;
        part.kind = seg.segments[static_cast<std::size_t>(label - 1)].kind;
      }
    }
    part.best_fraction = static_cast<double>(best) / part.pixels;
  }
  return parts;
}

TEST(AutoModel, OsdCurvedObjectsAreNotCutIntoPlanes) {
  // OSD test55 and test60 (Kinect, objects on a table): GT parts 150 (a bowl-like, spherical
  // part) and 151 (a cylindrical one) fall into 2-4 plane facets with the plane model. With
  // auto each is one curved segment, and no part is covered worse than by the plane model.
  for (const char* name : {"osd/test55.pcd", "osd/test60.pcd"}) {
    RANGESEG_REQUIRE_DATA(name);
    const OrganizedCloud cloud = io::read_pcd(data_file.string());
    const auto planes = cover_parts(cloud, RegionModel::plane);
    const auto automatic = cover_parts(cloud, RegionModel::automatic);
    for (const auto& [gt, p] : planes) {
      EXPECT_GE(automatic.at(gt).best_fraction, p.best_fraction - 0.02) << name << " part " << gt;
    }
    for (const int gt : {150, 151}) {
      ASSERT_TRUE(automatic.count(gt)) << name << " part " << gt;
      const PartCover& a = automatic.at(gt);
      std::printf("%s part %d: plane %.2f in %d pieces, auto %.2f (%s)\n", name, gt,
                  planes.at(gt).best_fraction, planes.at(gt).pieces, a.best_fraction,
                  to_string(a.kind));
      EXPECT_GE(planes.at(gt).pieces, 2) << name << " part " << gt;
      EXPECT_GE(a.best_fraction, 0.95) << name << " part " << gt;
      EXPECT_EQ(a.pieces, 1) << name << " part " << gt;
      EXPECT_NE(a.kind, SurfaceKind::plane) << name << " part " << gt;
    }
  }
}

/// PCL's table_scene_mug_stereo_textured: the mug's body comes out of the plane model in facets
/// that join into two cylinders (r 4.2 and 4.3 cm), the upper one cut off by a band of points no
/// facet took; once those are re-assigned to the cylinders, the two are one.
TEST(AutoModel, RealMugBodyIsOneCylinder) {
  RANGESEG_REQUIRE_DATA("kinect/table_scene_mug_stereo_textured.pcd");
  const OrganizedCloud cloud = io::read_pcd(data_file.string());
  PipelineSettings settings = pipeline_preset("kinect");
  settings.segmentation.model = RegionModel::automatic;
  settings.polygons = false;
  Pipeline pipeline(settings);
  pipeline.process(cloud);
  int mugs = 0;
  for (const Segment& s : pipeline.segmentation().segments) {
    // The mug stands 0.7-0.8 m away; the other cylinder found is 2 m away. The top of the mug's
    // handle (r 1.2 cm, 735 px) is a cylinder of its own.
    if (s.kind != SurfaceKind::cylinder || s.centroid[2] > 1.0 || s.pixel_count < 2000) continue;
    ++mugs;
    std::printf("mug segment: %lld px, radius %.4f m\n", static_cast<long long>(s.pixel_count),
                s.radius);
    EXPECT_GT(s.pixel_count, 12000);
    EXPECT_NEAR(s.radius, 0.04, 0.004);
  }
  EXPECT_EQ(mugs, 1);
}

TEST(AutoModel, DISABLED_OsdParts) {
  for (const char* name :
       {"osd/test0.pcd", "osd/test5.pcd", "osd/test55.pcd", "osd/test60.pcd", "osd/learn0.pcd"}) {
    const auto path = test::shared_data_dir() / name;
    if (!std::filesystem::exists(path)) continue;
    const OrganizedCloud cloud = io::read_pcd(path.string());
    const auto planes = cover_parts(cloud, RegionModel::plane);
    const auto automatic = cover_parts(cloud, RegionModel::automatic);
    for (const auto& [gt, p] : planes) {
      const PartCover& a = automatic.at(gt);
      std::printf("%s part %d: %d px | plane best %.2f pieces %d | auto best %.2f pieces %d %s\n",
                  name, gt, p.pixels, p.best_fraction, p.pieces, a.best_fraction, a.pieces,
                  to_string(a.kind));
    }
  }
}

}  // namespace
}  // namespace rangeseg
