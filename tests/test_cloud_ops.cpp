// downsample: every k-th pixel, with the optional planes, against an index formula;
// interleaved_to_cloud against the planes it was made from; to_sensor_frame; the scale checks.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/sensor.hpp"

namespace {

// Pixel (u, v) holds values that identify it, so any wrong source pixel is visible.
rangeseg::OrganizedCloud numbered_cloud(int width, int height) {
  rangeseg::OrganizedCloud c(width, height);
  c.add_intensity();
  c.add_rgb();
  c.add_label();
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      c.x(u, v) = static_cast<float>(u);
      c.y(u, v) = static_cast<float>(v);
      c.z(u, v) = (u + v) % 5 == 0 ? NAN : 1.0f + 0.01f * static_cast<float>(u + 100 * v);
      c.intensity(u, v) = static_cast<float>(u * v);
      c.r(u, v) = static_cast<std::uint8_t>(u);
      c.g(u, v) = static_cast<std::uint8_t>(v);
      c.b(u, v) = static_cast<std::uint8_t>(u + v);
      c.label(u, v) = u + 1000 * v;
    }
  }
  return c;
}

}  // namespace

TEST(Downsample, TakesEveryKthPixelOfEveryPlane) {
  const rangeseg::OrganizedCloud in = numbered_cloud(17, 10);
  for (const int k : {1, 2, 3, 4, 17, 40}) {
    const rangeseg::OrganizedCloud out = rangeseg::downsample(in, k);
    // ceil(17 / k) x ceil(10 / k)
    ASSERT_EQ(out.width(), (17 + k - 1) / k) << k;
    ASSERT_EQ(out.height(), (10 + k - 1) / k) << k;
    ASSERT_TRUE(out.has_intensity() && out.has_rgb() && out.has_label());
    for (int v = 0; v < out.height(); ++v) {
      for (int u = 0; u < out.width(); ++u) {
        const int su = k * u, sv = k * v;
        EXPECT_EQ(out.x(u, v), static_cast<float>(su));
        EXPECT_EQ(out.y(u, v), static_cast<float>(sv));
        if (std::isnan(in.z(su, sv))) {
          EXPECT_TRUE(std::isnan(out.z(u, v)));
        } else {
          EXPECT_EQ(out.z(u, v), in.z(su, sv));
        }
        EXPECT_EQ(out.intensity(u, v), in.intensity(su, sv));
        EXPECT_EQ(out.r(u, v), in.r(su, sv));
        EXPECT_EQ(out.g(u, v), in.g(su, sv));
        EXPECT_EQ(out.b(u, v), in.b(su, sv));
        EXPECT_EQ(out.label(u, v), su + 1000 * sv);
      }
    }
  }
}

TEST(Downsample, AbsentPlanesStayAbsent) {
  const rangeseg::OrganizedCloud in(640, 480);
  const rangeseg::OrganizedCloud out = rangeseg::downsample(in, 4);
  EXPECT_EQ(out.width(), 160);
  EXPECT_EQ(out.height(), 120);
  EXPECT_FALSE(out.has_intensity() || out.has_rgb() || out.has_label());
  EXPECT_EQ(out.count_valid(), 0u);
}

TEST(Downsample, RejectsFactorBelowOne) {
  const rangeseg::OrganizedCloud in(4, 4);
  EXPECT_THROW(rangeseg::downsample(in, 0), std::invalid_argument);
  EXPECT_THROW(rangeseg::downsample(in, -2), std::invalid_argument);
  EXPECT_TRUE(rangeseg::downsample(rangeseg::OrganizedCloud{}, 3).empty());
}

TEST(Downsample, AFactorBeyondTheSizeKeepsTheFirstPixel) {
  rangeseg::OrganizedCloud in(1000, 3);
  in.z(0, 0) = 2.0f;
  for (const int factor : {1000, 1001, 2147483000, std::numeric_limits<int>::max()}) {
    const rangeseg::OrganizedCloud out = rangeseg::downsample(in, factor);
    ASSERT_EQ(out.width(), 1) << factor;
    ASSERT_EQ(out.height(), 1) << factor;
    EXPECT_EQ(out.z(0, 0), 2.0f) << factor;
  }
}

TEST(Cloud, PlanesOfOtherSizesAreRejected) {
  // Every function indexes each plane with the cloud's size (z's): a plane of another size, or
  // some of r, g, b without the others, is an error naming the function and the plane, not a
  // read past the plane.
  const auto consistent = [] {
    rangeseg::OrganizedCloud c(32, 24);
    for (int v = 0; v < 24; ++v) {
      for (int u = 0; u < 32; ++u) {
        c.x(u, v) = 0.01f * static_cast<float>(u);
        c.y(u, v) = 0.01f * static_cast<float>(v);
        c.z(u, v) = 1.0f;
      }
    }
    return c;
  };
  const auto expect_rejected = [](const rangeseg::OrganizedCloud& c, const std::string& plane) {
    for (const auto& call : std::vector<std::function<void()>>{
             [&] { rangeseg::require_organized(c, "f"); },
             [&] { static_cast<void>(rangeseg::cloud_stats(c)); },
             [&] { static_cast<void>(rangeseg::downsample(c, 2)); }}) {
      try {
        call();
        ADD_FAILURE() << "no exception for " << plane;
      } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find(plane), std::string::npos) << e.what();
      }
    }
  };
  rangeseg::OrganizedCloud ok = consistent();
  ok.add_intensity();
  ok.add_rgb();
  ok.add_label();
  EXPECT_NO_THROW(rangeseg::require_organized(ok, "f"));
  EXPECT_EQ(rangeseg::cloud_stats(ok).valid, 32u * 24u);
  using Change = std::function<void(rangeseg::OrganizedCloud&)>;
  const std::vector<std::pair<Change, std::string>> changes = {
      {[](auto& c) { c.x.resize(31, 24, 0.0f); }, "x plane is 31x24"},
      {[](auto& c) { c.y.resize(32, 2, 0.0f); }, "y plane is 32x2"},
      {[](auto& c) { c.intensity.resize(10, 10, 0.0f); }, "intensity plane is 10x10"},
      {[](auto& c) { c.label.resize(32, 25, 0); }, "label plane is 32x25"},
      {[](auto& c) { c.r.resize(32, 24, 0); }, "1 of the r, g, b planes"},
      {[](auto& c) {
         c.add_rgb();
         c.b.resize(4, 4, 0);
       },
       "b plane is 4x4"}};
  for (const auto& [change, message] : changes) {
    rangeseg::OrganizedCloud c = consistent();
    change(c);
    expect_rejected(c, message);
  }
}

// Points seen by a sensor at a known pose come back into its frame; invalid points stay.
TEST(SensorFrame, UndoesTheSensorPose) {
  using rangeseg::OrganizedCloud;
  using rangeseg::to_sensor_frame;
  const double c = std::cos(0.3), s = std::sin(0.3);  // half of a 0.6 rad turn about y
  const std::array<double, 7> pose{1.0, -2.0, 0.5, c, 0.0, s, 0.0};
  const double angle = 0.6;
  // p_world = R p_sensor + t, R about y by `angle`.
  const auto to_world = [&](double x, double y, double z) {
    return std::array<double, 3>{std::cos(angle) * x + std::sin(angle) * z + pose[0], y + pose[1],
                                 -std::sin(angle) * x + std::cos(angle) * z + pose[2]};
  };
  OrganizedCloud cloud(3, 2);
  const std::array<std::array<double, 3>, 6> sensor{{{0.1, 0.2, 1.5},
                                                     {-0.3, 0.0, 2.0},
                                                     {0.0, 0.0, 0.7},
                                                     {0.4, -0.1, 3.0},
                                                     {0, 0, 0},
                                                     {1.0, 1.0, 4.0}}};
  for (int i = 0; i < 6; ++i) {
    const auto w = to_world(sensor[i][0], sensor[i][1], sensor[i][2]);
    cloud.x(i % 3, i / 3) = static_cast<float>(w[0]);
    cloud.y(i % 3, i / 3) = static_cast<float>(w[1]);
    cloud.z(i % 3, i / 3) = static_cast<float>(w[2]);
  }
  cloud.x(1, 1) = NAN;  // invalid: stays as it is
  const float kept_z = cloud.z(1, 1);
  to_sensor_frame(cloud, pose);
  for (int i = 0; i < 6; ++i) {
    if (i == 4) continue;
    EXPECT_NEAR(cloud.x(i % 3, i / 3), sensor[i][0], 1e-6) << i;
    EXPECT_NEAR(cloud.y(i % 3, i / 3), sensor[i][1], 1e-6) << i;
    EXPECT_NEAR(cloud.z(i % 3, i / 3), sensor[i][2], 1e-6) << i;
  }
  EXPECT_TRUE(std::isnan(cloud.x(1, 1)));
  EXPECT_EQ(cloud.z(1, 1), kept_z);

  // An unnormalised quaternion is the same rotation.
  OrganizedCloud twice(1, 1);
  twice.x(0, 0) = 1;
  twice.y(0, 0) = 0;
  twice.z(0, 0) = 0;
  to_sensor_frame(twice, {0, 0, 0, 2 * c, 0, 2 * s, 0});
  EXPECT_NEAR(twice.x(0, 0), std::cos(angle), 1e-6);
  EXPECT_NEAR(twice.z(0, 0), std::sin(angle), 1e-6);

  EXPECT_THROW(to_sensor_frame(cloud, {0, 0, 0, 0, 0, 0, 0}), std::invalid_argument);
  EXPECT_THROW(to_sensor_frame(cloud, {NAN, 0, 0, 1, 0, 0, 0}), std::invalid_argument);
}

namespace {

// The memory layout of pcl::PointXYZ (x, y, z and one float of padding, 16 bytes) and of a
// point with more fields after xyz (pcl::PointXYZRGB: 32 bytes).
struct PclLikePoint {
  float x, y, z, pad;
};
struct WidePoint {
  float x, y, z, pad;
  std::array<float, 4> more;
};

template <class Point>
std::vector<Point> interleave(const rangeseg::OrganizedCloud& c) {
  std::vector<Point> points;
  for (int v = 0; v < c.height(); ++v) {
    for (int u = 0; u < c.width(); ++u) {
      Point p{};
      p.x = c.x(u, v);
      p.y = c.y(u, v);
      p.z = c.z(u, v);
      p.pad = -7.0f;  // never read as a coordinate
      points.push_back(p);
    }
  }
  return points;
}

void expect_same_points(const rangeseg::OrganizedCloud& a, const rangeseg::OrganizedCloud& b) {
  ASSERT_EQ(a.width(), b.width());
  ASSERT_EQ(a.height(), b.height());
  for (int v = 0; v < a.height(); ++v) {
    for (int u = 0; u < a.width(); ++u) {
      ASSERT_EQ(a.valid(u, v), b.valid(u, v)) << u << ", " << v;
      if (!a.valid(u, v)) continue;
      ASSERT_EQ(a.x(u, v), b.x(u, v));
      ASSERT_EQ(a.y(u, v), b.y(u, v));
      ASSERT_EQ(a.z(u, v), b.z(u, v));
    }
  }
}

}  // namespace

TEST(Interleaved, CopiesPointsOfEveryStride) {
  const rangeseg::OrganizedCloud in = numbered_cloud(23, 7);
  const auto pcl = interleave<PclLikePoint>(in);
  expect_same_points(rangeseg::interleaved_to_cloud(&pcl[0].x, 23, 7, sizeof(PclLikePoint)), in);
  const auto wide = interleave<WidePoint>(in);
  expect_same_points(rangeseg::interleaved_to_cloud(&wide[0].x, 23, 7, sizeof(WidePoint)), in);
  std::vector<float> packed;
  for (const PclLikePoint& p : pcl) packed.insert(packed.end(), {p.x, p.y, p.z});
  const rangeseg::OrganizedCloud out = rangeseg::interleaved_to_cloud(packed.data(), 23, 7, 12);
  expect_same_points(out, in);
  EXPECT_FALSE(out.has_intensity() || out.has_rgb() || out.has_label());
  // One row is an unorganized cloud.
  const rangeseg::OrganizedCloud row = rangeseg::interleaved_to_cloud(packed.data(), 23 * 7, 1, 12);
  EXPECT_FALSE(row.is_organized());
  EXPECT_EQ(row.z(23 * 2 + 4, 0), in.z(4, 2));
}

TEST(Interleaved, NonFiniteAndOriginPointsAreNoPoints) {
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<float> xyz = {1, 2, 3, NAN, 1, 1, 1, inf, 1, 0, 0, 0, 0, 0, 2, -1, -2, 0.5f};
  const rangeseg::OrganizedCloud c = rangeseg::interleaved_to_cloud(xyz.data(), 3, 2, 12);
  const std::array<bool, 6> valid = {true, false, false, false, true, true};
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(c.valid(i % 3, i / 3), valid[static_cast<std::size_t>(i)]) << i;
    // An invalid point is NaN in all three coordinates, as every stage expects.
    if (!valid[static_cast<std::size_t>(i)]) {
      EXPECT_TRUE(std::isnan(c.x(i % 3, i / 3))) << i;
    }
  }
  EXPECT_EQ(c.z(1, 1), 2.0f);
  EXPECT_EQ(c.count_valid(), 3U);
}

TEST(Interleaved, ReusesTheCloudsBuffersAndDropsItsOptionalPlanes) {
  rangeseg::OrganizedCloud cloud = numbered_cloud(32, 8);
  const float* x = cloud.x.row(0);
  const auto pcl = interleave<PclLikePoint>(numbered_cloud(32, 8));
  rangeseg::interleaved_to_cloud(&pcl[0].x, 32, 8, sizeof(PclLikePoint), cloud);
  EXPECT_EQ(cloud.x.row(0), x);
  EXPECT_FALSE(cloud.has_intensity() || cloud.has_rgb() || cloud.has_label());
}

TEST(Interleaved, RejectsBadArgumentsWithTheirValues) {
  const std::vector<float> xyz(64, 1.0f);
  const auto message = [&](const float* p, int w, int h, std::size_t stride) {
    try {
      (void)rangeseg::interleaved_to_cloud(p, w, h, stride);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  EXPECT_NE(message(nullptr, 2, 2, 12).find("no points"), std::string::npos);
  EXPECT_NE(message(xyz.data(), 0, 2, 12).find("0 x 2"), std::string::npos);
  EXPECT_NE(message(xyz.data(), 2, -1, 12).find("2 x -1"), std::string::npos);
  EXPECT_NE(message(xyz.data(), 2, 2, 8).find("stride 8"), std::string::npos);
  EXPECT_NE(message(xyz.data(), 2, 2, 14).find("stride 14"), std::string::npos);
  EXPECT_EQ(message(xyz.data(), 2, 2, 16), "no exception");
}

namespace {

// A wall 4 m wide and 3 m high, 3 m in front of the origin, moved by `shift` along x: its
// bounding box's diagonal is 5 m.
rangeseg::OrganizedCloud wall(double shift) {
  rangeseg::OrganizedCloud c(41, 31);
  for (int v = 0; v < 31; ++v) {
    for (int u = 0; u < 41; ++u) {
      c.x(u, v) = static_cast<float>(-2.0 + 0.1 * u + shift);
      c.y(u, v) = static_cast<float>(-1.5 + 0.1 * v);
      c.z(u, v) = 3.0F;
    }
  }
  return c;
}

}  // namespace

// The rule: 3 sigma at the points' median distance from the origin above a tenth of their
// extent. A depth camera's model fits the wall in front of it, not the same wall 30 m away (a
// map's frame); a constant sigma fits both.
TEST(NoiseScale, NamesANoiseModelThatCannotTellTheSurfacesApart) {
  const rangeseg::SensorNoise kinect{.a = 0.0012, .b = 0.0019, .z0 = 0.4};
  EXPECT_EQ(rangeseg::noise_scale_problem(wall(0), kinect), "");
  const std::string far = rangeseg::noise_scale_problem(wall(30), kinect);
  // The median point lies sqrt(30^2 + 3^2) = 30.15 m away: 0.0012 + 0.0019 * 29.75^2 = 1.68 m.
  EXPECT_NE(far.find("sigma is 1.68 m"), std::string::npos) << far;
  EXPECT_NE(far.find("(5 m)"), std::string::npos) << far;
  EXPECT_EQ(rangeseg::noise_scale_problem(wall(30), {.a = 0.015, .b = 0, .z0 = 0}), "");
  // At the bound: 3 sigma = 0.5 m.
  EXPECT_EQ(rangeseg::noise_scale_problem(wall(30), {.a = 0.16, .b = 0, .z0 = 0}), "");
  EXPECT_NE(rangeseg::noise_scale_problem(wall(30), {.a = 0.17, .b = 0, .z0 = 0}), "");
  EXPECT_EQ(rangeseg::noise_scale_problem(rangeseg::OrganizedCloud(3, 2), kinect), "")
      << "no points, no problem";
}

// A metre-scale cloud 1 km from the origin is named as far from it, not as millimetres; a
// millimetre-scale room (as wide as it is far) as millimetres.
TEST(NoiseScale, ACloudFarFromTheOriginIsNotTakenForMillimetres) {
  const std::string far = rangeseg::cloud_scale_problem(wall(1000));
  EXPECT_NE(far.find("from the origin and span 5 m"), std::string::npos) << far;
  EXPECT_EQ(far.find("millimetres"), std::string::npos) << far;
  rangeseg::OrganizedCloud millimetres = wall(0);
  for (int v = 0; v < millimetres.height(); ++v) {
    for (int u = 0; u < millimetres.width(); ++u) {
      millimetres.x(u, v) *= 1000;
      millimetres.y(u, v) *= 1000;
      millimetres.z(u, v) *= 1000;
    }
  }
  EXPECT_NE(rangeseg::cloud_scale_problem(millimetres).find("millimetres"), std::string::npos);
}
