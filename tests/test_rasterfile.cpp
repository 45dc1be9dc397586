#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "rangeseg/io/file.hpp"
#include "rangeseg/io/rasterfile.hpp"
#include "test_util.hpp"

using namespace rangeseg;
using rangeseg::test::expect_runtime_error_with;

namespace {

void put32(std::vector<std::uint8_t>& b, int field, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) b[4 * field + k] = static_cast<std::uint8_t>(v >> (24 - 8 * k));
}

BytePlane pattern(int w, int h) {
  BytePlane p(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) p(x, y) = static_cast<std::uint8_t>(x * 31 + y * 17 + 1);
  }
  return p;
}

}  // namespace

TEST(Rasterfile, RoundTripOddWidthUsesEvenRowPadding) {
  const auto dir = test::scratch_dir("raster_round");
  const BytePlane img = pattern(7, 5);
  const std::vector<std::uint8_t> bytes = io::encode_rasterfile(img.view());
  ASSERT_EQ(bytes.size(), 32u + 8 * 5);  // rows padded from 7 to 8 bytes
  EXPECT_EQ(bytes[0], 0x59);
  EXPECT_EQ(bytes[3], 0x95);
  const std::string path = (dir / "x.ms-seg").string();
  io::write_rasterfile(path, img.view());
  const BytePlane back = io::read_rasterfile(path);
  ASSERT_EQ(back.width(), 7);
  ASSERT_EQ(back.height(), 5);
  for (int y = 0; y < 5; ++y) {
    for (int x = 0; x < 7; ++x) ASSERT_EQ(back(x, y), img(x, y));
  }

  // A type-0 file with length 0 and a colour map before the pixels.
  std::vector<std::uint8_t> old(32 + 6);
  put32(old, 0, 0x59a66a95);
  put32(old, 1, 2);
  put32(old, 2, 1);
  put32(old, 3, 8);
  put32(old, 7, 4);  // 4 bytes of map
  old.insert(old.begin() + 32, {9, 9, 9, 9});
  old.resize(32 + 4 + 2);
  old[36] = 42;
  old[37] = 43;
  const BytePlane o = io::decode_rasterfile(old.data(), old.size(), "old.ras");
  ASSERT_EQ(o.width(), 2);
  EXPECT_EQ(o(0, 0), 42);
  EXPECT_EQ(o(1, 0), 43);
}

TEST(Rasterfile, BadHeadersThrowNamingTheFile) {
  const BytePlane img = pattern(6, 4);
  const std::vector<std::uint8_t> good = io::encode_rasterfile(img.view());
  const auto expect_bad = [&](std::vector<std::uint8_t> b, const std::string& needle) {
    expect_runtime_error_with([&] { io::decode_rasterfile(b.data(), b.size(), "bad.ras"); },
                              "bad.ras");
    expect_runtime_error_with([&] { io::decode_rasterfile(b.data(), b.size(), "bad.ras"); },
                              needle);
  };
  auto b = good;
  put32(b, 0, 0x12345678);
  expect_bad(b, "magic");
  b = good;
  put32(b, 3, 24);
  expect_bad(b, "depth");
  b = good;
  put32(b, 5, 2);
  expect_bad(b, "type");
  b = good;
  put32(b, 4, 1000);  // length lies
  expect_bad(b, "length");
  b = good;
  put32(b, 2, 400);  // height lies, length field too
  put32(b, 4, 400 * 6);
  expect_bad(b, "truncated");
  b = good;
  put32(b, 7, 100000);  // colour map longer than the file
  expect_bad(b, "truncated");
  b = good;
  put32(b, 1, 0x10000);
  put32(b, 2, 0x10000);
  put32(b, 4, 0);
  expect_bad(b, "2^28");
  expect_bad(std::vector<std::uint8_t>(good.begin(), good.begin() + 20), "header");
  expect_bad(std::vector<std::uint8_t>(good.begin(), good.end() - 1), "truncated");
  expect_runtime_error_with([] { io::read_rasterfile("/nonexistent/abw.test.99.range"); },
                            "abw.test.99.range");
  BytePlane empty;
  EXPECT_THROW(io::write_rasterfile("/tmp/never.ras", empty.view()), std::invalid_argument);
}

TEST(Rasterfile, AbwCalibrationChoice) {
  const auto second = io::AbwCalibration::for_image("/data/abw.test.19.range");
  EXPECT_EQ(second.offset, 785.410786);
  EXPECT_EQ(second.scal, 0.773545);
  EXPECT_EQ(second.f, -1610.981722);
  EXPECT_EQ(second.c, 1.4508);
  EXPECT_EQ(io::AbwCalibration::for_image("abw.test.0.range").offset, 785.410786);
  EXPECT_EQ(io::AbwCalibration::for_image("abw.test.29").offset, 785.410786);
  // Prefix look-alikes keep the default.
  EXPECT_EQ(io::AbwCalibration::for_image("abw.test.1.range").offset, 771.016866);
  EXPECT_EQ(io::AbwCalibration::for_image("abw.test.2.range").offset, 771.016866);
  EXPECT_EQ(io::AbwCalibration::for_image("abw.test.190.range").offset, 771.016866);
  EXPECT_EQ(io::AbwCalibration::for_image("x/abw.test.00.range").offset, 785.410786);
  EXPECT_EQ(io::AbwCalibration::for_image("abw.test.0/abw.test.5.range").offset, 771.016866);
}

TEST(Rasterfile, AbwConversionFollowsTheSegCompFormula) {
  BytePlane range(512, 512, 0);
  range(255, 255) = 100;
  range(10, 300) = 200;
  const io::AbwCalibration cal;
  const OrganizedCloud cloud = io::abw_range_to_cloud(range.view(), cal);
  EXPECT_FALSE(cloud.valid(0, 0));
  const double d0 = 100 / cal.scal + cal.offset;
  EXPECT_NEAR(cloud.x(255, 255), 0.0, 1e-9);
  EXPECT_NEAR(cloud.y(255, 255), 0.0, 1e-9);
  EXPECT_NEAR(cloud.z(255, 255), 0.001 * d0, 1e-6);
  const double d1 = 200 / cal.scal + cal.offset;
  const double X = (10 - 255) * d1 / std::abs(cal.f);
  const double Y = (255 - 300) / cal.c * d1 / std::abs(cal.f);
  const double Z = (255 - 200) / cal.scal;
  EXPECT_NEAR(cloud.x(10, 300), 0.001 * X, 1e-6);
  EXPECT_NEAR(cloud.y(10, 300), -0.001 * Y, 1e-6);
  EXPECT_NEAR(cloud.z(10, 300), 0.001 * (255 / cal.scal + cal.offset - Z), 1e-6);
  EXPECT_GT(cloud.y(10, 300), 0.0f);  // lower rows are further down (y down)
}

// Planar ground-truth regions must come out planar: fit a plane (PCA in double) to each region
// >= 10 and compare the RMS residual with the ~0.5 scanner units (~0.5 mm) SegComp states.
TEST(Rasterfile, AbwGroundTruthRegionsArePlanar) {
  RANGESEG_REQUIRE_DATA("segcomp_abw/abw.test.0.range");
  const OrganizedCloud cloud = io::read_abw_range(data_file.string());
  const LabelImage gt =
      io::read_segcomp_gt((test::shared_data_dir() / "segcomp_abw/abw.test.0.gt-seg").string());
  ASSERT_EQ(cloud.width(), 512);
  ASSERT_EQ(cloud.height(), 512);
  ASSERT_EQ(gt.width(), 512);
  std::size_t valid = cloud.count_valid();
  EXPECT_GT(valid, 512u * 512u / 4);

  std::map<int, std::vector<Eigen::Vector3d>> regions;
  for (int v = 0; v < 512; ++v) {
    for (int u = 0; u < 512; ++u) {
      if (gt(u, v) >= 10 && cloud.valid(u, v)) {
        regions[gt(u, v)].emplace_back(cloud.x(u, v), cloud.y(u, v), cloud.z(u, v));
      }
    }
  }
  ASSERT_GE(regions.size(), 5u);
  std::vector<double> rms_mm;
  for (const auto& [label, points] : regions) {
    if (points.size() < 200) continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& p : points) mean += p;
    mean /= static_cast<double>(points.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& p : points) cov += (p - mean) * (p - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    const double rms = std::sqrt(std::max(eig.eigenvalues()(0), 0.0) / points.size());
    rms_mm.push_back(rms * 1000.0);
  }
  ASSERT_GE(rms_mm.size(), 5u);
  std::sort(rms_mm.begin(), rms_mm.end());
  const double median = rms_mm[rms_mm.size() / 2];
  RecordProperty("median_plane_rms_mm", std::to_string(median));
  // Measured 0.46 mm (tools: this test). Mapping pixels orthographically as (c, r, R) mm instead
  // of through the perspective formula gives 0.64 mm, so 0.6 separates right from wrong.
  EXPECT_LT(median, 0.6) << "median plane RMS " << median << " mm over " << rms_mm.size()
                         << " regions";
  EXPECT_GT(median, 0.05);  // quantised 8-bit ranges cannot be noise-free
}
