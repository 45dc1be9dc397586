// Plain-text point clouds: Open3D's .xyz, .xyzn, .xyzrgb and .pts, and malformed lines.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "rangeseg/io/cloud_file.hpp"
#include "rangeseg/io/ply.hpp"
#include "rangeseg/io/xyz.hpp"
#include "test_util.hpp"

namespace rangeseg {
namespace {

OrganizedCloud decode(const std::string& text, io::TextCloudFormat format) {
  const std::vector<std::uint8_t> bytes(text.begin(), text.end());
  return io::decode_text_cloud(bytes.data(), bytes.size(), "t.xyz", format);
}

TEST(TextCloud, XyzWithCommentsCommasAndWindowsLineEnds) {
  const OrganizedCloud c =
      decode("# exported\r\n+0.5 -1 +2\r\n\r\n// more\r\n1e-3,2,3.25\r\nnan nan nan\r\n4\t5\t6",
             io::TextCloudFormat::xyz);
  ASSERT_EQ(c.width(), 4);
  ASSERT_EQ(c.height(), 1);
  EXPECT_EQ(c.x(0, 0), 0.5f);
  EXPECT_EQ(c.y(0, 0), -1.0f);
  EXPECT_EQ(c.x(1, 0), 1e-3f);
  EXPECT_EQ(c.z(1, 0), 3.25f);
  EXPECT_FALSE(c.valid(2, 0));
  EXPECT_EQ(c.z(3, 0), 6.0f);
  EXPECT_FALSE(c.has_rgb() || c.has_intensity());
}

TEST(TextCloud, XyzrgbColoursAreZeroToOneAndNormalsAreSkipped) {
  const OrganizedCloud c = decode("1 2 3 1 0.5 0\n4 5 6 0 0 0.2\n", io::TextCloudFormat::xyzrgb);
  ASSERT_TRUE(c.has_rgb());
  EXPECT_EQ(c.r(0, 0), 255);
  EXPECT_EQ(c.g(0, 0), 128);
  EXPECT_EQ(c.b(1, 0), 51);
  const OrganizedCloud n = decode("1 2 3 0 0 -1\n", io::TextCloudFormat::xyzn);
  EXPECT_EQ(n.z(0, 0), 3.0f);
  EXPECT_FALSE(n.has_rgb());
}

TEST(TextCloud, PtsWithCountIntensityAndColours) {
  const OrganizedCloud c =
      decode("2\n1 2 3 -1200 10 20 30\n4 5 6 7 255 0 1\n", io::TextCloudFormat::pts);
  ASSERT_EQ(c.width(), 2);
  ASSERT_TRUE(c.has_intensity() && c.has_rgb());
  EXPECT_EQ(c.intensity(0, 0), -1200.0f);
  EXPECT_EQ(c.g(0, 0), 20);
  EXPECT_EQ(c.r(1, 0), 255);
  // A constant intensity (Open3D writes 0) is no measurement.
  EXPECT_FALSE(decode("1 2 3 0 9 9 9\n4 5 6 0 1 1 1\n", io::TextCloudFormat::pts).has_intensity());
  // A UTF-8 byte order mark before the first line.
  EXPECT_EQ(decode("\xEF\xBB\xBF"
                   "1 2 3\n",
                   io::TextCloudFormat::xyz)
                .x(0, 0),
            1.0f);
}

TEST(TextCloud, FormatFromTheExtension) {
  EXPECT_EQ(io::text_cloud_format(".XYZ"), io::TextCloudFormat::xyz);
  EXPECT_EQ(io::text_cloud_format(".xyzrgb"), io::TextCloudFormat::xyzrgb);
  EXPECT_THROW(io::text_cloud_format(".txt"), std::invalid_argument);
  EXPECT_TRUE(io::is_text_cloud_extension(".PTS"));
  EXPECT_FALSE(io::is_text_cloud_extension(".txt"));
}

TEST(TextCloud, MalformedLinesNameTheFileLineAndProblem) {
  struct Bad {
    std::string text;
    io::TextCloudFormat format;
    const char* message;
  };
  using F = io::TextCloudFormat;
  const std::vector<Bad> cases = {
      {"1 2 3\n4 five 6\n", F::xyz, "line 2: expected a number, got \"five\""},
      {"1 2\n", F::xyz, "line 1: 2 numbers, .xyz (x y z) needs at least 3"},
      {"7\n", F::xyz, "line 1: 1 number, .xyz"},
      {"1 2 3\n4 5 6 7\n", F::xyz, "line 2: 4 numbers where the first point has 3"},
      {"1 2 3 0 0 1\n", F::xyz, ""},  // extra columns of a .xyz are ignored
      {"1 2 3\n", F::xyzn, "needs at least 6"},
      {"1 2 3 128 0 0\n", F::xyzrgb, "outside 0..1"},
      {"1 2 3 0 300 0\n", F::pts, "outside 0..255"},
      {"1 2 3 4 5\n", F::pts, "a .pts point is"},
      {"3\n1 2 3\n4 5 6\n", F::pts, "the first line gives 3 points, the file has 2"},
      {"-2\n1 2 3\n", F::pts, "is no count"},
      {"", F::xyz, "no point (an empty file)"},
      {"# x y z\n\n", F::xyz, "no point (only comments and blank lines)"},
  };
  for (const Bad& c : cases) {
    if (*c.message == 0) {
      EXPECT_NO_THROW(decode(c.text, c.format)) << c.text;
      continue;
    }
    try {
      decode(c.text, c.format);
      ADD_FAILURE() << c.text << ": no error";
    } catch (const std::runtime_error& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("'t.xyz'"), std::string::npos) << message;
      EXPECT_NE(message.find(c.message), std::string::npos) << c.text << ": " << message;
    }
  }
}

TEST(TextCloud, ReadsAFileByItsExtension) {
  const auto dir = test::scratch_dir("text_cloud");
  std::ofstream(dir / "a.pts") << "2\n0 0 1 5\n0 0 2 6\n";
  const OrganizedCloud c = io::read_text_cloud((dir / "a.pts").string());
  EXPECT_EQ(c.width(), 2);
  EXPECT_TRUE(c.has_intensity());
  EXPECT_THROW(io::read_text_cloud((dir / "a.txt").string()), std::runtime_error);
}

// read_cloud picks the reader by the extension.
TEST(TextCloud, ReadCloudPicksTheReader) {
  const auto dir = test::scratch_dir("read_cloud");
  std::ofstream(dir / "a.XYZ") << "1 2 3\n4 5 6\n";
  EXPECT_EQ(io::read_cloud((dir / "a.XYZ").string()).width(), 2);
  OrganizedCloud grid(2, 2);
  grid.x(1, 1) = 0, grid.y(1, 1) = 0, grid.z(1, 1) = 1;
  io::write_ply_cloud((dir / "b.ply").string(), grid);
  const OrganizedCloud back = io::read_cloud((dir / "b.ply").string());
  EXPECT_EQ(back.height(), 2);
  EXPECT_TRUE(back.valid(1, 1));
  for (const char* file : {"c.png", "d.obj"}) {
    try {
      io::read_cloud((dir / file).string());
      ADD_FAILURE() << file << ": no error";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace rangeseg
