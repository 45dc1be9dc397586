#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "cli_util.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/perceptron.hpp"
#include "rangeseg/io/rasterfile.hpp"
#include "test_util.hpp"

using namespace rangeseg;
using rangeseg::test::expect_runtime_error_with;

namespace {

constexpr int kSide = 512;

/// A Perceptron file: a 10-line header with `line_end`, `gap` bytes, then the words.
std::vector<std::uint8_t> perceptron_file(const std::vector<std::uint32_t>& words,
                                          const std::string& line_end = "\n",
                                          const std::string& gap = "\n") {
  std::string header;
  for (int line = 0; line < 10; ++line) {
    header += "field" + std::to_string(line) + ": " + std::to_string(100 + line) + line_end;
  }
  header += gap;
  std::vector<std::uint8_t> bytes(header.begin(), header.end());
  for (const std::uint32_t w : words) {
    for (int k = 3; k >= 0; --k) bytes.push_back(static_cast<std::uint8_t>(w >> (8 * k)));
  }
  return bytes;
}

/// A box on a floor in front of a wall, in the camera frame (x right, y down, z forward) [m].
/// Labels: 10 floor, 11 wall, 12 box front, 13 box top, 14 box left side.
struct Hit {
  double t = std::numeric_limits<double>::infinity();
  int label = 0;
};

Hit cast(const io::PerceptronRay& ray) {
  const auto& o = ray.origin;
  const auto& d = ray.direction;
  Hit best;
  const auto consider = [&](double t, int label) {
    if (t > 0 && t < best.t) best = {t, label};
  };
  if (d[1] > 0) consider((1.0 - o[1]) / d[1], 10);  // floor y = 1
  if (d[2] > 0) consider((5.0 - o[2]) / d[2], 11);  // wall z = 5
  // Box x in [0.3, 1.0], y in [0.4, 1.0], z in [2.8, 3.4]: the entry face of the slab test.
  const std::array<double, 3> lo{0.3, 0.4, 2.8}, hi{1.0, 1.0, 3.4};
  double enter = -1e9, leave = 1e9;
  int face = 0;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (o[a] < lo[a] || o[a] > hi[a]) return best;
      continue;
    }
    double t0 = (lo[a] - o[a]) / d[a], t1 = (hi[a] - o[a]) / d[a];
    const bool from_low = t0 < t1;
    if (!from_low) std::swap(t0, t1);
    if (t0 > enter) {
      enter = t0;
      face = a == 2 ? 12 : a == 1 ? 13 : (from_low ? 14 : 15);
    }
    leave = std::min(leave, t1);
  }
  if (enter <= leave) consider(enter, face);
  return best;
}

struct Scan {
  std::vector<std::uint32_t> words;  // file words: reflectance bits above the range
  LabelImage labels{kSide, kSide, 0};
};

/// The box scene as the Perceptron scanner sees it, with Gaussian range noise [m].
Scan scan_scene(double noise_m, std::uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Scan scan;
  scan.words.resize(static_cast<std::size_t>(kSide) * kSide);
  for (int r = 0; r < kSide; ++r) {
    for (int c = 0; c < kSide; ++c) {
      const io::PerceptronRay ray = io::perceptron_ray(r, c, kSide, kSide);
      const Hit hit = cast(ray);
      const double t = hit.t + noise_m * gauss(rng);
      const long range = std::lround((t - ray.offset) / ray.step);
      EXPECT_GE(range, 0);
      EXPECT_LE(range, 4095);
      const auto reflectance = static_cast<std::uint32_t>((r * 7 + c * 3) & 0xfff);
      scan.words[static_cast<std::size_t>(r) * kSide + c] =
          0x80000000u | reflectance << 12 | static_cast<std::uint32_t>(range & 0xfff);
      scan.labels(c, r) = hit.label;
    }
  }
  return scan;
}

/// Least-squares plane of a set of points: RMS residual [m] and unit normal.
void fit_plane(const std::vector<Eigen::Vector3d>& pts, double& rms, Eigen::Vector3d& normal) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : pts) mean += p;
  mean /= static_cast<double>(pts.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) scatter += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  normal = eig.eigenvectors().col(0);
  rms = std::sqrt(eig.eigenvalues()(0) / static_cast<double>(pts.size()));
}

}  // namespace

TEST(Perceptron, ThePixelOnTheAxisMeasuresAlongZ) {
  // In a 3 x 3 image the centre pixel has both mirror angles 0: the beam leaves the nodding
  // mirror at the origin and R counts (R + r0) delta scanner units (cm) along z.
  Plane<std::uint16_t> range(3, 3, 1000);
  const OrganizedCloud cloud = io::perceptron_range_to_cloud(range.view());
  EXPECT_NEAR(cloud.x(1, 1), 0.0, 1e-7);
  EXPECT_NEAR(cloud.y(1, 1), 0.0, 1e-7);
  EXPECT_NEAR(cloud.z(1, 1), (1000 + 830.3) * 0.20236 * 0.01, 1e-5);
  // Column 0 is on the left (x < 0), row 0 at the top (y < 0, y points down).
  EXPECT_LT(cloud.x(0, 1), -0.1);
  EXPECT_GT(cloud.x(2, 1), 0.1);
  EXPECT_LT(cloud.y(1, 0), -0.1);
  EXPECT_GT(cloud.y(1, 2), 0.1);
  // The outermost columns are half a pixel inside the 51.65 deg field.
  const io::PerceptronRay left = io::perceptron_ray(1, 0, 3, 3);
  const double angle = std::atan2(-left.direction[0], left.direction[2]);
  EXPECT_NEAR(angle, 51.65 / 3 * 3.14159265358979 / 180, 1e-9);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      const auto d = io::perceptron_ray(r, c, 3, 3).direction;
      EXPECT_NEAR(d[0] * d[0] + d[1] * d[1] + d[2] * d[2], 1.0, 1e-12);
    }
  }
}

TEST(Perceptron, ACornerPixelFollowsTheMirrorGeometry) {
  // The USF model written out for pixel (row 0, column 0) of a 512 x 512 image and range 2000,
  // in scanner units (cm) and the scanner frame (X left, Y up, Z forward).
  const double deg = 3.14159265358979323846 / 180;
  const double alpha = 51.65 * 255.5 / 512 * deg, beta = 36.73 * 255.5 / 512 * deg;
  const double dz = -3.0 * (1 - std::cos(alpha)) / std::tan(45 * deg);
  const double dy = dz * std::tan(45 * deg + beta / 2);
  const double dx = (5.5 + dy) * std::tan(alpha);
  const double r1 = (dz - 5.5) / 0.20236;
  const double r2 = std::hypot(dx, 5.5 + dy) / 0.20236;
  const double r3 = (2000 + 830.3 - r1 - r2) * 0.20236;
  const double X = dx + r3 * std::sin(alpha), Y = dy + r3 * std::cos(alpha) * std::sin(beta),
               Z = dz + r3 * std::cos(alpha) * std::cos(beta);
  Plane<std::uint16_t> range(512, 512, 2000);
  const OrganizedCloud cloud = io::perceptron_range_to_cloud(range.view());
  EXPECT_NEAR(cloud.x(0, 0), -0.01 * X, 2e-6);
  EXPECT_NEAR(cloud.y(0, 0), -0.01 * Y, 2e-6);
  EXPECT_NEAR(cloud.z(0, 0), 0.01 * Z, 2e-6);
  // The beam leaves the nodding mirror off the origin there (millimetres, not zero).
  const io::PerceptronRay ray = io::perceptron_ray(0, 0, 512, 512);
  EXPECT_GT(std::abs(ray.origin[0]), 0.01);
}

TEST(Perceptron, DecodesTheTwelveRangeBitsOfEachWord) {
  std::vector<std::uint32_t> words(static_cast<std::size_t>(kSide) * kSide);
  for (std::size_t i = 0; i < words.size(); ++i) {
    words[i] = static_cast<std::uint32_t>(i * 2654435761u);  // every bit pattern appears
  }
  // Two bytes follow the header's last field, whatever they are made of.
  for (const auto& [line_end, gap] :
       {std::pair<std::string, std::string>{"\n", "\n"}, {"\r\n", ""}, {" \n", ""}}) {
    const std::vector<std::uint8_t> bytes = perceptron_file(words, line_end, gap);
    EXPECT_EQ(io::segcomp_sensor(bytes.data(), bytes.size()), io::SegcompSensor::perceptron);
    const Plane<std::uint16_t> range =
        io::decode_perceptron_range(bytes.data(), bytes.size(), "x.range");
    ASSERT_EQ(range.width(), kSide);
    ASSERT_EQ(range.height(), kSide);
    for (int r = 0; r < kSide; ++r) {
      for (int c = 0; c < kSide; ++c) {
        ASSERT_EQ(range(c, r), words[static_cast<std::size_t>(r) * kSide + c] & 0xfff)
            << "pixel " << c << ", " << r;
      }
    }
  }
}

TEST(Perceptron, BadFilesNameTheFileAndTheProblem) {
  const std::vector<std::uint32_t> words(static_cast<std::size_t>(kSide) * kSide, 0x123);
  const std::vector<std::uint8_t> good = perceptron_file(words);
  const auto decode = [](const std::vector<std::uint8_t>& bytes) {
    return [bytes] { io::decode_perceptron_range(bytes.data(), bytes.size(), "bad.range"); };
  };
  std::vector<std::uint8_t> truncated(good.begin(), good.end() - 1);
  expect_runtime_error_with(decode(truncated), "bad.range");
  std::vector<std::uint8_t> extra = good;
  extra.insert(extra.end(), 20, 0);
  expect_runtime_error_with(decode(extra), "bad.range");
  expect_runtime_error_with(decode({}), "bytes");
  std::vector<std::uint8_t> binary(good.size() + 2000, 0xff);
  expect_runtime_error_with(decode(binary), "not text (no line end in 1024 bytes)");
  std::vector<std::uint8_t> short_binary(good.size(), 0xff);
  expect_runtime_error_with(decode(short_binary), "header ends after 0 of its 10 lines");
  std::vector<std::uint8_t> nul = good;
  nul[3] = 0;
  expect_runtime_error_with(decode(nul), "NUL byte at 3");
  // Header text in any 8-bit encoding (here a Latin-1 degree sign) is read.
  std::vector<std::uint8_t> latin1 = good;
  latin1[2] = 0xb0;
  EXPECT_NO_THROW(decode(latin1)());
  // Nine header lines: the pixels would start inside the header.
  std::vector<std::uint8_t> nine = perceptron_file(words, "\n", "");
  nine.erase(nine.begin(), std::find(nine.begin(), nine.end(), '\n') + 1);
  expect_runtime_error_with(decode(nine), "bad.range");
  for (const auto& [line_end, gap] :
       {std::pair<std::string, std::string>{"\n", ""}, {"\r\n", "\r\n"}, {"\n", "#\n"}}) {
    expect_runtime_error_with(decode(perceptron_file(words, line_end, gap)), "bad.range");
  }
  // The reader of either format names the file too.
  const auto dir = test::scratch_dir("perceptron_bad");
  const std::string path = (dir / "perc.test.1.range").string();
  io::write_file_atomic(path, truncated);
  expect_runtime_error_with([&] { io::read_segcomp_range(path); }, "perc.test.1.range");
}

TEST(Perceptron, ScannedPlanesComeOutPlanarWithTheirNormals) {
  const Scan scan = scan_scene(0.0);
  const auto dir = test::scratch_dir("perceptron_planes");
  const std::string path = (dir / "perc.test.0.range").string();
  io::write_file_atomic(path, perceptron_file(scan.words));
  io::SegcompSensor sensor = io::SegcompSensor::abw;
  const OrganizedCloud cloud = io::read_segcomp_range(path, &sensor);
  EXPECT_EQ(sensor, io::SegcompSensor::perceptron);
  ASSERT_EQ(cloud.width(), kSide);
  ASSERT_EQ(cloud.count_valid(), static_cast<std::size_t>(kSide) * kSide);
  const Eigen::Vector3d normals[] = {Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(),
                                     Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitY(),
                                     Eigen::Vector3d::UnitX()};
  for (int label = 10; label <= 14; ++label) {
    std::vector<Eigen::Vector3d> pts;
    for (int v = 0; v < kSide; ++v) {
      for (int u = 0; u < kSide; ++u) {
        if (scan.labels(u, v) == label) {
          pts.emplace_back(cloud.x(u, v), cloud.y(u, v), cloud.z(u, v));
        }
      }
    }
    ASSERT_GT(pts.size(), 500u) << "label " << label;
    double rms = 0;
    Eigen::Vector3d n;
    fit_plane(pts, rms, n);
    // Range steps of 2.0 mm: a uniform rounding error of 0.58 mm RMS along the rays.
    EXPECT_LT(rms, 0.0008) << "label " << label;
    const double cosine = std::abs(n.dot(normals[label - 10]));
    EXPECT_GT(cosine, std::cos(0.2 * 3.14159265358979 / 180)) << "label " << label;
  }
}

TEST(Perceptron, EvalSegcompScoresPerceptronImagesInNumberOrder) {
  const Scan scan = scan_scene(0.004);
  const auto dir = test::scratch_dir("perceptron_segcomp");
  BytePlane gt(kSide, kSide, 0);
  for (int v = 0; v < kSide; ++v) {
    for (int u = 0; u < kSide; ++u) gt(u, v) = static_cast<std::uint8_t>(scan.labels(u, v));
  }
  for (const char* stem : {"perc.test.10", "perc.test.2"}) {
    io::write_file_atomic((dir / (std::string(stem) + ".range")).string(),
                          perceptron_file(scan.words));
    io::write_rasterfile((dir / (std::string(stem) + ".gt-seg")).string(), gt.view());
  }
  // A range image without ground truth is left out; a damaged one is reported and skipped.
  io::write_file_atomic((dir / "perc.test.3.range").string(), perceptron_file(scan.words));
  std::vector<std::uint8_t> damaged = perceptron_file(scan.words);
  damaged.pop_back();
  io::write_file_atomic((dir / "perc.test.7.range").string(), damaged);
  io::write_rasterfile((dir / "perc.test.7.gt-seg").string(), gt.view());
  const test::CliResult r = test::run_cli("eval-segcomp " + dir.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("perc.test.7.range      skipped: Perceptron range image"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("1 of 3 images skipped"), std::string::npos) << r.out;
  const std::size_t two = r.out.find("perc.test.2.range"), ten = r.out.find("perc.test.10.range");
  ASSERT_NE(two, std::string::npos) << r.out;
  ASSERT_NE(ten, std::string::npos) << r.out;
  EXPECT_LT(two, ten) << r.out;
  EXPECT_EQ(r.out.find("perc.test.3"), std::string::npos) << r.out;
  int gt_regions = 0, ms_regions = 0, correct = 0;
  ASSERT_EQ(std::sscanf(r.out.c_str() + two, "perc.test.2.range %d %d %d", &gt_regions, &ms_regions,
                        &correct),
            3)
      << r.out;
  EXPECT_EQ(gt_regions, 5);
  EXPECT_EQ(correct, 5) << r.out;

  const auto bad = test::scratch_dir("perceptron_segcomp_bad");
  io::write_file_atomic((bad / "perc.test.7.range").string(), damaged);
  io::write_rasterfile((bad / "perc.test.7.gt-seg").string(), gt.view());
  const test::CliResult none_scored = test::run_cli("eval-segcomp " + bad.string());
  EXPECT_EQ(none_scored.code, 2) << none_scored.out;
  EXPECT_NE(none_scored.out.find("none of the 1 images could be scored"), std::string::npos)
      << none_scored.out;
  const test::CliResult bad_preset =
      test::run_cli("eval-segcomp " + dir.string() + " --preset lidar");
  EXPECT_EQ(bad_preset.code, 2) << bad_preset.out;
  EXPECT_EQ(bad_preset.out.find("perc.test.2.range"), std::string::npos) << bad_preset.out;

  const auto empty = test::scratch_dir("perceptron_segcomp_empty");
  io::write_file_atomic((empty / "perc.test.3.range").string(), perceptron_file(scan.words));
  const test::CliResult none = test::run_cli("eval-segcomp " + empty.string());
  EXPECT_EQ(none.code, 2);
  EXPECT_NE(none.out.find("no .range file with a .gt-seg"), std::string::npos) << none.out;
  EXPECT_NE(none.out.find("perc.test.3.range has no ground truth"), std::string::npos) << none.out;

  const test::CliResult info = test::run_cli("info " + (dir / "perc.test.2.range").string());
  EXPECT_EQ(info.code, 0) << info.out;
  EXPECT_NE(info.out.find("SegComp Perceptron range image"), std::string::npos) << info.out;
}

TEST(Perceptron, SynthSimulatesTheScannerAndItsPresetHoldsAtTenMillimetres) {
  const auto dir = test::scratch_dir("perceptron_synth");
  const test::CliResult synth = test::run_cli(
      "synth --scene boxes --seed 3 --camera perceptron "
      "--noise constant:0.005 -o " +
      dir.string());
  ASSERT_EQ(synth.code, 0) << synth.out;
  const test::CliResult info = test::run_cli("info " + (dir / "cloud.pcd").string());
  EXPECT_NE(info.out.find("512 x 512"), std::string::npos) << info.out;
  std::ifstream camera_file(dir / "camera.json");
  const std::string camera((std::istreambuf_iterator<char>(camera_file)),
                           std::istreambuf_iterator<char>());
  EXPECT_NE(camera.find("528.97"), std::string::npos) << camera;  // 256 / tan(51.65 / 2 deg)

  // Constant range noise of 10 mm, the top of what such a laser shows: the preset's bounds
  // still find the boxes (39 of 44 regions when measured), where a sigma of 5 mm cuts them up.
  const std::string eval =
      "eval-synth --scene boxes --seeds 1-4 --camera perceptron --noise "
      "constant:0.01 --preset perceptron";
  const test::CliResult r = test::run_cli(eval);
  ASSERT_EQ(r.code, 0) << r.out;
  int correct = 0, regions = 0;
  const std::size_t at = r.out.find("correctly detected: ");
  ASSERT_NE(at, std::string::npos) << r.out;
  ASSERT_EQ(std::sscanf(r.out.c_str() + at, "correctly detected: %d of %d", &correct, &regions), 2);
  EXPECT_EQ(regions, 44);
  EXPECT_GE(correct, 37) << r.out;

  for (const char* bad :
       {"--noise constant:0", "--noise constant:x", "--noise laser", "--camera pinhole"}) {
    const test::CliResult b = test::run_cli("synth -o " + dir.string() + " " + bad);
    EXPECT_EQ(b.code, 2) << bad << ": " << b.out;
    const std::string value = std::string(bad).substr(std::string(bad).find(' ') + 1);
    EXPECT_NE(b.out.find(value), std::string::npos) << bad << ": " << b.out;
  }
}
