// Bilateral filtering of points and normals (stage 3): noise reduction on analytic planes, edge
// preservation at creases, depth jumps and intensity edges, invariants, and agreement with a slow
// double-precision reference of eqs. 3 and 4.
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <functional>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>

#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/smoothing.hpp"

#include "detail/simd.hpp"
#include "detail/smoothing_rows.hpp"

namespace rangeseg {
namespace {

constexpr double kFocal = 525.0;  // Kinect, matches kDefaultPixelAngle
constexpr int kWidth = 200, kHeight = 150;
constexpr double kCx = (kWidth - 1) / 2.0, kCy = (kHeight - 1) / 2.0;
constexpr double kPi = 3.14159265358979323846;

double kinect_sigma(double z) { return 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4); }

/// Ray-casts a surface given as depth along the optical axis per normalised pixel coordinate
/// (a, b) = ((u - cx) / f, (v - cy) / f), then adds Gaussian depth noise `noise_factor *
/// sigma(z)` along the viewing ray (x/z and y/z stay exact).
OrganizedCloud render(const std::function<double(double, double)>& depth_of, double noise_factor,
                      unsigned seed) {
  OrganizedCloud cloud(kWidth, kHeight);
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const double a = (u - kCx) / kFocal, b = (v - kCy) / kFocal;
      double z = depth_of(a, b);
      z += noise_factor * kinect_sigma(z) * normal(rng);
      cloud.x(u, v) = static_cast<float>(a * z);
      cloud.y(u, v) = static_cast<float>(b * z);
      cloud.z(u, v) = static_cast<float>(z);
    }
  }
  return cloud;
}

/// Plane through (0, 0, distance) whose normal is tilted by `tilt` about the y axis; the normal
/// returned faces the camera.
struct TestPlane {
  std::array<double, 3> n;  // unit, facing the camera at the origin
  double c;                 // n . p = c
};
TestPlane make_plane(double distance, double tilt) {
  TestPlane plane{{std::sin(tilt), 0.0, -std::cos(tilt)}, 0.0};
  plane.c = -std::cos(tilt) * distance;
  return plane;
}
double plane_depth(const TestPlane& plane, double a, double b) {
  return plane.c / (plane.n[0] * a + plane.n[1] * b + plane.n[2]);
}

double angle_deg(const NormalMap& normals, int u, int v, const std::array<double, 3>& n) {
  const double dot = normals.nx(u, v) * n[0] + normals.ny(u, v) * n[1] + normals.nz(u, v) * n[2];
  return std::acos(std::clamp(dot, -1.0, 1.0)) * 180.0 / kPi;
}

struct PlaneErrors {
  double rms_distance = 0;  // m
  double mean_angle = 0;    // deg
};
PlaneErrors plane_errors(const OrganizedCloud& cloud, const NormalMap& normals,
                         const TestPlane& plane) {
  double sum_d2 = 0, sum_angle = 0;
  std::size_t count = 0, count_n = 0;
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if (!cloud.valid(u, v)) continue;
      const double d = plane.n[0] * cloud.x(u, v) + plane.n[1] * cloud.y(u, v) +
                       plane.n[2] * cloud.z(u, v) - plane.c;
      sum_d2 += d * d;
      ++count;
      if (std::isfinite(normals.nz(u, v))) {
        sum_angle += angle_deg(normals, u, v, plane.n);
        ++count_n;
      }
    }
  }
  return {std::sqrt(sum_d2 / count), sum_angle / count_n};
}

struct Frame {
  OrganizedCloud cloud;
  Mesh mesh;
  NormalMap normals;
};
/// The mesh's default angle test (12.5 deg) cuts ~1/3 of the ring edges of a plane at 4 m under
/// Kinect noise (sigma = 3.4 pixel spacings there), which isolates the largest excursions from
/// any 1-ring filter; the noise tests use 5 deg so that they measure the filter, not the mesh.
constexpr float kNoisyMeshEpsTheta = 0.087f;

Frame make_frame(OrganizedCloud cloud, float eps_theta = MeshSettings{}.eps_theta) {
  Frame f{std::move(cloud), {}, {}};
  build_mesh(f.cloud, {.eps_theta = eps_theta}, f.mesh);
  compute_normals(f.cloud, f.mesh, {}, f.normals);
  return f;
}

// --- Noise reduction on planes ------------------------------------------------------------------

struct PlaneCase {
  double distance;  // m
  double tilt_deg;
};

class NoisyPlane : public ::testing::TestWithParam<PlaneCase> {};

TEST_P(NoisyPlane, DefaultSmoothingHalvesPointAndNormalErrors) {
  const PlaneCase pc = GetParam();
  const TestPlane plane = make_plane(pc.distance, pc.tilt_deg * kPi / 180.0);
  const Frame in =
      make_frame(render([&](double a, double b) { return plane_depth(plane, a, b); }, 1.0, 42),
                 kNoisyMeshEpsTheta);
  const SmoothedCloud out = smooth(in.cloud, in.mesh, in.normals);

  const PlaneErrors before = plane_errors(in.cloud, in.normals, plane);
  const PlaneErrors after = plane_errors(out.cloud, out.normals, plane);
  RecordProperty("rms_before_mm", std::to_string(before.rms_distance * 1e3));
  RecordProperty("rms_after_mm", std::to_string(after.rms_distance * 1e3));
  std::printf("  z=%.0f m tilt=%.0f deg: RMS %.2f -> %.2f mm, normal error %.1f -> %.1f deg\n",
              pc.distance, pc.tilt_deg, before.rms_distance * 1e3, after.rms_distance * 1e3,
              before.mean_angle, after.mean_angle);
  EXPECT_LE(after.rms_distance, 0.5 * before.rms_distance);
  EXPECT_LE(after.mean_angle, 0.5 * before.mean_angle);
}

INSTANTIATE_TEST_SUITE_P(Depths, NoisyPlane,
                         ::testing::Values(PlaneCase{1.0, 0.0}, PlaneCase{2.0, 0.0},
                                           PlaneCase{4.0, 0.0}, PlaneCase{1.0, 40.0},
                                           PlaneCase{2.0, 40.0}, PlaneCase{4.0, 40.0}),
                         [](const ::testing::TestParamInfo<PlaneCase>& info) {
                           const PlaneCase& c = info.param;
                           return std::to_string(static_cast<int>(c.distance * 10)) + "dm_tilt" +
                                  std::to_string(static_cast<int>(c.tilt_deg)) + "deg";
                         });

// --- Edge preservation
// ----------------------------------------------------------------------------

// A roof ridge pointing at the camera: faces at +-45 degrees meet in a 90-degree convex edge on
// the column u = cx (between two pixel columns).
TEST(Smoothing, CreaseNormalsStayOnTheirFaces) {
  const double distance = 1.0;
  const Frame in = make_frame(render(
      [&](double a, double) { return a >= 0 ? distance / (1 - a) : distance / (1 + a); }, 0.0, 1));
  const std::array<double, 3> n_right{1 / std::sqrt(2.0), 0, -1 / std::sqrt(2.0)};
  const std::array<double, 3> n_left{-1 / std::sqrt(2.0), 0, -1 / std::sqrt(2.0)};

  auto near_edge_error = [&](const SmoothingSettings& settings, double* max_far) {
    const SmoothedCloud out = smooth(in.cloud, in.mesh, in.normals, settings);
    double sum = 0;
    int count = 0;
    *max_far = 0;
    for (int v = 5; v < kHeight - 5; ++v) {
      for (int u = 5; u < kWidth - 5; ++u) {
        // Pixel distance from the ridge, which lies between columns 99 and 100.
        const int d = u >= 100 ? u - 100 + 1 : 99 - u + 1;
        const double err = angle_deg(out.normals, u, v, u >= 100 ? n_right : n_left);
        if (d >= 3) *max_far = std::max(*max_far, err);
        if (d == 2 || d == 3) {  // pixels whose own faces are exact, next to the blended ridge
          sum += err;
          ++count;
        }
      }
    }
    return sum / count;
  };
  double max_far_on = 0, max_far_off = 0;
  const double near_on = near_edge_error({}, &max_far_on);
  const double near_off = near_edge_error({.use_normals = false}, &max_far_off);
  std::printf(
      "  crease: max error >= 3 px from edge %.2f deg; mean error 2-3 px: %.2f deg with "
      "normal term, %.2f deg without\n",
      max_far_on, near_on, near_off);
  EXPECT_LE(max_far_on, 5.0);
  EXPECT_LT(near_on, 0.7 * near_off);  // the normal term is what keeps the crease
}

// A plane at 1 m in front of a plane at 2 m: the mesh cuts the jump, and no point moves towards
// the other surface.
TEST(Smoothing, DepthJumpStaysSharp) {
  const int jump_u = 100;
  const Frame in = make_frame(
      render([&](double a, double) { return a * kFocal + kCx < jump_u ? 1.0 : 2.0; }, 1.0, 7));
  const SmoothedCloud out = smooth(in.cloud, in.mesh, in.normals);
  for (int u : {jump_u - 1, jump_u}) {
    const double truth = u < jump_u ? 1.0 : 2.0;
    double sum = 0, sum2_in = 0, sum2_out = 0;
    int count = 0;
    for (int v = 1; v < kHeight - 1; ++v) {
      const double e = out.cloud.z(u, v) - truth;
      const double e_in = in.cloud.z(u, v) - truth;
      sum += e;
      sum2_out += e * e;
      sum2_in += e_in * e_in;
      ++count;
    }
    const double sigma = kinect_sigma(truth);
    // A pull of even 1 % of the 1 m jump would be ~10 sigma at 1 m.
    EXPECT_LT(std::abs(sum / count), 4 * sigma / std::sqrt(count)) << "column " << u;
    EXPECT_LT(std::sqrt(sum2_out / count), std::sqrt(sum2_in / count)) << "column " << u;
  }
}

// A plane at 1 m with an intensity checkerboard whose dark squares are 5 mm further away (small
// enough that the mesh keeps the edges). With the intensity term the step stays sharper: the
// pixels next to a checker edge stay closer to their own level.
TEST(Smoothing, IntensityTermKeepsStepAtIntensityEdges) {
  const int square = 12;
  const double step = 0.005;
  auto dark = [&](int u, int v) { return ((u / square) + (v / square)) % 2 == 1; };
  OrganizedCloud cloud = render(
      [&](double a, double b) {
        const int u = static_cast<int>(std::lround(a * kFocal + kCx));
        const int v = static_cast<int>(std::lround(b * kFocal + kCy));
        return dark(u, v) ? 1.0 + step : 1.0;
      },
      1.0, 11);
  cloud.add_intensity();
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0.0f, 2.0f);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      cloud.intensity(u, v) = (dark(u, v) ? 40.0f : 200.0f) + noise(rng);
    }
  }
  const Frame in = make_frame(std::move(cloud));

  auto edge_rms = [&](const OrganizedCloud& c) {
    double sum2 = 0;
    int count = 0;
    for (int v = 2; v < kHeight - 2; ++v) {
      for (int u = 2; u < kWidth - 2; ++u) {
        bool at_edge = false;
        for (int k = 0; k < 8; ++k) {
          at_edge |= dark(u + kNeighbourDu[k], v + kNeighbourDv[k]) != dark(u, v);
        }
        if (!at_edge) continue;
        const double e = c.z(u, v) - (dark(u, v) ? 1.0 + step : 1.0);
        sum2 += e * e;
        ++count;
      }
    }
    return std::sqrt(sum2 / count);
  };
  const SmoothedCloud with = smooth(in.cloud, in.mesh, in.normals, {.use_intensity = true});
  const SmoothedCloud without = smooth(in.cloud, in.mesh, in.normals, {.use_intensity = false});
  const double rms_in = edge_rms(in.cloud), rms_with = edge_rms(with.cloud),
               rms_without = edge_rms(without.cloud);
  std::printf("  checker edge depth RMS: input %.2f mm, intensity term on %.2f mm, off %.2f mm\n",
              rms_in * 1e3, rms_with * 1e3, rms_without * 1e3);
  EXPECT_LT(rms_with, 0.75 * rms_without);
  EXPECT_LT(rms_with, 0.6 * rms_in);

  // Grey from RGB drives the term the same way.
  OrganizedCloud rgb = in.cloud;
  rgb.intensity.clear();
  rgb.add_rgb();
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const auto grey =
          static_cast<std::uint8_t>(std::clamp(in.cloud.intensity(u, v), 0.0f, 255.0f));
      rgb.r(u, v) = rgb.g(u, v) = rgb.b(u, v) = grey;
    }
  }
  const SmoothedCloud with_rgb = smooth(rgb, in.mesh, in.normals);
  EXPECT_LT(edge_rms(with_rgb.cloud), 0.75 * rms_without);
}

// --- Invariants
// -----------------------------------------------------------------------------------

Frame plane_with_holes() {
  const TestPlane plane = make_plane(1.5, 0.5);
  OrganizedCloud cloud =
      render([&](double a, double b) { return plane_depth(plane, a, b); }, 1.0, 3);
  std::mt19937 rng(9);
  std::uniform_int_distribution<int> pu(0, kWidth - 1), pv(0, kHeight - 1);
  for (int i = 0; i < 2000; ++i) {
    const int u = pu(rng), v = pv(rng);
    cloud.x(u, v) = cloud.y(u, v) = cloud.z(u, v) = NAN;
  }
  for (int v = 40; v < 60; ++v) {
    for (int u = 50; u < 90; ++u) cloud.x(u, v) = cloud.y(u, v) = cloud.z(u, v) = NAN;
  }
  return make_frame(std::move(cloud));
}

TEST(Smoothing, ValidityUnitNormalsAndRays) {
  const Frame in = plane_with_holes();
  for (const bool along_ray : {true, false}) {
    const SmoothedCloud out =
        smooth(in.cloud, in.mesh, in.normals, {.iterations = 3, .move_along_ray = along_ray});
    EXPECT_EQ(out.cloud.count_valid(), in.cloud.count_valid());
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) {
        ASSERT_EQ(out.cloud.valid(u, v), in.cloud.valid(u, v)) << u << "," << v;
        const bool has_normal = std::isfinite(in.normals.nz(u, v));
        ASSERT_EQ(std::isfinite(out.normals.nz(u, v)), has_normal) << u << "," << v;
        if (has_normal) {
          const double len =
              std::hypot(out.normals.nx(u, v), out.normals.ny(u, v), out.normals.nz(u, v));
          ASSERT_NEAR(len, 1.0, 1e-5);
        }
        if (!in.cloud.valid(u, v)) continue;
        if (in.mesh.edges(u, v) == 0) {
          ASSERT_EQ(out.cloud.z(u, v), in.cloud.z(u, v)) << u << "," << v;  // no ring: unchanged
        }
        if (along_ray) {
          ASSERT_NEAR(out.cloud.x(u, v) / out.cloud.z(u, v), in.cloud.x(u, v) / in.cloud.z(u, v),
                      1e-6);
          ASSERT_NEAR(out.cloud.y(u, v) / out.cloud.z(u, v), in.cloud.y(u, v) / in.cloud.z(u, v),
                      1e-6);
        }
      }
    }
  }
}

TEST(Smoothing, RecomputedNormalsMatchComputeNormalsOfTheOutput) {
  const Frame in = plane_with_holes();
  const SmoothedCloud out = smooth(in.cloud, in.mesh, in.normals, {.recompute_normals = true});
  const NormalMap expected = compute_normals(out.cloud, in.mesh);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      if (!std::isfinite(expected.nz(u, v))) {
        ASSERT_FALSE(std::isfinite(out.normals.nz(u, v)));
        continue;
      }
      ASSERT_FLOAT_EQ(out.normals.nx(u, v), expected.nx(u, v));
      ASSERT_FLOAT_EQ(out.normals.nz(u, v), expected.nz(u, v));
    }
  }
  // Recomputing also smooths: the normals are better than the input's.
  const TestPlane plane = make_plane(1.5, 0.5);
  EXPECT_LT(plane_errors(out.cloud, out.normals, plane).mean_angle,
            0.7 * plane_errors(in.cloud, in.normals, plane).mean_angle);
}

// --- Against a slow reference of eqs. 3 and 4
// -----------------------------------------------------

struct Reference {
  std::vector<std::array<double, 3>> p, n;
};

/// One pass, straight from the header's formula, in double with std::exp.
Reference reference_pass(const OrganizedCloud& cloud, const NormalMap& normals, const Mesh& mesh,
                         const SmoothingSettings& st, const FloatPlane* intensity, double c_i) {
  const int w = cloud.width(), h = cloud.height(), s = mesh.pixel_stride;
  Reference out;
  out.p.resize(static_cast<std::size_t>(w) * h);
  out.n.resize(out.p.size());
  // 1 / (2 s_d(z)^2) and 1 / s_n(z) of one end point.
  auto inverse_scales = [&](double z) {
    const double sigma = static_cast<float>(st.noise.sigma(z));
    const double spacing = s * static_cast<double>(pixel_angle_for(st, 0)) * z;
    const double sd2 =
        st.distance_scale * st.distance_scale * (spacing * spacing + 2 * sigma * sigma);
    const double s_n = st.normal_scale * std::max(1.0, sigma / spacing);
    return std::array<double, 2>{1 / (2 * sd2), 1 / s_n};
  };
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const std::array<double, 3> p{cloud.x(u, v), cloud.y(u, v), cloud.z(u, v)};
      const std::array<double, 3> n{normals.nx(u, v), normals.ny(u, v), normals.nz(u, v)};
      const std::array<double, 2> scales_i = inverse_scales(p[2]);
      double sw = 1, sp[3] = {p[0], p[1], p[2]}, sn[3] = {n[0], n[1], n[2]};
      for (int k = 0; k < 8; ++k) {
        if (!(mesh.edges(u, v) & (1 << k))) continue;
        const int un = u + s * kNeighbourDu[k], vn = v + s * kNeighbourDv[k];
        const std::array<double, 3> q{cloud.x(un, vn), cloud.y(un, vn), cloud.z(un, vn)};
        const std::array<double, 3> m{normals.nx(un, vn), normals.ny(un, vn), normals.nz(un, vn)};
        // The edge's scales: the mean of both ends' inverse scales.
        const std::array<double, 2> scales_j = inverse_scales(q[2]);
        double arg = 0;
        if (st.use_distance) {
          const double d2 = (q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]) +
                            (q[2] - p[2]) * (q[2] - p[2]);
          arg += d2 * 0.5 * (scales_i[0] + scales_j[0]);
        }
        if (st.use_normals) {
          arg += (std::abs(m[0] - n[0]) + std::abs(m[1] - n[1]) + std::abs(m[2] - n[2])) * 0.5 *
                 (scales_i[1] + scales_j[1]);
        }
        if (intensity) {
          arg += std::abs((*intensity)(un, vn) - (*intensity)(u, v)) / (c_i * st.intensity_scale);
        }
        if (!(arg < 30)) continue;
        const double wt = std::exp(-arg);
        sw += wt;
        for (int i = 0; i < 3; ++i) {
          sp[i] += wt * q[i];
          sn[i] += wt * m[i];
        }
      }
      auto& po = out.p[static_cast<std::size_t>(v) * w + u];
      auto& no = out.n[static_cast<std::size_t>(v) * w + u];
      for (int i = 0; i < 3; ++i) po[i] = sp[i] / sw;
      if (st.move_along_ray) {
        const double qq = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
        const double t = (po[0] * p[0] + po[1] * p[1] + po[2] * p[2]) / qq;
        for (int i = 0; i < 3; ++i) po[i] = p[i] * t;
      }
      const double len = std::sqrt(sn[0] * sn[0] + sn[1] * sn[1] + sn[2] * sn[2]);
      for (int i = 0; i < 3; ++i) no[i] = sn[i] / len;
    }
  }
  return out;
}

class AgainstReference : public ::testing::TestWithParam<std::tuple<bool, bool, int>> {};

TEST_P(AgainstReference, OnePassMatches) {
  const auto [along_ray, with_intensity, stride] = GetParam();
  const TestPlane plane = make_plane(2.0, 0.6);
  OrganizedCloud cloud =
      render([&](double a, double b) { return plane_depth(plane, a, b) + 0.02 * std::sin(40 * a); },
             1.0, 17);
  if (with_intensity) {
    cloud.add_intensity();
    std::mt19937 rng(2);
    std::uniform_real_distribution<float> in(0.0f, 100.0f);
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) cloud.intensity(u, v) = in(rng);
    }
  }
  Frame in{std::move(cloud), {}, {}};
  build_mesh(in.cloud, {.pixel_stride = stride}, in.mesh);
  compute_normals(in.cloud, in.mesh, {}, in.normals);

  const SmoothingSettings st{.iterations = 1,
                             .intensity_range = with_intensity ? 100.0f : 0.0f,
                             .move_along_ray = along_ray};
  const SmoothedCloud out = smooth(in.cloud, in.mesh, in.normals, st);
  const Reference ref = reference_pass(in.cloud, in.normals, in.mesh, st,
                                       with_intensity ? &in.cloud.intensity : nullptr, 100.0);
  double max_dp = 0, max_dn = 0;
  int moved = 0;
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      if (!in.cloud.valid(u, v) || !std::isfinite(in.normals.nz(u, v))) continue;
      const auto& p = ref.p[static_cast<std::size_t>(v) * kWidth + u];
      const auto& n = ref.n[static_cast<std::size_t>(v) * kWidth + u];
      max_dp = std::max({max_dp, std::abs(out.cloud.x(u, v) - p[0]),
                         std::abs(out.cloud.y(u, v) - p[1]), std::abs(out.cloud.z(u, v) - p[2])});
      max_dn =
          std::max({max_dn, std::abs(out.normals.nx(u, v) - n[0]),
                    std::abs(out.normals.ny(u, v) - n[1]), std::abs(out.normals.nz(u, v) - n[2])});
      moved += std::abs(out.cloud.z(u, v) - in.cloud.z(u, v)) > 1e-4f;
    }
  }
  EXPECT_LT(max_dp, 2e-6);  // metres: float rounding at 2 m plus the exp approximation
  EXPECT_LT(max_dn, 2e-5);
  EXPECT_GT(moved, kWidth * kHeight / (4 * stride * stride));
}

INSTANTIATE_TEST_SUITE_P(Modes, AgainstReference,
                         ::testing::Combine(::testing::Bool(), ::testing::Bool(),
                                            ::testing::Values(1, 2)));

// --- Row bands (detail/smoothing_rows.hpp) ---------------------------------------------------

class RowBands : public ::testing::TestWithParam<std::tuple<bool, int>> {};

/// Bands covering the image, run in reverse order with one scratch, reproduce the whole-image
/// pass bit for bit (including band borders off the stride lattice and the intensity term).
TEST_P(RowBands, BandsAreBitIdenticalToTheWholeImage) {
  const auto [along_ray, stride] = GetParam();
  const TestPlane plane = make_plane(1.5, 0.4);
  OrganizedCloud cloud =
      render([&](double a, double b) { return plane_depth(plane, a, b) + (a > 0.02 ? 0.3 : 0.0); },
             1.0, 5);
  cloud.add_intensity();
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> in(0.0f, 50.0f);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      cloud.intensity(u, v) = in(rng);
      if ((u * 7 + v * 13) % 97 == 0) cloud.z(u, v) = NAN;  // holes: cut edges, NaN normals
    }
  }
  Frame f{std::move(cloud), {}, {}};
  build_mesh(f.cloud, {.pixel_stride = stride}, f.mesh);
  compute_normals(f.cloud, f.mesh, {}, f.normals);
  const SmoothingSettings st{.iterations = 1, .move_along_ray = along_ray};
  const SmoothedCloud whole = smooth(f.cloud, f.mesh, f.normals, st);

  const detail::SmoothRowsInput input{
      .cloud = &f.cloud,
      .mesh = &f.mesh,
      .normals = &f.normals,
      .intensity = &f.cloud.intensity,
      .intensity_range = detail::frame_intensity_range(f.cloud, f.cloud.intensity)};
  ASSERT_GT(input.intensity_range, 0.0f);
  detail::SmoothRowsScratch scratch;
  for (int bands : {1, 2, 3}) {
    OrganizedCloud out(kWidth, kHeight);
    NormalMap out_normals;
    for (FloatPlane* plane : {&out_normals.nx, &out_normals.ny, &out_normals.nz}) {
      plane->resize(kWidth, kHeight);
    }
    for (int b = bands - 1; b >= 0; --b) {
      detail::smooth_rows(input, st, kHeight * b / bands, kHeight * (b + 1) / bands, scratch, out,
                          out_normals);
    }
    int moved = 0;
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) {
        const auto same = [](float a, float b) {
          // bit-identical, NaN included
          return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b);
        };
        ASSERT_TRUE(same(out.x(u, v), whole.cloud.x(u, v))) << bands << " bands " << u << "," << v;
        ASSERT_TRUE(same(out.y(u, v), whole.cloud.y(u, v))) << bands << " bands " << u << "," << v;
        ASSERT_TRUE(same(out.z(u, v), whole.cloud.z(u, v))) << bands << " bands " << u << "," << v;
        ASSERT_TRUE(same(out_normals.nx(u, v), whole.normals.nx(u, v))) << bands << " " << u;
        ASSERT_TRUE(same(out_normals.ny(u, v), whole.normals.ny(u, v))) << bands << " " << u;
        ASSERT_TRUE(same(out_normals.nz(u, v), whole.normals.nz(u, v))) << bands << " " << u;
        moved += out.z(u, v) != f.cloud.z(u, v);
      }
    }
    EXPECT_GT(moved, kWidth * kHeight / (4 * stride * stride));  // the pass did filter
  }
}

INSTANTIATE_TEST_SUITE_P(Modes, RowBands,
                         ::testing::Combine(::testing::Bool(), ::testing::Values(1, 2)));

/// The pass runs on 4 (SSE2), 8 (AVX2) or 16 (AVX-512) lanes, whichever the CPU has up to the
/// limit, reading interior rows in place and the last row from a padded copy. The operations are
/// the same except for fused multiply-adds and the hardware reciprocal estimates (each refined by
/// a Newton step), so the widths agree to float rounding, amplified a little by the second pass's
/// weights: points within 5 um, normal components within 5e-5 (measured: 1.2 um, 9e-6), for
/// every term and mode, on a width that is no multiple of 16, with holes
/// and at pixel stride 2. NaN where and only where the baseline has NaN.
TEST(Smoothing, InstructionSetsAgree) {
  using detail::simd::Isa;
  const TestPlane plane = make_plane(2.0, 0.3);
  OrganizedCloud cloud =
      render([&](double a, double b) { return plane_depth(plane, a, b) + (b > 0.01 ? 0.2 : 0.0); },
             1.0, 9);
  cloud.add_intensity();
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      cloud.intensity(u, v) = static_cast<float>((u / 5 + v / 7) % 3);
      if ((u * 5 + v * 11) % 89 == 0) cloud.z(u, v) = NAN;
    }
  }
  // Largest |a - b| over the plane; infinity where only one of them is NaN.
  const auto max_diff = [](const FloatPlane& a, const FloatPlane& b) {
    double worst = 0.0;
    for (int v = 0; v < a.height(); ++v) {
      for (int u = 0; u < a.width(); ++u) {
        if (std::isnan(a(u, v)) != std::isnan(b(u, v))) return HUGE_VAL;
        if (!std::isnan(a(u, v))) worst = std::max(worst, std::abs(double{a(u, v)} - b(u, v)));
      }
    }
    return worst;
  };
  for (int stride : {1, 2}) {
    Frame f{cloud, {}, {}};
    build_mesh(f.cloud, {.pixel_stride = stride}, f.mesh);
    compute_normals(f.cloud, f.mesh, {}, f.normals);
    for (bool along_ray : {true, false}) {
      for (bool normal_term : {true, false}) {
        const SmoothingSettings st{.iterations = 2,
                                   .use_normals = normal_term,
                                   .move_along_ray = along_ray,
                                   .viewpoint = {0.01f, -0.02f, 0.0f}};
        detail::simd::isa_limit = Isa::baseline;
        const SmoothedCloud baseline = smooth(f.cloud, f.mesh, f.normals, st);
        for (Isa isa : {Isa::avx2, Isa::avx512}) {
          detail::simd::isa_limit = isa;
          const SmoothedCloud wide = smooth(f.cloud, f.mesh, f.normals, st);
          const std::string what = "stride " + std::to_string(stride) + " along_ray " +
                                   std::to_string(along_ray) + " normal term " +
                                   std::to_string(normal_term) + " isa " +
                                   std::to_string(static_cast<int>(isa));
          EXPECT_LE(max_diff(baseline.cloud.x, wide.cloud.x), 5e-6) << what;
          EXPECT_LE(max_diff(baseline.cloud.z, wide.cloud.z), 5e-6) << what;
          EXPECT_LE(max_diff(baseline.normals.nx, wide.normals.nx), 5e-5) << what;
          EXPECT_LE(max_diff(baseline.normals.nz, wide.normals.nz), 5e-5) << what;
        }
      }
    }
  }
  detail::simd::isa_limit = Isa::avx512;
}

// --- API
// ------------------------------------------------------------------------------------------

TEST(Smoothing, SmootherReuseAndPingPong) {
  const Frame a = plane_with_holes();
  const Frame b = make_frame(render([](double, double) { return 1.0; }, 1.0, 4));
  for (int iterations : {0, 1, 2, 3}) {
    Smoother smoother({.iterations = iterations});
    OrganizedCloud out;
    NormalMap out_normals;
    smoother.run(b.cloud, b.mesh, b.normals, out, out_normals);
    smoother.run(a.cloud, a.mesh, a.normals, out, out_normals);
    const SmoothedCloud fresh = smooth(a.cloud, a.mesh, a.normals, {.iterations = iterations});
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) {
        if (!a.cloud.valid(u, v)) continue;
        ASSERT_EQ(out.z(u, v), fresh.cloud.z(u, v));
        if (std::isnan(fresh.normals.nx(u, v))) {
          ASSERT_TRUE(std::isnan(out_normals.nx(u, v)));
        } else {
          ASSERT_EQ(out_normals.nx(u, v), fresh.normals.nx(u, v));
        }
        if (iterations == 0) {
          ASSERT_EQ(out.z(u, v), a.cloud.z(u, v));
        }
      }
    }
  }
  // Each further pass smooths more.
  const TestPlane plane = make_plane(1.5, 0.5);
  double last = plane_errors(a.cloud, a.normals, plane).rms_distance;
  for (int iterations : {1, 2, 3}) {
    const SmoothedCloud out = smooth(a.cloud, a.mesh, a.normals, {.iterations = iterations});
    const double rms = plane_errors(out.cloud, out.normals, plane).rms_distance;
    EXPECT_LT(rms, last) << iterations;
    last = rms;
  }
}

TEST(Smoothing, RejectsBadInput) {
  const Frame in = plane_with_holes();
  OrganizedCloud out;
  NormalMap out_normals;
  OrganizedCloud aliased = in.cloud;
  EXPECT_THROW(smooth(aliased, in.mesh, in.normals, {}, aliased, out_normals),
               std::invalid_argument);
  OrganizedCloud flat(kWidth * kHeight, 1);
  EXPECT_THROW(smooth(flat, in.mesh, in.normals, {}, out, out_normals), std::invalid_argument);
  OrganizedCloud other(kWidth + 1, kHeight);
  EXPECT_THROW(smooth(other, in.mesh, in.normals, {}, out, out_normals), std::invalid_argument);
  NormalMap bad_normals;
  EXPECT_THROW(smooth(in.cloud, in.mesh, bad_normals, {}, out, out_normals), std::invalid_argument);
  EXPECT_THROW(Smoother({.iterations = -1}), std::invalid_argument);
  // 2^31 - 1 passes ran for hours; the most a setting may ask for is kMaxSmoothingIterations.
  EXPECT_NO_THROW(Smoother({.iterations = kMaxSmoothingIterations}));
  EXPECT_THROW(Smoother({.iterations = kMaxSmoothingIterations + 1}), std::invalid_argument);
  EXPECT_THROW(Smoother({.distance_scale = 0}), std::invalid_argument);
  EXPECT_THROW(Smoother({.normal_scale = NAN}), std::invalid_argument);
  // The message names the member as it is spelt in code and in --config.
  try {
    [[maybe_unused]] const Smoother rejected({.noise = {.a = 0.001, .b = -1.0}});
    ADD_FAILURE() << "a negative noise.b was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("SmoothingSettings::noise.b must be >= 0"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace rangeseg
