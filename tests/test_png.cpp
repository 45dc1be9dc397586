#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "rangeseg/camera.hpp"
#include "rangeseg/colorize.hpp"
#include "rangeseg/io/camera_json.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/png.hpp"
#include "test_util.hpp"

#include <png.h>
#include <zlib.h>

using namespace rangeseg;
using rangeseg::test::expect_runtime_error_with;

namespace {

DepthImage pattern(int w, int h) {
  DepthImage d(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      d(x, y) = static_cast<std::uint16_t>((x * 2654435761u + y * 40503u) & 0xffff);
    }
  }
  d(0, 0) = 0;
  d(w - 1, h - 1) = 65535;
  return d;
}

void write_bytes(const std::filesystem::path& p, const std::vector<std::uint8_t>& b) {
  io::write_file_atomic(p.string(), b);
}

}  // namespace

TEST(Png, DepthRoundTripIsBitExact) {
  const auto dir = test::scratch_dir("png_depth");
  const DepthImage d = pattern(37, 11);  // odd width: no stride assumptions
  const std::string path = (dir / "d.png").string();
  io::write_depth_png(path, d.view());
  const DepthImage back = io::read_depth_png(path);
  ASSERT_EQ(back.width(), 37);
  ASSERT_EQ(back.height(), 11);
  for (int y = 0; y < 11; ++y) {
    for (int x = 0; x < 37; ++x) ASSERT_EQ(back(x, y), d(x, y)) << x << "," << y;
  }
}

TEST(Png, LabelRoundTripIsBitExactAndRangeChecked) {
  const auto dir = test::scratch_dir("png_label");
  LabelImage labels(20, 7, 0);
  for (int y = 0; y < 7; ++y) {
    for (int x = 0; x < 20; ++x) labels(x, y) = (x * 7 + y * 1000) % 65536;
  }
  labels(3, 3) = 65535;
  const std::string path = (dir / "l.png").string();
  io::write_label_png(path, labels);
  const LabelImage back = io::read_label_png(path);
  ASSERT_EQ(back.width(), 20);
  for (int y = 0; y < 7; ++y) {
    for (int x = 0; x < 20; ++x) ASSERT_EQ(back(x, y), labels(x, y));
  }

  labels(1, 2) = 70000;
  EXPECT_THROW(io::write_label_png((dir / "bad.png").string(), labels), std::invalid_argument);
  labels(1, 2) = -1;
  EXPECT_THROW(io::write_label_png((dir / "bad.png").string(), labels), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.png"));
}

TEST(Png, RgbIsRejectedAsDepthAndEightBitGrayIsWidened) {
  const auto dir = test::scratch_dir("png_rgb");
  RgbImage rgb = RgbImage::black(5, 4);
  for (std::size_t i = 0; i < rgb.rgb.size(); ++i) rgb.rgb[i] = static_cast<std::uint8_t>(i * 13);
  const std::string path = (dir / "c.png").string();
  io::write_rgb_png(path, rgb);
  expect_runtime_error_with([&] { io::read_depth_png(path); }, path);
  expect_runtime_error_with([&] { io::read_depth_png(path); }, "RGB");
  EXPECT_THROW(io::write_rgb_png(path, RgbImage{.width = 2, .height = 2, .rgb = {1, 2, 3}}),
               std::invalid_argument);
}

namespace {

// An independent 8-bit encoder: libpng's simplified write API (the library uses the low-level
// one), so the 8-bit and non-gray reading paths are checked against files we did not write.
std::vector<std::uint8_t> simplified_png(int w, int h, png_uint_32 format,
                                         const std::vector<std::uint8_t>& pixels) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(w);
  image.height = static_cast<png_uint_32>(h);
  image.format = format;
  png_alloc_size_t size = 0;
  EXPECT_TRUE(png_image_write_get_memory_size(image, size, 0, pixels.data(), 0, nullptr));
  std::vector<std::uint8_t> bytes(size);
  EXPECT_TRUE(png_image_write_to_memory(&image, bytes.data(), &size, 0, pixels.data(), 0, nullptr));
  bytes.resize(size);
  return bytes;
}

}  // namespace

TEST(Png, EightBitGrayIsWidenedAndOtherTypesAreRejected) {
  const std::vector<std::uint8_t> gray = {0, 7, 200, 255, 1, 2};
  const auto file = simplified_png(3, 2, PNG_FORMAT_GRAY, gray);
  const DepthImage d = io::decode_depth_png(file.data(), file.size(), "gray8.png");
  ASSERT_EQ(d.width(), 3);
  ASSERT_EQ(d.height(), 2);
  EXPECT_EQ(d(1, 0), 7);
  EXPECT_EQ(d(2, 0), 200);
  EXPECT_EQ(d(0, 1), 255);

  const std::vector<std::uint8_t> ga = {0, 255, 7, 255, 9, 255, 1, 0, 3, 3, 4, 4};
  const auto gray_alpha = simplified_png(3, 2, PNG_FORMAT_GA, ga);
  expect_runtime_error_with(
      [&] { io::decode_depth_png(gray_alpha.data(), gray_alpha.size(), "ga.png"); }, "ga.png");
  expect_runtime_error_with(
      [&] { io::decode_depth_png(gray_alpha.data(), gray_alpha.size(), "ga.png"); },
      "grayscale+alpha");
}

TEST(Png, BadInputsThrowNamingTheFile) {
  const auto dir = test::scratch_dir("png_bad");
  const DepthImage d = pattern(64, 48);
  const std::vector<std::uint8_t> good = io::encode_depth_png(d.view());

  // Truncated at many points: always an exception, never a crash or a silent success.
  for (std::size_t cut : {std::size_t{0}, std::size_t{5}, std::size_t{8}, std::size_t{20},
                          std::size_t{33}, good.size() / 2, good.size() - 13, good.size() - 1}) {
    const std::string name = "cut" + std::to_string(cut) + ".png";
    EXPECT_THROW(io::decode_depth_png(good.data(), cut, name), std::runtime_error) << cut;
  }
  const auto truncated = dir / "truncated.png";
  write_bytes(truncated, std::vector<std::uint8_t>(good.begin(), good.begin() + good.size() / 2));
  expect_runtime_error_with([&] { io::read_depth_png(truncated.string()); }, "truncated.png");

  const auto text = dir / "text.png";
  io::write_file_atomic(text.string(), std::string("this is not a PNG file at all"));
  expect_runtime_error_with([&] { io::read_depth_png(text.string()); }, "text.png");
  expect_runtime_error_with([&] { io::read_label_png(text.string()); }, "text.png");
  expect_runtime_error_with([&] { io::read_depth_png((dir / "absent.png").string()); },
                            "absent.png");

  // Corrupt compressed data (flip bytes inside IDAT, CRC left wrong): libpng must report it.
  std::vector<std::uint8_t> corrupt = good;
  for (std::size_t i = 60; i < corrupt.size() - 20; i += 7) corrupt[i] ^= 0x5a;
  EXPECT_THROW(io::decode_depth_png(corrupt.data(), corrupt.size(), "corrupt.png"),
               std::runtime_error);
}

TEST(Png, HugeDimensionsAreRefusedBeforeAllocating) {
  const DepthImage d = pattern(4, 4);
  std::vector<std::uint8_t> file = io::encode_depth_png(d.view());
  // IHDR data starts at byte 16: width, height big-endian. Claim 60000 x 60000 and fix the CRC
  // with zlib's crc32 (linked through libpng) so that the size check is what rejects it.
  const auto put32 = [&](std::size_t at, std::uint32_t v) {
    for (int k = 0; k < 4; ++k) file[at + k] = static_cast<std::uint8_t>(v >> (24 - 8 * k));
  };
  put32(16, 60000);
  put32(20, 60000);
  put32(29, static_cast<std::uint32_t>(crc32(0, file.data() + 12, 17)));
  try {
    io::decode_depth_png(file.data(), file.size(), "huge.png");
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("huge.png"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("60000"), std::string::npos) << e.what();
  }
  // Below the 2^28 pixel cap but far more than a file of this size can decompress to.
  put32(16, 16000);
  put32(20, 16000);
  put32(29, static_cast<std::uint32_t>(crc32(0, file.data() + 12, 17)));
  try {
    io::decode_depth_png(file.data(), file.size(), "lying.png");
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("lying.png"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("16000"), std::string::npos) << e.what();
  }
}

TEST(Png, SharedDepthFrameMatchesIndependentDecode) {
  RANGESEG_REQUIRE_DATA("depth_png/00000.png");
  const DepthImage d = io::read_depth_png(data_file.string());
  ASSERT_EQ(d.width(), 640);
  ASSERT_EQ(d.height(), 480);
  std::size_t valid = 0;
  std::uint64_t sum = 0;
  for (int y = 0; y < 480; ++y) {
    for (int x = 0; x < 640; ++x) {
      if (d(x, y) != 0) ++valid, sum += d(x, y);
    }
  }
  // Reference values from an independent decoder: Python's zlib.decompress of the IDAT chunks
  // plus a hand-written PNG unfilter (filters 0-4), counting non-zero big-endian 16-bit samples.
  EXPECT_EQ(valid, 267129u);
  EXPECT_EQ(sum, 479199333u);
  EXPECT_EQ(d(320, 240), 2195);
  EXPECT_EQ(d(100, 240), 1377);
}

TEST(CameraJson, Open3dLayoutAndFlatLayout) {
  RANGESEG_REQUIRE_DATA("depth_png/camera_primesense.json");
  const CameraIntrinsics cam = io::read_camera_json(data_file.string());
  EXPECT_EQ(cam.fx, 525.0);
  EXPECT_EQ(cam.fy, 525.0);
  EXPECT_EQ(cam.cx, 319.5);
  EXPECT_EQ(cam.cy, 239.5);
  EXPECT_EQ(cam.width, 640);
  EXPECT_EQ(cam.height, 480);

  const CameraIntrinsics flat = io::parse_camera_json(
      R"({"fx": 600.5, "fy": 601, "cx": 320, "cy": 240.25, "width": 640, "height": 480})", "f");
  EXPECT_EQ(flat.fx, 600.5);
  EXPECT_EQ(flat.fy, 601.0);
  EXPECT_EQ(flat.cx, 320.0);
  EXPECT_EQ(flat.cy, 240.25);
  EXPECT_EQ(flat.width, 640);
  // Column-major: cx, cy are elements 6 and 7, not 2 and 5.
  const CameraIntrinsics o3d = io::parse_camera_json(
      R"({"width": 8, "height": 6, "intrinsic_matrix": [10, 0, 0, 0, 12, 0, 3.5, 2.5, 1]})", "o");
  EXPECT_EQ(o3d.fx, 10.0);
  EXPECT_EQ(o3d.fy, 12.0);
  EXPECT_EQ(o3d.cx, 3.5);
  EXPECT_EQ(o3d.cy, 2.5);
}

TEST(CameraJson, BadFilesNameFileAndKey) {
  const auto dir = test::scratch_dir("camera_json");
  const auto check = [&](const std::string& text, const std::string& key) {
    const auto path = (dir / "cam.json").string();
    io::write_file_atomic(path, text);
    expect_runtime_error_with([&] { io::read_camera_json(path); }, "cam.json");
    expect_runtime_error_with([&] { io::read_camera_json(path); }, key);
  };
  check("{ not json", "invalid JSON");
  check("[1, 2, 3]", "object");
  check(R"({"fx": 1, "fy": 1, "cx": 1})", "\"cy\"");
  check(R"({"fx": "525", "fy": 1, "cx": 1, "cy": 1})", "\"fx\"");
  check(R"({"fx": -5, "fy": 1, "cx": 1, "cy": 1})", "fx");
  check(R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0]})", "intrinsic_matrix");
  check(R"({"height": 480, "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})",
        "\"width\"");
  check(
      R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]})",
      "column-major");
  expect_runtime_error_with([&] { io::read_camera_json((dir / "none.json").string()); },
                            "none.json");
}

// Found by fuzz_png: a chunk declaring ~1 GB in a 91-byte file made libpng allocate the declared
// length (out of memory under the fuzzer). It must now fail cleanly before libpng sees it.
TEST(Png, FuzzRegressionLyingChunkLength) {
  const std::vector<std::uint8_t> file = {
      0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48,
      0x44, 0x52, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x10, 0x00, 0x00, 0x00,
      0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52, 0x00, 0x0c, 0x74, 0x45, 0x58, 0x74, 0x43,
      0x6f, 0x6d, 0x6d, 0x65, 0x6e, 0x74, 0x00, 0x73, 0x65, 0x65, 0x64, 0xcb, 0x99, 0xb6,
      0xe3, 0x00, 0x00, 0x00, 0x0b, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0x10, 0x32,
      0x01, 0x00, 0x00, 0x5b, 0x00, 0x47, 0x96, 0xfb, 0x1b, 0x65, 0x00, 0x00, 0x00, 0x00,
      0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};
  expect_runtime_error_with([&] { io::decode_depth_png(file.data(), file.size(), "oom.png"); },
                            "oom.png");
}
