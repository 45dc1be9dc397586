// PLY point clouds: the writer's round trip, files as other tools write them (ASCII, big-endian,
// PCL's range_grid and camera element, Stanford's range grids), and malformed files.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "rangeseg/io/ply.hpp"
#include "test_util.hpp"

namespace rangeseg {
namespace {

std::vector<std::uint8_t> bytes_of(const std::string& text) { return {text.begin(), text.end()}; }

OrganizedCloud decode(const std::string& text, io::PlyCloudInfo* info = nullptr) {
  const std::vector<std::uint8_t> bytes = bytes_of(text);
  return io::decode_ply_cloud(bytes.data(), bytes.size(), "t.ply", info);
}

// Appends a value in the given byte order.
template <class T>
void put(std::string& out, T value, bool big_endian) {
  char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  if (big_endian == (std::endian::native == std::endian::little)) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

/// A 7 x 5 cloud with holes, colour, intensity and labels (negative ones too).
OrganizedCloud sample_cloud() {
  OrganizedCloud c(7, 5);
  c.add_rgb(), c.add_intensity(), c.add_label();
  for (int v = 0; v < 5; ++v) {
    for (int u = 0; u < 7; ++u) {
      if ((u + 2 * v) % 4 == 1) continue;  // a hole
      c.x(u, v) = 0.1f * u - 0.3f, c.y(u, v) = 0.07f * v, c.z(u, v) = 1.0f + 0.013f * (u * v);
      c.r(u, v) = static_cast<std::uint8_t>(30 * u), c.g(u, v) = static_cast<std::uint8_t>(40 * v);
      c.b(u, v) = 7, c.intensity(u, v) = 0.5f * u, c.label(u, v) = u - 3;
    }
  }
  c.x(6, 4) = INFINITY;  // invalid: comes back as a hole
  return c;
}

void expect_same_valid_points(const OrganizedCloud& a, const OrganizedCloud& b) {
  ASSERT_EQ(a.width(), b.width());
  ASSERT_EQ(a.height(), b.height());
  for (int v = 0; v < a.height(); ++v) {
    for (int u = 0; u < a.width(); ++u) {
      ASSERT_EQ(a.valid(u, v), b.valid(u, v)) << u << "," << v;
      if (!a.valid(u, v)) {
        EXPECT_TRUE(std::isnan(b.x(u, v)) && std::isnan(b.z(u, v))) << u << "," << v;
        continue;
      }
      EXPECT_EQ(std::bit_cast<std::uint32_t>(a.x(u, v)), std::bit_cast<std::uint32_t>(b.x(u, v)));
      EXPECT_EQ(std::bit_cast<std::uint32_t>(a.y(u, v)), std::bit_cast<std::uint32_t>(b.y(u, v)));
      EXPECT_EQ(std::bit_cast<std::uint32_t>(a.z(u, v)), std::bit_cast<std::uint32_t>(b.z(u, v)));
      EXPECT_EQ(a.r(u, v), b.r(u, v));
      EXPECT_EQ(a.g(u, v), b.g(u, v));
      EXPECT_EQ(a.b(u, v), b.b(u, v));
      EXPECT_EQ(a.intensity(u, v), b.intensity(u, v));
      EXPECT_EQ(a.label(u, v), b.label(u, v));
    }
  }
}

TEST(PlyCloud, OrganizedCloudRoundTripsThroughItsRangeGrid) {
  const OrganizedCloud cloud = sample_cloud();
  const auto path = (test::scratch_dir("ply_cloud") / "organized.ply").string();
  io::write_ply_cloud(path, cloud);
  io::PlyCloudInfo info;
  const OrganizedCloud back = io::read_ply_cloud(path, &info);
  EXPECT_EQ(info.format, "binary_little_endian");
  EXPECT_EQ(info.grid, "range_grid");
  EXPECT_EQ(info.vertices, cloud.count_valid());
  EXPECT_EQ(info.fields_summary, "x y z intensity red green blue label");
  EXPECT_EQ(info.width, 7);
  EXPECT_EQ(info.height, 5);
  expect_same_valid_points(cloud, back);
}

TEST(PlyCloud, ViewpointRoundTripsThroughPclsCameraElement) {
  const double n = std::sqrt(0.9 * 0.9 + 0.1 * 0.1 + 0.3 * 0.3 + 0.2 * 0.2);
  const std::array<double, 7> pose{0.1, -0.2, 0.3, 0.9 / n, 0.1 / n, 0.3 / n, -0.2 / n};
  for (const bool organized : {true, false}) {
    const OrganizedCloud cloud = organized ? sample_cloud() : OrganizedCloud(3, 1);
    const std::vector<std::uint8_t> bytes = io::encode_ply_cloud(cloud, pose);
    io::PlyCloudInfo info;
    const OrganizedCloud back = io::decode_ply_cloud(bytes.data(), bytes.size(), "v.ply", &info);
    for (int k = 0; k < 7; ++k) EXPECT_NEAR(info.viewpoint[k], pose[k], 1e-6) << k;
    // Still a range grid, not the camera's viewport, for an organized cloud.
    EXPECT_EQ(info.grid, organized ? "range_grid" : "");
    EXPECT_EQ(back.width(), cloud.width());
  }
  // Without one, no camera element.
  const std::vector<std::uint8_t> plain = io::encode_ply_cloud(sample_cloud());
  EXPECT_EQ(std::string(plain.begin(), plain.end()).find("element camera"), std::string::npos);
  EXPECT_THROW(io::encode_ply_cloud(sample_cloud(), {0, 0, 0, 0, 0, 0, 0}), std::invalid_argument);
  EXPECT_THROW(io::encode_ply_cloud(sample_cloud(), {NAN, 0, 0, 1, 0, 0, 0}),
               std::invalid_argument);
}

TEST(PlyCloud, UnorganizedCloudKeepsEveryPointInOrder) {
  OrganizedCloud cloud(4, 1);
  for (int i = 0; i < 4; ++i) cloud.x(i, 0) = 1.0f * i, cloud.y(i, 0) = -2.0f, cloud.z(i, 0) = 3;
  cloud.z(2, 0) = NAN;
  const std::vector<std::uint8_t> bytes = io::encode_ply_cloud(cloud);
  io::PlyCloudInfo info;
  const OrganizedCloud back = io::decode_ply_cloud(bytes.data(), bytes.size(), "u.ply", &info);
  EXPECT_EQ(info.grid, "");
  EXPECT_EQ(info.vertices, 4u);
  ASSERT_EQ(back.width(), 4);
  ASSERT_EQ(back.height(), 1);
  EXPECT_FALSE(back.valid(2, 0));
  EXPECT_EQ(back.x(3, 0), 3.0f);
  EXPECT_FALSE(back.has_rgb() || back.has_label() || back.has_intensity());
}

// Open3D writes ASCII or binary PLYs with double coordinates, normals and uchar colours.
TEST(PlyCloud, AsciiWithDoublesNormalsAndWindowsLineEnds) {
  const std::string text =
      "ply\r\nformat ascii 1.0\r\ncomment Created by Open3D\r\nelement vertex 3\r\n"
      "property double x\r\nproperty double y\r\nproperty double z\r\n"
      "property double nx\r\nproperty double ny\r\nproperty double nz\r\n"
      "property uchar red\r\nproperty uchar green\r\nproperty uchar blue\r\nend_header\r\n"
      "0.25 -1.5e-1 2 0 0 -1 255 128 0\r\n"
      "nan nan nan 0 0 1 1 2 3\r\n"
      "-0.001 0 1.0000001 0 0 1 9 8 7\r\n";
  io::PlyCloudInfo info;
  const OrganizedCloud c = decode(text, &info);
  EXPECT_EQ(info.format, "ascii");
  EXPECT_EQ(info.fields_summary, "x y z nx ny nz red green blue");
  ASSERT_EQ(c.width(), 3);
  ASSERT_EQ(c.height(), 1);
  EXPECT_FLOAT_EQ(c.x(0, 0), 0.25f);
  EXPECT_FLOAT_EQ(c.y(0, 0), -0.15f);
  EXPECT_FLOAT_EQ(c.z(0, 0), 2.0f);
  EXPECT_EQ(c.r(0, 0), 255);
  EXPECT_EQ(c.g(0, 0), 128);
  EXPECT_FALSE(c.valid(1, 0));
  EXPECT_EQ(c.b(2, 0), 7);
  EXPECT_FLOAT_EQ(c.z(2, 0), 1.0000001f);
}

// PCL's PLYWriter with its default use_camera: every point of an organized cloud (NaN ones
// too) in row order, then `element camera 1` whose viewport is the grid. Here big-endian.
TEST(PlyCloud, PclCameraViewportGivesTheGridOfABigEndianFile) {
  std::string text =
      "ply\nformat binary_big_endian 1.0\ncomment PCL generated\nelement vertex 6\n"
      "property float x\nproperty float y\nproperty float z\nproperty float rgb\n"
      "element face 0\nproperty list uchar int vertex_indices\n"
      "element camera 1\nproperty float view_px\nproperty float view_py\nproperty float view_pz\n"
      "property float x_axisx\nproperty float x_axisy\nproperty float x_axisz\n"
      "property float y_axisx\nproperty float y_axisy\nproperty float y_axisz\n"
      "property float z_axisx\nproperty float z_axisy\nproperty float z_axisz\n"
      "property int viewportx\nproperty int viewporty\nproperty float k1\nend_header\n";
  for (int i = 0; i < 6; ++i) {
    const float x = i == 4 ? NAN : 0.5f * i;
    put(text, x, true), put(text, -0.25f * i, true), put(text, 1.5f + i, true);
    put(text, 0.0f, true);  // the packed colour, skipped
  }
  // The sensor 0.5 m along z, turned half about x (as PCL's OpenNI grabber stores it).
  for (const float v : {0.0f, 0.0f, 0.5f, 1.0f, 0.0f, 0.0f, 0.0f, -1.0f, 0.0f, 0.0f, 0.0f, -1.0f}) {
    put(text, v, true);
  }
  put(text, std::int32_t{3}, true), put(text, std::int32_t{2}, true), put(text, 0.0f, true);
  io::PlyCloudInfo info;
  const OrganizedCloud c = decode(text, &info);
  EXPECT_EQ(info.grid, "viewport");
  const std::array<double, 7> pose{0, 0, 0.5, 0, 1, 0, 0};
  for (int k = 0; k < 7; ++k) EXPECT_NEAR(info.viewpoint[k], pose[k], 1e-12) << k;
  ASSERT_EQ(c.width(), 3);
  ASSERT_EQ(c.height(), 2);
  EXPECT_FLOAT_EQ(c.x(2, 0), 1.0f);
  EXPECT_FLOAT_EQ(c.z(0, 1), 4.5f);
  EXPECT_FLOAT_EQ(c.y(2, 1), -1.25f);
  EXPECT_FALSE(c.valid(1, 1));
  EXPECT_TRUE(c.valid(2, 1));

  // A viewport that does not hold the vertices is no grid: the points stay unorganized.
  const std::size_t at = text.size() - 12;
  std::string wrong = text;
  wrong.replace(at, 4, std::string("\0\0\0\4", 4));
  EXPECT_EQ(decode(wrong).height(), 1);
}

// Stanford range scans: an ASCII range_grid with empty cells and, in merged scans, several
// vertices in one cell (the first is kept); vertices in any order.
TEST(PlyCloud, StanfordRangeGridPlacesEachVertexOnItsPixel) {
  const std::string text =
      "ply\nformat ascii 1.0\nobj_info is_cyberware_data 0\nobj_info num_cols 2\n"
      "obj_info num_rows 3\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\nproperty uchar confidence\nelement range_grid 6\n"
      "property list uchar int vertex_indices\nend_header\n"
      "0 0 1 5\n1 0 2 5\n2 0 3 5\n3 0 4 5\n"
      "1 3\n0\n2 1 0\n0\n0\n1 2\n";
  io::PlyCloudInfo info;
  const OrganizedCloud c = decode(text, &info);
  EXPECT_EQ(info.grid, "range_grid");
  ASSERT_EQ(c.width(), 2);
  ASSERT_EQ(c.height(), 3);
  EXPECT_EQ(c.x(0, 0), 3.0f);
  EXPECT_FALSE(c.valid(1, 0));
  EXPECT_EQ(c.x(0, 1), 1.0f);
  EXPECT_FALSE(c.valid(1, 1));
  EXPECT_FALSE(c.valid(0, 2));
  EXPECT_EQ(c.z(1, 2), 3.0f);
}

TEST(PlyCloud, GridWithoutRangeGridFillsRowsInOrder) {
  std::string text =
      "ply\nformat binary_little_endian 1.0\nobj_info num_cols 2\nobj_info num_rows 2\n"
      "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
      "property ushort red\nproperty ushort green\nproperty ushort blue\nend_header\n";
  for (int i = 0; i < 4; ++i) {
    put(text, 1.0f * i, false), put(text, 0.0f, false), put(text, 2.0f, false);
    put(text, std::uint16_t{65535}, false), put(text, std::uint16_t{257}, false);
    put(text, std::uint16_t{0}, false);
  }
  io::PlyCloudInfo info;
  const OrganizedCloud c = decode(text, &info);
  EXPECT_EQ(info.grid, "rows");
  ASSERT_EQ(c.width(), 2);
  ASSERT_EQ(c.height(), 2);
  EXPECT_EQ(c.x(1, 1), 3.0f);
  EXPECT_EQ(c.r(0, 1), 255);
  EXPECT_EQ(c.g(0, 1), 1);
}

// CloudCompare writes colours and scalar fields as floats; labels must still be integers.
TEST(PlyCloud, FloatColoursScalarFieldsAndListsInTheVertex) {
  const std::string text =
      "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
      "element vertex 2\nproperty float red\nproperty float green\nproperty float blue\n"
      "property list uchar float extra\nproperty float x\nproperty float y\nproperty float z\n"
      "property float scalar_Intensity\nproperty float scalar_Label\nend_header\n"
      "3 0 1 1\n"
      "1.0 0.5 0 2 7 7 1 2 3 0.25 4\n"
      "0 2.0 -1 0 4 5 6 100 -2\n";
  const OrganizedCloud c = decode(text);
  ASSERT_EQ(c.width(), 2);
  EXPECT_EQ(c.x(0, 0), 1.0f);
  EXPECT_EQ(c.z(1, 0), 6.0f);
  EXPECT_EQ(c.r(0, 0), 255);
  EXPECT_EQ(c.g(0, 0), 128);
  EXPECT_EQ(c.g(1, 0), 255);  // clamped
  EXPECT_EQ(c.b(1, 0), 0);
  EXPECT_EQ(c.intensity(0, 0), 0.25f);
  EXPECT_EQ(c.label(0, 0), 4);
  EXPECT_EQ(c.label(1, 0), -2);
}

// Cases from a review of the reader against other writers' files.
TEST(PlyCloud, OtherWritersQuirks) {
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  // Two camera elements before the vertices: the first is the sensor, the second is skipped.
  OrganizedCloud c = decode(
      "ply\nformat ascii 1.0\nelement camera 2\nproperty float view_px\n"
      "property float view_py\nproperty float view_pz\nelement vertex 2\n" +
      xyz + "end_header\n0 2 1\n5 5 5\n1 2 3\n4 5 6\n");
  ASSERT_EQ(c.width(), 2);
  EXPECT_EQ(c.x(0, 0), 1.0f);
  EXPECT_EQ(c.z(1, 0), 6.0f);
  // PCL's uint labels keep their bits; '+' signs; "ply " with a trailing space; two properties
  // with one meaning (the first counts); a double beyond float's range is an invalid point.
  io::PlyCloudInfo info;
  c = decode("ply \nformat ascii 1.0\nelement vertex 2\n" + xyz +
                 "property uint label\nproperty float scalar_label\nend_header\n"
                 "+1 +2.5 3 4294967295 7\n1e300 0 1 2147483648 7\n",
             &info);
  ASSERT_EQ(c.width(), 2);
  EXPECT_EQ(c.x(0, 0), 1.0f);
  EXPECT_EQ(c.y(0, 0), 2.5f);
  EXPECT_EQ(c.label(0, 0), -1);
  EXPECT_EQ(c.label(1, 0), std::numeric_limits<std::int32_t>::min());
  EXPECT_FALSE(c.valid(1, 0));
  // A header alone, ending right after end_header.
  EXPECT_EQ(decode("ply\nformat binary_little_endian 1.0\nelement vertex 0\n" + xyz + "end_header")
                .size(),
            0u);
  // A range_grid of one row gives its holes; a viewport of width 0 is no grid.
  c = decode("ply\nformat ascii 1.0\nobj_info num_cols 3\nobj_info num_rows 1\nelement vertex 1\n" +
             xyz +
             "element range_grid 3\nproperty list uchar int vertex_indices\nend_header\n"
             "1 2 3\n0\n1 0\n0\n");
  ASSERT_EQ(c.width(), 3);
  EXPECT_FALSE(c.valid(0, 0));
  EXPECT_EQ(c.z(1, 0), 3.0f);
  c = decode("ply\nformat ascii 1.0\nelement vertex 0\n" + xyz +
             "element camera 1\nproperty int viewportx\nproperty int viewporty\nend_header\n0 5\n");
  EXPECT_EQ(c.width() * c.height(), 0);
  EXPECT_FALSE(c.is_organized());
  // Camera axes that are no rotation: no pose, and the caller is told.
  c = decode("ply\nformat ascii 1.0\nelement vertex 1\n" + xyz +
                 "element camera 1\nproperty float view_px\nproperty float x_axisx\nend_header\n"
                 "1 2 3\n0.5 2\n",
             &info);
  EXPECT_TRUE(info.viewpoint_ignored);
  EXPECT_EQ(info.viewpoint[0], 0.0);
  // A tiny quaternion cannot be written faithfully.
  EXPECT_THROW(io::encode_ply_cloud(sample_cloud(), {0, 0, 0, 1e-200, 0, 0, 1e-200}),
               std::invalid_argument);
}

// A header with many properties is read and its values stay aligned. (The duplicate check was
// quadratic, 13.8 s for 100k properties; tests have no time limits, so this does not catch that.)
TEST(PlyCloud, HeaderWithManyPropertiesIsRead) {
  std::string text = "ply\nformat ascii 1.0\nelement vertex 1\n";
  for (int k = 0; k < 20000; ++k) text += "property uchar p" + std::to_string(k) + "\n";
  text += "property float x\nproperty float y\nproperty float z\nend_header\n";
  for (int k = 0; k < 20000; ++k) text += "0 ";
  text += "1 2 3\n";
  const OrganizedCloud c = decode(text);
  ASSERT_EQ(c.width(), 1);
  EXPECT_EQ(c.z(0, 0), 3.0f);
}

TEST(PlyCloud, ReadsTheVerticesOfAMesh) {
  io::PlyMesh mesh;
  mesh.xyz = {0, 0, 1, 1, 0, 1, 0, 1, 1};
  mesh.normals = {0, 0, -1, 0, 0, -1, 0, 0, -1};
  mesh.faces = {0, 1, 2};
  const std::vector<std::uint8_t> bytes = io::encode_ply(mesh);
  const OrganizedCloud c = io::decode_ply_cloud(bytes.data(), bytes.size(), "m.ply");
  ASSERT_EQ(c.width(), 3);
  EXPECT_EQ(c.x(1, 0), 1.0f);
  EXPECT_EQ(c.y(2, 0), 1.0f);
}

struct BadPly {
  const char* what;
  std::string text;
  const char* message;
};

TEST(PlyCloud, MalformedFilesGiveErrorsNamingTheFileAndTheProblem) {
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  const std::string ascii = "ply\nformat ascii 1.0\n";
  const std::string binary = "ply\nformat binary_little_endian 1.0\n";
  const std::vector<BadPly> cases = {
      {"no magic", "PLY\nformat ascii 1.0\nend_header\n", "not a PLY file"},
      {"no end", ascii + "element vertex 1\n" + xyz, "without end_header"},
      {"format", "ply\nformat binary_middle_endian 1.0\nend_header\n", "unsupported format"},
      {"version", "ply\nformat ascii 2.0\nend_header\n", "unsupported format"},
      {"no format", "ply\nelement vertex 0\n" + xyz + "end_header\n", "no format line"},
      {"type", ascii + "element vertex 1\nproperty float128 x\nend_header\n",
       "unknown property type"},
      {"orphan", ascii + "property float x\nend_header\n", "before any element"},
      {"keyword", ascii + "vertices 3\nend_header\n", "unknown header line"},
      {"count", ascii + "element vertex -3\n" + xyz + "end_header\n", "expected a count"},
      {"no vertex", ascii + "element face 0\nend_header\n", "no vertex element"},
      {"no z", ascii + "element vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n",
       "no x, y and z"},
      {"twice", ascii + "element vertex 1\n" + xyz + "property float x\nend_header\n",
       "declared twice"},
      {"red only", ascii + "element vertex 1\n" + xyz + "property uchar red\nend_header\n1 2 3 4\n",
       "red, green and blue"},
      {"int colour",
       ascii + "element vertex 1\n" + xyz +
           "property int red\nproperty int green\nproperty int blue\nend_header\n1 2 3 4 5 6\n",
       "must be uchar"},
      {"list x",
       ascii + "element vertex 1\nproperty list uchar float x\nproperty float y\n"
               "property float z\nend_header\n1 1 2 3\n",
       "is a list"},
      {"short ascii", ascii + "element vertex 2\n" + xyz + "end_header\n1 2 3\n4 5            \n",
       "ends early"},
      {"word", ascii + "element vertex 1\n" + xyz + "end_header\n1 two 3\n", "expected a number"},
      {"uchar range",
       ascii + "element vertex 1\n" + xyz +
           "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n1 2 3 256 0 "
           "0\n",
       "out of its type's range"},
      {"label",
       ascii + "element vertex 1\n" + xyz + "property float label\nend_header\n1 2 3 0.5\n",
       "not an int32"},
      {"short binary", binary + "element vertex 2\n" + xyz + "end_header\n" + std::string(20, '\0'),
       "cannot fit"},
      {"lying count",
       binary + "element vertex 4000000000\n" + xyz + "end_header\n" + std::string(12, '\0'),
       "too many"},
      {"lying count 2",
       binary + "element vertex 400000000\n" + xyz + "end_header\n" + std::string(12, '\0'),
       "cannot fit"},
      {"skipped element",
       binary + "element extra 1000\nproperty double a\nelement vertex 0\n" + xyz + "end_header\n",
       "truncated"},
      {"grid size",
       ascii + "obj_info num_cols 3\nobj_info num_rows 2\nelement vertex 1\n" + xyz +
           "end_header\n1 2 3\n",
       "no range_grid"},
      {"grid cells",
       ascii + "obj_info num_cols 3\nobj_info num_rows 2\nelement vertex 1\n" + xyz +
           "element range_grid 5\nproperty list uchar int vertex_indices\nend_header\n1 2 3\n",
       "5 cells"},
      {"grid index",
       ascii + "obj_info num_cols 1\nobj_info num_rows 2\nelement vertex 1\n" + xyz +
           "element range_grid 2\nproperty list uchar int vertex_indices\nend_header\n1 2 3\n1 "
           "0\n1 "
           "1\n",
       "names vertex 1"},
      {"data context", ascii + "element vertex 1\n" + xyz + "end_header\n1 2 x\n",
       "(line 8, element \"vertex\")"},
      {"extra value", ascii + "element vertex 2\n" + xyz + "end_header\n1 2 3 4\n5 6 7\n",
       "more values on a line"},
      {"empty", "", "the file is empty"},
      {"grid reuse",
       ascii + "obj_info num_cols 1\nobj_info num_rows 2\nelement vertex 1\n" + xyz +
           "element range_grid 2\nproperty list uchar int vertex_indices\nend_header\n1 2 3\n1 "
           "0\n1 "
           "0\n",
       "which an earlier cell holds"},
      {"grid alone",
       ascii + "element vertex 1\n" + xyz +
           "element range_grid 1\nproperty list uchar int vertex_indices\nend_header\n1 2 3\n1 0\n",
       "without obj_info"},
      {"huge grid",
       ascii + "obj_info num_cols 2000000\nobj_info num_rows 2000000\nelement vertex 1\n" + xyz +
           "end_header\n1 2 3\n",
       "too large"},
  };
  for (const BadPly& c : cases) {
    try {
      decode(c.text);
      ADD_FAILURE() << c.what << ": no error";
    } catch (const std::runtime_error& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("t.ply"), std::string::npos) << c.what << ": " << message;
      EXPECT_NE(message.find(c.message), std::string::npos) << c.what << ": " << message;
    }
  }
}

TEST(PlyCloud, MissingFileIsNamed) {
  try {
    io::read_ply_cloud("/nonexistent/cloud.ply");
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/cloud.ply"), std::string::npos);
  }
}

}  // namespace
}  // namespace rangeseg
