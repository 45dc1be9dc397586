// Tests of the plane polygons against analytic scenes (synthetic renderer with ground-truth
// labels and planes), hand-made label patterns with pinch vertices, and an independent
// computation of the mesh area from the explicit face list.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>

#include "detail/simd.hpp"
#include "polygon_test_util.hpp"
#include "polygons/internal.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/polygons.hpp"
#include "rangeseg/synth.hpp"
#include "rangeseg/thread_pool.hpp"
#include "test_util.hpp"

namespace rangeseg {
namespace {

using V3 = std::array<double, 3>;
using test::check_properties;
using test::expect_identical_polygons;
using test::loop2d;
using test::orient;
using test::P2;
using test::point_in;
using test::shoelace;

double dot(const V3& a, const V3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/// Segmentation from the renderer's ground truth: labels and the analytic planes (normal facing
/// the camera), centroid = mean of the labelled points.
Segmentation truth_segmentation(const synth::Rendering& r) {
  Segmentation seg;
  seg.labels = r.labels;
  const int n = static_cast<int>(r.surfaces.size());
  std::vector<V3> sum(n, V3{0, 0, 0});
  std::vector<int> count(n, 0);
  for (int v = 0; v < r.labels.height(); ++v) {
    for (int u = 0; u < r.labels.width(); ++u) {
      const int l = r.labels(u, v);
      if (l <= 0 || !r.cloud.valid(u, v)) continue;
      sum[l - 1][0] += r.cloud.x(u, v);
      sum[l - 1][1] += r.cloud.y(u, v);
      sum[l - 1][2] += r.cloud.z(u, v);
      ++count[l - 1];
    }
  }
  for (int i = 0; i < n; ++i) {
    Segment s;
    s.label = i + 1;
    const synth::Surface& surf = r.surfaces[i];
    s.model = surf.type == synth::SurfaceType::plane ? SegmentModel::plane : SegmentModel::smooth;
    s.pixel_count = count[i];
    if (count[i] > 0) {
      s.centroid = {sum[i][0] / count[i], sum[i][1] / count[i], sum[i][2] / count[i]};
    }
    s.normal = surf.normal;
    s.offset = surf.offset;
    if (dot(s.normal, s.centroid) > 0) {  // face the camera
      for (double& c : s.normal) c = -c;
      s.offset = -s.offset;
    }
    seg.segments.push_back(s);
  }
  return seg;
}

/// A flat fronto-parallel cloud at depth z with the default intrinsics.
OrganizedCloud flat_cloud(int w, int h, double z) {
  OrganizedCloud c(w, h);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      c.x(u, v) = static_cast<float>((u - 319.5) / 525.0 * z);
      c.y(u, v) = static_cast<float>((v - 239.5) / 525.0 * z);
      c.z(u, v) = static_cast<float>(z);
    }
  }
  return c;
}

/// Area of each segment's faces projected onto its plane along the viewing rays, from the
/// explicit face list (independent of the boundary tracing).
std::vector<double> mesh_areas(const OrganizedCloud& cloud, const Mesh& mesh,
                               const Segmentation& seg) {
  TriangleList tl;
  extract_faces(mesh, false, tl);
  std::vector<double> area(seg.segments.size() + 1, 0.0);
  const int w = cloud.width();
  for (std::size_t f = 0; f < tl.indices.size(); f += 3) {
    std::array<V3, 3> q{};
    int label = -1;
    bool same = true;
    for (int k = 0; k < 3; ++k) {
      const int idx = tl.indices[f + k], u = idx % w, v = idx / w;
      const int l = seg.labels(u, v);
      if (label < 0) label = l;
      same &= l == label;
      if (l <= 0) continue;
      const Segment& s = seg.segments[l - 1];
      const V3 p{cloud.x(u, v), cloud.y(u, v), cloud.z(u, v)};
      const double t = -s.offset / dot(s.normal, p);
      q[k] = {p[0] * t, p[1] * t, p[2] * t};
    }
    if (!same || label <= 0) continue;
    const V3 a{q[1][0] - q[0][0], q[1][1] - q[0][1], q[1][2] - q[0][2]};
    const V3 b{q[2][0] - q[0][0], q[2][1] - q[0][1], q[2][2] - q[0][2]};
    const V3 c{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    area[label] += 0.5 * std::sqrt(dot(c, c));
  }
  return area;
}

double dist_to_segment(const V3& p, const V3& a, const V3& b) {
  const V3 e{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, d{p[0] - a[0], p[1] - a[1], p[2] - a[2]};
  const double t = std::clamp(dot(d, e) / dot(e, e), 0.0, 1.0);
  const V3 r{d[0] - t * e[0], d[1] - t * e[1], d[2] - t * e[2]};
  return std::sqrt(dot(r, r));
}

/// Every true corner has a polygon vertex within `tol`, and every polygon vertex is within
/// `tol` of the true rectangle's outline.
void expect_rectangle(const PolygonSet& ps, const PolygonLoop& lp, const std::array<V3, 4>& corners,
                      double tol) {
  for (const V3& c : corners) {
    double best = 1e9;
    for (int i = lp.first; i < lp.first + lp.count; ++i) {
      const auto& p = ps.points3d[i];
      best = std::min(best, std::hypot(p[0] - c[0], p[1] - c[1], p[2] - c[2]));
    }
    EXPECT_LT(best, tol) << "corner (" << c[0] << ", " << c[1] << ", " << c[2] << ")";
  }
  for (int i = lp.first; i < lp.first + lp.count; ++i) {
    const V3 p{ps.points3d[i][0], ps.points3d[i][1], ps.points3d[i][2]};
    double best = 1e9;
    for (int k = 0; k < 4; ++k) {
      best = std::min(best, dist_to_segment(p, corners[k], corners[(k + 1) % 4]));
    }
    EXPECT_LT(best, tol) << "vertex " << i;
  }
}

// A wall (rectangle 1.4 x 1.0 m at 1.5 m) with a box in front: the box's silhouette is a hole
// in the wall's segment, the box's front face a rectangle.
synth::Scene wall_and_box() {
  synth::Scene scene;
  scene.rectangles.push_back({.centre = {0.0, 0.0, 1.5},
                              .half_u = {0.7, 0.0, 0.0},
                              .half_v = {0.0, 0.5, 0.0},
                              .name = "wall"});
  scene.boxes.push_back({.centre = {0.1, 0.05, 1.1}, .half_extent = {0.3, 0.2, 0.1}});
  return scene;
}

TEST(Polygons, WallWithBoxNoiseFreeCornersAreaAndHole) {
  const synth::Rendering r = synth::render(wall_and_box());
  const Segmentation seg = truth_segmentation(r);
  const Mesh mesh = build_mesh(r.cloud);
  const PolygonSet ps = extract_polygons(r.cloud, mesh, seg);
  check_properties(ps);

  // Wall: label 1. Outer loop = the rectangle, one hole = the box silhouette.
  const SegmentPolygons* wall = ps.find(1);
  ASSERT_NE(wall, nullptr);
  ASSERT_EQ(wall->loop_count, 2);
  // find: every segment by its label, null for a label without polygons.
  for (const SegmentPolygons& sp : ps.segments) EXPECT_EQ(ps.find(sp.label), &sp);
  EXPECT_EQ(ps.find(0), nullptr);
  EXPECT_EQ(ps.find(ps.segments.back().label + 1), nullptr);
  const PolygonLoop& outer = ps.loops[wall->first_loop];
  const PolygonLoop& hole = ps.loops[wall->first_loop + 1];
  EXPECT_FALSE(outer.is_hole);
  EXPECT_TRUE(hole.is_hole);
  EXPECT_EQ(outer.count, 4);
  expect_rectangle(ps, outer,
                   {V3{-0.7, -0.5, 1.5}, V3{0.7, -0.5, 1.5}, V3{0.7, 0.5, 1.5}, V3{-0.7, 0.5, 1.5}},
                   0.01);
  // The hole: the box's silhouette (convex hull of its corners seen from the camera) on the wall.
  std::vector<P2> silhouette, hull;
  for (int k = 0; k < 8; ++k) {
    const double x = 0.1 + ((k & 1) ? 0.3 : -0.3), y = 0.05 + ((k & 2) ? 0.2 : -0.2),
                 z = 1.1 + ((k & 4) ? 0.1 : -0.1);
    silhouette.push_back({static_cast<float>(x * 1.5 / z), static_cast<float>(y * 1.5 / z)});
  }
  convex_hull(silhouette, hull);
  const double hole_area = std::abs(shoelace(hull));
  EXPECT_NEAR(hole.area, hole_area, 0.02 * hole_area);
  EXPECT_NEAR(outer.area, 1.4, 0.01 * 1.4);
  EXPECT_NEAR(wall->area, 1.4 - hole_area, 0.01 * (1.4 - hole_area));
  EXPECT_NEAR(wall->hull_area, 1.4, 0.01 * 1.4);

  // Box front face (-z, label 1 + 6): 0.6 x 0.4 m at z = 1.0.
  const SegmentPolygons* front = ps.find(1 + 6);
  ASSERT_NE(front, nullptr);
  ASSERT_EQ(front->loop_count, 1);
  EXPECT_EQ(ps.loops[front->first_loop].count, 4);
  expect_rectangle(
      ps, ps.loops[front->first_loop],
      {V3{-0.2, -0.15, 1.0}, V3{0.4, -0.15, 1.0}, V3{0.4, 0.25, 1.0}, V3{-0.2, 0.25, 1.0}}, 0.01);
  // The mesh ends at the outermost pixel centres, on average half a pixel (1 mm here) inside.
  EXPECT_NEAR(front->area, 0.24, 0.01 * 0.24);
  EXPECT_NEAR(front->hull_area, front->area, 1e-3 * 0.24);

  // Plane frame: orthonormal, right-handed with the normal, origin on the plane.
  const PlaneFrame& fr = wall->frame;
  EXPECT_NEAR(dot(fr.e1, fr.e1), 1.0, 1e-9);
  EXPECT_NEAR(dot(fr.e1, fr.e2), 0.0, 1e-9);
  EXPECT_NEAR(dot(fr.e1, fr.normal), 0.0, 1e-9);
  EXPECT_NEAR(dot(fr.normal, fr.origin) + fr.offset, 0.0, 1e-9);
  EXPECT_NEAR(fr.e1[0], 1.0, 1e-9);   // image right
  EXPECT_NEAR(fr.e2[1], -1.0, 1e-9);  // image up
}

TEST(Polygons, AreaMatchesMeshFacesWithoutSimplification) {
  for (synth::Noise noise : {synth::Noise::none, synth::Noise::kinect}) {
    const synth::Rendering r = synth::render(synth::random_scene(7), {.noise = noise});
    const Segmentation seg = truth_segmentation(r);
    const Mesh mesh = build_mesh(r.cloud);
    const PolygonSet ps = extract_polygons(
        r.cloud, mesh, seg,
        {.simplify_tolerance = 0, .simplify_tolerance_pixels = 0, .min_loop_pixels = 0});
    check_properties(ps);
    const std::vector<double> truth = mesh_areas(r.cloud, mesh, seg);
    int checked = 0;
    for (const SegmentPolygons& sp : ps.segments) {
      EXPECT_NEAR(sp.raw_area, truth[sp.label], 1e-5 * truth[sp.label] + 1e-9) << sp.label;
      EXPECT_NEAR(sp.area, sp.raw_area, 1e-9);
      checked += truth[sp.label] > 0;
    }
    EXPECT_GE(checked, 4);
  }
}

TEST(Polygons, KinectNoiseAt2mAreaWithin5Percent) {
  synth::Scene scene;
  scene.rectangles.push_back({.centre = {0.0, 0.0, 2.0},
                              .half_u = {0.9, 0.0, 0.0},
                              .half_v = {0.0, 0.6, 0.0},
                              .name = "wall"});
  scene.boxes.push_back({.centre = {-0.2, 0.1, 1.7}, .half_extent = {0.25, 0.2, 0.15}});
  const synth::Rendering r = synth::render(scene, {.noise = synth::Noise::kinect, .seed = 3});
  const Segmentation seg = truth_segmentation(r);
  const Mesh mesh = build_mesh(r.cloud);
  const PolygonSet ps = extract_polygons(r.cloud, mesh, seg);
  check_properties(ps);
  const SegmentPolygons* wall = ps.find(1);
  ASSERT_NE(wall, nullptr);
  std::vector<P2> silhouette, hull;
  for (int k = 0; k < 8; ++k) {
    const double x = -0.2 + ((k & 1) ? 0.25 : -0.25), y = 0.1 + ((k & 2) ? 0.2 : -0.2),
                 z = 1.7 + ((k & 4) ? 0.15 : -0.15);
    silhouette.push_back({static_cast<float>(x * 2.0 / z), static_cast<float>(y * 2.0 / z)});
  }
  convex_hull(silhouette, hull);
  const double truth = 1.8 * 1.2 - std::abs(shoelace(hull));
  EXPECT_NEAR(wall->area, truth, 0.05 * truth);
  int holes = 0;
  for (int li = wall->first_loop; li < wall->first_loop + wall->loop_count; ++li) {
    holes += ps.loops[li].is_hole;
  }
  EXPECT_GE(holes, 1);
  const SegmentPolygons* front = ps.find(1 + 6);
  ASSERT_NE(front, nullptr);
  EXPECT_NEAR(front->area, 0.5 * 0.4, 0.05 * 0.2);
  EXPECT_LE(ps.loops[front->first_loop].count, 12);
}

// Labels drawn by hand on a flat cloud at 1 m: pinch vertices where loops touch.
struct Handmade {
  OrganizedCloud cloud = flat_cloud(48, 40, 1.0);
  Segmentation seg;
  Mesh mesh;
  Handmade(MeshType type) {
    seg.labels.resize(48, 40, 0);
    Segment s;
    s.label = 1;
    s.normal = {0, 0, -1};
    s.offset = 1.0;
    s.centroid = {0, 0, 1};
    s.pixel_count = 1000;
    seg.segments.push_back(s);
    mesh = build_mesh(cloud, {.type = type});
  }
  void fill(int u0, int u1, int v0, int v1) {
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) seg.labels(u, v) = 1;
    }
  }
};

double pixel_area(const PolygonSet& ps, const PolygonLoop& lp) {
  return -shoelace({ps.pixels.begin() + lp.first, ps.pixels.begin() + lp.first + lp.count});
}

TEST(Polygons, PinchBetweenTwoBlocksGivesTwoSimpleLoops) {
  Handmade h(MeshType::left_cut);
  h.fill(10, 20, 10, 20);
  h.fill(20, 30, 20, 30);
  const PolygonSettings raw{
      .simplify_tolerance = 0, .simplify_tolerance_pixels = 0, .min_loop_pixels = 0};
  const PolygonSet ps = extract_polygons(h.cloud, h.mesh, h.seg, raw);
  check_properties(ps);
  ASSERT_EQ(ps.segments.size(), 1u);
  ASSERT_EQ(ps.loops.size(), 2u);
  EXPECT_FALSE(ps.loops[0].is_hole);
  EXPECT_FALSE(ps.loops[1].is_hole);
  EXPECT_DOUBLE_EQ(pixel_area(ps, ps.loops[0]), 100.0);
  EXPECT_DOUBLE_EQ(pixel_area(ps, ps.loops[1]), 100.0);
  EXPECT_EQ(ps.loops[0].count, 40);
  EXPECT_NEAR(ps.segments[0].area, 200.0 / (525.0 * 525.0), 1e-9);
}

TEST(Polygons, HoleTouchingOuterLoopIsSplitOff) {
  Handmade h(MeshType::left_cut);
  h.fill(10, 20, 10, 20);  // A
  h.fill(20, 30, 20, 30);  // B, touches A in (20, 20)
  h.fill(25, 30, 10, 20);  // C joins B
  h.fill(20, 25, 10,
         12);  // D joins A and C; the hole (20..25, 12..20) touches the outside at (20, 20)
  const PolygonSet ps = extract_polygons(
      h.cloud, h.mesh, h.seg,
      {.simplify_tolerance = 0, .simplify_tolerance_pixels = 0, .min_loop_pixels = 0});
  check_properties(ps);
  ASSERT_EQ(ps.loops.size(), 2u);
  EXPECT_FALSE(ps.loops[0].is_hole);
  EXPECT_TRUE(ps.loops[1].is_hole);
  EXPECT_EQ(ps.loops[1].parent, 0);
  // 8 x 5 pixels, less the half cells that the cut diagonals add at two of its corners.
  EXPECT_GE(pixel_area(ps, ps.loops[1]), -40.0);
  EXPECT_LE(pixel_area(ps, ps.loops[1]), -38.0);
  // With the default simplification the result is still simple and keeps the hole.
  const PolygonSet simplified = extract_polygons(h.cloud, h.mesh, h.seg);
  check_properties(simplified);
  ASSERT_EQ(simplified.loops.size(), 2u);
  EXPECT_TRUE(simplified.loops[1].is_hole);
}

TEST(Polygons, SmallHolesAndFilters) {
  Handmade h(MeshType::adaptive);
  h.fill(5, 40, 5, 35);
  h.seg.labels(20, 20) = 0;  // one missing pixel: a hole of 3 pixel^2 (its 6 triangles)
  PolygonSet ps = extract_polygons(h.cloud, h.mesh, h.seg, {.min_loop_pixels = 0});
  check_properties(ps);
  ASSERT_EQ(ps.loops.size(), 2u);
  EXPECT_NEAR(ps.loops[1].raw_area, 3.0 / (525.0 * 525.0), 1e-4 * 3.0 / (525.0 * 525.0));
  ps = extract_polygons(h.cloud, h.mesh, h.seg);  // default: holes under 8 pixel^2 dropped
  EXPECT_EQ(ps.loops.size(), 1u);
  ps = extract_polygons(h.cloud, h.mesh, h.seg, {.min_segment_pixels = 2000});
  EXPECT_TRUE(ps.segments.empty());
  // The incremental plane model's segments are planes too.
  h.seg.segments[0].model = SegmentModel::incremental_plane;
  EXPECT_EQ(extract_polygons(h.cloud, h.mesh, h.seg).segments.size(), 1u);
  for (const SurfaceKind curved : {SurfaceKind::cylinder, SurfaceKind::sphere}) {
    h.seg.segments[0].model = SegmentModel::automatic;
    h.seg.segments[0].kind = curved;
    EXPECT_TRUE(extract_polygons(h.cloud, h.mesh, h.seg).segments.empty());
  }
  h.seg.segments[0].kind = SurfaceKind::plane;
  h.seg.segments[0].model = SegmentModel::smooth;
  EXPECT_TRUE(extract_polygons(h.cloud, h.mesh, h.seg).segments.empty());
  EXPECT_EQ(extract_polygons(h.cloud, h.mesh, h.seg, {.planes_only = false}).segments.size(), 1u);
  EXPECT_THROW(extract_polygons(h.cloud, h.mesh, h.seg, {.simplify_tolerance = -1}),
               std::invalid_argument);
  // Each field by its name and value.
  const auto message = [](const PolygonSettings& settings) {
    try {
      validate(settings);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  EXPECT_EQ(message({.min_loop_pixels = INFINITY}),
            "PolygonSettings::min_loop_pixels = inf must be finite and >= 0");
  EXPECT_EQ(message({.min_segment_pixels = -1}),
            "PolygonSettings::min_segment_pixels = -1 must be >= 0");
  EXPECT_EQ(message({.viewpoint = {0.0f, 0.0f, NAN}}),
            "PolygonSettings::viewpoint[2] = nan must be finite [m]");
  EXPECT_EQ(message({}), "no exception");
  OrganizedCloud other = flat_cloud(10, 10, 1.0);
  EXPECT_THROW(extract_polygons(other, h.mesh, h.seg), std::invalid_argument);
  // A label that names no segment (it would cut a hole in its neighbour's polygon).
  const auto n = static_cast<std::int32_t>(h.seg.segments.size());
  for (const std::int32_t bad : {n + 1, 99, -1, -7, std::numeric_limits<std::int32_t>::max(),
                                 std::numeric_limits<std::int32_t>::min()}) {
    Segmentation labelled = h.seg;
    labelled.labels(labelled.labels.width() / 2, labelled.labels.height() / 2) = bad;
    try {
      extract_polygons(h.cloud, h.mesh, labelled);
      ADD_FAILURE() << bad << " accepted";
    } catch (const std::invalid_argument& e) {
      const std::string expected = "label " + std::to_string(bad) + " in row " +
                                   std::to_string(labelled.labels.height() / 2) +
                                   " is not in [0, " + std::to_string(n) + "]";
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  }
  // The highest label names the last segment.
  Segmentation last = h.seg;
  last.labels(0, 0) = n;
  EXPECT_NO_THROW(extract_polygons(h.cloud, h.mesh, last));
}

TEST(Polygons, PipelineSegmentationIsHandledAndExtractorReuseIsDeterministic) {
  const synth::Rendering a = synth::render(synth::demo_scene(), {.noise = synth::Noise::kinect});
  const synth::Rendering b = synth::render(synth::random_scene(3), {.noise = synth::Noise::kinect});
  // Unsmoothed points: polygons must not depend on the smoother (points then lie on pixel rays).
  const PipelineSettings settings{.smooth = false};
  Pipeline pipeline(settings);
  pipeline.process(a.cloud);
  PolygonExtractor extractor;
  PolygonSet first, other, again;
  extractor.extract(pipeline.cloud(), pipeline.mesh(), pipeline.segmentation(), {}, first);
  check_properties(first);
  EXPECT_GE(first.segments.size(), 3u);
  Pipeline pipeline_b(settings);
  pipeline_b.process(b.cloud);
  extractor.extract(pipeline_b.cloud(), pipeline_b.mesh(), pipeline_b.segmentation(), {}, other);
  check_properties(other);
  extractor.extract(pipeline.cloud(), pipeline.mesh(), pipeline.segmentation(), {}, again);
  ASSERT_EQ(first.loops.size(), again.loops.size());
  EXPECT_EQ(first.points3d, again.points3d);
  EXPECT_EQ(first.hull_points2d, again.hull_points2d);
  // Simplified areas stay within tolerance * perimeter of the mesh areas.
  for (const SegmentPolygons& sp : first.segments) {
    double bound = 0;
    for (int li = sp.first_loop; li < sp.first_loop + sp.loop_count; ++li) {
      bound += first.loops[li].tolerance * first.loops[li].raw_perimeter;
    }
    EXPECT_LE(std::abs(sp.area - sp.raw_area), bound + 1e-9) << sp.label;
    EXPECT_GE(sp.hull_area + 1e-9, sp.raw_area);
  }
  // Pixels line up with the loops for drawing.
  std::vector<P2> px;
  loop_pixels(first, 0, px);
  EXPECT_EQ(static_cast<int>(px.size()), first.loops[0].count);
}

TEST(Polygons, ConvexHullContainsAllPoints) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> d(-1, 1);
  std::vector<P2> pts, hull;
  for (int i = 0; i < 500; ++i) pts.push_back({d(rng), d(rng) * 0.5f});
  convex_hull(pts, hull);
  ASSERT_GE(hull.size(), 3u);
  EXPECT_GT(shoelace(hull), 0);
  for (std::size_t i = 0, j = hull.size() - 1; i < hull.size(); j = i++) {
    for (const P2& p : pts) EXPECT_GE(orient(hull[j], hull[i], p), -1e-6);
  }
}

TEST(Polygons, ConcaveHullOfLShapeAndRing) {
  // L shape of points on a 1 cm grid: [0, 1] x [0, 0.3] and [0, 0.3] x [0, 1].
  std::vector<P2> pts;
  for (int i = 0; i <= 100; ++i) {
    for (int j = 0; j <= 100; ++j) {
      if (i <= 30 || j <= 30) pts.push_back({i * 0.01f, j * 0.01f});
    }
  }
  Polygons2D out;
  concave_hull(pts, 0.03, out);
  ASSERT_EQ(out.first.size(), 1u);
  EXPECT_FALSE(out.is_hole[0]);
  std::vector<P2> loop(out.points.begin(), out.points.begin() + out.count[0]);
  const double truth = 1.0 * 0.3 + 0.3 * 0.7;
  EXPECT_NEAR(shoelace(loop), truth, 0.1 * truth);
  EXPECT_LE(out.count[0], 12);
  for (const P2& p : pts) {
    // Inside, or within alpha / 2 * sqrt(2) of the outline.
    bool near = point_in(loop, p[0], p[1]);
    for (std::size_t i = 0, j = loop.size() - 1; i < loop.size() && !near; j = i++) {
      near = dist_to_segment({p[0], p[1], 0}, {loop[j][0], loop[j][1], 0},
                             {loop[i][0], loop[i][1], 0}) < 0.03 * 0.71;
    }
    ASSERT_TRUE(near);
  }
  // A ring: a hole.
  pts.clear();
  for (int i = 0; i <= 100; ++i) {
    for (int j = 0; j <= 100; ++j) {
      if (i <= 20 || i >= 80 || j <= 20 || j >= 80) pts.push_back({i * 0.01f, j * 0.01f});
    }
  }
  concave_hull(pts, 0.03, out);
  ASSERT_EQ(out.first.size(), 2u);
  EXPECT_EQ(out.is_hole[0] + out.is_hole[1], 1);
  EXPECT_THROW(concave_hull(pts, 0.0, out), std::invalid_argument);
}

TEST(Polygons, ObjTriangulationCoversThePolygonArea) {
  const synth::Rendering r = synth::render(wall_and_box());
  const Segmentation seg = truth_segmentation(r);
  const PolygonSet ps = extract_polygons(r.cloud, build_mesh(r.cloud), seg);
  std::vector<std::array<int, 3>> tris;
  triangulate_polygons(ps, tris);
  std::vector<double> area(ps.segments.size(), 0.0);
  for (const auto& t : tris) {
    const double a = orient(ps.points2d[t[0]], ps.points2d[t[1]], ps.points2d[t[2]]) * 0.5;
    EXPECT_GT(a, 0);
    int si = -1;
    for (const PolygonLoop& lp : ps.loops) {
      if (t[0] >= lp.first && t[0] < lp.first + lp.count) si = lp.segment;
    }
    area[si] += a;
  }
  for (std::size_t i = 0; i < ps.segments.size(); ++i) {
    EXPECT_NEAR(area[i], ps.segments[i].area, 1e-6 + 1e-4 * ps.segments[i].area) << i;
  }

  const auto dir = test::scratch_dir("polygons_obj");
  const std::string path = (dir / "planes.obj").string();
  write_polygons_obj(path, ps);
  std::ifstream in(path);
  std::string line;
  int nv = 0, nf = 0;
  while (std::getline(in, line)) {
    if (line.rfind("v ", 0) == 0) {
      // Each coordinate reads back as the float written (a 5 um rounding turned slivers over).
      std::istringstream ss(line.substr(2));
      std::array<float, 3> p{};
      ss >> p[0] >> p[1] >> p[2];
      ASSERT_LT(static_cast<std::size_t>(nv), ps.points3d.size());
      EXPECT_EQ(p, ps.points3d[static_cast<std::size_t>(nv)]) << line;
      ++nv;
    }
    if (line.rfind("f ", 0) == 0) {
      ++nf;
      std::istringstream ss(line.substr(2));
      int a, b, c;
      ss >> a >> b >> c;
      EXPECT_TRUE(a >= 1 && b >= 1 && c >= 1 && a <= nv && b <= nv && c <= nv);
    }
  }
  EXPECT_EQ(nv, static_cast<int>(ps.points3d.size()));
  EXPECT_EQ(nf, static_cast<int>(tris.size()));
}

// An outline with thousands of holes (the boxes scene with Kinect noise segmented with the abw
// preset, whose 0.5 mm noise model leaves most points of the floor unlabelled), many of them
// touching the outline or each other: bridging and ear clipping that rescanned the whole polygon
// per vertex took minutes on it, and ear clipping of touching loops emitted overlapping
// triangles. The triangles are counter-clockwise and cover each segment's polygon area.
TEST(Polygons, ObjTriangulationOfOutlinesWithManyHoles) {
  const OrganizedCloud cloud =
      synth::render(synth::random_scene(1, false), {.noise = synth::Noise::kinect, .seed = 1})
          .cloud;
  Pipeline pipeline(pipeline_preset("abw"));
  pipeline.process(cloud);
  const PolygonSet& ps = pipeline.polygons();
  std::vector<int> segment_of(ps.points2d.size(), -1);
  int most_holes = 0;
  for (const PolygonLoop& loop : ps.loops) {
    for (int i = loop.first; i < loop.first + loop.count; ++i) segment_of[i] = loop.segment;
  }
  for (const SegmentPolygons& sp : ps.segments) {
    int holes = 0;
    for (int l = sp.first_loop; l < sp.first_loop + sp.loop_count; ++l) {
      holes += ps.loops[l].is_hole;
    }
    most_holes = std::max(most_holes, holes);
  }
  ASSERT_GT(most_holes, 1000);
  std::vector<std::array<int, 3>> tris;
  triangulate_polygons(ps, tris);
  std::vector<double> area(ps.segments.size(), 0.0);
  int clockwise = 0;
  for (const auto& t : tris) {
    const double a = 0.5 * orient(ps.points2d[t[0]], ps.points2d[t[1]], ps.points2d[t[2]]);
    clockwise += a <= 0;
    area[segment_of[t[0]]] += a;
  }
  EXPECT_EQ(clockwise, 0);
  for (std::size_t i = 0; i < ps.segments.size(); ++i) {
    EXPECT_NEAR(area[i], ps.segments[i].area, 1e-6 + 1e-4 * ps.segments[i].area) << i;
  }
}

// --- Instruction-set paths: the AVX2 kernels (boundary masks, Douglas-Peucker distances, hull
// candidates) must give bit-identical polygons to the scalar code. On a CPU without AVX2 both
// runs take the scalar path and the comparison is trivially true.

/// Polygons with the widest instruction set, and with the scalar code only.
std::pair<PolygonSet, PolygonSet> both_paths(const OrganizedCloud& cloud, const Mesh& mesh,
                                             const Segmentation& seg,
                                             const PolygonSettings& settings) {
  using detail::simd::Isa;
  PolygonExtractor extractor;  // one extractor: the paths also share its buffers
  PolygonSet fast, scalar;
  extractor.extract(cloud, mesh, seg, settings, fast);
  detail::simd::isa_limit = Isa::baseline;
  extractor.extract(cloud, mesh, seg, settings, scalar);
  detail::simd::isa_limit = Isa::avx512;
  return {std::move(fast), std::move(scalar)};
}

/// Polygons extracted with 2 and 3 threads (boundary masks in row bands, segments split among
/// the threads), with the widest instruction set and the scalar code, equal the single-threaded
/// ones; one extractor serves all, as a pipeline's does frame after frame.
void expect_threads_match(const OrganizedCloud& cloud, const Mesh& mesh, const Segmentation& seg,
                          const PolygonSettings& settings, const std::string& what) {
  using detail::simd::Isa;
  PolygonExtractor extractor;
  for (const Isa isa : {Isa::avx512, Isa::baseline}) {
    detail::simd::isa_limit = isa;
    PolygonSet single, threaded;
    extractor.extract(cloud, mesh, seg, settings, single);
    for (const int threads : {2, 3}) {
      ThreadPool pool(threads);
      extractor.extract(cloud, mesh, seg, settings, threaded, pool);
      expect_identical_polygons(threaded, single,
                                what + ", " + std::to_string(threads) + " threads, isa " +
                                    std::to_string(static_cast<int>(isa)));
    }
  }
  detail::simd::isa_limit = Isa::avx512;
}

const PolygonSettings kRaw{
    .simplify_tolerance = 0, .simplify_tolerance_pixels = 0, .min_loop_pixels = 0};

TEST(Polygons, VectorPathsMatchScalarOnSyntheticScenes) {
  for (std::uint64_t seed : {2u, 5u, 9u}) {
    const synth::Rendering r =
        synth::render(synth::random_scene(seed, seed == 9), {.noise = synth::Noise::kinect});
    const Segmentation seg = truth_segmentation(r);
    for (MeshType type : {MeshType::adaptive, MeshType::quad, MeshType::left_cut}) {
      for (int stride : {1, 2}) {
        const Mesh mesh = build_mesh(r.cloud, {.type = type, .pixel_stride = stride});
        const std::string what = "seed " + std::to_string(seed) + " type " +
                                 std::to_string(static_cast<int>(type)) + " stride " +
                                 std::to_string(stride);
        for (const PolygonSettings& settings : {PolygonSettings{}, kRaw}) {
          const auto [fast, scalar] = both_paths(r.cloud, mesh, seg, settings);
          expect_identical_polygons(fast, scalar, what);
          expect_threads_match(r.cloud, mesh, seg, settings, what);
        }
      }
    }
  }
}

// Random labels on blocks with speckle: many pinch vertices, tiny loops, odd image sizes (the
// vector kernels' row tails), and labels out of range or of disabled segments.
TEST(Polygons, VectorPathsMatchScalarOnSpeckledLabels) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 4; ++trial) {
    const int w = 37 + 29 * trial, h = 23 + 11 * trial;
    OrganizedCloud cloud = flat_cloud(w, h, 1.0);
    std::uniform_real_distribution<float> jitter(0.998f, 1.002f);  // depth noise along the ray
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        const float f = jitter(rng);
        cloud.x(u, v) *= f;
        cloud.y(u, v) *= f;
        cloud.z(u, v) *= f;
      }
    }
    Segmentation seg;
    seg.labels.resize(w, h, 0);
    for (int l = 1; l <= 4; ++l) {
      Segment s;
      s.label = l;
      s.normal = {0, 0, -1};
      s.offset = 1.0;
      s.centroid = {0, 0, 1};
      s.pixel_count = 100;
      s.model = l == 4 ? SegmentModel::smooth : SegmentModel::plane;  // 4 is not outlined
      seg.segments.push_back(s);
    }
    // Labels that name no segment are refused (SmallHolesAndFilters); speckle with the others.
    std::uniform_int_distribution<int> label(0, 4), speckle(0, 9);
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        int l = (u / 9 + v / 7) % 5;
        if (speckle(rng) == 0) l = label(rng);
        seg.labels(u, v) = l;
      }
    }
    for (MeshType type : {MeshType::adaptive, MeshType::quad, MeshType::right_cut}) {
      for (int stride : {1, 2, 3}) {
        const Mesh mesh = build_mesh(cloud, {.type = type, .pixel_stride = stride});
        const std::string what = std::to_string(w) + "x" + std::to_string(h) + " type " +
                                 std::to_string(static_cast<int>(type)) + " stride " +
                                 std::to_string(stride);
        for (const PolygonSettings& settings : {PolygonSettings{}, kRaw}) {
          const auto [fast, scalar] = both_paths(cloud, mesh, seg, settings);
          expect_identical_polygons(fast, scalar, what);
          expect_threads_match(cloud, mesh, seg, settings, what);
          // The mesh boundary itself is simple (simplified loops of such speckle may touch
          // their parent at pinch vertices, which the midpoint test cannot tell from leaving).
          SCOPED_TRACE(what);
          if (settings.simplify_tolerance == 0) check_properties(fast);
        }
      }
    }
  }
}

TEST(Polygons, VectorPathsMatchScalarOnRealFrame) {
  RANGESEG_REQUIRE_DATA("kinect/grabber_frame0.pcd");
  const OrganizedCloud cloud = io::read_pcd(data_file.string());
  PipelineSettings settings = pipeline_preset("kinect");
  settings.smoothing.iterations = 1;  // as `rangeseg bench`
  Pipeline pipeline(settings);
  pipeline.process(cloud);
  for (const PolygonSettings& ps : {PolygonSettings{}, kRaw}) {
    const auto [fast, scalar] =
        both_paths(pipeline.cloud(), pipeline.mesh(), pipeline.segmentation(), ps);
    expect_identical_polygons(fast, scalar, "real frame");
    expect_threads_match(pipeline.cloud(), pipeline.mesh(), pipeline.segmentation(), ps,
                         "real frame");
    EXPECT_GE(fast.segments.size(), 5u);
    check_properties(fast);
  }
}

// Nested loops of one segment: a square with a hole, an island in the hole with its own hole.
// Each hole belongs to the smallest outer loop around it.
TEST(Polygons, HolesBelongToTheSmallestEnclosingOuterLoop) {
  Handmade h(MeshType::left_cut);
  h.fill(2, 45, 2, 37);            // outer loop A
  for (int v = 8; v <= 31; ++v) {  // hole H1 in A
    for (int u = 8; u <= 39; ++u) h.seg.labels(u, v) = 0;
  }
  h.fill(13, 34, 12, 27);           // island B inside H1
  for (int v = 17; v <= 22; ++v) {  // hole H2 in B
    for (int u = 20; u <= 27; ++u) h.seg.labels(u, v) = 0;
  }
  const PolygonSet ps = extract_polygons(h.cloud, h.mesh, h.seg, kRaw);
  check_properties(ps);
  ASSERT_EQ(ps.segments.size(), 1u);
  ASSERT_EQ(ps.loops.size(), 4u);
  // Outer loops by area (A, B), then the holes in the order of their parents.
  const PolygonLoop &a = ps.loops[0], &b = ps.loops[1], &h1 = ps.loops[2], &h2 = ps.loops[3];
  EXPECT_FALSE(a.is_hole);
  EXPECT_FALSE(b.is_hole);
  EXPECT_TRUE(h1.is_hole);
  EXPECT_TRUE(h2.is_hole);
  EXPECT_EQ(h1.parent, 0);
  EXPECT_EQ(h2.parent, 1);
  EXPECT_GT(pixel_area(ps, a), pixel_area(ps, b));
  // H2: 8 x 6 missing pixels, the mesh hole spans 9 x 7 pixel steps less the cut corners.
  EXPECT_NEAR(-pixel_area(ps, h2), 9 * 7, 2.0);
  EXPECT_NEAR(-pixel_area(ps, h1), 33 * 25, 2.0);  // the island is a loop of its own
}

// The hull's point sort (radix on x above a size, std::sort below) against std::sort with the
// (x, y, index) comparator: ties in x and y, -0 and +0, negative and positive coordinates,
// shuffled input, sizes on both sides of the radix threshold.
TEST(Polygons, PointSortMatchesComparisonSort) {
  std::mt19937 rng(7);
  polygons_detail::PointSortScratch scratch;  // reused: no state may leak between calls
  for (int n : {0, 1, 5, 255, 256, 300, 2000, 5000}) {
    for (int kind = 0; kind < 3; ++kind) {
      std::vector<double> xy(2 * static_cast<std::size_t>(n));
      std::uniform_real_distribution<double> coord(-3.0, 3.0);
      std::uniform_int_distribution<int> grid(-4, 4);
      for (int i = 0; i < n; ++i) {
        double x = kind == 0 ? coord(rng) : 0.25 * grid(rng);  // kinds 1, 2: many ties
        const double y = kind == 2 ? 0.5 * grid(rng) : coord(rng);
        if (x == 0 && (i & 1)) x = -0.0;
        xy[2 * static_cast<std::size_t>(i)] = x;
        xy[2 * static_cast<std::size_t>(i) + 1] = y;
      }
      std::vector<int> order(static_cast<std::size_t>(n));
      for (int i = 0; i < n; ++i) order[static_cast<std::size_t>(i)] = i;
      std::shuffle(order.begin(), order.end(), rng);
      std::vector<int> expected = order;
      std::sort(expected.begin(), expected.end(), [&](int a, int b) {
        const std::size_t ia = 2 * static_cast<std::size_t>(a),
                          ib = 2 * static_cast<std::size_t>(b);
        if (xy[ia] != xy[ib]) return xy[ia] < xy[ib];
        if (xy[ia + 1] != xy[ib + 1]) return xy[ia + 1] < xy[ib + 1];
        return a < b;
      });
      polygons_detail::sort_points_xy(xy.data(), order, scratch);
      EXPECT_EQ(order, expected) << "n " << n << " kind " << kind;
    }
  }
}

// The crossing check's grid (large edge sets) against the plain x sweep: random short edges on
// lattice points (many shared ends and touching pairs), long edges across everything (the case
// the grid is for), vertical and zero-length edges, sizes on both sides of the grid threshold.
TEST(Polygons, CrossingGridMatchesSweep) {
  polygons_detail::CrossingScratch scratch;
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> lattice(0, 60);
  std::uniform_int_distribution<int> step(-2, 2);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int crossing_sets = 0;
  for (int n : {10, 128, 129, 400, 3000}) {
    // One loop per edge (loops == n) compares the marks edge by edge.
    for (int loops : {1, 7, 40, n}) {
      std::vector<polygons_detail::CheckEdge> edges;
      for (int i = 0; i < n; ++i) {
        const int u = lattice(rng), v = lattice(rng);
        int du = step(rng), dv = step(rng);
        if (unit(rng) < 0.02) {  // a long edge across the field
          du = 60 - 2 * u;
          dv = 60 - 2 * v;
        }
        const double h = 0.01;  // [m] lattice spacing
        edges.push_back({u * h, v * h, (u + du) * h, (v + dv) * h, std::int64_t{u} * 1000 + v,
                         std::int64_t{u + du} * 1000 + v + dv, i % loops});
      }
      std::vector<polygons_detail::CheckEdge> copy = edges;
      std::vector<std::uint8_t> grid_bad(static_cast<std::size_t>(loops), 0), sweep_bad = grid_bad;
      const bool grid_any = polygons_detail::mark_crossings(edges, grid_bad, scratch);
      const bool sweep_any = polygons_detail::mark_crossings_sweep(copy, sweep_bad, scratch);
      EXPECT_EQ(grid_any, sweep_any) << "n " << n << " loops " << loops;
      EXPECT_EQ(grid_bad, sweep_bad) << "n " << n << " loops " << loops;
      crossing_sets += sweep_any;
      // Both leave the edges in the same (sorted) order.
      for (std::size_t i = 0; i < edges.size(); ++i) {
        EXPECT_EQ(edges[i].x0, copy[i].x0);
        EXPECT_EQ(edges[i].id0, copy[i].id0);
      }
      // With some loops marked as changed only their pairs are tested: a changed loop is marked
      // exactly when it is without the mask, any loop at most when it is, on both paths.
      std::vector<std::uint8_t> changed(static_cast<std::size_t>(loops));
      for (auto& c : changed) c = unit(rng) < 0.3 ? 1 : 0;
      std::vector<std::uint8_t> grid_part(changed.size(), 0), sweep_part = grid_part;
      polygons_detail::mark_crossings(edges, grid_part, scratch, changed.data());
      polygons_detail::mark_crossings_sweep(copy, sweep_part, scratch, changed.data());
      EXPECT_EQ(grid_part, sweep_part) << "n " << n << " loops " << loops;
      for (std::size_t k = 0; k < changed.size(); ++k) {
        if (changed[k] != 0) {
          EXPECT_EQ(grid_part[k], grid_bad[k]) << "loop " << k;
        }
        EXPECT_LE(grid_part[k], grid_bad[k]) << "loop " << k;
      }
      std::vector<std::uint8_t> all_changed(changed.size(), 1), grid_all(changed.size(), 0);
      polygons_detail::mark_crossings(edges, grid_all, scratch, all_changed.data());
      EXPECT_EQ(grid_all, grid_bad);
    }
  }
  EXPECT_GT(crossing_sets, 5);  // the sets do cross (else the comparison proves little)
  // Disjoint loops: nothing to mark on either path.
  std::vector<polygons_detail::CheckEdge> apart;
  for (int i = 0; i < 300; ++i) {
    const double x = 0.1 * i;
    apart.push_back({x, 0.0, x + 0.05, 0.0, std::int64_t{2} * i, std::int64_t{2} * i + 1, i});
  }
  std::vector<std::uint8_t> none(300, 0);
  EXPECT_FALSE(polygons_detail::mark_crossings(apart, none, scratch));
  EXPECT_EQ(std::count(none.begin(), none.end(), 1), 0);
}

// A loop traced from the middle of a straight side (a rectangle turned slightly traces from
// wherever its first boundary vertex lies) keeps its four corners only: vertex 0, an anchor by
// position, goes too.
TEST(Polygons, SimplificationDropsAStartVertexOnAStraightSide) {
  std::vector<double> xy;
  std::vector<int> corners;
  // Along one axis, unit steps: (x0, y0) included, (x1, y1) not.
  const auto walk = [&](int x0, int y0, int x1, int y1) {
    const int steps = std::abs(x1 - x0) + std::abs(y1 - y0);
    const int dx = (x1 > x0) - (x1 < x0), dy = (y1 > y0) - (y1 < y0);
    for (int i = 0; i < steps; ++i) {
      xy.push_back(x0 + dx * i);
      xy.push_back(y0 + dy * i);
    }
    corners.push_back(static_cast<int>(xy.size() / 2));  // the next vertex is (x1, y1)
  };
  walk(5, 0, 10, 0);
  walk(10, 0, 10, 4);
  walk(10, 4, 0, 4);
  walk(0, 4, 0, 0);
  walk(0, 0, 5, 0);
  corners.pop_back();  // (5, 0) again: vertex 0
  std::vector<int> keep;
  std::vector<std::array<int, 2>> stack;
  polygons_detail::simplify_closed(xy.data(), static_cast<int>(xy.size() / 2), 0.1, keep, stack);
  std::sort(keep.begin(), keep.end());
  EXPECT_EQ(keep, corners);
}

// The absolute tolerance (1 cm) is capped by the loop's size (simplify_inradius_fraction), so a
// scene scaled down a hundredfold, as a structured-light scan of a small part sees it, keeps
// its outlines: the box's 6 x 4 mm front face comes out as the rectangle it is, not cut down by
// a tolerance as large as the face. At full scale the polygons are those of the 1 cm tolerance.
TEST(Polygons, TheToleranceFollowsTheLoopsSize) {
  for (const double scale : {1.0, 0.01}) {
    synth::Scene scene = wall_and_box();
    const auto scaled = [&](synth::Vec3 p) {
      return synth::Vec3{p[0] * scale, p[1] * scale, p[2] * scale};
    };
    for (auto& r : scene.rectangles) {
      r.centre = scaled(r.centre), r.half_u = scaled(r.half_u), r.half_v = scaled(r.half_v);
    }
    for (auto& b : scene.boxes) b.centre = scaled(b.centre), b.half_extent = scaled(b.half_extent);
    const synth::Rendering r = synth::render(scene);
    const Segmentation seg = truth_segmentation(r);
    const PolygonSet ps = extract_polygons(r.cloud, build_mesh(r.cloud), seg);
    check_properties(ps);
    const SegmentPolygons* front = ps.find(1 + 6);
    ASSERT_NE(front, nullptr) << scale;
    ASSERT_EQ(front->loop_count, 1) << scale;
    const PolygonLoop& loop = ps.loops[front->first_loop];
    EXPECT_EQ(loop.count, 4) << scale;
    const double s = scale;
    expect_rectangle(ps, loop,
                     {V3{-0.2 * s, -0.15 * s, 1.0 * s}, V3{0.4 * s, -0.15 * s, 1.0 * s},
                      V3{0.4 * s, 0.25 * s, 1.0 * s}, V3{-0.2 * s, 0.25 * s, 1.0 * s}},
                     0.01 * s);
    EXPECT_NEAR(front->area, 0.24 * s * s, 0.01 * 0.24 * s * s) << scale;
    // 2 area / perimeter of the 0.6 x 0.4 face is 0.24 m (5 %: 1.2 cm); a pixel footprint
    // at depth 1.0 is 1 / 525 of it.
    const double expected = std::max(std::min(0.01, 0.05 * 0.24 * s), 1.5 * s / 525);
    EXPECT_NEAR(loop.tolerance, expected, 0.05 * expected) << scale;
  }
}

}  // namespace
}  // namespace rangeseg
