// Synthetic renderer: geometry against the analytic surfaces, noise statistics, determinism.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "rangeseg/synth.hpp"

namespace {

using namespace rangeseg;
using namespace rangeseg::synth;

Vec3 point(const Rendering& r, int u, int v) {
  return {r.cloud.x(u, v), r.cloud.y(u, v), r.cloud.z(u, v)};
}

double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

std::int64_t count_of(const Rendering& r, const std::string& name) {
  for (std::size_t i = 0; i < r.surfaces.size(); ++i) {
    if (r.surfaces[i].name == name) return r.pixel_counts[i];
  }
  ADD_FAILURE() << "no surface named " << name;
  return -1;
}

std::int64_t count_prefix(const Rendering& r, const std::string& prefix) {
  std::int64_t total = 0;
  for (std::size_t i = 0; i < r.surfaces.size(); ++i) {
    if (r.surfaces[i].name.rfind(prefix, 0) == 0) total += r.pixel_counts[i];
  }
  return total;
}

// Checks every labelled point against its analytic surface; counts the points checked.
void check_points_on_surfaces(const Rendering& r, std::int64_t& checked) {
  checked = 0;
  for (int v = 0; v < r.labels.height(); ++v) {
    for (int u = 0; u < r.labels.width(); ++u) {
      const int label = r.labels(u, v);
      if (label == 0) continue;
      ASSERT_LE(label, static_cast<int>(r.surfaces.size()));
      ASSERT_TRUE(r.cloud.valid(u, v)) << u << "," << v;
      const Surface& s = r.surfaces[label - 1];
      const Vec3 p = point(r, u, v);
      ASSERT_LT(std::abs(signed_distance(s, p)), 1e-5) << s.name << " at " << u << "," << v;
      if (s.type == SurfaceType::cylinder) {
        const Vec3 q{p[0] - s.centre[0], p[1] - s.centre[1], p[2] - s.centre[2]};
        const double along = dot(q, s.axis);
        ASSERT_GE(along, -1e-5) << s.name;
        ASSERT_LE(along, s.extent + 1e-5) << s.name;
      }
      if (s.type == SurfaceType::plane) {
        // A visible face is seen from the side its normal points to: n . (camera - p) > 0.
        ASSERT_LT(dot(s.normal, p), 0.0) << s.name;
      }
      ++checked;
    }
  }
}

std::int64_t expect_points_on_surfaces(const Rendering& r) {
  std::int64_t checked = 0;
  check_points_on_surfaces(r, checked);
  return checked;
}

TEST(Synth, NoiseFreePointsLieOnTheirLabelledSurfaces) {
  const Rendering demo = render(demo_scene());
  EXPECT_GT(expect_points_on_surfaces(demo), 300000);
  for (std::uint64_t seed : {1, 2, 3, 4}) {
    const Rendering r = render(random_scene(seed, true));
    EXPECT_GT(expect_points_on_surfaces(r), 200000) << "seed " << seed;
  }
}

TEST(Synth, CylinderCapsAreDiscsAndSideNormalsAreRadial) {
  // A lying cylinder seen obliquely shows its side and one cap.
  Scene scene;
  scene.cylinders.push_back({.base = {-0.4, 0.0, 2.0},
                             .axis = {1.0, 0.0, 0.6},
                             .radius = 0.25,
                             .height = 0.8,
                             .name = "log"});
  const Rendering r = render(scene);
  EXPECT_GT(count_of(r, "log/side"), 2000);
  EXPECT_GT(count_of(r, "log/base"), 500);
  EXPECT_EQ(count_of(r, "log/top"), 0);
  EXPECT_GT(expect_points_on_surfaces(r), 2500);
  const Surface& side = r.surfaces[0];
  for (int v = 0; v < r.labels.height(); ++v) {
    for (int u = 0; u < r.labels.width(); ++u) {
      const Vec3 p = point(r, u, v);
      if (r.labels(u, v) == 2) {
        const Vec3 q{p[0] - side.centre[0], p[1] - side.centre[1], p[2] - side.centre[2]};
        const double along = dot(q, side.axis);
        const double radial2 = dot(q, q) - along * along;
        ASSERT_LE(radial2, side.radius * side.radius * (1 + 1e-6));
      }
      if (r.labels(u, v) == 1) {
        const Vec3 n = surface_normal(side, p);
        EXPECT_NEAR(dot(n, side.axis), 0.0, 1e-6);
        EXPECT_NEAR(dot(n, n), 1.0, 1e-9);
      }
    }
  }
}

TEST(Synth, AnalyticDepths) {
  const Rendering plane = render(plane_scene(2.0, 0.0));
  EXPECT_EQ(plane.cloud.count_valid(), plane.cloud.size());
  for (int v = 0; v < 480; v += 7) {
    for (int u = 0; u < 640; u += 7) ASSERT_NEAR(plane.cloud.z(u, v), 2.0, 1e-6);
  }

  // The tilted plane's depth on each ray matches the plane equation.
  const Rendering tilted = render(plane_scene(2.0, 0.5));
  EXPECT_EQ(tilted.cloud.count_valid(), tilted.cloud.size());
  EXPECT_NEAR(tilted.cloud.z(320, 240), 2.0, 0.01);
  EXPECT_GT(expect_points_on_surfaces(tilted), 300000);
  EXPECT_NEAR(std::abs(tilted.surfaces[0].normal[1]), std::sin(0.5), 1e-12);

  Scene ball;
  ball.spheres.push_back({.centre = {0.0, 0.0, 3.0}, .radius = 0.5});
  const Rendering b = render(ball, {.camera = {.cx = 320, .cy = 240, .width = 640, .height = 480}});
  EXPECT_NEAR(b.cloud.z(320, 240), 2.5, 1e-6);
  // Silhouette: the tangent ray makes angle asin(r / d) with the axis.
  const double tangent_pixels = 525.0 * std::tan(std::asin(0.5 / 3.0));
  EXPECT_NEAR(static_cast<double>(b.pixel_counts[0]),
              std::numbers::pi * tangent_pixels * tangent_pixels,
              0.02 * std::numbers::pi * tangent_pixels * tangent_pixels);
}

TEST(Synth, PointsLieOnTheirPixelRays) {
  for (Noise noise : {Noise::none, Noise::kinect}) {
    const RenderSettings settings{.noise = noise};
    const Rendering r = render(demo_scene(), settings);
    const CameraIntrinsics& c = settings.camera;
    for (int v = 0; v < r.labels.height(); ++v) {
      for (int u = 0; u < r.labels.width(); ++u) {
        if (!r.cloud.valid(u, v)) continue;
        const double z = r.cloud.z(u, v);
        ASSERT_NEAR(r.cloud.x(u, v) / z, (u - c.cx) / c.fx, 1e-6);
        ASSERT_NEAR(r.cloud.y(u, v) / z, (v - c.cy) / c.fy, 1e-6);
      }
    }
  }
}

// A quarter-resolution camera with the same field of view, to keep the multi-scene tests fast.
const CameraIntrinsics kSmallCamera{
    .fx = 131.25, .fy = 131.25, .cx = 79.5, .cy = 59.5, .width = 160, .height = 120};

bool same_bytes(const Rendering& a, const Rendering& b) {
  auto same = [](const auto& pa, const auto& pb) {
    return pa.width() == pb.width() && pa.height() == pb.height() &&
           std::memcmp(pa.row(0), pb.row(0),
                       sizeof(*pa.row(0)) * static_cast<std::size_t>(pa.stride()) * pa.height()) ==
               0;
  };
  return same(a.cloud.x, b.cloud.x) && same(a.cloud.y, b.cloud.y) && same(a.cloud.z, b.cloud.z) &&
         same(a.labels, b.labels);
}

TEST(Synth, DeterministicFromTheSeed) {
  const Scene scene = demo_scene();
  const Rendering a = render(scene, {.noise = Noise::kinect, .seed = 7});
  const Rendering b = render(scene, {.noise = Noise::kinect, .seed = 7});
  const Rendering c = render(scene, {.noise = Noise::kinect, .seed = 8});
  EXPECT_TRUE(same_bytes(a, b));
  EXPECT_FALSE(same_bytes(a, c));
  std::int64_t differing = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      if (a.cloud.valid(u, v) && c.cloud.valid(u, v) && a.cloud.z(u, v) != c.cloud.z(u, v)) {
        ++differing;
      }
    }
  }
  EXPECT_GT(differing, 100000);  // the noise itself changes, not just a few dropouts

  const RenderSettings small{.camera = kSmallCamera};
  EXPECT_TRUE(
      same_bytes(render(random_scene(5, true), small), render(random_scene(5, true), small)));
  EXPECT_FALSE(
      same_bytes(render(random_scene(5, true), small), render(random_scene(6, true), small)));
}

TEST(Synth, KinectAxialNoiseMatchesSigma) {
  const KinectModel model;
  for (double distance : {1.0, 2.0, 4.0}) {
    const Rendering r = render(plane_scene(distance), {.noise = Noise::kinect, .seed = 3});
    double sum = 0, sum2 = 0;
    std::int64_t n = 0;
    const double bf8 = 8 * model.baseline * 525.0;
    for (int v = 0; v < 480; ++v) {
      for (int u = 0; u < 640; ++u) {
        if (!r.cloud.valid(u, v)) continue;
        const double z = r.cloud.z(u, v);
        // Depths are quantised in 1/8 pixel disparity steps.
        const double steps = bf8 / z;
        ASSERT_NEAR(steps, std::round(steps), 1e-3) << z;
        sum += z - distance;
        sum2 += (z - distance) * (z - distance);
        ++n;
      }
    }
    ASSERT_GT(n, 300000);
    const double rms = std::sqrt(sum2 / n);
    const double sigma = kinect_sigma(model, distance);
    EXPECT_NEAR(rms, sigma, 0.15 * sigma) << "at " << distance << " m";
    EXPECT_LT(std::abs(sum / n), 0.1 * sigma) << "bias at " << distance << " m";
  }
  EXPECT_NEAR(kinect_sigma(model, 2.0), 0.0012 + 0.0019 * 1.6 * 1.6, 1e-15);
}

TEST(Synth, KinectDepthStepsAreTheSensorsAtAnyStreamSize) {
  // A Kinect streaming 320x240 matches its pattern at 640x480: its disparity steps are 1/8 of a
  // 525 px camera's pixel, half as large as 1/8 of the stream's 262.5 px pixel would be.
  constexpr CameraIntrinsics qvga{
      .fx = 262.5, .fy = 262.5, .cx = 159.5, .cy = 119.5, .width = 320, .height = 240};
  const double bf8 = 8 * KinectModel{}.baseline * 525.0;
  for (const double quantisation_fx : {525.0, 0.0}) {
    const Rendering r = render(plane_scene(3.0), {.camera = qvga,
                                                  .noise = Noise::kinect,
                                                  .kinect = {.quantisation_fx = quantisation_fx},
                                                  .seed = 4});
    std::int64_t odd = 0, n = 0;
    for (int v = 0; v < qvga.height; ++v) {
      for (int u = 0; u < qvga.width; ++u) {
        if (!r.cloud.valid(u, v)) continue;
        const double steps = bf8 / r.cloud.z(u, v);
        ASSERT_NEAR(steps, std::round(steps), 1e-3) << r.cloud.z(u, v);
        odd += static_cast<std::int64_t>(std::round(steps)) % 2;
        ++n;
      }
    }
    ASSERT_GT(n, 70000);
    if (quantisation_fx > 0) {
      EXPECT_GT(odd, n / 4) << "steps of the 525 px sensor";
    } else {
      EXPECT_EQ(odd, 0) << "steps of the stream's 262.5 px pixels";
    }
  }
}

TEST(Synth, KinectNoiseOnTiltedPlaneScalesWithDepth) {
  // Residuals normalised by sigma(true depth) have unit RMS over a plane spanning 1.5 - 3 m.
  const Rendering clean = render(plane_scene(2.0, 0.6));
  const Rendering noisy = render(plane_scene(2.0, 0.6), {.noise = Noise::kinect});
  double sum2 = 0;
  std::int64_t n = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      if (!noisy.cloud.valid(u, v)) continue;
      const double truth = clean.cloud.z(u, v);
      const double e = (noisy.cloud.z(u, v) - truth) / kinect_sigma({}, truth);
      sum2 += e * e;
      ++n;
    }
  }
  EXPECT_NEAR(std::sqrt(sum2 / n), 1.0, 0.1);
}

TEST(Synth, RangeLimits) {
  for (double distance : {0.3, 6.5}) {
    const Rendering r = render(plane_scene(distance), {.noise = Noise::kinect});
    EXPECT_EQ(r.cloud.count_valid(), 0u) << distance;
    EXPECT_EQ(count_of(r, "plane"), 0);
  }
  EXPECT_GT(render(plane_scene(0.3)).cloud.count_valid(), 0u);  // no limits without noise
}

// A 0.6 m box 1.5 m in front of a wall.
Scene box_before_wall(bool box_first) {
  Scene scene = plane_scene(3.0);
  scene.boxes.push_back(
      {.centre = {0.0, 0.0, 1.8}, .half_extent = {0.3, 0.3, 0.3}, .name = "near"});
  scene.boxes.push_back(
      {.centre = {0.0, 0.0, 3.5}, .half_extent = {0.2, 0.2, 0.2}, .name = "hidden"});
  if (!box_first) std::swap(scene.boxes[0], scene.boxes[1]);
  return scene;
}

TEST(Synth, NearestSurfaceWins) {
  for (bool box_first : {true, false}) {
    const Rendering r = render(box_before_wall(box_first));
    EXPECT_EQ(count_prefix(r, "hidden/"), 0);
    EXPECT_EQ(count_prefix(r, "near/"), count_of(r, "near/-z"));  // only the front face
    // The front face at z = 1.5 spans 0.6 m: 210 x 210 pixels.
    EXPECT_NEAR(static_cast<double>(count_of(r, "near/-z")), 210.0 * 210.0, 2 * 210.0 + 1);
    EXPECT_EQ(r.labels(320, 240), r.labels(319, 239));
    EXPECT_EQ(r.surfaces[r.labels(320, 240) - 1].name, "near/-z");
    EXPECT_NEAR(r.cloud.z(320, 240), 1.5, 1e-6);
    EXPECT_EQ(r.surfaces[r.labels(10, 10) - 1].name, "plane");
    EXPECT_NEAR(r.cloud.z(10, 10), 3.0, 1e-6);
    // Labels stay stable: every surface is listed whether visible or not.
    EXPECT_EQ(r.surfaces.size(), 1u + 6 + 6);
  }
}

TEST(Synth, DropoutsAtDepthJumpsNotInsideFlatSurfaces) {
  const Scene scene = box_before_wall(true);
  const Rendering clean = render(scene);
  const Rendering noisy = render(scene, {.noise = Noise::kinect, .seed = 11});
  // Edge pixels from the noise-free depth (jumps of 1.5 m); interior: > 3 pixels from any edge.
  const int w = 640, h = 480;
  std::vector<int> edge(static_cast<std::size_t>(w) * h, 0);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const float z = clean.cloud.z(u, v);
      auto jump = [&](int uu, int vv) {
        return uu >= 0 && vv >= 0 && uu < w && vv < h && std::abs(clean.cloud.z(uu, vv) - z) > 0.5;
      };
      edge[v * w + u] = jump(u - 1, v) || jump(u + 1, v) || jump(u, v - 1) || jump(u, v + 1);
    }
  }
  std::int64_t edge_total = 0, edge_dropped = 0, flat_total = 0, flat_dropped = 0;
  for (int v = 4; v < h - 4; ++v) {
    for (int u = 4; u < w - 4; ++u) {
      const bool dropped = !noisy.cloud.valid(u, v);
      EXPECT_EQ(dropped, noisy.labels(u, v) == 0);
      if (edge[v * w + u]) {
        ++edge_total;
        edge_dropped += dropped;
        continue;
      }
      bool near_edge = false;
      for (int dv = -3; dv <= 3 && !near_edge; ++dv) {
        for (int du = -3; du <= 3 && !near_edge; ++du) near_edge = edge[(v + dv) * w + u + du];
      }
      if (near_edge) continue;
      ++flat_total;
      flat_dropped += dropped;
    }
  }
  ASSERT_GT(edge_total, 1500);
  const double edge_rate = static_cast<double>(edge_dropped) / edge_total;
  const double flat_rate = static_cast<double>(flat_dropped) / flat_total;
  EXPECT_NEAR(edge_rate, 0.5 + 0.5 * 0.005, 0.05);
  EXPECT_NEAR(flat_rate, 0.005, 0.002);

  // A single flat plane loses only the random dropouts.
  const Rendering plane = render(plane_scene(2.0, 0.3), {.noise = Noise::kinect});
  const double plane_rate =
      1.0 - static_cast<double>(plane.cloud.count_valid()) / plane.cloud.size();
  EXPECT_NEAR(plane_rate, 0.005, 0.002);
}

TEST(Synth, DemoSceneShowsEverything) {
  const Rendering r = render(demo_scene());
  const std::int64_t total = std::int64_t{640} * 480;
  EXPECT_EQ(static_cast<std::int64_t>(r.cloud.count_valid()), total);  // a closed view
  EXPECT_GT(count_of(r, "floor"), total / 20);
  EXPECT_GT(count_of(r, "left_wall"), total / 20);
  EXPECT_GT(count_of(r, "back_wall"), total / 5);
  for (const char* box : {"table/", "stack_lower/", "stack_upper/", "rotated/"}) {
    EXPECT_GT(count_prefix(r, box), 2000) << box;
  }
  EXPECT_GT(count_of(r, "table/-y"), 500);  // the table top is seen from above
  EXPECT_GT(count_of(r, "stack_upper/-y"), 50);
  EXPECT_GT(count_of(r, "pillar/side"), 3000);
  EXPECT_GT(count_of(r, "ball"), 1500);
  // All objects are in view: no object touches the image border except floor and walls.
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      if (u != 0 && u != 639 && v != 0 && v != 479) continue;
      const std::string& name = r.surfaces[r.labels(u, v) - 1].name;
      ASSERT_TRUE(name == "floor" || name == "left_wall" || name == "back_wall") << name;
    }
  }
  double min_z = 1e9, max_z = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      min_z = std::min<double>(min_z, r.cloud.z(u, v));
      max_z = std::max<double>(max_z, r.cloud.z(u, v));
    }
  }
  EXPECT_GT(min_z, 1.0);
  EXPECT_LT(max_z, 6.0);  // the whole demo is within the Kinect range

  const Rendering noisy = render(demo_scene(), {.noise = Noise::kinect});
  EXPECT_GT(noisy.cloud.count_valid(), 0.95 * total);
}

TEST(Synth, RandomScenes) {
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const Scene plain = random_scene(seed);
    EXPECT_GE(plain.boxes.size(), 1u);
    EXPECT_TRUE(plain.cylinders.empty() && plain.spheres.empty());
    const Scene curved = random_scene(seed, true);
    EXPECT_GE(curved.cylinders.size() + curved.spheres.size(), 1u);
    const Rendering r = render(curved, {.camera = kSmallCamera});
    EXPECT_GT(count_of(r, "floor"), 100) << seed;
    EXPECT_GT(count_of(r, "back_wall"), 100) << seed;
    EXPECT_GT(count_prefix(r, "box"), 100) << seed;
    EXPECT_GT(count_prefix(r, "cylinder") + count_prefix(r, "sphere"), 10) << seed;
  }
}

TEST(Synth, MinSurfacePixelsClearsSmallSurfaces) {
  const Rendering all = render(demo_scene());
  const Rendering big = render(demo_scene(), {.min_surface_pixels = 1000});
  for (std::size_t i = 0; i < all.surfaces.size(); ++i) {
    EXPECT_EQ(big.pixel_counts[i], all.pixel_counts[i] >= 1000 ? all.pixel_counts[i] : 0);
  }
  EXPECT_EQ(big.cloud.count_valid(), all.cloud.count_valid());  // points stay
  EXPECT_EQ(std::memcmp(big.cloud.label.row(0), big.labels.row(0),
                        sizeof(std::int32_t) * big.labels.stride() * big.labels.height()),
            0);
}

// 8-connected parts of each label's pixels: parts[l] for label l (index 0 unused).
std::vector<int> parts_per_label(const LabelImage& labels, std::size_t label_count) {
  const int w = labels.width(), h = labels.height();
  std::vector<int> parts(label_count + 1, 0);
  std::vector<char> seen(static_cast<std::size_t>(w) * h, 0);
  std::vector<std::pair<int, int>> stack;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const int label = labels(u, v);
      if (label == 0 || seen[static_cast<std::size_t>(v) * w + u]) continue;
      ++parts[label];
      seen[static_cast<std::size_t>(v) * w + u] = 1;
      stack.assign(1, {u, v});
      while (!stack.empty()) {
        const auto [pu, pv] = stack.back();
        stack.pop_back();
        for (int dv = -1; dv <= 1; ++dv) {
          for (int du = -1; du <= 1; ++du) {
            const int nu = pu + du, nv = pv + dv;
            if (nu < 0 || nv < 0 || nu >= w || nv >= h || labels(nu, nv) != label) continue;
            char& s = seen[static_cast<std::size_t>(nv) * w + nu];
            if (s == 0) stack.emplace_back(nu, nv);
            s = 1;
          }
        }
      }
    }
  }
  return parts;
}

TEST(Synth, SurfaceSplitByAnOccluderIsTwoRegions) {
  // A wall at 3 m and a pole 0.4 m wide at 1.5 m, right of centre and taller than the view.
  Scene scene = plane_scene(3.0);
  scene.boxes.push_back(
      {.centre = {0.3, 0.0, 1.5}, .half_extent = {0.2, 5.0, 0.2}, .name = "pole"});
  const Rendering split = render(scene);
  const Rendering whole = render(scene, {.split_disconnected = false});
  ASSERT_EQ(whole.surfaces.size(), 7u);
  ASSERT_EQ(split.surfaces.size(), 8u);
  EXPECT_EQ(split.surfaces[7].name, "plane#2");
  EXPECT_EQ(split.part_of, (std::vector<std::int32_t>{1, 2, 3, 4, 5, 6, 7, 1}));
  EXPECT_EQ(whole.part_of, (std::vector<std::int32_t>{1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(split.surfaces[7].normal, split.surfaces[0].normal);
  EXPECT_EQ(split.surfaces[7].offset, split.surfaces[0].offset);
  // The larger (left) part keeps the label; the pixel counts add up to the unsplit surface.
  EXPECT_EQ(split.surfaces[split.labels(5, 240) - 1].name, "plane");
  EXPECT_EQ(split.surfaces[split.labels(634, 240) - 1].name, "plane#2");
  EXPECT_GT(split.pixel_counts[0], split.pixel_counts[7]);
  EXPECT_GT(split.pixel_counts[7], 1000);
  EXPECT_EQ(split.pixel_counts[0] + split.pixel_counts[7], whole.pixel_counts[0]);
  EXPECT_EQ(whole.labels(5, 240), whole.labels(634, 240));
  EXPECT_EQ(parts_per_label(whole.labels, whole.surfaces.size())[1], 2);
}

TEST(Synth, EveryGroundTruthRegionIsConnected) {
  std::size_t extra_parts = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    const Scene scene = random_scene(seed, true);
    const Rendering split = render(scene, {.camera = kSmallCamera});
    const Rendering whole = render(scene, {.camera = kSmallCamera, .split_disconnected = false});
    const std::vector<int> parts = parts_per_label(split.labels, split.surfaces.size());
    for (std::size_t l = 1; l < parts.size(); ++l) {
      EXPECT_LE(parts[l], 1) << "seed " << seed << " " << split.surfaces[l - 1].name;
      EXPECT_EQ(parts[l], split.pixel_counts[l - 1] > 0 ? 1 : 0) << split.surfaces[l - 1].name;
    }
    // Each surface's parts add up to its pixels, and the points are the same.
    std::vector<std::int64_t> total(
        split.pixel_counts.begin(),
        split.pixel_counts.begin() + static_cast<std::ptrdiff_t>(whole.surfaces.size()));
    for (std::size_t i = whole.surfaces.size(); i < split.surfaces.size(); ++i) {
      const std::string& name = split.surfaces[i].name;
      const auto base = static_cast<std::size_t>(split.part_of[i] - 1);
      ASSERT_LT(base, whole.surfaces.size());
      EXPECT_EQ(name.substr(0, name.rfind('#')), whole.surfaces[base].name);
      total[base] += split.pixel_counts[i];
    }
    for (std::size_t j = 0; j < whole.surfaces.size(); ++j) {
      EXPECT_EQ(total[j], whole.pixel_counts[j])
          << "seed " << seed << " " << whole.surfaces[j].name;
    }
    EXPECT_EQ(split.cloud.count_valid(), whole.cloud.count_valid());
    extra_parts += split.surfaces.size() - whole.surfaces.size();
  }
  EXPECT_GT(extra_parts, 0u);  // some of these scenes have occluded surfaces
}

TEST(Synth, RejectsInvalidInput) {
  Scene bad_box;
  bad_box.boxes.push_back({.half_extent = {0.1, 0.0, 0.1}});
  EXPECT_THROW(render(bad_box), std::invalid_argument);
  Scene bad_cylinder;
  bad_cylinder.cylinders.push_back({.axis = {0, 0, 0}});
  EXPECT_THROW(render(bad_cylinder), std::invalid_argument);
  Scene bad_rectangle;
  bad_rectangle.rectangles.push_back({.half_u = {1, 0, 0}, .half_v = {1, 1, 0}});
  EXPECT_THROW(render(bad_rectangle), std::invalid_argument);
  EXPECT_THROW(render(plane_scene(1.0), {.camera = {.width = 0, .height = 480}}),
               std::invalid_argument);
  EXPECT_THROW(render(plane_scene(1.0), {.camera = {.fx = -1, .width = 64, .height = 48}}),
               std::invalid_argument);
  EXPECT_THROW(plane_scene(-1.0), std::invalid_argument);
  EXPECT_THROW(plane_scene(1.0, 1.5), std::invalid_argument);
  RenderSettings bad_noise{.noise = Noise::kinect};
  bad_noise.kinect.edge_dropout = 2.0;
  EXPECT_THROW(render(plane_scene(1.0), bad_noise), std::invalid_argument);
  bad_noise.kinect = {.quantisation_fx = -525.0};
  EXPECT_THROW(render(plane_scene(1.0), bad_noise), std::invalid_argument);
  bad_noise.kinect = {.quantisation_fx = NAN};
  EXPECT_THROW(render(plane_scene(1.0), bad_noise), std::invalid_argument);
}

}  // namespace
