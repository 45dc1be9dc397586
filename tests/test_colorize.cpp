#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <set>
#include <stdexcept>
#include <vector>

#include "rangeseg/colorize.hpp"
#include "rangeseg/io/png.hpp"
#include "test_util.hpp"

using namespace rangeseg;

namespace {

std::array<std::uint8_t, 3> at(const RgbImage& img, int x, int y) {
  const std::uint8_t* p = img.pixel(x, y);
  return {p[0], p[1], p[2]};
}

int colour_distance(std::array<std::uint8_t, 3> a, std::array<std::uint8_t, 3> b) {
  int d = 0;
  for (int k = 0; k < 3; ++k) d += std::abs(int(a[k]) - int(b[k]));
  return d;
}

}  // namespace

TEST(Colorize, LabelColours) {
  LabelImage labels(51, 1, 0);
  for (int i = 0; i < 51; ++i) labels(i, 0) = i;
  const RgbImage img = colorize_labels(labels);
  ASSERT_EQ(img.width, 51);
  ASSERT_EQ(img.rgb.size(), 51u * 3);
  EXPECT_EQ(at(img, 0, 0), kNoLabelColour);
  EXPECT_LT(int(kNoLabelColour[0]) + kNoLabelColour[1] + kNoLabelColour[2], 3 * 64);
  std::set<std::array<std::uint8_t, 3>> seen;
  int closest = 1 << 30;
  for (int i = 1; i <= 50; ++i) {
    const auto c = at(img, i, 0);
    EXPECT_EQ(c, label_colour(i));
    EXPECT_GT(colour_distance(c, kNoLabelColour), 120) << "label " << i << " looks like none";
    seen.insert(c);
    for (int j = 1; j < i; ++j) closest = std::min(closest, colour_distance(c, label_colour(j)));
  }
  EXPECT_EQ(seen.size(), 50u);
  EXPECT_GE(closest, 40);  // L1 distance in 0..765: no two of the first 50 are near-identical
  // Neighbouring labels are far apart.
  for (int i = 1; i < 50; ++i) {
    EXPECT_GT(colour_distance(label_colour(i), label_colour(i + 1)), 100);
  }
}

TEST(Colorize, LabelsShadedByDepth) {
  LabelImage labels(6, 6, 3);
  OrganizedCloud cloud(6, 6);
  for (int v = 0; v < 6; ++v) {
    for (int u = 0; u < 6; ++u) {
      // Left half faces the camera, right half is steeply tilted.
      cloud.x(u, v) = 0.01f * (u - 3);
      cloud.y(u, v) = 0.01f * (v - 3);
      cloud.z(u, v) = u < 3 ? 1.0f : 1.0f + 0.05f * (u - 3);
    }
  }
  cloud.z(0, 0) = NAN;
  const RgbImage img = colorize_labels(labels, &cloud);
  const auto base = label_colour(3);
  const auto facing = at(img, 1, 3);
  const auto tilted = at(img, 4, 3);
  int sum_facing = 0, sum_tilted = 0, sum_base = 0;
  for (int k = 0; k < 3; ++k) sum_facing += facing[k], sum_tilted += tilted[k], sum_base += base[k];
  EXPECT_GT(sum_facing, sum_tilted);
  EXPECT_LE(sum_facing, sum_base);
  EXPECT_GT(sum_facing, sum_base * 9 / 10);
  EXPECT_EQ(at(img, 0, 0), (std::array<std::uint8_t, 3>{0, 0, 0}));  // no point: black
  OrganizedCloud small(5, 6);
  EXPECT_THROW(colorize_labels(labels, &small), std::invalid_argument);
}

// The shading factor's rules where neighbours are missing: a point without a valid neighbour
// along its row (or its column) gets 0.8, a frontal point 1, and the colour of every label in a
// row of alternating labels is its own (the colour of a run is computed once).
TEST(Colorize, LabelsShadedAtHolesAndBorders) {
  const auto scaled = [](std::array<std::uint8_t, 3> c, double factor) {
    for (auto& v : c) v = static_cast<std::uint8_t>(std::lround(v * factor));
    return c;
  };
  OrganizedCloud cloud(5, 3);
  LabelImage labels(5, 3, 7);
  for (int v = 0; v < 3; ++v) {
    for (int u = 0; u < 5; ++u) {
      cloud.x(u, v) = 0.0f;  // every ray of this toy camera along z: a frontal plane
      cloud.y(u, v) = 0.0f;
      cloud.z(u, v) = 2.0f;
    }
  }
  // (1, 1) and (3, 1) missing: (2, 1) has no row neighbour; (2, 0) keeps row and column ones.
  cloud.z(1, 1) = cloud.z(3, 1) = NAN;
  RgbImage img = colorize_labels(labels, &cloud);
  const auto base = label_colour(7);
  EXPECT_EQ(at(img, 2, 1), scaled(base, 0.8));
  EXPECT_EQ(at(img, 1, 1), (std::array<std::uint8_t, 3>{0, 0, 0}));
  // Frontal points: x and y differences of 0 give a zero normal here, hence also 0.8 ...
  EXPECT_EQ(at(img, 2, 0), scaled(base, 0.8));
  // ... and with real rays the normal faces the camera: factor 1.
  for (int v = 0; v < 3; ++v) {
    for (int u = 0; u < 5; ++u) {
      cloud.x(u, v) = 0.01f * static_cast<float>(u - 2);
      cloud.y(u, v) = 0.01f * static_cast<float>(v - 1);
      cloud.z(u, v) = 2.0f;
    }
  }
  img = colorize_labels(labels, &cloud);
  EXPECT_EQ(at(img, 2, 1), base);
  // One row: no column neighbour anywhere.
  OrganizedCloud row(3, 1);
  LabelImage row_labels(3, 1, 7);
  for (int u = 0; u < 3; ++u) row.x(u, 0) = 0.01f * u, row.y(u, 0) = 0.0f, row.z(u, 0) = 1.0f;
  EXPECT_EQ(at(colorize_labels(row_labels, &row), 1, 0), scaled(base, 0.8));

  LabelImage alternating(6, 1);
  const std::int32_t values[6] = {1, 2, 1, -1, 0, 2};
  for (int u = 0; u < 6; ++u) alternating(u, 0) = values[u];
  const RgbImage flat = colorize_labels(alternating);
  for (int u = 0; u < 6; ++u) {
    EXPECT_EQ(at(flat, u, 0), values[u] > 0 ? label_colour(values[u]) : kNoLabelColour) << u;
  }
}

TEST(Colorize, Normals) {
  FloatPlane nx(3, 1), ny(3, 1), nz(3, 1);
  nx(0, 0) = 0, ny(0, 0) = 0, nz(0, 0) = -1;
  nx(1, 0) = 1, ny(1, 0) = -1, nz(1, 0) = 0;
  nx(2, 0) = NAN, ny(2, 0) = 0, nz(2, 0) = 1;
  const RgbImage img = colorize_normals(nx.view(), ny.view(), nz.view());
  const auto c0 = at(img, 0, 0);
  EXPECT_NEAR(c0[0], 128, 1);
  EXPECT_NEAR(c0[1], 128, 1);
  EXPECT_EQ(c0[2], 0);
  EXPECT_EQ(at(img, 1, 0), (std::array<std::uint8_t, 3>{255, 0, 128}));
  EXPECT_EQ(at(img, 2, 0), (std::array<std::uint8_t, 3>{0, 0, 0}));
  FloatPlane other(2, 1);
  EXPECT_THROW(colorize_normals(nx.view(), other.view(), nz.view()), std::invalid_argument);
}

TEST(Colorize, ScalarMapIsContinuousAndNanIsBlack) {
  // The map never goes black (reserved for missing data) and has no jumps.
  for (int i = 0; i <= 1000; ++i) {
    const auto c = colour_map(i / 1000.0f);
    EXPECT_GT(int(c[0]) + c[1] + c[2], 60) << i;
    if (i > 0) {
      EXPECT_LE(colour_distance(c, colour_map((i - 1) / 1000.0f)), 12) << i;
    }
  }
  EXPECT_NE(colour_map(0), colour_map(1));
  FloatPlane v(4, 1);
  v(0, 0) = 0, v(1, 0) = 10, v(2, 0) = NAN, v(3, 0) = -INFINITY;
  const RgbImage img = colorize_scalar(v.view(), 0, 10);
  EXPECT_EQ(at(img, 0, 0), colour_map(0));
  EXPECT_EQ(at(img, 1, 0), colour_map(1));
  EXPECT_EQ(at(img, 2, 0), (std::array<std::uint8_t, 3>{0, 0, 0}));
  EXPECT_EQ(at(img, 3, 0), (std::array<std::uint8_t, 3>{0, 0, 0}));
  EXPECT_THROW(colorize_scalar(v.view(), 1, 1), std::invalid_argument);
  EXPECT_THROW(colorize_scalar(v.view(), NAN, 1), std::invalid_argument);
}

TEST(Colorize, AutoRangeIgnoresOutliers) {
  FloatPlane v(200, 1);
  for (int i = 0; i < 200; ++i) v(i, 0) = static_cast<float>(i);
  v(0, 0) = -1e9f;  // single outliers must not squeeze the range
  v(199, 0) = 1e9f;
  v(100, 0) = NAN;
  const RgbImage img = colorize_scalar_auto(v.view());
  // 1st / 99th percentiles are ~2 and ~197: pixel 50 sits about a quarter along the map.
  const auto c = at(img, 50, 0);
  int best = 0;
  for (int i = 1; i <= 100; ++i) {
    if (colour_distance(colour_map(i / 100.0f), c) <
        colour_distance(colour_map(best / 100.0f), c)) {
      best = i;
    }
  }
  EXPECT_NEAR(best, 25, 3);
  EXPECT_EQ(at(img, 100, 0), (std::array<std::uint8_t, 3>{0, 0, 0}));
  FloatPlane nan(3, 2, NAN);
  const RgbImage black = colorize_scalar_auto(nan.view());
  EXPECT_EQ(black.rgb, std::vector<std::uint8_t>(18, 0));

  OrganizedCloud cloud(3, 2);
  cloud.x(1, 1) = 0, cloud.y(1, 1) = 0, cloud.z(1, 1) = 2;
  const RgbImage depth = colorize_depth(cloud);
  EXPECT_EQ(at(depth, 0, 0), (std::array<std::uint8_t, 3>{0, 0, 0}));
  EXPECT_NE(at(depth, 1, 1), (std::array<std::uint8_t, 3>{0, 0, 0}));
}

TEST(Colorize, PolylineIsBresenhamAndClipped) {
  RgbImage img = RgbImage::black(10, 8);
  const std::array<std::uint8_t, 3> red = {255, 0, 0};
  draw_polyline(img, {{1, 1}, {6, 1}, {6, 5}, {1, 5}}, red, true);
  int lit = 0;
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 10; ++x) {
      const bool on_rectangle =
          ((y == 1 || y == 5) && x >= 1 && x <= 6) || ((x == 1 || x == 6) && y >= 1 && y <= 5);
      EXPECT_EQ(at(img, x, y) == red, on_rectangle) << x << "," << y;
      lit += at(img, x, y) == red;
    }
  }
  EXPECT_EQ(lit, 18);

  // A diagonal: exactly one pixel per column, each within half a pixel of the line.
  RgbImage diag = RgbImage::black(10, 10);
  draw_polyline(diag, {{0, 0}, {9, 4}}, red, false);
  for (int x = 0; x < 10; ++x) {
    int count = 0;
    for (int y = 0; y < 10; ++y) {
      if (at(diag, x, y) == red) {
        ++count;
        EXPECT_LE(std::abs(y - x * 4.0 / 9.0), 0.5 + 1e-9);
      }
    }
    EXPECT_EQ(count, 1) << x;
  }
  // Far outside, NaN and a single point: no crash, clipped.
  RgbImage clip = RgbImage::black(4, 4);
  draw_polyline(clip, {{-1e30f, 2}, {1e30f, 2}, {NAN, 1}, {2, 1e9f}}, red, true);
  draw_polyline(clip, {{3, 3}}, red, false);
  EXPECT_EQ(at(clip, 3, 3), red);
}

TEST(Colorize, RgbPngRoundTripThroughDisk) {
  const auto dir = test::scratch_dir("colorize_png");
  LabelImage labels(16, 9, 0);
  for (int y = 0; y < 9; ++y) {
    for (int x = 0; x < 16; ++x) labels(x, y) = (x / 4) + 3 * (y / 3);
  }
  const RgbImage img = colorize_labels(labels);
  const std::string path = (dir / "labels.png").string();
  io::write_rgb_png(path, img);
  EXPECT_GT(std::filesystem::file_size(path), 60u);
}
