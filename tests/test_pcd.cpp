#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "rangeseg/io/file.hpp"
#include "rangeseg/io/pcd.hpp"
#include "test_util.hpp"

namespace {

using rangeseg::BytePlane;
using rangeseg::FloatPlane;
using rangeseg::LabelImage;
using rangeseg::OrganizedCloud;
using namespace rangeseg::io;

using Bytes = std::vector<std::uint8_t>;

Bytes to_bytes(const std::string& s) { return Bytes(s.begin(), s.end()); }

template <class T>
void append_value(Bytes& out, T value) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(&value);
  out.insert(out.end(), p, p + sizeof(T));
}

// An LZF stream made of literal runs only (control byte n-1, then n <= 32 bytes): valid LZF that
// any decoder must accept, built without the library under test.
Bytes lzf_literals(const Bytes& raw) {
  Bytes out;
  for (std::size_t i = 0; i < raw.size(); i += 32) {
    const std::size_t n = std::min<std::size_t>(32, raw.size() - i);
    out.push_back(static_cast<std::uint8_t>(n - 1));
    out.insert(out.end(), raw.begin() + i, raw.begin() + i + n);
  }
  return out;
}

// LZF stream of `n` zero bytes: one literal, then back-references at distance 1 of up to 264
// bytes each (the format's longest match, ~88x expansion).
Bytes lzf_zeros(std::size_t n) {
  Bytes out = {0x00, 0x00};
  std::size_t remaining = n - 1;
  while (remaining > 0) {
    const std::size_t len = std::min<std::size_t>(264, remaining);
    if (len < 3) {
      out.push_back(static_cast<std::uint8_t>(len - 1));
      out.insert(out.end(), len, 0);
    } else if (len <= 8) {
      out.insert(out.end(), {static_cast<std::uint8_t>((len - 2) << 5), 0x00});
    } else {
      out.insert(out.end(), {0xe0, static_cast<std::uint8_t>(len - 9), 0x00});
    }
    remaining -= len;
  }
  return out;
}

Bytes compressed_file(const std::string& header, const Bytes& soa) {
  Bytes out = to_bytes(header);
  const Bytes lzf = lzf_literals(soa);
  append_value<std::uint32_t>(out, static_cast<std::uint32_t>(lzf.size()));
  append_value<std::uint32_t>(out, static_cast<std::uint32_t>(soa.size()));
  out.insert(out.end(), lzf.begin(), lzf.end());
  return out;
}

OrganizedCloud parse(const Bytes& bytes, PcdInfo* info = nullptr,
                     const PcdReadOptions& options = {}) {
  return parse_pcd(bytes.data(), bytes.size(), "test.pcd", info, options);
}

std::uint32_t bits(float f) { return std::bit_cast<std::uint32_t>(f); }

template <class T>
bool same_bits(const rangeseg::Plane<T>& a, const rangeseg::Plane<T>& b) {
  if (a.width() != b.width() || a.height() != b.height()) return false;
  for (int v = 0; v < a.height(); ++v) {
    if (std::memcmp(a.row(v), b.row(v), sizeof(T) * a.width()) != 0) return false;
  }
  return true;
}

void expect_same_cloud(const OrganizedCloud& a, const OrganizedCloud& b) {
  EXPECT_TRUE(same_bits(a.x, b.x));
  EXPECT_TRUE(same_bits(a.y, b.y));
  EXPECT_TRUE(same_bits(a.z, b.z));
  EXPECT_TRUE(same_bits(a.intensity, b.intensity));
  EXPECT_TRUE(same_bits(a.r, b.r));
  EXPECT_TRUE(same_bits(a.g, b.g));
  EXPECT_TRUE(same_bits(a.b, b.b));
  EXPECT_TRUE(same_bits(a.label, b.label));
}

// Expects parse_pcd to throw std::runtime_error whose message names the file and contains `what`.
void expect_error(const Bytes& bytes, const std::string& what) {
  const std::string name = "bad_input_case.pcd";
  try {
    parse_pcd(bytes.data(), bytes.size(), name);
    ADD_FAILURE() << "no error for input expected to fail with '" << what << "'";
  } catch (const std::runtime_error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(name), std::string::npos) << msg;
    EXPECT_NE(msg.find(what), std::string::npos) << "message: " << msg << "\nexpected: " << what;
  }
}
void expect_error(const std::string& text, const std::string& what) {
  expect_error(to_bytes(text), what);
}

const char* kXyzHeader =
    "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
    "WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\n";

Bytes xyz_binary(int points_in_data) {
  Bytes file = to_bytes(std::string(kXyzHeader) + "DATA binary\n");
  for (int i = 0; i < points_in_data * 3; ++i) append_value(file, 1.0f);
  return file;
}

std::string xyz_header(const std::string& width, const std::string& height,
                       const std::string& points) {
  return "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " + width +
         "\nHEIGHT " + height + "\nPOINTS " + points + "\n";
}

// ---------------------------------------------------------------------------------------------
// Real files in ../shared/data.

struct RealFile {
  const char* path;
  PcdEncoding encoding;
  const char* fields;
  int width, height;
  std::size_t valid;              // points with finite x, y, z
  double sum_z;                   // sum of z over valid points (metres)
  long long sum_r, sum_g, sum_b;  // -1 when the file has no colour
  std::size_t labelled;           // points with label != 0 (OSD only)
  int max_label;
  double sum_intensity;  // -1 when the file has no intensity
};

// Expected numbers from an independent Python script written for this test (pure Python: its own
// header parser, struct-unpacking of the binary data and a from-scratch LZF decoder; floats are
// checked with math.isfinite, ascii values rounded to float32 as the file declares F4, colours
// unpacked from 0x00RRGGBB, sums in double, row-major order).
const RealFile kRealFiles[] = {
    {"kinect/grabber_frame0.pcd", PcdEncoding::binary_compressed, "x y z rgba", 640, 480, 271575,
     269271.272601, 21149585, 21451249, 19831951, 0, 0, -1},
    {"kinect/grabber_frame1.pcd", PcdEncoding::binary_compressed, "x y z rgba", 640, 480, 271395,
     269156.069561, 20980304, 21360795, 19857877, 0, 0, -1},
    {"kinect/grabber_frame2.pcd", PcdEncoding::binary_compressed, "x y z rgba", 640, 480, 271328,
     266021.604418, 20863185, 21314797, 19852973, 0, 0, -1},
    {"kinect/milk_cartoon_all_small_clorox.pcd", PcdEncoding::binary_compressed, "x y z rgba", 640,
     480, 241407, 218447.378968, 24001028, 21760851, 19743536, 0, 0, -1},
    {"kinect/organized_edge_1.pcd", PcdEncoding::binary_compressed, "x y z rgb", 640, 480, 307200,
     450120.314289, 7009025, 28720910, 13290241, 0, 0, -1},
    {"kinect/qvga_inputCloud0.pcd", PcdEncoding::binary, "x y z rgba", 320, 240, 39810,
     52911.024446, 11394508, 8839833, 9550083, 0, 0, -1},
    {"kinect/table_scene_mug_stereo_textured.pcd", PcdEncoding::binary_compressed, "x y z rgba",
     640, 480, 209280, 264682.154889, 54255613, 35504128, 24300682, 0, 0, -1},
    {"laser/A601.pcd", PcdEncoding::ascii, "x y z", 361, 144, 51984, 98268.074004, -1, -1, -1, 0, 0,
     -1},
    {"laser/B604.pcd", PcdEncoding::ascii, "x y z", 361, 236, 85196, 96595.882023, -1, -1, -1, 0, 0,
     -1},
    {"laser/test_500.pcd", PcdEncoding::binary_compressed, "x y z intensity", 500, 500, 250000,
     56148.281941, -1, -1, -1, 0, 0, 5301954.0},
    {"osd/learn0.pcd", PcdEncoding::binary_compressed, "label x y z rgba", 640, 480, 182292,
     155107.450759, 66005905, 61426136, 60963298, 182292, 30, -1},
    {"osd/test0.pcd", PcdEncoding::binary_compressed, "label x y z rgba", 640, 480, 189198,
     146779.496368, 50827073, 45859024, 45385330, 189198, 30, -1},
    {"osd/test5.pcd", PcdEncoding::binary_compressed, "label x y z rgba", 640, 480, 196454,
     154784.458490, 50130241, 44117354, 44713953, 196454, 31, -1},
    {"osd/test55.pcd", PcdEncoding::binary_compressed, "label x y z rgba", 640, 480, 175178,
     140031.786150, 36445746, 32339779, 32424228, 175178, 151, -1},
    {"osd/test60.pcd", PcdEncoding::binary_compressed, "label x y z rgba", 640, 480, 171546,
     133493.979036, 43399991, 40789167, 42255871, 171546, 160, -1},
};

class RealPcd : public ::testing::TestWithParam<RealFile> {};

TEST_P(RealPcd, LoadsWithExpectedContent) {
  const RealFile& e = GetParam();
  RANGESEG_REQUIRE_DATA(e.path);
  PcdInfo info;
  const OrganizedCloud cloud = read_pcd(data_file.string(), &info);
  EXPECT_EQ(info.width, e.width);
  EXPECT_EQ(info.height, e.height);
  EXPECT_EQ(info.points, static_cast<std::uint64_t>(e.width) * e.height);
  EXPECT_EQ(info.encoding, e.encoding);
  EXPECT_EQ(info.fields_summary, e.fields);
  ASSERT_EQ(cloud.width(), e.width);
  ASSERT_EQ(cloud.height(), e.height);
  EXPECT_EQ(cloud.count_valid(), e.valid);

  double sum_z = 0, sum_intensity = 0;
  long long sum_r = 0, sum_g = 0, sum_b = 0;
  std::size_t labelled = 0;
  int max_label = std::numeric_limits<int>::min();
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if (cloud.valid(u, v)) sum_z += cloud.z(u, v);
      if (cloud.has_rgb()) {
        sum_r += cloud.r(u, v);
        sum_g += cloud.g(u, v);
        sum_b += cloud.b(u, v);
      }
      if (cloud.has_label()) {
        labelled += cloud.label(u, v) != 0;
        max_label = std::max(max_label, cloud.label(u, v));
      }
      if (cloud.has_intensity() && std::isfinite(cloud.intensity(u, v))) {
        sum_intensity += cloud.intensity(u, v);
      }
    }
  }
  EXPECT_NEAR(sum_z, e.sum_z, 1e-5);
  EXPECT_EQ(cloud.has_rgb(), e.sum_r >= 0);
  if (e.sum_r >= 0) {
    EXPECT_EQ(sum_r, e.sum_r);
    EXPECT_EQ(sum_g, e.sum_g);
    EXPECT_EQ(sum_b, e.sum_b);
  }
  EXPECT_EQ(cloud.has_label(), e.labelled > 0);
  if (e.labelled > 0) {
    EXPECT_EQ(labelled, e.labelled);
    EXPECT_EQ(max_label, e.max_label);
  }
  EXPECT_EQ(cloud.has_intensity(), e.sum_intensity >= 0);
  if (e.sum_intensity >= 0) {
    EXPECT_NEAR(sum_intensity, e.sum_intensity, 1e-3);
  }
}

INSTANTIATE_TEST_SUITE_P(SharedData, RealPcd, ::testing::ValuesIn(kRealFiles),
                         [](const ::testing::TestParamInfo<RealFile>& p) {
                           std::string n = p.param.path;
                           for (char& c : n) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           }
                           return n;
                         });

TEST(PcdRealData, RoundTripBitExactAllEncodings) {
  for (const char* path : {"osd/test0.pcd", "laser/test_500.pcd", "kinect/qvga_inputCloud0.pcd"}) {
    RANGESEG_REQUIRE_DATA(path);
    const OrganizedCloud original = read_pcd(data_file.string());
    for (PcdEncoding enc :
         {PcdEncoding::binary, PcdEncoding::binary_compressed, PcdEncoding::ascii}) {
      SCOPED_TRACE(std::string(path) + " encoding " + std::to_string(static_cast<int>(enc)));
      const Bytes bytes = encode_pcd(original, {.encoding = enc});
      PcdInfo info;
      const OrganizedCloud back = parse(bytes, &info);
      EXPECT_EQ(info.encoding, enc);
      expect_same_cloud(original, back);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Round trips of a synthetic cloud.

OrganizedCloud synthetic_cloud(int w, int h) {
  OrganizedCloud c(w, h);
  c.add_intensity();
  c.add_rgb();
  c.add_label();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const int centre_column = w / 2;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const int i = v * w + u;
      c.x(u, v) = 0.001f * static_cast<float>(u - centre_column) / 3.0f;
      c.y(u, v) = -1e-30f * static_cast<float>(v + 1);
      c.z(u, v) = 1.0f + std::ldexp(static_cast<float>(i), -20) + 1e7f * (i % 7 == 0);
      c.intensity(u, v) = i % 5 == 0 ? nan : static_cast<float>(i) * 0.1f;
      c.r(u, v) = static_cast<std::uint8_t>(i * 37);
      c.g(u, v) = static_cast<std::uint8_t>(i * 91 + 3);
      c.b(u, v) = static_cast<std::uint8_t>(255 - i);
      c.label(u, v) = i % 3 == 0 ? -i : i * 1000;
      if (i % 4 == 1) c.z(u, v) = nan;
      if (i % 6 == 2) c.x(u, v) = -nan;
      if (i % 9 == 3) c.y(u, v) = std::numeric_limits<float>::infinity();
    }
  }
  c.label(0, 0) = std::numeric_limits<std::int32_t>::min();
  c.label(1, 0) = std::numeric_limits<std::int32_t>::max();
  c.x(2, 0) = std::numeric_limits<float>::denorm_min();
  c.x(3, 0) = -0.0f;
  c.x(4, 0) = std::numeric_limits<float>::max();
  return c;
}

TEST(PcdRoundTrip, SyntheticBitExactAllEncodings) {
  const OrganizedCloud original = synthetic_cloud(23, 7);
  for (PcdEncoding enc :
       {PcdEncoding::binary, PcdEncoding::binary_compressed, PcdEncoding::ascii}) {
    SCOPED_TRACE(static_cast<int>(enc));
    PcdInfo info;
    const OrganizedCloud back = parse(encode_pcd(original, {.encoding = enc}), &info);
    EXPECT_EQ(info.fields_summary, "x y z intensity rgb label");
    EXPECT_EQ(info.version, "0.7");
    EXPECT_EQ(info.width, 23);
    EXPECT_EQ(info.height, 7);
    expect_same_cloud(original, back);
    EXPECT_EQ(back.count_valid(), original.count_valid());
    EXPECT_LT(back.count_valid(), back.size());
    // The packed colour is a float in binary, as PCL stores it, and in text the integer PCL
    // writes, typed U as PCL types it (PCL and Open3D read integer text of a TYPE F field as
    // that number, another colour).
    const Bytes file = encode_pcd(original, {.encoding = enc});
    const std::string text(file.begin(), file.begin() + 400);
    EXPECT_NE(
        text.find(enc == PcdEncoding::ascii ? "\nTYPE F F F F U U\n" : "\nTYPE F F F F F U\n"),
        std::string::npos)
        << text;
  }
}

TEST(PcdRoundTrip, NanPayloadsKeptInBinary) {
  OrganizedCloud c(3, 1);
  for (int u = 0; u < 3; ++u) c.x(u, 0) = c.y(u, 0) = 1.0f;
  c.z(0, 0) = std::bit_cast<float>(0x7fc00001u);
  c.z(1, 0) = std::bit_cast<float>(0xffa00000u);
  c.z(2, 0) = 2.0f;
  for (PcdEncoding enc : {PcdEncoding::binary, PcdEncoding::binary_compressed}) {
    const OrganizedCloud back = parse(encode_pcd(c, {.encoding = enc}));
    EXPECT_EQ(bits(back.z(0, 0)), 0x7fc00001u);
    EXPECT_EQ(bits(back.z(1, 0)), 0xffa00000u);
    EXPECT_EQ(back.count_valid(), 1u);
  }
}

TEST(PcdRoundTrip, PlainXyzUnorganizedAndExtraFields) {
  OrganizedCloud c(5, 1);
  FloatPlane nx(5, 1), curvature(5, 1);
  for (int u = 0; u < 5; ++u) {
    c.x(u, 0) = static_cast<float>(u);
    c.y(u, 0) = 0.5f;
    c.z(u, 0) = 2.0f;
    nx(u, 0) = 0.25f * static_cast<float>(u);
    curvature(u, 0) = -1.0f;
  }
  for (PcdEncoding enc :
       {PcdEncoding::binary, PcdEncoding::binary_compressed, PcdEncoding::ascii}) {
    const Bytes bytes = encode_pcd(
        c, {.encoding = enc, .extra_float_fields = {{"normal_x", &nx}, {"curvature", &curvature}}});
    PcdInfo info;
    const OrganizedCloud back = parse(bytes, &info);
    EXPECT_EQ(info.fields_summary, "x y z normal_x curvature");
    EXPECT_EQ(info.height, 1);
    EXPECT_FALSE(back.is_organized());
    EXPECT_FALSE(back.has_rgb() || back.has_label() || back.has_intensity());
    expect_same_cloud(c, back);
    if (enc == PcdEncoding::binary) {
      // Binary layout: 5 floats per point, the extras after x y z.
      const std::size_t data = bytes.size() - std::size_t{5} * 5 * 4;
      for (int u = 0; u < 5; ++u) {
        float value;
        std::memcpy(&value, bytes.data() + data + (static_cast<std::size_t>(u) * 5 + 3) * 4, 4);
        EXPECT_EQ(value, nx(u, 0));
      }
    }
  }
  FloatPlane wrong(4, 1);
  EXPECT_THROW(encode_pcd(c, {.extra_float_fields = {{"normal_x", &wrong}}}),
               std::invalid_argument);
  EXPECT_THROW(encode_pcd(c, {.extra_float_fields = {{"x", &nx}}}), std::invalid_argument);
  EXPECT_THROW(encode_pcd(OrganizedCloud{}), std::invalid_argument);
}

TEST(PcdRoundTrip, WriteAndReadFile) {
  const auto dir = rangeseg::test::scratch_dir("pcd_file");
  const std::string path = (dir / "cloud.pcd").string();
  const OrganizedCloud original = synthetic_cloud(16, 4);
  write_pcd(path, original, {.encoding = PcdEncoding::binary_compressed});
  PcdInfo info;
  expect_same_cloud(original, read_pcd(path, &info));
  EXPECT_EQ(info.encoding, PcdEncoding::binary_compressed);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);  // no temporary left

  const std::string missing = (dir / "no_such_dir" / "x.pcd").string();
  try {
    write_pcd(missing, original);
    ADD_FAILURE() << "writing into a missing directory should fail";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  try {
    read_pcd(missing);
    ADD_FAILURE() << "reading a missing file should fail";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  // Bad content read from disk names the path too.
  const std::string bad = (dir / "bad.pcd").string();
  write_file_atomic(bad, std::string(kXyzHeader) + "DATA binary\n\x01\x02");
  try {
    read_pcd(bad);
    ADD_FAILURE() << "truncated file should fail";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// Hand-written files.

TEST(PcdHandWritten, AnyFieldOrderMixedTypesAndSkippedFields) {
  // Per point: intensity U1, _ (3 bytes padding, U1 x3), z F8, descriptor F4 x33, y I2, x F4,
  // label I2, rgb U4.
  const std::string header =
      "VERSION 0.7\nFIELDS intensity _ z descriptor y x label rgb\nSIZE 1 1 8 4 2 4 2 4\n"
      "TYPE U U F F I F I U\nCOUNT 1 3 1 33 1 1 1 1\nWIDTH 2\nHEIGHT 2\nPOINTS 4\n";
  const std::size_t point_size = 1 + 3 + 8 + 33 * 4 + 2 + 4 + 2 + 4;
  Bytes aos, soa;
  std::vector<Bytes> columns(8);
  for (int i = 0; i < 4; ++i) {
    Bytes p;
    auto put = [&](int col, const auto& value, int repeat = 1) {
      for (int k = 0; k < repeat; ++k) {
        append_value(p, value);
        append_value(columns[col], value);
      }
    };
    put(0, static_cast<std::uint8_t>(200 + i));
    put(1, std::uint8_t{0xee}, 3);
    put(2, 1.0 + 0.125 * i);
    put(3, 99.0f, 33);
    put(4, static_cast<std::int16_t>(-300 * i));
    put(5, i == 2 ? std::numeric_limits<float>::quiet_NaN() : 0.5f * i);
    put(6, static_cast<std::int16_t>(-i));
    put(7, static_cast<std::uint32_t>(0xff000000u | (10u * i) << 16 | (20u * i) << 8 | (30u * i)));
    ASSERT_EQ(p.size(), point_size);
    aos.insert(aos.end(), p.begin(), p.end());
  }
  for (const Bytes& c : columns) soa.insert(soa.end(), c.begin(), c.end());

  Bytes binary = to_bytes(header + "DATA binary\n");
  binary.insert(binary.end(), aos.begin(), aos.end());
  const Bytes compressed = compressed_file(header + "DATA binary_compressed\n", soa);
  std::string ascii = header + "DATA ascii\n";
  for (int i = 0; i < 4; ++i) {
    ascii += std::to_string(200 + i) + " 238 238 238 " + std::to_string(1.0 + 0.125 * i);
    for (int k = 0; k < 33; ++k) ascii += " 99";
    ascii += " " + std::to_string(-300 * i) +
             (i == 2 ? " nan " : " " + std::to_string(0.5 * i) + " ") + std::to_string(-i) + " " +
             std::to_string(0xff000000u | (10u * i) << 16 | (20u * i) << 8 | (30u * i)) + "\n";
  }
  for (const Bytes& file : {binary, compressed, to_bytes(ascii)}) {
    PcdInfo info;
    const OrganizedCloud c = parse(file, &info);
    EXPECT_EQ(info.fields_summary, "intensity _ z descriptor y x label rgb");
    ASSERT_EQ(c.width(), 2);
    ASSERT_EQ(c.height(), 2);
    ASSERT_TRUE(c.has_intensity() && c.has_rgb() && c.has_label());
    for (int i = 0; i < 4; ++i) {
      const int u = i % 2, v = i / 2;
      SCOPED_TRACE(i);
      if (i == 2) {
        EXPECT_TRUE(std::isnan(c.x(u, v)));
      } else {
        EXPECT_EQ(c.x(u, v), 0.5f * i);
      }
      EXPECT_EQ(c.y(u, v), -300.0f * i);
      EXPECT_EQ(c.z(u, v), static_cast<float>(1.0 + 0.125 * i));
      EXPECT_EQ(c.intensity(u, v), 200.0f + i);
      EXPECT_EQ(c.label(u, v), -i);
      EXPECT_EQ(c.r(u, v), 10 * i);
      EXPECT_EQ(c.g(u, v), 20 * i);
      EXPECT_EQ(c.b(u, v), 30 * i);
    }
    EXPECT_EQ(c.count_valid(), 3u);
  }
}

TEST(PcdHandWritten, RgbFloatAndRgbaUintGiveSameColours) {
  const std::uint32_t colours[2] = {0x00123456u, 0x00fedcbau};
  Bytes as_float = to_bytes(
      "FIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS "
      "2\nDATA binary\n");
  Bytes as_uint = to_bytes(
      "FIELDS x y z rgba\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS "
      "2\nDATA binary\n");
  for (std::uint32_t colour : colours) {
    for (float f : {1.0f, 2.0f, 3.0f}) {
      append_value(as_float, f);
      append_value(as_uint, f);
    }
    append_value(as_float, std::bit_cast<float>(colour));
    append_value(as_uint, colour | 0x80000000u);  // alpha must be ignored
  }
  // PCL's ascii form of a float rgb is the packed integer; a float rendering is accepted too.
  char subnormal[64];
  std::snprintf(subnormal, sizeof subnormal, "%.9g", std::bit_cast<float>(colours[1]));
  const std::string ascii =
      "FIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F F\nWIDTH 2\nPOINTS 2\nDATA ascii\n1 2 3 " +
      std::to_string(colours[0]) + "\n1 2 3 " + subnormal + "\n";
  for (const Bytes& file : {as_float, as_uint, to_bytes(ascii)}) {
    const OrganizedCloud c = parse(file);
    ASSERT_TRUE(c.has_rgb());
    EXPECT_EQ(c.r(0, 0), 0x12);
    EXPECT_EQ(c.g(0, 0), 0x34);
    EXPECT_EQ(c.b(0, 0), 0x56);
    EXPECT_EQ(c.r(1, 0), 0xfe);
    EXPECT_EQ(c.g(1, 0), 0xdc);
    EXPECT_EQ(c.b(1, 0), 0xba);
  }
}

TEST(PcdHandWritten, AsciiNanSpellingsAndOldHeader) {
  // No VERSION, VIEWPOINT, COUNT or HEIGHT; a comment, CRLF line ends and blank lines.
  const std::string text =
      "# an old file\r\nFIELDS x y z\r\nSIZE 4 4 4\r\nTYPE F F F\r\nWIDTH 4\r\nPOINTS 4\r\nDATA "
      "ascii\r\n"
      "1 2 3\r\nnan NaN nan\r\n\r\n-4.5e-3 +7 1e-3\r\n0.1 NAN 3";
  PcdInfo info;
  const OrganizedCloud c = parse(to_bytes(text), &info);
  EXPECT_EQ(info.version, "");
  EXPECT_EQ(info.encoding, PcdEncoding::ascii);
  ASSERT_EQ(c.width(), 4);
  ASSERT_EQ(c.height(), 1);
  EXPECT_EQ(c.z(0, 0), 3.0f);
  EXPECT_TRUE(std::isnan(c.x(1, 0)) && std::isnan(c.y(1, 0)) && std::isnan(c.z(1, 0)));
  EXPECT_EQ(c.x(2, 0), -4.5e-3f);
  EXPECT_EQ(c.y(2, 0), 7.0f);
  EXPECT_EQ(c.z(2, 0), 1e-3f);  // correctly rounded
  EXPECT_TRUE(std::isnan(c.y(3, 0)));
  EXPECT_EQ(c.count_valid(), 2u);

  // Headers before v0.7 may lack SIZE/TYPE (4-byte floats) and use COLUMNS.
  const OrganizedCloud d =
      parse(to_bytes("VERSION .5\nCOLUMNS x y z\nPOINTS 1\nDATA ascii\n1 2 3\n"));
  EXPECT_EQ(d.width(), 1);
  EXPECT_EQ(d.y(0, 0), 2.0f);
}

// The sensor's pose is reported as stored; the points are not moved.
TEST(PcdHandWritten, ViewpointIsReportedAndThePointsKept) {
  const std::string body = "FIELDS x y z\nWIDTH 1\nPOINTS 1\nDATA ascii\n1 2 3\n";
  PcdInfo info;
  const OrganizedCloud c = parse(to_bytes("VIEWPOINT 0.5 -1 +2 0.7071 0 0.7071 0\n" + body), &info);
  EXPECT_EQ(info.viewpoint, (std::array<double, 7>{0.5, -1, 2, 0.7071, 0, 0.7071, 0}));
  EXPECT_TRUE(info.moved_from_sensor());
  EXPECT_EQ(c.x(0, 0), 1.0f);
  PcdInfo identity;
  parse(to_bytes("VIEWPOINT 0 0 0 1 0 0 0\n" + body), &identity);
  EXPECT_FALSE(identity.moved_from_sensor());
  PcdInfo none;
  parse(to_bytes(body), &none);
  EXPECT_FALSE(none.moved_from_sensor());
  PcdInfo negated;
  parse(to_bytes("VIEWPOINT 0 0 0 -1 0 0 0\n" + body), &negated);
  EXPECT_FALSE(negated.moved_from_sensor());

  // Written and read back to the bit.
  const std::array<double, 7> pose{0.1, -2.5e-7, 3, 0.9238795325112867, 0, 0.3826834323650898, 0};
  const Bytes written = encode_pcd(c, {.encoding = PcdEncoding::ascii, .viewpoint = pose});
  PcdInfo back;
  parse(written, &back);
  EXPECT_EQ(back.viewpoint, pose);
  EXPECT_THROW(encode_pcd(c, {.viewpoint = {0, 0, 0, NAN, 0, 0, 0}}), std::invalid_argument);
}

// With to_sensor_frame the reader moves the points as to_sensor_frame does, from the stored
// values in double: doubles 5.4e6 m from the origin (a map's UTM coordinates) keep their
// millimetres, which floats there, 0.5 m apart, lose; float fields give to_sensor_frame's bits.
TEST(PcdHandWritten, ViewpointAppliedWhileReadingKeepsTheDoublesPrecision) {
  // The sensor at (500000, 5400000, 300), turned 90 deg about z: R^T maps (x, y) to (y, -x).
  const std::string pose =
      "VIEWPOINT 500000 5400000 300 0.7071067811865476 0 0 0.7071067811865476\n";
  const std::string fields = "FIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nWIDTH 2\nPOINTS 2\n";
  const std::string data = "DATA ascii\n500001.2345 5400002.5 301.75\nnan nan nan\n";
  PcdInfo info;
  const OrganizedCloud moved =
      parse(to_bytes(pose + fields + data), &info, {.to_sensor_frame = true});
  EXPECT_NEAR(moved.x(0, 0), 2.5, 1e-6);
  EXPECT_NEAR(moved.y(0, 0), -1.2345, 1e-6);
  EXPECT_NEAR(moved.z(0, 0), 1.75, 1e-6);
  EXPECT_FALSE(moved.valid(1, 0));
  EXPECT_EQ(info.viewpoint[1], 5400000);  // the file's pose is still reported
  OrganizedCloud as_float = parse(to_bytes(pose + fields + data));
  to_sensor_frame(as_float, info.viewpoint);
  EXPECT_GT(std::abs(as_float.y(0, 0) + 1.2345F) + std::abs(as_float.x(0, 0) - 2.5F), 0.01F)
      << "float points at 5.4e6 m lose their centimetres";

  const std::string near_pose = "VIEWPOINT 0.5 -1 2 0.9238795325112867 0 0.3826834323650898 0\n";
  const std::string floats =
      "FIELDS x y z\nWIDTH 2\nPOINTS 2\nDATA ascii\n1.25 -0.5 3.125\n0.1 0.2 nan\n";
  const OrganizedCloud read_moved =
      parse(to_bytes(near_pose + floats), nullptr, {.to_sensor_frame = true});
  OrganizedCloud then_moved = parse(to_bytes(near_pose + floats), &info);
  to_sensor_frame(then_moved, info.viewpoint);
  for (int u = 0; u < 2; ++u) {
    EXPECT_EQ(bits(read_moved.x(u, 0)), bits(then_moved.x(u, 0))) << u;
    EXPECT_EQ(bits(read_moved.y(u, 0)), bits(then_moved.y(u, 0))) << u;
    EXPECT_EQ(bits(read_moved.z(u, 0)), bits(then_moved.z(u, 0))) << u;
  }

  // A VIEWPOINT that is no rotation is an error only when it is applied.
  const Bytes no_rotation = to_bytes("VIEWPOINT 1 2 3 0 0 0 0\n" + floats);
  EXPECT_NO_THROW(parse(no_rotation));
  try {
    parse(no_rotation, nullptr, {.to_sensor_frame = true});
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("test.pcd"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("quaternion of norm >= 1e-6"), std::string::npos)
        << e.what();
  }
}

TEST(PcdHandWritten, TrailingBytesAfterBinaryDataAreIgnored) {
  // PCL pads binary files to a page size.
  Bytes file = to_bytes(std::string(kXyzHeader) + "DATA binary\n");
  for (int i = 0; i < 6; ++i) append_value(file, static_cast<float>(i));
  file.resize(file.size() + 100, 0);
  const OrganizedCloud c = parse(file);
  EXPECT_EQ(c.z(1, 0), 5.0f);
  // A legitimate narrow cloud (one column) is fine.
  Bytes column = to_bytes(xyz_header("1", "4", "4") + "DATA binary\n");
  for (int i = 0; i < 12; ++i) append_value(column, static_cast<float>(i));
  const OrganizedCloud d = parse(column);
  EXPECT_EQ(d.height(), 4);
  EXPECT_EQ(d.z(0, 3), 11.0f);
}

// ---------------------------------------------------------------------------------------------
// Bad input.

TEST(PcdBadInput, HeaderProblems) {
  expect_error(std::string(), "empty file (0 bytes)");
  expect_error(std::string("VERSION 0.7\nFIELDS x y z\nSIZE 4 4"),
               "no DATA line");  // truncated header
  expect_error(std::string(kXyzHeader), "no DATA line");
  expect_error(std::string("\x89PNG\r\n\x1a\n....", 12), "unknown header line");
  expect_error(xyz_header("2", "2", "3") + "DATA binary\n", "does not match POINTS");
  expect_error(xyz_header("4000000000", "1", "4000000000") + "DATA binary\n",
               "WIDTH 4000000000 is too large");
  expect_error(xyz_header("2000000000", "2000000000", "4000000000000000000") + "DATA binary\n",
               "shorter than POINTS");
  expect_error(xyz_header("-5", "1", "-5") + "DATA binary\n",
               "WIDTH: expected a non-negative integer, got '-5'");
  expect_error(xyz_header("abc", "1", "3") + "DATA binary\n", "got 'abc'");
  expect_error(xyz_header("3", "1", "3x") + "DATA binary\n", "got '3x'");
  expect_error(xyz_header("2", "1", "99999999999999999999999") + "DATA binary\n", "POINTS");
  expect_error(xyz_header("0", "1", "0") + "DATA binary\n", "no points");
  expect_error(xyz_header("0", "0", "0") + "DATA ascii\n", "no points");
  expect_error("FIELDS x y z\nSIZE 4 4 4\nTYPE F X F\nWIDTH 1\nDATA binary\n", "unknown TYPE 'X'");
  expect_error("FIELDS x y z\nSIZE 4 4 4\nTYPE F FF F\nWIDTH 1\nDATA binary\n",
               "unknown TYPE 'FF'");
  expect_error("FIELDS x y z\nSIZE 4 3 4\nTYPE F F F\nWIDTH 1\nDATA binary\n",
               "unsupported SIZE 3");
  expect_error("FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nWIDTH 1\nDATA binary\n",
               "unsupported SIZE 2 for TYPE F");
  expect_error("FIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nDATA binary\n", "SIZE lists 2 values");
  expect_error("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F F\nWIDTH 1\nDATA binary\n",
               "TYPE lists 4 values");
  expect_error("FIELDS x y z\nCOUNT 1 1\nWIDTH 1\nDATA binary\n", "COUNT lists 2 values");
  expect_error("FIELDS x y z\nCOUNT 1 0 1\nWIDTH 1\nDATA binary\n", "COUNT 0 out of range");
  expect_error("FIELDS x y z\nCOUNT 1 1 3\nWIDTH 1\nDATA binary\n", "field z has COUNT 3");
  expect_error("FIELDS x y z\nWIDTH 1\nDATA lzma\n", "unknown DATA encoding 'lzma'");
  expect_error("FIELDS x y z\nWIDTH 1\nWIDTH 1\nDATA binary\n", "WIDTH appears twice");
  expect_error("FIELDS\nWIDTH 1\nDATA binary\n", "FIELDS line lists no field");
  expect_error("WIDTH 1\nDATA binary\n", "no FIELDS line");
  expect_error("FIELDS x y z\nDATA binary\n", "neither WIDTH nor POINTS");
  expect_error("FIELDS x y intensity\nWIDTH 1\nDATA ascii\n1 2 3\n",
               "fields x, y and z are required");
  expect_error("FIELDS x y z rgb\nSIZE 4 4 4 2\nTYPE F F F U\nWIDTH 1\nDATA ascii\n1 2 3 4\n",
               "field rgb has SIZE 2");
  expect_error("VIEWPOINT 0 0 0 1 0 0\nFIELDS x y z\nWIDTH 1\nDATA ascii\n1 2 3\n",
               "VIEWPOINT needs 7 values (tx ty tz qw qx qy qz), got 6");
  expect_error("VIEWPOINT 0 0 0 1 0 nan 0\nFIELDS x y z\nWIDTH 1\nDATA ascii\n1 2 3\n",
               "VIEWPOINT: expected a finite number, got 'nan'");
}

TEST(PcdBadInput, BinaryDataProblems) {
  EXPECT_NO_THROW(parse(xyz_binary(2)));
  expect_error(xyz_binary(1), "binary data of 12 bytes is shorter than POINTS*point size = 2*12");
  expect_error(xyz_binary(0), "shorter than POINTS");
  // Every proper prefix of a valid binary file fails cleanly.
  const Bytes good = encode_pcd(synthetic_cloud(5, 3), {.encoding = PcdEncoding::binary});
  for (std::size_t n = 0; n < good.size(); ++n) {
    EXPECT_THROW(parse_pcd(good.data(), n, "prefix.pcd"), std::runtime_error) << n;
  }
}

TEST(PcdBadInput, CompressedDataProblems) {
  const std::string header = std::string(kXyzHeader) + "DATA binary_compressed\n";
  Bytes soa;
  for (int i = 0; i < 6; ++i) append_value(soa, static_cast<float>(i));
  EXPECT_NO_THROW(parse(compressed_file(header, soa)));

  Bytes file = compressed_file(header, soa);
  const std::size_t sizes_at = header.size();
  auto with_sizes = [&](std::uint32_t compressed, std::uint32_t uncompressed) {
    Bytes f = file;
    std::memcpy(f.data() + sizes_at, &compressed, 4);
    std::memcpy(f.data() + sizes_at + 4, &uncompressed, 4);
    return f;
  };
  expect_error(to_bytes(header + "\x05"), "truncated before its size fields");
  expect_error(with_sizes(1000, 24), "compressed size 1000 is larger than the remaining");
  expect_error(with_sizes(25, 48), "uncompressed size 48 does not match POINTS*point size = 2*12");
  expect_error(with_sizes(0, 24), "lying header");
  // Corrupt stream: a back-reference before the start of the output.
  Bytes corrupt = with_sizes(25, 24);
  corrupt[sizes_at + 8] = 0xe0;  // long back-reference
  expect_error(corrupt, "expected 24 (corrupt data)");
  // Stream shorter than declared: decompresses to fewer bytes.
  Bytes short_stream = to_bytes(header);
  const Bytes lzf = lzf_literals(Bytes(soa.begin(), soa.begin() + 20));
  append_value<std::uint32_t>(short_stream, static_cast<std::uint32_t>(lzf.size()));
  append_value<std::uint32_t>(short_stream, 24);
  short_stream.insert(short_stream.end(), lzf.begin(), lzf.end());
  expect_error(short_stream, "decompressed to 20 bytes, expected 24");
  // A tiny file claiming a huge cloud must fail before allocating it.
  Bytes lying = to_bytes(xyz_header("100000000", "1", "100000000") + "DATA binary_compressed\n");
  append_value<std::uint32_t>(lying, 4);
  append_value<std::uint32_t>(lying, 1200000000u);
  lying.insert(lying.end(), {0, 0, 0, 0});
  expect_error(lying, "lying header");
  // A narrow cloud's planes (rows padded to 16 elements) from a maximally compressed stream need
  // 16 * 100000 * 12 bytes, over 1000x the ~14 kB file: rejected. The same stream as one row is
  // fine.
  const Bytes zeros = lzf_zeros(1200000);
  for (const char* dims : {"1 100000", "100000 1"}) {
    const std::string width = std::string(dims).substr(0, std::string(dims).find(' '));
    const std::string height = std::string(dims).substr(width.size() + 1);
    Bytes f = to_bytes(xyz_header(width, height, "100000") + "DATA binary_compressed\n");
    append_value<std::uint32_t>(f, static_cast<std::uint32_t>(zeros.size()));
    append_value<std::uint32_t>(f, 1200000);
    f.insert(f.end(), zeros.begin(), zeros.end());
    if (width == "1") {
      expect_error(f, "bytes can justify");
    } else {
      const OrganizedCloud c = parse(f);
      EXPECT_EQ(c.count_valid(), 100000u);
      EXPECT_EQ(c.z(99999, 0), 0.0f);
    }
  }
  // Declared size past 4 GiB cannot match the 32-bit size field.
  expect_error(to_bytes(xyz_header("1000000000", "1", "1000000000") + "DATA binary_compressed\n" +
                        std::string(8, '\0')),
               "does not match POINTS*point size");

  const Bytes good =
      encode_pcd(synthetic_cloud(5, 3), {.encoding = PcdEncoding::binary_compressed});
  for (std::size_t n = 0; n < good.size(); ++n) {
    EXPECT_THROW(parse_pcd(good.data(), n, "prefix.pcd"), std::runtime_error) << n;
  }
}

TEST(PcdBadInput, AsciiDataProblems) {
  const std::string header = std::string(kXyzHeader) + "DATA ascii\n";
  EXPECT_NO_THROW(parse(to_bytes(header + "1 2 3\n4 5 6\n")));
  expect_error(header + "1 2 3\n", "cannot hold 2 points");
  expect_error(header + "1 2 3\n\n\n\n\n\n\n\n\n\n\n", "ascii data ends after 1 of 2 points");
  expect_error(header + "1 2 3\n4 5\n   \n", "line 2 (point 1) has 2 values, expected 3");
  expect_error(header + "1 2 3 4\n4 5 6\n", "has more than 3 values");
  expect_error(header + "1 2 3\n4 five 6\n", "bad value 'five' for field y");
  expect_error(header + "1 2 3\n4 1e99 6\n", "bad value '1e99'");
  expect_error("FIELDS x y z label\nSIZE 4 4 4 1\nTYPE F F F U\nWIDTH 1\nDATA ascii\n1 2 3 256\n",
               "bad value '256' for field label");
  expect_error(
      "FIELDS x y z label\nSIZE 4 4 4 2\nTYPE F F F I\nWIDTH 1\nDATA ascii\n1 2 3 -40000\n",
      "bad value '-40000'");
  expect_error(xyz_header("1000000", "1000", "1000000000") + "DATA ascii\n1 2 3\n", "cannot hold");
}

}  // namespace

namespace {

// The fuzzer's seed files are valid PCD files of every encoding.
TEST(PcdCorpus, SeedFilesParse) {
  const std::filesystem::path dir =
      std::filesystem::path(RANGESEG_SOURCE_DIR) / "fuzz" / "corpus" / "pcd";
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << "no corpus at " << dir;
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".pcd") continue;
    SCOPED_TRACE(entry.path().string());
    PcdInfo info;
    const OrganizedCloud c = read_pcd(entry.path().string(), &info);
    EXPECT_GT(c.count_valid(), 0u);
    ++files;
  }
  EXPECT_GE(files, 6);
}

}  // namespace
