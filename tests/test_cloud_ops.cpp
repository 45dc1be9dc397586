// downsample: every k-th pixel, with the optional planes, against an index formula.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "rangeseg/cloud.hpp"

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
