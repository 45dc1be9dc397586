// Stages 2-4 over k-nearest-neighbour rings (unorganized.hpp): rings against a brute-force
// search, normals and curvature on analytic surfaces and against PCA over the same ring, point
// areas, the bilateral filter on noisy planes and a crease, segmentation of synthetic scenes
// scored against their ground truth, and the unorganized path of Pipeline.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <numbers>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "rangeseg/eval.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/synth.hpp"
#include "rangeseg/thread_pool.hpp"
#include "rangeseg/unorganized.hpp"
#include "segmentation_test_util.hpp"
#include "test_util.hpp"

namespace rangeseg {
namespace {

using test::kDeg;
using Vec3 = std::array<double, 3>;
using Points = std::vector<Vec3>;

// --- Geometry helpers ----------------------------------------------------------------------------

double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 scaled(const Vec3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }
Vec3 unit(const Vec3& a) { return scaled(a, 1.0 / norm(a)); }
/// Angle between two directions [rad], accurate near 0 (atan2 of the cross and dot products).
double angle(const Vec3& a, const Vec3& b) { return std::atan2(norm(cross(a, b)), dot(a, b)); }
/// The same for lines (sign-free) [rad].
double line_angle(const Vec3& a, const Vec3& b) {
  return std::min(angle(a, b), angle(a, scaled(b, -1)));
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// Kinect axial noise sigma(r) with the library's default model [m].
double kinect_sigma(double r) { return SensorNoise{}.sigma(r); }

// --- Clouds --------------------------------------------------------------------------------------

using test::row_cloud;

/// Point i = v * width + u of any cloud, in double.
Vec3 point_of(const OrganizedCloud& c, std::size_t i) {
  const auto w = static_cast<std::size_t>(c.width());
  const int u = static_cast<int>(i % w), v = static_cast<int>(i / w);
  return {c.x(u, v), c.y(u, v), c.z(u, v)};
}
Vec3 normal_of(const NormalMap& n, std::size_t i) {
  const auto w = static_cast<std::size_t>(n.width());
  const int u = static_cast<int>(i % w), v = static_cast<int>(i / w);
  return {n.nx(u, v), n.ny(u, v), n.nz(u, v)};
}
float curvature_of(const NormalMap& n, std::size_t i) {
  return n.curvature(static_cast<int>(i), 0);  // 1-row maps only
}

/// Whether two planes hold the same values (NaN equal to NaN).
template <class T>
bool same_values(const Plane<T>& a, const Plane<T>& b) {
  if (a.width() != b.width() || a.height() != b.height()) return false;
  for (int v = 0; v < a.height(); ++v) {
    for (int u = 0; u < a.width(); ++u) {
      const T x = a(u, v), y = b(u, v);
      if (!(x == y || (std::isnan(static_cast<double>(x)) && std::isnan(static_cast<double>(y))))) {
        return false;
      }
    }
  }
  return true;
}
bool same_points(const OrganizedCloud& a, const OrganizedCloud& b) {
  return same_values(a.x, b.x) && same_values(a.y, b.y) && same_values(a.z, b.z);
}
bool same_normals(const NormalMap& a, const NormalMap& b) {
  return same_values(a.nx, b.nx) && same_values(a.ny, b.ny) && same_values(a.nz, b.nz) &&
         same_values(a.curvature, b.curvature);
}

double uniform(std::mt19937& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

/// n points uniform in a cube of side `side` centred on (0, 0, 1.5), in front of the sensor.
Points random_box(std::size_t n, unsigned seed, double side = 1.0) {
  std::mt19937 rng(seed);
  const double h = side / 2;
  Points p(n);
  for (Vec3& q : p) q = {uniform(rng, -h, h), uniform(rng, -h, h), 1.5 + uniform(rng, -h, h)};
  return p;
}

/// n points uniform on the rectangle centre + a half_u + b half_v, |a|, |b| <= 1.
Points random_rectangle(const Vec3& centre, const Vec3& half_u, const Vec3& half_v, std::size_t n,
                        std::mt19937& rng) {
  Points p(n);
  for (Vec3& q : p) {
    const double a = uniform(rng, -1, 1), b = uniform(rng, -1, 1);
    for (int c = 0; c < 3; ++c) q[c] = centre[c] + a * half_u[c] + b * half_v[c];
  }
  return p;
}

/// Points on a surface seen from the origin as a depth camera sees it: n random viewing rays
/// t (a, b, 1), |a|, |b| <= half_fov, hitting the surface at depth `depth(a, b)`, with Gaussian
/// noise of noise_factor * sigma(z) along the ray.
Points random_view(const std::function<double(double, double)>& depth, std::size_t n,
                   double noise_factor, unsigned seed, double half_fov = 0.3) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Points p(n);
  for (Vec3& q : p) {
    const double a = uniform(rng, -half_fov, half_fov), b = uniform(rng, -half_fov, half_fov);
    double z = depth(a, b);
    z += noise_factor * kinect_sigma(z) * gauss(rng);
    q = {a * z, b * z, z};
  }
  return p;
}

/// A plane n . p = c (n unit, facing the origin: c < 0).
struct TestPlane {
  Vec3 n;
  double c;
  double distance(const Vec3& p) const { return dot(n, p) - c; }
  /// Depth of the ray (a, b, 1) at the plane.
  double depth(double a, double b) const { return c / dot(n, {a, b, 1.0}); }
};

// --- Rings ---------------------------------------------------------------------------------------

using Point3f = std::array<float, 3>;

float distance2(const Point3f& a, const Point3f& b) {
  const float dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
  return dx * dx + dy * dy + dz * dz;
}

/// The points of a cloud in float (NaN triples for invalid ones), and the space the rings
/// search: the points, or their directions from the origin (computed in float as the library
/// does, so that distances compare exactly).
struct SearchSpace {
  std::vector<Point3f> points, space;

  SearchSpace(const OrganizedCloud& c, bool by_direction) {
    for (std::size_t i = 0; i < c.size(); ++i) {
      const Vec3 p = point_of(c, i);
      const bool valid = std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
      const Point3f f = valid ? Point3f{static_cast<float>(p[0]), static_cast<float>(p[1]),
                                        static_cast<float>(p[2])}
                              : Point3f{NAN, NAN, NAN};
      points.push_back(f);
      const float inv = 1.0f / std::sqrt(distance2({0, 0, 0}, f));
      space.push_back(by_direction ? Point3f{f[0] * inv, f[1] * inv, f[2] * inv} : f);
    }
  }
  bool valid(std::size_t i) const { return !std::isnan(points[i][0]); }
  float search_distance2(std::size_t i, std::size_t j) const {
    return distance2(space[i], space[j]);
  }

  /// The k nearest valid points of valid point i by brute force, nearest first, without those
  /// farther than max_distance (when > 0).
  std::vector<std::int32_t> ring(std::size_t i, int k, float max_distance) const {
    std::vector<std::pair<float, std::int32_t>> all;
    for (std::size_t j = 0; j < points.size(); ++j) {
      if (j != i && valid(j)) {
        all.emplace_back(search_distance2(i, j), static_cast<std::int32_t>(j));
      }
    }
    const auto m = std::min(all.size(), static_cast<std::size_t>(k));
    std::partial_sort(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(m), all.end());
    std::vector<std::int32_t> ring;
    for (std::size_t j = 0; j < m; ++j) {
      const auto q = static_cast<std::size_t>(all[j].second);
      if (max_distance <= 0 || distance2(points[i], points[q]) <= max_distance * max_distance) {
        ring.push_back(all[j].second);
      }
    }
    return ring;
  }
};

bool valid_point(const OrganizedCloud& c, std::size_t i) {
  const Vec3 p = point_of(c, i);
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

/// Builds the rings (eps_theta = 0) and expects every ring to equal the brute-force one as a
/// set and to run nearest first, and invalid points to have none. Returns the neighbours found.
std::size_t expect_brute_force_rings(const OrganizedCloud& c, RingSettings settings) {
  settings.eps_theta = 0;
  settings.balanced = false;  // plain k nearest (RingSettings::balanced has a test of its own)
  const PointRings rings = build_rings(c, settings);
  EXPECT_EQ(rings.k, settings.k);
  EXPECT_EQ(rings.size(), c.size());
  EXPECT_EQ(rings.neighbours.size(), c.size() * static_cast<std::size_t>(settings.k));
  const SearchSpace search(c, settings.by_direction);
  std::size_t found = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    std::vector<std::int32_t> got(rings.ring(i).begin(), rings.ring(i).end());
    if (!search.valid(i)) {
      EXPECT_EQ(rings.count[i], 0) << "invalid point " << i;
      continue;
    }
    for (std::size_t j = 1; j < got.size(); ++j) {
      EXPECT_LE(search.search_distance2(i, static_cast<std::size_t>(got[j - 1])),
                search.search_distance2(i, static_cast<std::size_t>(got[j])))
          << "ring of " << i << " not nearest first";
    }
    std::vector<std::int32_t> want = search.ring(i, settings.k, settings.max_distance);
    std::sort(got.begin(), got.end());
    std::sort(want.begin(), want.end());
    EXPECT_EQ(got, want) << "ring of point " << i << (settings.by_direction ? " by direction" : "");
    found += got.size();
    // The unused slots hold -1.
    for (int j = rings.count[i]; j < settings.k; ++j) {
      EXPECT_EQ(
          rings.neighbours[i * static_cast<std::size_t>(settings.k) + static_cast<std::size_t>(j)],
          -1);
    }
  }
  return found;
}

TEST(Rings, EqualBruteForceKNearest) {
  const OrganizedCloud cloud = row_cloud(random_box(2000, 1));
  for (const bool by_direction : {false, true}) {
    for (const int k : {2, 12, 64}) {
      EXPECT_EQ(expect_brute_force_rings(cloud, {.k = k, .by_direction = by_direction}),
                cloud.size() * static_cast<std::size_t>(k))
          << "k = " << k;
    }
  }
}

TEST(Rings, InvalidPointsHaveNoRingAndAreNoNeighbours) {
  Points points = random_box(500, 2);
  const double inf = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < points.size(); i += 7) points[i][i % 3] = i % 2 ? NAN : inf;
  points[1] = {-inf, NAN, 0.0};
  const OrganizedCloud cloud = row_cloud(points);
  for (const bool by_direction : {false, true}) {
    expect_brute_force_rings(cloud, {.k = 12, .by_direction = by_direction});
  }
  const PointRings rings = build_rings(cloud);  // with the veil test
  for (std::size_t i = 0; i < rings.size(); ++i) {
    EXPECT_EQ(rings.count[i] == 0, !valid_point(cloud, i)) << i;
    for (const std::int32_t j : rings.ring(i)) {
      EXPECT_TRUE(valid_point(cloud, static_cast<std::size_t>(j))) << j << " in the ring of " << i;
    }
  }
  // Nothing valid at all: no rings, no neighbours.
  const PointRings none = build_rings(row_cloud(Points(10, {NAN, NAN, NAN})));
  EXPECT_EQ(std::count(none.count.begin(), none.count.end(), 0), 10);
  EXPECT_EQ(std::count(none.neighbours.begin(), none.neighbours.end(), -1), 10 * 12);
}

TEST(Rings, MaxDistanceDropsFartherNeighbours) {
  // At 2000 points per m^3 the 12th neighbour is ~11 cm away: a 7 cm bound cuts most rings.
  const OrganizedCloud cloud = row_cloud(random_box(2000, 3));
  for (const bool by_direction : {false, true}) {
    const std::size_t kept = expect_brute_force_rings(
        cloud, {.k = 12, .max_distance = 0.07f, .by_direction = by_direction});
    std::printf("  max_distance 7 cm, by_direction %d: %zu of %zu ring slots used\n", by_direction,
                kept, 12 * cloud.size());
    EXPECT_LT(kept, 12 * cloud.size() / 2);
    EXPECT_GT(kept, 0u);
  }
}

// A point p on a small fronto-parallel patch at 1 m and a point q behind it on the viewing ray
// through p (the edge p-q is along the ray): a veil unless the range step is noise.
TEST(Rings, VeilTestDropsNeighboursAlongTheRayUnlessTheStepIsNoise) {
  const double threshold = 3.0 * std::sqrt(2.0) * kinect_sigma(1.0);  // ~8 mm at 1 m
  const auto ring_of_p = [](const Vec3& q, float eps_theta) {
    const Points points = {{0, 0, 1}, {0.01, 0, 1}, {-0.01, 0, 1}, {0, 0.01, 1}, {0, -0.01, 1}, q};
    const PointRings rings = build_rings(row_cloud(points), {.k = 5, .eps_theta = eps_theta});
    std::vector<std::int32_t> ring(rings.ring(0).begin(), rings.ring(0).end());
    std::sort(ring.begin(), ring.end());
    return ring;
  };
  const std::vector<std::int32_t> patch = {1, 2, 3, 4}, all = {1, 2, 3, 4, 5};
  const float eps = RingSettings{}.eps_theta;
  EXPECT_EQ(ring_of_p({0, 0, 1 + 10 * threshold}, eps), patch);      // a step of 8 cm: veil
  EXPECT_EQ(ring_of_p({0.002, 0, 1 + 10 * threshold}, eps), patch);  // 1.4 deg off the ray
  EXPECT_EQ(ring_of_p({0, 0, 1 + 0.7 * threshold}, eps), all);       // within the noise
  EXPECT_EQ(ring_of_p({0, 0, 1 - 0.7 * threshold}, eps), all);       // in front, within it
  EXPECT_EQ(ring_of_p({0.04, 0, 1 + 10 * threshold}, eps), all);     // 27 deg off the ray
  EXPECT_EQ(ring_of_p({0, 0, 1 + 10 * threshold}, 0.0f), all);       // test off
  // The veil edge is cut in both directions: p is not in the ring of q either.
  const Points points = {{0, 0, 1}, {0.03, 0, 1}, {-0.03, 0, 1}, {0, 0, 1.08}};
  const PointRings rings = build_rings(row_cloud(points), {.k = 3});
  EXPECT_EQ(rings.count[0], 2);
  EXPECT_EQ(rings.count[3], 2);
  EXPECT_EQ(std::count(rings.ring(3).begin(), rings.ring(3).end(), 0), 0);
}

void expect_invalid(const RingSettings& s, const std::string& field) {
  try {
    build_rings(row_cloud(random_box(20, 4)), s);
    ADD_FAILURE() << "no exception for " << field;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
}

TEST(Rings, InvalidSettingsThrow) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float half_pi = static_cast<float>(test::kPi / 2);
  expect_invalid({.k = 1}, "k");
  expect_invalid({.k = 65}, "k");
  expect_invalid({.max_distance = -0.01f}, "max_distance");
  expect_invalid({.max_distance = nan}, "max_distance");
  expect_invalid({.eps_theta = half_pi}, "eps_theta");
  expect_invalid({.eps_theta = 2.0f}, "eps_theta");
  expect_invalid({.eps_theta = -0.1f}, "eps_theta");
  expect_invalid({.eps_theta = nan}, "eps_theta");
  expect_invalid({.jump_sigmas = nan}, "jump_sigmas");
  expect_invalid({.viewpoint = {0, nan, 0}}, "viewpoint");
  EXPECT_NO_THROW(build_rings(row_cloud(random_box(20, 4)), {.k = 64, .eps_theta = 1.57f}));
  // An inconsistent cloud.
  OrganizedCloud broken = row_cloud(random_box(20, 4));
  broken.x.resize(19, 1);
  EXPECT_THROW(build_rings(broken), std::invalid_argument);
}

TEST(Rings, OrganizedCloudIsTakenAsAListOfPoints) {
  constexpr std::size_t w = 40, h = 30;
  Points points = random_box(w * h, 5);
  for (std::size_t i = 3; i < points.size(); i += 11) points[i] = {NAN, NAN, NAN};
  OrganizedCloud grid(static_cast<int>(w), static_cast<int>(h));
  for (std::size_t i = 0; i < points.size(); ++i) {
    const int u = static_cast<int>(i % w), v = static_cast<int>(i / w);
    grid.x(u, v) = static_cast<float>(points[i][0]);
    grid.y(u, v) = static_cast<float>(points[i][1]);
    grid.z(u, v) = static_cast<float>(points[i][2]);
  }
  const RingSettings settings{.k = 10};
  const PointRings a = build_rings(grid, settings), b = build_rings(row_cloud(points), settings);
  EXPECT_EQ(a.neighbours, b.neighbours);
  EXPECT_EQ(a.count, b.count);
  expect_brute_force_rings(grid, settings);
}

/// A 16-beam lidar (beams 2 deg apart from -15 to +15 deg elevation, points 0.2 deg apart in
/// azimuth, 360 deg) 0.5 m above the floor of a 11 x 9 x 3 m room, Gaussian range noise of
/// 1 cm; `labels` (1-row) names the plane each point is on: floor 1, walls 2-5, ceiling 6.
struct LidarRoom {
  OrganizedCloud cloud;
  LabelImage labels;
  LidarRoom() {
    // n . p + d = 0 with n pointing into the room (y down).
    const std::array<std::pair<Vec3, double>, 6> planes{{{{0, -1, 0}, 0.5},
                                                         {{1, 0, 0}, 5.0},
                                                         {{-1, 0, 0}, 6.0},
                                                         {{0, 0, 1}, 4.0},
                                                         {{0, 0, -1}, 5.0},
                                                         {{0, 1, 0}, 2.5}}};
    std::mt19937 rng(16);
    std::normal_distribution<double> noise(0.0, 0.01);
    Points points;
    std::vector<int> label;
    for (int beam = 0; beam < 16; ++beam) {
      const double el = (-15.0 + 2.0 * beam) * kDeg;
      for (int column = 0; column < 1800; ++column) {
        const double az = 0.2 * column * kDeg;
        const Vec3 d{std::cos(el) * std::sin(az), -std::sin(el), std::cos(el) * std::cos(az)};
        double t = INFINITY;
        int hit = 0;
        for (std::size_t k = 0; k < planes.size(); ++k) {
          const double nd = dot(planes[k].first, d);
          if (nd < 0 && -planes[k].second / nd < t) {
            t = -planes[k].second / nd;
            hit = static_cast<int>(k) + 1;
          }
        }
        points.push_back(scaled(d, t + noise(rng)));
        label.push_back(hit);
      }
    }
    std::vector<std::size_t> order(points.size());
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    Points shuffled;
    labels = LabelImage(static_cast<int>(points.size()), 1, 0);
    for (std::size_t i = 0; i < order.size(); ++i) {
      shuffled.push_back(points[order[i]]);
      labels(static_cast<int>(i), 0) = label[order[i]];
    }
    cloud = row_cloud(shuffled);
  }
};

TEST(Rings, BalancedRingsSurroundLidarPointsWhoseNearestLieOnTheirScanLine) {
  const LidarRoom room;
  for (const bool balanced : {true, false}) {
    PipelineSettings settings = test::ring_preset("laser");
    settings.rings.balanced = balanced;
    Pipeline pipeline(settings);
    pipeline.process(room.cloud);
    // Rings: how many reach another beam (elevation differs by more than 1 deg).
    const PointRings& rings = pipeline.rings();
    std::size_t across = 0, with_normal = 0;
    for (std::size_t i = 0; i < rings.size(); ++i) {
      const Vec3 p = point_of(room.cloud, i);
      const double el = std::atan2(-p[1], std::hypot(p[0], p[2]));
      for (const std::int32_t j : rings.ring(i)) {
        const Vec3 q = point_of(room.cloud, static_cast<std::size_t>(j));
        if (std::abs(std::atan2(-q[1], std::hypot(q[0], q[2])) - el) > kDeg) {
          ++across;
          break;
        }
      }
      with_normal += std::isfinite(normal_of(pipeline.normals(), i)[0]) ? 1 : 0;
    }
    const eval::EvalResult e =
        eval::evaluate(room.labels, pipeline.segmentation().labels, {.tolerance = 0.8});
    std::printf(
        "  lidar room, %s rings: %zu of %zu rings reach another beam, %zu normals; GT %d, "
        "correct %d, over %d, under %d, missed %d, noise %d\n",
        balanced ? "balanced" : "plain", across, rings.size(), with_normal, e.gt_regions, e.correct,
        e.over, e.under, e.missed, e.noise);
    // Measured (2026-12-04): balanced 25602 rings across beams, 4 of 5 planes correct (the floor
    // beyond ~2.5 m is seen within 12.5 deg of the rays, where the veil test cuts the edges
    // between beams); plain 0 rings across, 0 correct.
    if (balanced) {
      EXPECT_GT(across, rings.size() * 8 / 10);
      EXPECT_GE(e.correct, 4);
    } else {
      EXPECT_LT(across, rings.size() / 10);  // the plain k nearest stay on their scan line
      EXPECT_LE(e.correct, 1);
    }
  }
}

TEST(Rings, ThreadPoolGivesIdenticalRings) {
  const OrganizedCloud cloud = row_cloud(random_box(70000, 6, 2.0));
  ThreadPool pool(2);
  for (const RingSettings& s : {RingSettings{}, RingSettings{.k = 20, .max_distance = 0.05f}}) {
    const PointRings one = build_rings(cloud, s);
    PointRings two;
    build_rings(cloud, s, two, pool);
    EXPECT_EQ(one.k, two.k);
    EXPECT_EQ(one.neighbours, two.neighbours);
    EXPECT_EQ(one.count, two.count);
  }
}

/// The cloud with a copy of points [0, copies) appended, each moved by up to 1e-5 m along each
/// axis: overlapping scans or tiles stored twice.
OrganizedCloud with_near_copies(const OrganizedCloud& cloud, std::size_t copies, unsigned seed) {
  std::mt19937 rng(seed);
  const std::size_t n = cloud.size();
  OrganizedCloud out(static_cast<int>(n + copies), 1);
  for (std::size_t i = 0; i < n + copies; ++i) {
    const auto from = static_cast<int>(i < n ? i : i - n);
    const auto to = static_cast<int>(i);
    const float jitter = i < n ? 0.0f : 1e-5f;
    out.x(to, 0) = cloud.x(from, 0) + jitter * static_cast<float>(uniform(rng, -1, 1));
    out.y(to, 0) = cloud.y(from, 0) + jitter * static_cast<float>(uniform(rng, -1, 1));
    out.z(to, 0) = cloud.z(from, 0) + jitter * static_cast<float>(uniform(rng, -1, 1));
  }
  return out;
}

/// A point measured twice takes one place in a ring, not two, and none in its own: with half
/// of a plane's points copied 1e-5 m away, each ring holds the same points as without the
/// copies (either copy of each), up to the order of neighbours at equal distances.
TEST(Rings, CoincidentPointsTakeOnePlace) {
  const TestPlane plane{{0.0, 0.6, -0.8}, -1.6};
  const OrganizedCloud cloud =
      row_cloud(random_view([&](double a, double b) { return plane.depth(a, b); }, 4000, 1.0, 3));
  const std::size_t n = cloud.size(), copies = n / 2;
  const OrganizedCloud doubled = with_near_copies(cloud, copies, 4);
  const auto base = [&](std::int32_t j) {
    const auto u = static_cast<std::size_t>(j);
    return u < n ? u : u - n;
  };
  for (const bool by_direction : {true, false}) {
    const RingSettings settings{.eps_theta = 0, .by_direction = by_direction};
    const PointRings once = build_rings(cloud, settings);
    const PointRings twice = build_rings(doubled, settings);
    std::size_t other = 0;
    for (std::size_t i = 0; i < doubled.size(); ++i) {
      std::vector<std::size_t> got;
      for (const std::int32_t j : twice.ring(i)) got.push_back(base(j));
      std::sort(got.begin(), got.end());
      EXPECT_TRUE(std::adjacent_find(got.begin(), got.end()) == got.end())
          << "ring of " << i << " holds both copies of a point";
      EXPECT_TRUE(std::find(got.begin(), got.end(), base(static_cast<std::int32_t>(i))) ==
                  got.end())
          << "ring of " << i << " holds its own copy";
      std::vector<std::size_t> want;
      for (const std::int32_t j : once.ring(base(static_cast<std::int32_t>(i)))) {
        want.push_back(static_cast<std::size_t>(j));
      }
      std::sort(want.begin(), want.end());
      if (got != want) ++other;
    }
    EXPECT_LE(other, doubled.size() / 100) << "by direction " << by_direction;
  }
}

// The pool overloads of the stages after the rings, on a noisy crease of 80000 points.
TEST(Rings, ThreadPoolGivesIdenticalNormalsAndSmoothing) {
  const auto depth = [](double a, double) { return 2 / (1 - std::fabs(a)); };
  const OrganizedCloud cloud = row_cloud(random_view(depth, 80000, 1.0, 17));
  ThreadPool pool(2);
  const PointRings rings = build_rings(cloud);
  const NormalMap one = compute_normals(cloud, rings);
  NormalMap two;
  compute_normals(cloud, rings, {}, two, pool);
  EXPECT_TRUE(same_normals(one, two));
  OrganizedCloud cloud1, cloud2;
  NormalMap normals1, normals2;
  smooth(cloud, rings, one, {}, cloud1, normals1);
  smooth(cloud, rings, one, {}, cloud2, normals2, pool);
  EXPECT_TRUE(same_points(cloud1, cloud2));
  EXPECT_TRUE(same_normals(normals1, normals2));
  EXPECT_FALSE(same_points(cloud, cloud1));  // the filter did move the points
}

// --- Normals -------------------------------------------------------------------------------------

TEST(RingNormals, TiltedPlaneIsExact) {
  const Vec3 n = unit({0.3, -0.4, -1.0});  // faces the origin
  const Vec3 centre{0.1, -0.05, 1.5};
  const Vec3 half_u = scaled(unit(cross(n, {0, 1, 0})), 0.3),
             half_v = scaled(cross(n, unit(half_u)), 0.3);
  std::mt19937 rng(7);
  const OrganizedCloud cloud = row_cloud(random_rectangle(centre, half_u, half_v, 2000, rng));
  const PointRings rings = build_rings(cloud);
  const NormalMap normals = compute_normals(cloud, rings);
  ASSERT_EQ(normals.width(), cloud.width());
  ASSERT_EQ(normals.height(), 1);
  double max_angle = 0, max_curvature = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3 m = normal_of(normals, i);
    max_angle = std::max(max_angle, angle(m, n));  // NaN fails below
    max_curvature = std::max<double>(max_curvature, curvature_of(normals, i));
    EXPECT_LT(dot(m, point_of(cloud, i)), 0.0) << "normal " << i << " faces away";
  }
  std::printf("  plane: max normal error %.2e rad, max curvature %.2e 1/m\n", max_angle,
              max_curvature);
  EXPECT_LE(max_angle, 1e-3);
  EXPECT_LE(max_curvature, 0.01);
}

/// n random points of the cap of a sphere (centre c, radius r) seen from the origin.
Points visible_sphere(const Vec3& c, double r, std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Points points;
  while (points.size() < n) {
    const Vec3 d = unit({gauss(rng), gauss(rng), gauss(rng)});
    const Vec3 p = {c[0] + r * d[0], c[1] + r * d[1], c[2] + r * d[2]};
    if (dot(d, p) < 0) points.push_back(p);
  }
  return points;
}

// Near the silhouette the edges to the neighbours run within eps_theta of the viewing ray and the
// veil test cuts them, as the mesh does on the grid: normals are checked up to 70 deg incidence.
TEST(RingNormals, SphereNormalsAreRadialAndCurvatureIsInverseRadius) {
  const Vec3 c{0, 0, 1.5};
  const double r = 0.3;
  const OrganizedCloud cloud = row_cloud(visible_sphere(c, r, 20000, 8));
  const NormalMap normals = compute_normals(cloud, build_rings(cloud));
  std::vector<double> curvature;
  double max_error = 0;
  int checked = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3 p = point_of(cloud, i), radial = unit(sub(p, c));
    if (std::isfinite(curvature_of(normals, i))) curvature.push_back(curvature_of(normals, i));
    if (angle(radial, scaled(p, -1)) > 70 * kDeg) continue;
    const double error = angle(normal_of(normals, i), radial) / kDeg;
    max_error = std::isnan(error) ? INFINITY : std::max(max_error, error);
    ++checked;
  }
  std::printf(
      "  sphere: max normal error %.3f deg over %d points up to 70 deg incidence; median "
      "curvature %.3f 1/m (1/R = %.3f) over %zu of %zu points\n",
      max_error, checked, median(curvature), 1 / r, curvature.size(), cloud.size());
  EXPECT_LE(max_error, 2.0);
  EXPECT_NEAR(median(curvature), 1 / r, 0.1 / r);
  EXPECT_GE(curvature.size(), cloud.size() * 99 / 100);
}

/// The least-squares normal of point i and its ring (the slow reference), sign-free.
Vec3 pca_normal(const OrganizedCloud& cloud, const PointRings& rings, std::size_t i) {
  std::vector<Vec3> pts = {point_of(cloud, i)};
  for (const std::int32_t j : rings.ring(i)) {
    pts.push_back(point_of(cloud, static_cast<std::size_t>(j)));
  }
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Vec3& p : pts) mean += Eigen::Vector3d(p[0], p[1], p[2]);
  mean /= static_cast<double>(pts.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Vec3& p : pts) {
    const Eigen::Vector3d d = Eigen::Vector3d(p[0], p[1], p[2]) - mean;
    cov += d * d.transpose();
  }
  const Eigen::Vector3d n =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(0);
  return {n(0), n(1), n(2)};
}

TEST(RingNormals, AgreeWithPcaOverTheSameRingOnANoisyCylinder) {
  // A vertical cylinder of radius 0.2 m with its axis 1.5 m away, Kinect noise along the rays.
  const double radius = 0.2, axis_z = 1.5;
  const auto depth = [&](double a, double) {  // nearer intersection of the ray (a, ., 1)
    const double qa = a * a + 1, qb = -2 * axis_z, qc = axis_z * axis_z - radius * radius;
    const double disc = qb * qb - 4 * qa * qc;
    return disc < 0 ? NAN : (-qb - std::sqrt(disc)) / (2 * qa);
  };
  Points points = random_view(depth, 4000, 0.3, 9, 0.12);
  std::erase_if(points, [](const Vec3& p) { return !std::isfinite(p[2]); });
  const OrganizedCloud cloud = row_cloud(points);
  const PointRings rings = build_rings(cloud);
  const NormalMap normals = compute_normals(cloud, rings);
  double to_pca = 0, fan_error = 0, pca_error = 0;
  int count = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3 m = normal_of(normals, i), p = point_of(cloud, i);
    if (!std::isfinite(m[0])) continue;
    const Vec3 pca = pca_normal(cloud, rings, i);
    const Vec3 radial = unit({p[0], 0, p[2] - axis_z});
    to_pca += line_angle(m, pca) / kDeg;
    fan_error += angle(m, radial) / kDeg;
    pca_error += line_angle(pca, radial) / kDeg;
    ++count;
  }
  std::printf(
      "  cylinder: %d of %zu normals; mean angle to PCA %.2f deg; error to the radial "
      "direction: fan %.2f, PCA %.2f deg\n",
      count, cloud.size(), to_pca / count, fan_error / count, pca_error / count);
  EXPECT_GE(count, static_cast<int>(cloud.size() * 99 / 100));
  EXPECT_LE(to_pca / count, 4.0);
  EXPECT_LE(fan_error, 1.5 * pca_error);  // not much worse than the least-squares normal
}

// Rings by direction go round a point as the pixels of a range image go round a pixel, so the
// fan over them is the mesh's 1-ring (with 12 neighbours instead of 8). Ordered about a PCA
// normal instead, a noisy surface tilts that normal and the fan it orders is not the one the
// sensor sampled. A plane 1.4-1.8 m away at 50 deg incidence with Kinect noise (sigma 3-4 mm,
// pixels ~3 mm apart), raw normals; measured (2026-12-05): mean error on the grid 35.2 deg,
// rings by direction 22.3, the same rings ordered about their PCA normals 39.4.
TEST(RingNormals, FanByDirectionIsTheGridsFanOnANoisyPlane) {
  const TestPlane plane{unit({std::sin(50 * kDeg), 0.1, -std::cos(50 * kDeg)}), -1.0};
  std::mt19937 rng(11);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const OrganizedCloud grid = test::cast(200, 150, [&](double a, double b) {
    const double z = plane.depth(a, b);
    return z + kinect_sigma(z) * gauss(rng);
  });
  const auto mean_error = [&](const OrganizedCloud& cloud, const NormalMap& normals) {
    double sum = 0;
    std::size_t count = 0;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const Vec3 m = normal_of(normals, i);
      if (!std::isfinite(m[0])) continue;
      sum += angle(m, plane.n) / kDeg;
      ++count;
    }
    EXPECT_GE(count, cloud.size() * 95 / 100);
    return sum / static_cast<double>(count);
  };
  const double on_grid = mean_error(grid, compute_normals(grid, build_mesh(grid)));
  const test::Unorganized points = test::shuffled(grid, 3);
  PointRings rings = build_rings(points.cloud);
  ASSERT_TRUE(rings.by_direction);
  const double by_direction = mean_error(points.cloud, compute_normals(points.cloud, rings));
  rings.by_direction = false;  // the same rings, each ordered about its PCA normal
  const double about_pca = mean_error(points.cloud, compute_normals(points.cloud, rings));
  std::printf(
      "  noisy plane: mean normal error, grid %.1f, rings by direction %.1f, the same rings "
      "ordered about the PCA normal %.1f deg\n",
      on_grid, by_direction, about_pca);
  EXPECT_LT(by_direction, on_grid);
  EXPECT_GT(about_pca, on_grid);
}

/// The number of points of `points` whose normal and curvature over rings of k are NaN.
int nan_normals(const Points& points, int k) {
  const OrganizedCloud cloud = row_cloud(points);
  const NormalMap normals = compute_normals(cloud, build_rings(cloud, {.k = k}));
  int nan = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    nan += std::isnan(normal_of(normals, i)[0]) && std::isnan(curvature_of(normals, i)) ? 1 : 0;
  }
  return nan;
}

/// 20 points on the line start + t step, t = 0..19.
Points line_points(const Vec3& start, const Vec3& step) {
  Points line;
  for (int t = 0; t < 20; ++t) {
    line.push_back({start[0] + t * step[0], start[1] + t * step[1], start[2] + t * step[2]});
  }
  return line;
}

TEST(RingNormals, PointsWithoutATriangleGetNaN) {
  // Rings of one neighbour.
  EXPECT_EQ(nan_normals({{0, 0, 1}, {0.01, 0, 1}}, 2), 2);
  // Exactly collinear points (coordinates exact in float): on an axis and on a diagonal.
  const double step = 1.0 / 128;
  EXPECT_EQ(nan_normals(line_points({0, 0, 2}, {step, 0, 0}), 6), 20);
  EXPECT_EQ(nan_normals(line_points({0.25, -0.125, 2}, {step, step, -step}), 6), 20);
  // An invalid point keeps NaN, its valid neighbours get normals.
  EXPECT_EQ(nan_normals({{0, 0, 1}, {0.01, 0, 1}, {0, 0.01, 1}, {0.01, 0.01, 1}, {NAN, 0, 1}}, 3),
            1);
}

TEST(RingNormals, CollinearRingOffTheAxesGetsNaN) {
  EXPECT_EQ(nan_normals(line_points({0.3, -0.2, 2}, scaled(unit({1, 2, 3}), 0.01)), 6), 20);
}

TEST(RingNormals, RingsOfAnotherCloudThrow) {
  const OrganizedCloud cloud = row_cloud(random_box(100, 10));
  const PointRings rings = build_rings(row_cloud(random_box(101, 10)));
  EXPECT_THROW(compute_normals(cloud, rings), std::invalid_argument);
  PointRings truncated = build_rings(cloud);
  truncated.neighbours.pop_back();
  EXPECT_THROW(compute_normals(cloud, truncated), std::invalid_argument);
}

// --- Point areas ---------------------------------------------------------------------------------

double total_area(const OrganizedCloud& cloud, const RingSettings& settings = {}) {
  const PointRings rings = build_rings(cloud, settings);
  double sum = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) sum += point_area(cloud, rings, i);
  return sum;
}

TEST(PointArea, SumsToTheAreaOfRandomPointsAndOfAGrid) {
  // A 1 x 1 m square at 2 m, facing the camera, 4000 random points.
  std::mt19937 rng(11);
  const double random_sum =
      total_area(row_cloud(random_rectangle({0, 0, 2}, {0.5, 0, 0}, {0, 0.5, 0}, 4000, rng)));
  // A 60 x 60 grid of spacing h = 1 cm on a plane tilted by 27 deg: 60^2 cells of h^2.
  const double h = 0.01;
  const Vec3 e1 = unit({1, 0, 0.5});
  Points points;
  for (int v = 0; v < 60; ++v) {
    for (int u = 0; u < 60; ++u) {
      points.push_back({h * u * e1[0] - 0.3, h * (v - 30), 1.5 + h * u * e1[2]});
    }
  }
  const OrganizedCloud grid = row_cloud(points);
  std::printf("  area: random square %.3f m^2 (1)", random_sum);
  EXPECT_NEAR(random_sum, 1.0, 0.15);
  // The header's constants for the interior of a grid (rings by distance: on the grid, not on
  // its image): 2 pi mean(d^2) / (k + 1) = 2 pi 1.5 / 9 h^2 (k = 8), 2 pi (28 / 12) / 13 h^2.
  for (const auto& [k, interior] :
       {std::pair{8, 2 * test::kPi * 1.5 / 9}, std::pair{12, 2 * test::kPi * 28 / 12 / 13}}) {
    const PointRings rings = build_rings(grid, {.k = k, .by_direction = false});
    for (int v = 3; v < 57; ++v) {
      for (int u = 3; u < 57; ++u) {
        EXPECT_NEAR(point_area(grid, rings, static_cast<std::size_t>(v * 60 + u)), interior * h * h,
                    1e-4 * h * h);
      }
    }
    for (const bool by_direction : {false, true}) {
      const double sum = total_area(grid, {.k = k, .by_direction = by_direction});
      std::printf("; grid k = %d%s %.4f", k, by_direction ? " by direction" : "", sum);
      EXPECT_NEAR(sum, 0.36, (k == 8 ? 0.15 : 0.25) * 0.36)
          << "k = " << k << ", by_direction " << by_direction;
    }
  }
  std::printf(" m^2 (0.36)\n");
  // No ring, no area; an index past the end is 0 as well.
  const OrganizedCloud lone = row_cloud({{0, 0, 1}, {NAN, 0, 1}});
  const PointRings rings = build_rings(lone);
  EXPECT_EQ(point_area(lone, rings, 0), 0.0);
  EXPECT_EQ(point_area(lone, rings, 1), 0.0);
  EXPECT_EQ(point_area(lone, rings, 2), 0.0);
}

/// The summed point areas of n random points on a 1 x 1 m square at 2 m whose normal is turned
/// by `incidence` from the viewing ray, relative to its area.
double slanted_area_ratio(double incidence, const RingSettings& settings) {
  std::mt19937 rng(16);
  const Vec3 half_u = {0.5 * std::cos(incidence), 0, 0.5 * std::sin(incidence)};
  return total_area(row_cloud(random_rectangle({0, 0, 2}, half_u, {0, 0.5, 0}, 5000, rng)),
                    settings);
}

/// point_area by the definition: 4 pi sqrt(lambda_1 lambda_2) / (count + 1), with Eigen's
/// iterative eigen-solver (the library finds lambda_1 lambda_2 without one).
double reference_point_area(const OrganizedCloud& cloud, const PointRings& rings, std::size_t i) {
  const Vec3 p = point_of(cloud, i);
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (const std::int32_t j : rings.ring(i)) {
    const Vec3 q = point_of(cloud, static_cast<std::size_t>(j));
    const Eigen::Vector3d d(q[0] - p[0], q[1] - p[1], q[2] - p[2]);
    second += d * d.transpose();
  }
  const double m = rings.count[i];
  const Eigen::Vector3d ev =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(second / m, Eigen::EigenvaluesOnly)
          .eigenvalues();
  return 4.0 * std::numbers::pi * std::sqrt(std::max(0.0, ev(1) * ev(2))) / (m + 1.0);
}

// Rings of a plane, a noisy plane, a box's corner (three planes), a ball of random points and a
// line with a little spread across it: lambda_0 far below, near and equal to lambda_1.
TEST(PointArea, EqualsTheEigenvalueDefinitionOnEveryKindOfRing) {
  std::mt19937 rng(21);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Points points;
  for (int row = 0; row < 20; ++row) {
    for (int column = 0; column < 20; ++column) {
      points.push_back({0.01 * column, 0.01 * row, 2.0});
      points.push_back({1 + 0.01 * column, 0.01 * row, 2.0 + 0.002 * gauss(rng)});
    }
  }
  for (int j = 0; j < 300; ++j) {
    const double a = uniform(rng, 0, 0.2), b = uniform(rng, 0, 0.2);
    points.push_back(j % 3 == 0   ? Vec3{2 + a, b, 2.0}
                     : j % 3 == 1 ? Vec3{2 + a, 0, 2 + b}
                                  : Vec3{2, a, 2 + b});
  }
  for (int j = 0; j < 300; ++j) {
    points.push_back({-1 + 0.05 * gauss(rng), 0.05 * gauss(rng), 2.0 + 0.05 * gauss(rng)});
  }
  for (int j = 0; j < 100; ++j) points.push_back({-2 + 0.01 * j, 1e-4 * gauss(rng), 2.0});
  const OrganizedCloud cloud = row_cloud(points);
  const PointRings rings = build_rings(cloud, {.by_direction = false});
  double worst = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const double expected = reference_point_area(cloud, rings, i);
    const double area = point_area(cloud, rings, i);
    worst = std::max(worst, std::fabs(area - expected) / std::max(expected, 1e-12));
  }
  std::printf("  point_area against the eigenvalues: largest relative difference %.2e\n", worst);
  EXPECT_LT(worst, 1e-9);
}

TEST(PointArea, SlantedPlaneWithDirectionRings) {
  std::printf("  slanted square, summed area / true area:");
  for (const double incidence_deg : {0.0, 45.0, 60.0, 70.0}) {
    const double by_distance = slanted_area_ratio(incidence_deg * kDeg, {.by_direction = false});
    const double by_direction = slanted_area_ratio(incidence_deg * kDeg, {});
    std::printf(" %.0f deg: %.3f by distance, %.3f by direction;", incidence_deg, by_distance,
                by_direction);
    EXPECT_NEAR(by_distance, 1.0, 0.15) << incidence_deg << " deg";
  }
  std::printf("\n");
  for (const double incidence_deg : {45.0, 60.0, 70.0}) {
    EXPECT_NEAR(slanted_area_ratio(incidence_deg * kDeg, {}), 1.0, 0.15) << incidence_deg << " deg";
  }
}

// --- Smoothing -----------------------------------------------------------------------------------

struct Stage3 {
  OrganizedCloud cloud;
  PointRings rings;
  NormalMap normals;
  OrganizedCloud out;
  NormalMap out_normals;
};

Stage3 smooth_points(const Points& points, const SmoothingSettings& settings = {}) {
  Stage3 s{row_cloud(points), {}, {}, {}, {}};
  s.rings = build_rings(s.cloud);
  s.normals = compute_normals(s.cloud, s.rings);
  smooth(s.cloud, s.rings, s.normals, settings, s.out, s.out_normals);
  return s;
}

double rms_to_plane(const OrganizedCloud& cloud, const TestPlane& plane) {
  double sum = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const double d = plane.distance(point_of(cloud, i));
    sum += d * d;
  }
  return std::sqrt(sum / static_cast<double>(cloud.size()));
}

/// The largest sine of the angle between a point's input and output viewing rays.
double max_off_ray(const Stage3& s) {
  double worst = 0;
  for (std::size_t i = 0; i < s.cloud.size(); ++i) {
    worst = std::max(worst, std::sin(angle(point_of(s.cloud, i), point_of(s.out, i))));
  }
  return worst;
}

TEST(RingSmoothing, KinectNoiseOnAPlaneAt2mDrops) {
  const TestPlane plane{unit({0.2, 0.1, -1}), 0};
  const TestPlane at_2m{plane.n, plane.n[2] * 2.0};  // through (0, 0, 2)
  const auto depth = [&](double a, double b) { return at_2m.depth(a, b); };
  const Stage3 s = smooth_points(random_view(depth, 20000, 1.0, 12));
  const double before = rms_to_plane(s.cloud, at_2m), after = rms_to_plane(s.out, at_2m);
  const double on_ray = max_off_ray(s);
  std::printf("  plane at 2 m: RMS %.2f -> %.2f mm (sigma %.2f mm); max sin off the ray %.1e\n",
              before * 1e3, after * 1e3, kinect_sigma(2.0) * 1e3, on_ray);
  EXPECT_LE(after, before / 1.5);
  EXPECT_LE(on_ray, 1e-6);
  // Without move_along_ray the point becomes the weighted mean, off its ray.
  const Stage3 mean = smooth_points(random_view(depth, 20000, 1.0, 12), {.move_along_ray = false});
  EXPECT_LE(rms_to_plane(mean.out, at_2m), before / 1.5);
  EXPECT_GT(max_off_ray(mean), 1e-3);
}

TEST(RingSmoothing, RightAngleCreaseStaysSharp) {
  // A concave corner at 2 m: z = 2 + |x|, the crease along the line x = 0, z = 2.
  const double s2 = 1 / std::sqrt(2.0);
  const TestPlane right{{s2, 0, -s2}, -2 * s2}, left{{-s2, 0, -s2}, -2 * s2};
  const auto depth = [](double a, double) { return 2 / (1 - std::fabs(a)); };
  const Stage3 s = smooth_points(random_view(depth, 20000, 1.0, 13));
  int far = 0, outside = 0;
  double worst = 0, sum_before = 0, sum_after = 0;
  for (std::size_t i = 0; i < s.cloud.size(); ++i) {
    const Vec3 p = point_of(s.cloud, i), q = point_of(s.out, i);
    if (std::hypot(p[0], p[2] - 2) <= 0.02) continue;
    const TestPlane& own = p[0] >= 0 ? right : left;  // the side of the point's ray
    const double sigma = kinect_sigma(q[2]);
    const double after = std::fabs(own.distance(q)) / sigma;
    ++far;
    outside += after > 3 ? 1 : 0;
    worst = std::max(worst, after);
    sum_before += std::pow(own.distance(p) / sigma, 2);
    sum_after += after * after;
  }
  std::printf(
      "  crease: %d points > 2 cm away, RMS %.2f -> %.2f sigma, %d beyond 3 sigma (max "
      "%.2f)\n",
      far, std::sqrt(sum_before / far), std::sqrt(sum_after / far), outside, worst);
  EXPECT_EQ(outside, 0);
  EXPECT_LT(sum_after, sum_before / (1.5 * 1.5));
}

// A 16-beam lidar's rings span scan lines far apart (0.2 m at 6 m), so a ring's weighted mean
// lies off its point across the ray; the point moves to where its ray meets the mean's plane,
// by at most sigma per pass, and the walls, floor and ceiling come out about as noisy as they
// went in, not 3-6 times noisier.
TEST(RingSmoothing, LidarScanLinesStayOnTheirPlanes) {
  const LidarRoom room;
  const PipelineSettings settings = test::ring_preset("laser");
  Pipeline pipeline(settings);
  pipeline.process(room.cloud);
  // LidarRoom's planes n . p + d = 0 as TestPlane's n . p = c.
  const std::array<TestPlane, 6> planes{{{{0, -1, 0}, -0.5},
                                         {{1, 0, 0}, -5.0},
                                         {{-1, 0, 0}, -6.0},
                                         {{0, 0, 1}, -4.0},
                                         {{0, 0, -1}, -5.0},
                                         {{0, 1, 0}, -2.5}}};
  std::array<double, 6> before{}, after{};
  std::array<int, 6> count{};
  double most_moved = 0;  // in units of the preset's sigma
  for (std::size_t i = 0; i < room.cloud.size(); ++i) {
    const int plane = room.labels(static_cast<int>(i), 0) - 1;
    const Vec3 p = point_of(room.cloud, i), q = point_of(pipeline.cloud(), i);
    const double r = std::sqrt(dot(p, p));
    most_moved = std::max(most_moved,
                          std::sqrt(dot(sub(q, p), sub(q, p))) / settings.smoothing.noise.sigma(r));
    if (plane < 0) continue;
    before[plane] += std::pow(planes[plane].distance(p), 2);
    after[plane] += std::pow(planes[plane].distance(q), 2);
    ++count[plane];
  }
  double all_before = 0, all_after = 0;
  for (std::size_t k = 0; k < planes.size(); ++k) {
    all_before += before[k];
    all_after += after[k];
    if (count[k] < 100) continue;
    const double b = std::sqrt(before[k] / count[k]), a = std::sqrt(after[k] / count[k]);
    std::printf("  lidar room, plane %zu: %d points, RMS to the plane %.1f -> %.1f mm\n", k + 1,
                count[k], b * 1e3, a * 1e3);
    // Measured (2026-12-06): 1.9 -> 1.3, 9.1 -> 7.0, 9.5 -> 14.0 (the wall at 6 m, where the
    // beams lie 0.21 m apart and a point's neighbours on its own line 2 cm), 8.7 -> 8.7, 8.9 ->
    // 6.9 mm; projecting the mean onto the ray without a bound gave 26-55 mm on every plane.
    EXPECT_LE(a, 1.6 * b) << "plane " << k + 1;
  }
  // All planes together about as noisy as before (sums of squares 1.59 -> 1.65 m^2): where
  // rings span scan lines this far apart the filter has little to average.
  EXPECT_LE(all_after, 1.1 * all_before);
  std::printf("  largest move %.2f sigma\n", most_moved);
  EXPECT_LE(most_moved, settings.smoothing.iterations + 1e-3);
}

// A lidar's rings span scan lines far apart, and the ellipses that share out a plane's area
// among its points overlap: the pipeline gives a plane over rings the area of their union, its
// polygon's, which cannot exceed the polygon's convex hull.
TEST(RingSegmentation, PlaneAreasOfALidarScanAreTheirPolygons) {
  const LidarRoom room;
  Pipeline pipeline(test::ring_preset("laser"));
  pipeline.process(room.cloud);
  const Segmentation& seg = pipeline.segmentation();
  double ellipses = 0, polygons = 0;
  int planes = 0;
  for (const SegmentPolygons& sp : pipeline.polygons().segments) {
    const Segment& s = seg.segments[static_cast<std::size_t>(sp.label - 1)];
    if (s.kind != SurfaceKind::plane) continue;
    ++planes;
    EXPECT_EQ(s.area_m2, sp.area) << s.label;
    EXPECT_LE(s.area_m2, sp.hull_area * (1 + 1e-9)) << s.label;
    for (int i = 0; i < seg.labels.width(); ++i) {
      if (seg.labels(i, 0) == s.label) {
        ellipses += point_area(pipeline.cloud(), pipeline.rings(), static_cast<std::size_t>(i));
      }
    }
    polygons += sp.area;
  }
  std::printf("  lidar room: %d planes, %.1f m^2 of polygons, %.1f m^2 of ring ellipses\n", planes,
              polygons, ellipses);
  EXPECT_GE(planes, 4);
  EXPECT_GT(ellipses, 1.3 * polygons);  // what the ellipses' sum would have said
}

TEST(RingSmoothing, IterationsZeroCopiesAndOutputMustNotBeInput) {
  Points points = random_view([](double, double) { return 1.5; }, 2000, 1.0, 14);
  points[5] = {NAN, NAN, NAN};
  Stage3 s = smooth_points(points, {.iterations = 0});
  s.cloud.add_intensity();  // optional planes are copied
  s.cloud.intensity(3, 0) = 7.0f;
  smooth(s.cloud, s.rings, s.normals, {.iterations = 0}, s.out, s.out_normals);
  EXPECT_TRUE(same_points(s.out, s.cloud));
  EXPECT_TRUE(same_values(s.out.intensity, s.cloud.intensity));
  EXPECT_TRUE(same_normals(s.out_normals, s.normals));
  OrganizedCloud cloud = s.cloud;
  NormalMap normals = s.normals;
  EXPECT_THROW(smooth(cloud, s.rings, normals, {}, cloud, s.out_normals), std::invalid_argument);
  EXPECT_THROW(smooth(cloud, s.rings, normals, {}, s.out, normals), std::invalid_argument);
  EXPECT_THROW(smooth(cloud, s.rings, normals, {.iterations = -1}, s.out, s.out_normals),
               std::invalid_argument);
  const PointRings other = build_rings(row_cloud(random_box(10, 1)));
  EXPECT_THROW(smooth(cloud, other, normals, {}, s.out, s.out_normals), std::invalid_argument);
}

// --- Segmentation --------------------------------------------------------------------------------

using test::qvga_boxes_scene;
using test::shuffled;
using test::to_grid;
using test::Unorganized;

synth::Rendering boxes_scene(std::uint64_t seed) {
  return synth::render(synth::random_scene(seed),
                       {.noise = synth::Noise::kinect, .seed = seed, .min_surface_pixels = 1000});
}

TEST(RingSegmentation, SyntheticBoxScenesThroughThePipeline) {
  RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS();
  Pipeline pipeline(test::ring_preset("kinect"));
  int gt = 0, correct = 0, normals = 0;
  double worst_normal = 0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const synth::Rendering r = boxes_scene(seed);
    const Unorganized u = shuffled(r.cloud, static_cast<unsigned>(seed));
    pipeline.process(u.cloud);
    const Segmentation& seg = pipeline.segmentation();
    test::expect_labels_name_segments(u.cloud, seg);
    const LabelImage labels = to_grid(seg.labels, u, r.cloud.width(), r.cloud.height());
    const eval::EvalResult e = eval::evaluate(r.labels, labels, {.tolerance = 0.8});
    for (const auto& [g, m] : e.correct_pairs) {
      const double error = test::angle_deg(r.surfaces[static_cast<std::size_t>(g) - 1].normal,
                                           seg.segments[static_cast<std::size_t>(m) - 1].normal);
      // Measured (2026-12-05): worst 2.41 deg, seed 4's plane of 1577 points at 3.5 m, about
      // 27 cm wide, over which the Kinect's disparity quantisation (3.9 cm steps there) leaves
      // the fit ~1 cm of systematic error at either side (~2-3 deg); the rest are within 1.82
      // deg. That plane was missed before the re-assignment moved ahead of merging (worst then
      // 1.66 deg).
      EXPECT_LE(error, 3.0) << "seed " << seed << ", GT region " << g;
      worst_normal = std::max(worst_normal, error);
      ++normals;
    }
    std::printf(
        "  boxes %llu (%zu points): GT %d, correct %d, over %d, under %d, missed %d, "
        "noise %d\n",
        static_cast<unsigned long long>(seed), u.cloud.size(), e.gt_regions, e.correct, e.over,
        e.under, e.missed, e.noise);
    gt += e.gt_regions;
    correct += e.correct;
  }
  std::printf("  unorganized boxes: %d of %d GT planes correct; worst normal %.2f deg over %d\n",
              correct, gt, worst_normal, normals);
  EXPECT_GE(correct, 20);  // measured 24 of 29 (2026-12-05)
}

/// A scene whose every point is stored twice, 1e-5 m apart, with the rings for merged scans
/// (by distance, no ray test), is segmented much as the scene: measured 18 and 23 segments,
/// 0.905 of the points in their segment; each copy in its point's (0.999). Before copies took
/// one place in a ring: 80 segments, 0.853. The 5 more are pieces that reach min_region_size
/// only with their copies, as it counts points (twice the size: 18 segments).
TEST(RingSegmentation, PointsStoredTwiceAreSegmentedAsOnce) {
  RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS();
  const synth::Rendering r = boxes_scene(2);
  const Unorganized u = shuffled(r.cloud, 2);
  const std::size_t n = u.cloud.size();
  const OrganizedCloud doubled = with_near_copies(u.cloud, n, 5);
  PipelineSettings settings = test::ring_preset("kinect");
  settings.rings.by_direction = false;
  settings.rings.eps_theta = 0;
  Pipeline once(settings), twice(settings);
  once.process(u.cloud);
  twice.process(doubled);
  const LabelImage& a = once.segmentation().labels;
  const LabelImage& b = twice.segmentation().labels;
  // Each segment of `once` maps to the segment of `twice` that holds most of its points.
  std::vector<std::vector<std::size_t>> votes(
      once.segmentation().segments.size() + 1,
      std::vector<std::size_t>(twice.segmentation().segments.size() + 1, 0));
  for (std::size_t i = 0; i < n; ++i) {
    ++votes[static_cast<std::size_t>(a(static_cast<int>(i), 0))]
           [static_cast<std::size_t>(b(static_cast<int>(i), 0))];
  }
  std::size_t same = 0, copies_agree = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto& row = votes[static_cast<std::size_t>(a(static_cast<int>(i), 0))];
    const auto mapped =
        static_cast<std::int32_t>(std::max_element(row.begin(), row.end()) - row.begin());
    same += b(static_cast<int>(i), 0) == mapped ? 1 : 0;
    copies_agree += b(static_cast<int>(i), 0) == b(static_cast<int>(i + n), 0) ? 1 : 0;
  }
  std::printf(
      "  stored twice: %zu and %zu segments, %.4f of the points in the same one, copies "
      "agree on %.4f\n",
      once.segmentation().segments.size(), twice.segmentation().segments.size(),
      static_cast<double>(same) / static_cast<double>(n),
      static_cast<double>(copies_agree) / static_cast<double>(n));
  EXPECT_LE(2 * twice.segmentation().segments.size(), 3 * once.segmentation().segments.size());
  EXPECT_GE(static_cast<double>(same), 0.88 * static_cast<double>(n));
  EXPECT_GE(static_cast<double>(copies_agree), 0.99 * static_cast<double>(n));
}

/// Box tops a few degrees below the sensor's height, without noise: the rings' veil test cuts
/// their edges between scan lines (nearly along the ray), so region growing leaves them in
/// strips; the grid's grazing-plane search over nearest neighbours by viewing direction finds
/// them as one plane each, flagged `grazing`, as the grid does.
TEST(RingSegmentation, BoxTopsSeenAtGrazingIncidenceAreOnePlaneEach) {
  RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS();
  Pipeline pipeline(test::ring_preset("ideal"));
  int tops = 0, found = 0, flagged = 0;
  for (const std::uint64_t seed : {1u, 6u, 15u}) {
    const synth::Rendering r = synth::render(
        synth::random_scene(seed), {.noise = synth::Noise::none, .min_surface_pixels = 300});
    const Unorganized u = shuffled(r.cloud, static_cast<unsigned>(seed));
    pipeline.process(u.cloud);
    const Segmentation& seg = pipeline.segmentation();
    const LabelImage labels = to_grid(seg.labels, u, r.cloud.width(), r.cloud.height());
    const eval::EvalResult e = eval::evaluate(r.labels, labels, {.tolerance = 0.8});
    for (std::size_t g = 0; g < r.surfaces.size(); ++g) {
      const synth::Surface& surface = r.surfaces[g];
      if (!surface.name.ends_with("/-y") || r.pixel_counts[g] < 300) continue;
      ++tops;
      const auto pair =
          std::find_if(e.correct_pairs.begin(), e.correct_pairs.end(),
                       [&](const auto& p) { return p.first == static_cast<int>(g) + 1; });
      if (pair == e.correct_pairs.end()) continue;
      ++found;
      const Segment& s = seg.segments[static_cast<std::size_t>(pair->second) - 1];
      flagged += s.grazing ? 1 : 0;
      EXPECT_LE(test::angle_deg(surface.normal, s.normal), 1.0) << "seed " << seed;
    }
  }
  std::printf(
      "  unorganized, no noise: %d of %d box tops of >= 300 px one segment, %d of them "
      "found by the grazing search\n",
      found, tops, flagged);
  // Measured (2026-12-05): 7 of 8, 6 of them by the search; 1 of 8 before it. The eighth is a
  // top seen in two parts (a box in front cuts it) that come out as one segment.
  EXPECT_EQ(tops, 8);
  EXPECT_GE(found, 7);
  EXPECT_GE(flagged, 6);
}

/// Two perpendicular noise-free rectangles, random points: a wall at z = 2 (1.0 x 1.2 m) and a
/// floor at y = 0.8 (1.0 x 0.8 m) meeting it along its bottom edge.
struct TwoPlanes {
  static constexpr double kWallArea = 1.2, kFloorArea = 0.8;
  Points points;
  TwoPlanes() {
    std::mt19937 rng(15);
    points = random_rectangle({0, 0.2, 2}, {0.5, 0, 0}, {0, 0.6, 0}, 12000, rng);
    const Points floor = random_rectangle({0, 0.8, 1.6}, {0.5, 0, 0}, {0, 0, 0.4}, 8000, rng);
    points.insert(points.end(), floor.begin(), floor.end());
  }
};

Segmentation segment_points(const OrganizedCloud& cloud, const SegmentationSettings& s = {},
                            const RingSettings& ring_settings = {}) {
  const PointRings rings = build_rings(cloud, ring_settings);
  return segment(cloud, rings, compute_normals(cloud, rings), s);
}

/// A floor 20 cm below the sensor, sampled as a 640 x 480 camera's rays meet it 1.5-4 m away
/// (2.9-7.6 deg to the rays; 440 columns, about 5.8 m^2), shuffled, without noise, plus one
/// point at the sensor's origin (no viewing direction). Consecutive rows lie 2-15 cm apart in
/// range, so the veil test cuts the rings between them; the grazing search makes the floor one
/// plane segment (measured: all of it; 40 % in the largest segment without the search), whose
/// area and outline count each point's patch of the plane, not its ring's (a line).
TEST(RingSegmentation, FloorSeenAtGrazingIncidenceIsOnePlane) {
  constexpr double kF = 525.0, kHeight = 0.2, kNear = 1.5, kFar = 4.0;
  constexpr int kFirstColumn = 100, kColumns = 440;
  Points points;
  for (int v = 240; v < 480; ++v) {
    const double z = kHeight / ((v - 239.5) / kF);
    if (z < kNear || z > kFar) continue;
    for (int u = kFirstColumn; u < kFirstColumn + kColumns; ++u) {
      points.push_back({(u - 319.5) / kF * z, kHeight, z});
    }
  }
  const std::size_t floor_points = points.size();
  std::mt19937 rng(3);
  std::shuffle(points.begin(), points.end(), rng);
  points.push_back({0.0, 0.0, 0.0});
  const OrganizedCloud cloud = row_cloud(points);
  const PointRings rings = build_rings(cloud);
  const NormalMap normals = compute_normals(cloud, rings);
  SegmentationSettings settings = preset("ideal");
  const auto largest_share = [&](const Segmentation& seg) {
    std::vector<std::size_t> count(seg.segments.size() + 1, 0);
    for (int i = 0; i < seg.labels.width(); ++i) {
      ++count[static_cast<std::size_t>(seg.labels(i, 0))];
    }
    count[0] = 0;
    return static_cast<double>(*std::max_element(count.begin(), count.end())) /
           static_cast<double>(floor_points);
  };
  const Segmentation with = segment(cloud, rings, normals, settings);
  ASSERT_FALSE(with.segments.empty());
  const Segment& floor = with.segments[0];
  EXPECT_GT(largest_share(with), 0.95);
  EXPECT_TRUE(floor.grazing);
  EXPECT_LT(test::angle_deg({0, -1, 0}, floor.normal), 0.1);
  EXPECT_NEAR(floor.offset, kHeight, 1e-3);
  // The sampled trapezoid: kColumns / kF wide per metre of depth, from kNear to kFar.
  const double area = kColumns / kF * (kFar * kFar - kNear * kNear) / 2.0;
  const PolygonSet polygons = extract_polygons(cloud, rings, with);
  ASSERT_FALSE(polygons.segments.empty());
  const SegmentPolygons& outline = polygons.segments[0];
  std::printf(
      "  grazing floor: %.3f of it one segment, area %.3f m^2, outline %.3f m^2 in %d loop(s), "
      "true %.3f m^2\n",
      largest_share(with), floor.area_m2, outline.area, outline.loop_count, area);
  // Measured 6.7 % over: a camera's rays are not evenly spaced in angle, and the scan's spacing
  // (the median angle between ring neighbours) is cos(theta) / f, not the cos(theta)^1.5 / f
  // of a pixel's patch, theta being up to 25 deg off the axis here.
  EXPECT_NEAR(floor.area_m2, area, 0.1 * area);
  EXPECT_EQ(outline.loop_count, 1);
  EXPECT_NEAR(outline.area, area, 0.1 * area);
  settings.grazing_min_angle = 0;  // the search off
  EXPECT_LT(largest_share(segment(cloud, rings, normals, settings)), 0.5);
}

TEST(RingSegmentation, PerpendicularPlanesAreTwoSegmentsWithTheirNormalsAndAreas) {
  const OrganizedCloud cloud = row_cloud(TwoPlanes().points);
  for (const bool by_direction : {true, false}) {
    const Segmentation seg = segment_points(cloud, {}, {.by_direction = by_direction});
    test::expect_consistent(cloud, seg, {});
    ASSERT_EQ(seg.segments.size(), 2u);
    const Segment &wall = seg.segments[0], &floor = seg.segments[1];
    // Points more than 2 cm from the crease (y = 0.8, z = 2) carry their own plane's label.
    int wrong = 0;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const Vec3 p = point_of(cloud, i);
      if (std::max(0.8 - p[1], 2 - p[2]) <= 0.02) continue;
      wrong += seg.labels(static_cast<int>(i), 0) != (i < 12000 ? 1 : 2) ? 1 : 0;
    }
    std::printf(
        "  two planes by %s: wall %d points, %.3f m^2 (%.1f), %.3f deg; floor %d points, "
        "%.3f m^2 (%.1f), %.3f deg; %d points > 2 cm from the crease on the other plane\n",
        by_direction ? "direction" : "distance", wall.pixel_count, wall.area_m2,
        TwoPlanes::kWallArea, test::angle_deg(wall.normal, {0, 0, -1}), floor.pixel_count,
        floor.area_m2, TwoPlanes::kFloorArea, test::angle_deg(floor.normal, {0, -1, 0}), wrong);
    EXPECT_EQ(wrong, 0);
    EXPECT_EQ(wall.pixel_count + floor.pixel_count, static_cast<int>(cloud.size()));
    EXPECT_LE(test::angle_deg(wall.normal, {0, 0, -1}), 0.1);
    EXPECT_LE(test::angle_deg(floor.normal, {0, -1, 0}), 0.1);
    EXPECT_NEAR(wall.area_m2, TwoPlanes::kWallArea, 0.2 * TwoPlanes::kWallArea);
    // The floor, seen at 56-68 deg incidence: by distance only (see PointArea.SlantedPlane*).
    if (!by_direction) {
      EXPECT_NEAR(floor.area_m2, TwoPlanes::kFloorArea, 0.2 * TwoPlanes::kFloorArea);
    }
  }
  // The smooth model finds the same two surfaces apart (a 90 deg crease).
  const Segmentation smooth_seg = segment_points(cloud, {.model = RegionModel::smooth});
  test::expect_labels_name_segments(cloud, smooth_seg);
  EXPECT_EQ(smooth_seg.segments.size(), 2u);
}

/// The grid's RegionThatCreptOverACreaseIsSplit over rings: two box fronts 3 m away, 14 and 20
/// deg apart, with the full Kinect noise, smoothed (the wall behind them only around them, to
/// keep the test fast); growth over the rings takes both fronts into one region for at least
/// one angle, and the split (split_residual_factor, against the segment's own ring residual)
/// cuts it at the crease, each part with its front's normal.
TEST(RingSegmentation, RegionThatCreptOverACreaseIsSplit) {
  int joined_without_split = 0;
  for (const double degrees : {14.0, 20.0}) {
    OrganizedCloud grid = test::two_fronts(degrees, 1.0, preset("kinect").noise, 5);
    for (int v = 0; v < grid.height(); ++v) {
      for (int u = 0; u < grid.width(); ++u) {
        if (std::abs(u - 320) > 100 || std::abs(v - 240) > 80) grid.z(u, v) = NAN;
      }
    }
    const Unorganized u = shuffled(grid, 7);
    const auto segment_fronts = [&](double split_factor) {
      PipelineSettings settings = test::ring_preset("kinect");
      settings.segmentation.split_residual_factor = split_factor;
      Pipeline pipeline(settings);
      pipeline.process(u.cloud);
      const Segmentation& seg = pipeline.segmentation();
      test::expect_labels_name_segments(u.cloud, seg);
      return std::pair{to_grid(seg.labels, u, grid.width(), grid.height()), seg.segments};
    };
    const auto [labels, segments] =
        segment_fronts(test::ring_preset("kinect").segmentation.split_residual_factor);
    const int left = labels(296, 240), right = labels(343, 240);
    ASSERT_NE(left, 0) << degrees;
    ASSERT_NE(right, 0) << degrees;
    EXPECT_NE(left, right) << degrees;
    if (left != right) {
      const double c = std::cos(degrees * kDeg), s = std::sin(degrees * kDeg);
      EXPECT_LT(test::angle_deg(segments[left - 1].normal, {0.0, 0.0, -1.0}), 2.0) << degrees;
      EXPECT_LT(test::angle_deg(segments[right - 1].normal, {s, 0.0, -c}), 2.0) << degrees;
    }
    const LabelImage joined = segment_fronts(0.0).first;
    joined_without_split += joined(296, 240) == joined(343, 240) ? 1 : 0;
  }
  EXPECT_GE(joined_without_split, 1);
}

TEST(RingSegmentation, IncrementalPlaneModelThrows) {
  const OrganizedCloud cloud = row_cloud(TwoPlanes().points);
  const PointRings rings = build_rings(cloud);
  const NormalMap normals = compute_normals(cloud, rings);
  SegmentationSettings s;
  s.model = RegionModel::incremental_plane;
  EXPECT_THROW(segment(cloud, rings, normals, s), std::invalid_argument);
  PipelineSettings p;
  p.segmentation.model = RegionModel::incremental_plane;
  Pipeline pipeline(p);
  EXPECT_THROW(pipeline.process(cloud), std::invalid_argument);
  EXPECT_THROW(segment(cloud, build_rings(row_cloud(random_box(5, 1))), normals),
               std::invalid_argument);
}

TEST(RingSegmentation, SortedSegmentsAndLabelsOnAScene) {
  const synth::Rendering r = qvga_boxes_scene(2);
  const Unorganized u = shuffled(r.cloud, 2);
  const PipelineSettings p = test::ring_preset("kinect");
  for (const RegionModel model : {RegionModel::plane, RegionModel::smooth}) {
    SegmentationSettings s = p.segmentation;
    s.model = model;
    const Segmentation seg = segment_points(u.cloud, s);
    test::expect_labels_name_segments(u.cloud, seg, to_string(model));
    EXPECT_GE(seg.segments.size(), 3u) << to_string(model);
    for (const Segment& sgm : seg.segments) {
      EXPECT_GE(sgm.pixel_count, s.min_region_size);
      EXPECT_GT(sgm.area_m2, 0.0);
      EXPECT_LE(dot(sgm.normal, sgm.centroid), 0.0);  // faces the camera
    }
  }
}

// --- Pipeline ------------------------------------------------------------------------------------

TEST(RingPipeline, RepeatableWithoutAMesh) {
  const synth::Rendering r = qvga_boxes_scene(3);
  const Unorganized u = shuffled(r.cloud, 3);
  Pipeline pipeline(test::ring_preset("kinect"));
  pipeline.process(r.cloud);  // an organized frame first: mesh, polygons, no rings
  EXPECT_EQ(pipeline.rings().size(), 0u);
  EXPECT_GT(pipeline.mesh().width(), 0);
  EXPECT_FALSE(pipeline.polygons().segments.empty());

  pipeline.process(u.cloud);
  const LabelImage first = pipeline.segmentation().labels;
  const std::size_t segments = pipeline.segmentation().segments.size();
  EXPECT_EQ(pipeline.rings().size(), u.cloud.size());
  EXPECT_EQ(pipeline.rings().k, RingSettings{}.k);
  EXPECT_EQ(pipeline.mesh().width(), 0);
  EXPECT_EQ(count_faces(pipeline.mesh()), 0u);
  EXPECT_FALSE(pipeline.polygons().segments.empty());  // outlined without a mesh
  EXPECT_TRUE(pipeline.polygons().pixels.empty());
  EXPECT_EQ(pipeline.cloud().width(), u.cloud.width());
  EXPECT_GT(segments, 3u);

  pipeline.process(u.cloud);
  EXPECT_EQ(pipeline.segmentation().segments.size(), segments);
  EXPECT_TRUE(same_values(first, pipeline.segmentation().labels));

  pipeline.process(r.cloud);  // back to the grid
  EXPECT_EQ(pipeline.rings().size(), 0u);
  EXPECT_TRUE(pipeline.rings().neighbours.empty());
  EXPECT_GT(pipeline.mesh().width(), 0);
}

TEST(RingPipeline, ThreadsGiveIdenticalResults) {
  const synth::Rendering r = qvga_boxes_scene(4);
  const Unorganized u = shuffled(r.cloud, 4);
  ASSERT_GE(u.cloud.size(), std::size_t{1} << 16)
      << "the pipeline splits clouds of 65536 points on";
  PipelineSettings settings = test::ring_preset("kinect");
  Pipeline one(settings);
  settings.threads = 2;
  Pipeline two(settings);
  one.process(u.cloud);
  two.process(u.cloud);
  EXPECT_EQ(one.rings().neighbours, two.rings().neighbours);
  EXPECT_TRUE(same_normals(one.normals(), two.normals()));
  EXPECT_TRUE(same_points(one.cloud(), two.cloud()));
  EXPECT_TRUE(same_values(one.segmentation().labels, two.segmentation().labels));
  EXPECT_EQ(one.segmentation().segments.size(), two.segmentation().segments.size());
}

}  // namespace
}  // namespace rangeseg
