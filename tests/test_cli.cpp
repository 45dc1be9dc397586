// End-to-end tests of the rangeseg command-line tool: outputs, exit codes, error messages.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include "cli_util.hpp"
#include "rangeseg/camera.hpp"
#include "rangeseg/colorize.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/sensor.hpp"
#include "rangeseg/synth.hpp"
#include "rangeseg/version.hpp"
#include "test_util.hpp"

namespace fs = std::filesystem;

namespace {

using rangeseg::test::CliResult;
using rangeseg::test::contains;
CliResult run(const std::string& args) { return rangeseg::test::run_cli(args); }

using rangeseg::test::read_text;
using rangeseg::test::small_frame;
using rangeseg::test::write_small_pcd;

void write_truncated_pcd(const fs::path& path) {
  std::ofstream(path) << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                         "WIDTH 100\nHEIGHT 100\nPOINTS 10000\nDATA binary\nabc";
}

using rangeseg::test::read_json;

int count_files(const fs::path& dir) {
  int n = 0;
  for ([[maybe_unused]] const auto& e : fs::recursive_directory_iterator(dir)) ++n;
  return n;
}

}  // namespace

TEST(Cli, SynthSegmentEvalRoundTrip) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_synth");
  const CliResult synth =
      run("synth -o " + (dir / "scene").string() + " --scene boxes --seed 3 --noise kinect");
  ASSERT_EQ(synth.code, 0) << synth.out;
  for (const char* f : {"cloud.pcd", "depth.png", "labels.png", "surfaces.json", "camera.json"}) {
    EXPECT_TRUE(fs::exists(dir / "scene" / f)) << f;
  }
  const CliResult seg =
      run("segment " + (dir / "scene" / "cloud.pcd").string() + " -o " + (dir / "seg").string());
  ASSERT_EQ(seg.code, 0) << seg.out;
  const rangeseg::LabelImage labels =
      rangeseg::io::read_label_png((dir / "seg" / "labels.png").string());
  EXPECT_EQ(labels.width(), 640);
  EXPECT_EQ(labels.height(), 480);
  const auto json = nlohmann::json::parse(read_text(dir / "seg" / "segments.json"));
  EXPECT_EQ(json["rangeseg_version"], RANGESEG_VERSION_STRING);
  ASSERT_FALSE(json["segments"].empty());
  int max_label = 0;
  for (int v = 0; v < labels.height(); ++v) {
    for (int u = 0; u < labels.width(); ++u) max_label = std::max(max_label, labels(u, v));
  }
  EXPECT_EQ(max_label, static_cast<int>(json["segments"].size()));
  const auto& first = json["segments"][0];
  EXPECT_NEAR(std::hypot(first["normal"][0].get<double>(), first["normal"][1].get<double>(),
                         first["normal"][2].get<double>()),
              1.0, 1e-6);
  EXPECT_TRUE(fs::exists(dir / "seg" / "overlay.png"));
  EXPECT_TRUE(fs::exists(dir / "seg" / "mesh.ply"));
  EXPECT_TRUE(fs::exists(dir / "seg" / "polygons.obj"));
  ASSERT_TRUE(first.contains("polygon")) << first.dump();
  EXPECT_GT(first["polygon"]["area_m2"].get<double>(), 0.0);
  EXPECT_EQ(first["plane_group"], first["id"]);  // the largest segment leads its group

  const CliResult eval = run("eval " + (dir / "scene" / "labels.png").string() + " " +
                             (dir / "seg" / "labels.png").string());
  ASSERT_EQ(eval.code, 0) << eval.out;
  EXPECT_NE(eval.out.find("correct"), std::string::npos);
  EXPECT_FALSE(rangeseg::test::contains(eval.out, "depth image")) << eval.out;
  // The scene's depth PNG given as the segmentation is scored, with a warning.
  const CliResult depth_as_labels = run("eval " + (dir / "scene" / "labels.png").string() + " " +
                                        (dir / "scene" / "depth.png").string());
  EXPECT_EQ(depth_as_labels.code, 0) << depth_as_labels.out;
  EXPECT_TRUE(rangeseg::test::contains(depth_as_labels.out, "depth.png: its "))
      << depth_as_labels.out;
  EXPECT_TRUE(rangeseg::test::contains(depth_as_labels.out, "is it a depth image?"))
      << depth_as_labels.out;
  // Labels numbered from 1000 (class x 1000 + instance) are piecewise constant: no warning.
  rangeseg::LabelImage from_1000 =
      rangeseg::io::read_label_png((dir / "scene" / "labels.png").string());
  for (int v = 0; v < from_1000.height(); ++v) {
    for (int u = 0; u < from_1000.width(); ++u) {
      if (from_1000(u, v) > 0) from_1000(u, v) += 1000;
    }
  }
  rangeseg::io::write_label_png((dir / "labels_from_1000.png").string(), from_1000);
  const CliResult shifted = run("eval " + (dir / "labels_from_1000.png").string() + " " +
                                (dir / "seg" / "labels.png").string() + " --min-gt-label 1001");
  EXPECT_EQ(shifted.code, 0) << shifted.out;
  EXPECT_FALSE(rangeseg::test::contains(shifted.out, "depth image")) << shifted.out;

  // Per-region outcomes, the JSON report, and the angle error from the scene's points.
  const std::string eval_args = "eval " + (dir / "scene" / "labels.png").string() + " " +
                                (dir / "seg" / "labels.png").string() + " --cloud " +
                                (dir / "scene" / "cloud.pcd").string();
  const CliResult detailed = run(eval_args + " --regions --json " + (dir / "eval.json").string());
  ASSERT_EQ(detailed.code, 0) << detailed.out;
  EXPECT_NE(detailed.out.find("ground-truth regions:"), std::string::npos) << detailed.out;
  const auto report = nlohmann::json::parse(read_text(dir / "eval.json"));
  ASSERT_EQ(report["gt"].size(), report["gt_regions"].get<std::size_t>());
  std::map<std::string, int> gt_outcomes;
  for (const auto& r : report["gt"]) ++gt_outcomes[r["outcome"].get<std::string>()];
  EXPECT_EQ(gt_outcomes["correct"], report["correct"].get<int>());
  EXPECT_EQ(gt_outcomes["missed"], report["missed"].get<int>());
  EXPECT_EQ(report["ms"].size(), report["ms_regions"].get<std::size_t>());
  ASSERT_GT(report["angle_pairs"].get<int>(), 0) << report.dump();
  EXPECT_LT(report["angle_mean_deg"].get<double>(), 5.0);
  const CliResult no_cloud =
      run("eval " + (dir / "scene" / "labels.png").string() + " " +
          (dir / "seg" / "labels.png").string() + " --cloud " + (dir / "missing.pcd").string());
  EXPECT_EQ(no_cloud.code, 2);
  EXPECT_NE(no_cloud.out.find("missing.pcd"), std::string::npos) << no_cloud.out;
  // A segmentation of another size: exit code 2, naming the file and both sizes.
  const fs::path small = dir / "small_labels.png";
  rangeseg::io::write_label_png(small.string(), rangeseg::LabelImage(64, 48));
  const CliResult wrong_size =
      run("eval " + (dir / "scene" / "labels.png").string() + " " + small.string());
  EXPECT_EQ(wrong_size.code, 2);
  EXPECT_NE(wrong_size.out.find("small_labels.png: the segmentation is 64x48"), std::string::npos)
      << wrong_size.out;
  EXPECT_NE(wrong_size.out.find("640x480"), std::string::npos) << wrong_size.out;
  // Ground truth the library rejects (a label beyond its range): the message names the files.
  rangeseg::OrganizedCloud labelled =
      rangeseg::io::read_pcd((dir / "scene" / "cloud.pcd").string());
  labelled.add_label();
  labelled.label(3, 3) = 2000000000;
  const fs::path huge_label = dir / "huge_label.pcd";
  rangeseg::io::write_pcd(huge_label.string(), labelled);
  const CliResult bad_gt =
      run("eval " + huge_label.string() + " " + (dir / "seg" / "labels.png").string());
  EXPECT_EQ(bad_gt.code, 2);
  EXPECT_NE(bad_gt.out.find("huge_label.pcd against"), std::string::npos) << bad_gt.out;
  EXPECT_NE(bad_gt.out.find("2000000000"), std::string::npos) << bad_gt.out;
  // An unsigned label from 2^31 on (kept bit for bit, negative as int32) is refused, not
  // scored as unlabelled.
  labelled.label(3, 3) = static_cast<std::int32_t>(3000000000U);
  const fs::path unsigned_label = dir / "unsigned_label.pcd";
  rangeseg::io::write_pcd(unsigned_label.string(), labelled);
  const CliResult bad_ms =
      run("eval " + (dir / "scene" / "labels.png").string() + " " + unsigned_label.string());
  EXPECT_EQ(bad_ms.code, 2);
  EXPECT_TRUE(rangeseg::test::contains(bad_ms.out, "unsigned_label.pcd: label 3000000000"))
      << bad_ms.out;
  // --min-gt-label: ground-truth labels below it are no region.
  const int all_regions = report["gt_regions"].get<int>();
  const CliResult without_first =
      run(eval_args + " --min-gt-label 2 --json " + (dir / "eval2.json").string());
  ASSERT_EQ(without_first.code, 0) << without_first.out;
  EXPECT_TRUE(rangeseg::test::contains(without_first.out, "labels >= 2 are regions"))
      << without_first.out;
  const auto report2 = nlohmann::json::parse(read_text(dir / "eval2.json"));
  EXPECT_EQ(report2["gt_regions"].get<int>(), all_regions - 1);
  EXPECT_EQ(report2["min_gt_label"].get<int>(), 2);

  // The depth PNG with the camera file gives the same grid as the PCD.
  const CliResult info = run("info " + (dir / "scene" / "depth.png").string() + " --intrinsics " +
                             (dir / "scene" / "camera.json").string());
  ASSERT_EQ(info.code, 0) << info.out;
  EXPECT_NE(info.out.find("640 x 480"), std::string::npos) << info.out;
}

// A frame whose mesh has no face (every other row empty) gives no segment, and says why and
// which setting joins its points; the batch says it once.
TEST(Cli, AFrameWithoutSegmentsSaysWhy) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_no_segments");
  rangeseg::OrganizedCloud rows = small_frame(3);
  for (int v = 1; v < rows.height(); v += 2) {
    for (int u = 0; u < rows.width(); ++u) rows.x(u, v) = rows.y(u, v) = rows.z(u, v) = NAN;
  }
  fs::create_directories(dir / "in");
  rangeseg::io::write_pcd((dir / "in" / "a.pcd").string(), rows);
  rangeseg::io::write_pcd((dir / "in" / "b.pcd").string(), rows);
  const CliResult one =
      run("segment " + (dir / "in" / "a.pcd").string() + " -o " + (dir / "out").string());
  EXPECT_EQ(one.code, 0) << one.out;
  EXPECT_TRUE(contains(one.out, "a.pcd: no segments: the mesh joins hardly any of the points"))
      << one.out;
  EXPECT_TRUE(contains(one.out, "every 2nd row from row 0")) << one.out;
  EXPECT_TRUE(contains(one.out, "\"pixel_stride\": 2")) << one.out;
  const CliResult batch =
      run("segment " + (dir / "in").string() + " -o " + (dir / "batch").string());
  EXPECT_EQ(batch.code, 0) << batch.out;
  std::size_t notes = 0;
  for (std::size_t at = batch.out.find("no segments"); at != std::string::npos;
       at = batch.out.find("no segments", at + 1)) {
    ++notes;
  }
  EXPECT_EQ(notes, 1u) << batch.out;
  // A frame with segments says nothing of the kind.
  write_small_pcd(dir / "full.pcd", 3);
  const CliResult full =
      run("segment " + (dir / "full.pcd").string() + " -o " + (dir / "full").string());
  EXPECT_EQ(full.code, 0) << full.out;
  EXPECT_FALSE(contains(full.out, "no segments")) << full.out;
}

TEST(Cli, BenchJsonHasEveryStage) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_bench");
  ASSERT_EQ(run("synth -o " + dir.string() + " --noise none").code, 0);
  const CliResult bench = run("bench " + (dir / "cloud.pcd").string() + " --json --repeat 2");
  ASSERT_EQ(bench.code, 0) << bench.out;
  const auto line = bench.out.substr(bench.out.find('{'));
  const auto json = nlohmann::json::parse(line);
  for (const char* key : {"mesh", "normals", "smoothing", "segmentation", "polygons", "total"}) {
    ASSERT_TRUE(json.contains(key)) << key;
    EXPECT_GE(json[key].get<double>(), 0.0);
  }
  EXPECT_GE(json["total"].get<double>(), json["mesh"].get<double>());
}

TEST(Cli, BadInputExitsWithTwoAndNamesTheFile) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_bad");
  const fs::path truncated = dir / "truncated.pcd";
  std::ofstream(truncated)
      << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 100\n"
         "HEIGHT 100\nPOINTS 10000\nDATA binary\nabc";
  const fs::path not_png = dir / "fake.png";
  std::ofstream(not_png) << "this is not a PNG";
  for (const fs::path& f : {truncated, not_png, dir / "missing.pcd", dir / "unknown.xyz"}) {
    const CliResult r = run("info " + f.string());
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_NE(r.out.find(f.filename().string()), std::string::npos) << r.out;
  }
  const CliResult seg = run("segment " + truncated.string() + " -o " + (dir / "out").string());
  EXPECT_EQ(seg.code, 2);
  EXPECT_FALSE(fs::exists(dir / "out" / "labels.png"));
  EXPECT_EQ(run("segment --preset nosuchsensor " + truncated.string() + " -o x").code, 2);
  EXPECT_EQ(run("no-such-command").code, 2);
  EXPECT_EQ(run("--help").code, 0);
}

TEST(Cli, FailedWriteLeavesNoFile) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_write");
  ASSERT_EQ(run("synth -o " + dir.string() + " --noise none").code, 0);
  const int before = count_files(dir);
  // The target directory does not exist: the write fails and nothing is left behind.
  const CliResult r =
      run("convert " + (dir / "cloud.pcd").string() + " " + (dir / "nodir" / "out.pcd").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(count_files(dir), before);
  const CliResult ok = run("convert " + (dir / "cloud.pcd").string() + " " +
                           (dir / "ascii.pcd").string() + " --encoding ascii");
  ASSERT_EQ(ok.code, 0) << ok.out;
  const auto a = rangeseg::io::read_pcd((dir / "cloud.pcd").string());
  const auto b = rangeseg::io::read_pcd((dir / "ascii.pcd").string());
  EXPECT_EQ(a.count_valid(), b.count_valid());
}

// A depth PNG keeps z only: `convert` writes the camera it fitted beside it, so that the points
// come back with --intrinsics; a cloud that is no depth camera's image is refused.
TEST(Cli, ConvertToDepthPngWritesItsIntrinsics) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_convert_png");
  ASSERT_EQ(run("synth -o " + dir.string() + " --noise none --seed 3").code, 0);
  const std::string png = (dir / "depth16.png").string(), json = (dir / "depth16.json").string();
  const CliResult r = run("convert " + (dir / "cloud.pcd").string() + " " + png);
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_TRUE(fs::exists(json)) << r.out;
  const CliResult back =
      run("convert " + png + " --intrinsics " + json + " " + (dir / "back.pcd").string());
  ASSERT_EQ(back.code, 0) << back.out;
  const auto a = rangeseg::io::read_pcd((dir / "cloud.pcd").string());
  const auto b = rangeseg::io::read_pcd((dir / "back.pcd").string());
  ASSERT_EQ(a.width(), b.width());
  ASSERT_EQ(a.height(), b.height());
  double worst = 0;
  for (int v = 0; v < a.height(); ++v) {
    for (int u = 0; u < a.width(); ++u) {
      ASSERT_EQ(a.valid(u, v), b.valid(u, v));
      if (!a.valid(u, v)) continue;
      // Millimetre depth units: z within 0.5 mm, x and y within that times the ray's slope.
      for (const float d : {a.x(u, v) - b.x(u, v), a.y(u, v) - b.y(u, v), a.z(u, v) - b.z(u, v)}) {
        worst = std::max(worst, static_cast<double>(std::abs(d)));
      }
    }
  }
  EXPECT_LT(worst, 6e-4);

  // Depths that 16 bits in this unit cannot hold (1 to 5 m in 10 um: beyond 0.66 m) are refused
  // with a unit that fits, not written as holes; --depth-scale is the output's unit here.
  const CliResult lossy = run("convert " + (dir / "cloud.pcd").string() + " " +
                              (dir / "fine.png").string() + " --depth-scale 0.00001");
  EXPECT_EQ(lossy.code, 2) << lossy.out;
  EXPECT_TRUE(contains(lossy.out, "cloud.pcd: " + std::to_string(a.count_valid()) + " of " +
                                      std::to_string(a.count_valid()) + " points would be lost"))
      << lossy.out;
  EXPECT_TRUE(contains(lossy.out, "give --depth-scale 0.0001 ")) << lossy.out;
  EXPECT_FALSE(contains(lossy.out, "apply to depth PNGs only")) << lossy.out;
  EXPECT_FALSE(fs::exists(dir / "fine.png"));
  EXPECT_FALSE(fs::exists(dir / "fine.json"));
  const CliResult fine = run("convert " + (dir / "cloud.pcd").string() + " " +
                             (dir / "fine.png").string() + " --depth-scale 0.0001");
  EXPECT_EQ(fine.code, 0) << fine.out;
  EXPECT_FALSE(contains(fine.out, "warning")) << fine.out;

  // x / z falling along the rows (a scanner's grid): no camera's image.
  const fs::path scan = dir / "scan.pcd";
  std::ofstream(scan) << "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                         "WIDTH 3\nHEIGHT 2\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 6\nDATA ascii\n"
                         "0.2 0 1\n0.1 0 1\n0 0 1\n0.2 0.1 1\n0.1 0.1 1\n0 0.1 1\n";
  const CliResult refused = run("convert " + scan.string() + " " + (dir / "scan.png").string());
  EXPECT_EQ(refused.code, 2) << refused.out;
  EXPECT_NE(refused.out.find("scan.pcd: not a depth camera's image"), std::string::npos)
      << refused.out;
  EXPECT_FALSE(fs::exists(dir / "scan.png"));
  EXPECT_FALSE(fs::exists(dir / "scan.json"));
}

// A cloud moved out of its sensor's frame, with the sensor's pose as VIEWPOINT (as PCL keeps
// it), is segmented with --apply-viewpoint in the sensor's frame like the cloud as it was seen;
// without it the points are taken as stored, and `convert` keeps them and the VIEWPOINT.
TEST(Cli, ViewpointMovesTheCloudBackIntoItsSensorsFrame) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_viewpoint");
  ASSERT_EQ(run("synth -o " + dir.string() + " --noise none --seed 2").code, 0);
  rangeseg::OrganizedCloud cloud = rangeseg::io::read_pcd((dir / "cloud.pcd").string());
  // The sensor 1.2 m up and turned 30 deg about x: p_world = R p + t.
  const double half = 0.5 * 30 * 3.14159265358979323846 / 180;
  const std::array<double, 7> pose{0.3, -1.2, 0.5, std::cos(half), std::sin(half), 0, 0};
  const double c = std::cos(2 * half), s = std::sin(2 * half);
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if (!cloud.valid(u, v)) continue;
      const double y = cloud.y(u, v), z = cloud.z(u, v);
      cloud.x(u, v) = static_cast<float>(cloud.x(u, v) + pose[0]);
      cloud.y(u, v) = static_cast<float>(c * y - s * z + pose[1]);
      cloud.z(u, v) = static_cast<float>(s * y + c * z + pose[2]);
    }
  }
  const std::string moved = (dir / "moved.pcd").string();
  rangeseg::io::write_pcd(moved, cloud, {.viewpoint = pose});
  const CliResult original = run("segment " + (dir / "cloud.pcd").string() + " -o " +
                                 (dir / "a").string() + " --preset ideal --no-mesh");
  ASSERT_EQ(original.code, 0) << original.out;
  const CliResult r = run("segment " + moved + " -o " + (dir / "b").string() +
                          " --preset ideal --no-mesh --apply-viewpoint");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("VIEWPOINT"), std::string::npos) << r.out;
  const auto a = rangeseg::io::read_label_png((dir / "a" / "labels.png").string());
  const auto b = rangeseg::io::read_label_png((dir / "b" / "labels.png").string());
  ASSERT_EQ(a.width(), b.width());
  // Each segment of the original against the one that shares most of its pixels (float
  // rounding of the move may flip a few border points, and equal segments may swap numbers).
  std::map<std::pair<int, int>, std::size_t> pairs;
  std::size_t labelled = 0;
  for (int v = 0; v < a.height(); ++v) {
    for (int u = 0; u < a.width(); ++u) {
      if (a(u, v) == 0) continue;
      ++labelled;
      ++pairs[{a(u, v), b(u, v)}];
    }
  }
  std::map<int, std::size_t> best;
  for (const auto& [key, n] : pairs) best[key.first] = std::max(best[key.first], n);
  std::size_t same = 0;
  for (const auto& [label, n] : best) same += n;
  ASSERT_GT(labelled, 100000u);
  EXPECT_GT(static_cast<double>(same), 0.995 * static_cast<double>(labelled));

  const CliResult stored = run("info " + moved);
  EXPECT_NE(stored.out.find("not applied"), std::string::npos) << stored.out;
  const CliResult applied = run("info " + moved + " --apply-viewpoint");
  EXPECT_NE(applied.out.find("moved into this sensor's frame"), std::string::npos) << applied.out;
  // Back in the sensor's frame: the depth range of the cloud as it was seen.
  const CliResult seen = run("info " + (dir / "cloud.pcd").string());
  const auto depth_line = [](const std::string& out) {
    const std::size_t at = out.find("depth:");
    return at == std::string::npos ? std::string() : out.substr(at, out.find('\n', at) - at);
  };
  EXPECT_FALSE(depth_line(seen.out).empty()) << seen.out;
  EXPECT_EQ(depth_line(applied.out), depth_line(seen.out));
  EXPECT_NE(depth_line(stored.out), depth_line(seen.out));

  const std::string copy = (dir / "copy.pcd").string();
  ASSERT_EQ(run("convert " + moved + " " + copy).code, 0);
  rangeseg::io::PcdInfo info;
  const rangeseg::OrganizedCloud kept = rangeseg::io::read_pcd(copy, &info);
  EXPECT_EQ(info.viewpoint, pose);
  EXPECT_EQ(kept.z(320, 240), cloud.z(320, 240));
  // The results' clouds keep the points' frame, and so their VIEWPOINT; moved into the
  // sensor's frame, the sensor is at the origin.
  ASSERT_EQ(run("segment " + moved + " -o " + (dir / "c").string() + " --no-mesh --cloud").code, 0);
  ASSERT_EQ(run("smooth " + moved + " -o " + (dir / "s.pcd").string()).code, 0);
  for (const fs::path& written : {dir / "c" / "cloud.pcd", dir / "s.pcd"}) {
    rangeseg::io::read_pcd(written.string(), &info);
    EXPECT_EQ(info.viewpoint, pose) << written;
  }
  ASSERT_EQ(run("smooth " + moved + " -o " + (dir / "s.pcd").string() + " --apply-viewpoint").code,
            0);
  rangeseg::io::read_pcd((dir / "s.pcd").string(), &info);
  EXPECT_EQ(info.viewpoint, (std::array<double, 7>{0, 0, 0, 1, 0, 0, 0}));

  // A PLY keeps it in PCL's camera element (as floats), and --apply-viewpoint applies it.
  const std::string ply = (dir / "moved.ply").string();
  ASSERT_EQ(run("convert " + moved + " " + ply).code, 0);
  const CliResult from_ply = run("info " + ply + " --apply-viewpoint");
  EXPECT_NE(from_ply.out.find("viewpoint: 0.3 -1.2 0.5 "), std::string::npos) << from_ply.out;
  EXPECT_EQ(depth_line(from_ply.out), depth_line(seen.out));
}

// A result folder written again holds that run's files only.
TEST(Cli, SegmentIntoAnOldFolderRemovesItsEarlierResults) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_segment_again");
  ASSERT_EQ(run("synth -o " + dir.string() + " --noise none").code, 0);
  const std::string out = (dir / "out").string(), cloud = (dir / "cloud.pcd").string();
  ASSERT_EQ(run("segment " + cloud + " -o " + out + " --cloud").code, 0);
  ASSERT_TRUE(fs::exists(dir / "out" / "mesh.ply"));
  ASSERT_TRUE(fs::exists(dir / "out" / "cloud.pcd"));
  std::ofstream(dir / "out" / "notes.txt") << "the user's own file\n";
  // A temporary of a killed run (process 999999999 does not run: Linux's pids stay below 2^22)
  // goes; one of a running process, and a user's file of that form, stay.
  std::ofstream(dir / "out" / "mesh.ply.tmp.999999999") << "half";
  const std::string running = "cloud.pcd.tmp." + std::to_string(::getpid());
  std::ofstream(dir / "out" / running) << "half";
  std::ofstream(dir / "out" / "notes.txt.tmp.999999999") << "the user's";
  const CliResult again = run("segment " + cloud + " -o " + out + " --no-mesh");
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_FALSE(fs::exists(dir / "out" / "mesh.ply.tmp.999999999"));
  EXPECT_NE(again.out.find("left by an interrupted run"), std::string::npos) << again.out;
  EXPECT_TRUE(fs::exists(dir / "out" / running));
  EXPECT_TRUE(fs::exists(dir / "out" / "notes.txt.tmp.999999999"));
  fs::remove(dir / "out" / running);
  EXPECT_FALSE(fs::exists(dir / "out" / "mesh.ply"));
  EXPECT_FALSE(fs::exists(dir / "out" / "cloud.pcd"));
  EXPECT_TRUE(fs::exists(dir / "out" / "labels.png"));
  EXPECT_TRUE(fs::exists(dir / "out" / "notes.txt"));

  // A batch into a single frame's folder, and a single frame into a batch's.
  ASSERT_EQ(run("segment " + cloud + " " + cloud + " -o " + out + " --no-mesh").code, 0);
  EXPECT_TRUE(fs::exists(dir / "out" / "summary.json"));
  EXPECT_FALSE(fs::exists(dir / "out" / "labels.png"));
  ASSERT_EQ(run("segment " + cloud + " -o " + out + " --no-mesh").code, 0);
  EXPECT_FALSE(fs::exists(dir / "out" / "summary.json"));
  EXPECT_TRUE(fs::exists(dir / "out" / "labels.png"));
  EXPECT_TRUE(fs::exists(dir / "out" / "notes.txt"));
}

// `eval-synth` scores what `synth`, `segment` and `eval` score seed by seed, and counts the
// sphere and cylinder regions that one segment of the right kind detects.
TEST(Cli, EvalSynthScoresWhatSynthSegmentAndEvalScore) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_eval_synth");
  const std::string scene = (dir / "scene").string(), seg = (dir / "seg").string();
  ASSERT_EQ(run("synth -o " + scene + " --scene mixed --seed 5").code, 0);
  ASSERT_EQ(run("segment " + scene + "/cloud.pcd -o " + seg + " --model auto").code, 0);
  const std::string eval_args =
      "eval " + scene + "/labels.png " + seg + "/labels.png --cloud " + scene + "/cloud.pcd";
  const CliResult eval = run(eval_args + " --surfaces " + scene + "/surfaces.json --json " +
                             (dir / "eval.json").string());
  ASSERT_EQ(eval.code, 0) << eval.out;
  // The angle error is Hoover's over planes: without the surface types, pairs with the sphere
  // or a cylinder count too (measured: 30 pairs against 21).
  const CliResult all_pairs = run(eval_args + " --json " + (dir / "all_pairs.json").string());
  ASSERT_EQ(all_pairs.code, 0) << all_pairs.out;
  EXPECT_LT(read_json(dir / "eval.json")["angle_pairs"].get<int>(),
            read_json(dir / "all_pairs.json")["angle_pairs"].get<int>());
  for (const char* bad :
       {R"({"surfaces": [{"label": "x", "type": "plane"}]})", R"({"surfaces": 3})", "{"}) {
    const fs::path file = dir / "bad_surfaces.json";
    std::ofstream(file) << bad;
    const CliResult r = run(eval_args + " --surfaces " + file.string());
    EXPECT_EQ(r.code, 2) << bad;
    EXPECT_NE(r.out.find("bad_surfaces.json"), std::string::npos) << r.out;
  }
  const CliResult all = run("eval-synth --scene mixed --seeds 4-5 --model auto --json " +
                            (dir / "all.json").string());
  ASSERT_EQ(all.code, 0) << all.out;
  EXPECT_NE(all.out.find("mixed 5"), std::string::npos) << all.out;
  EXPECT_NE(all.out.find("curved regions:"), std::string::npos) << all.out;

  const nlohmann::json expected = read_json(dir / "eval.json");
  const nlohmann::json report = read_json(dir / "all.json");
  ASSERT_EQ(report["seeds"].size(), 2u);
  const nlohmann::json& row = report["seeds"][1];
  EXPECT_EQ(row["seed"].get<int>(), 5);
  for (const char* key :
       {"gt_regions", "ms_regions", "correct", "over", "under", "missed", "noise"}) {
    EXPECT_EQ(row[key].get<int>(), expected[key].get<int>()) << key;
    EXPECT_EQ(report["total"][key].get<int>(),
              report["seeds"][0][key].get<int>() + row[key].get<int>())
        << key;
  }
  EXPECT_NEAR(row["angle_mean_deg"].get<double>(), expected["angle_mean_deg"].get<double>(), 1e-9);

  // The curved regions of seed 5 scored from the files: a correct ground-truth region whose
  // segment's surface type is the surface's own.
  const nlohmann::json surfaces = read_json(dir / "scene" / "surfaces.json")["surfaces"];
  const nlohmann::json segments = read_json(dir / "seg" / "segments.json")["segments"];
  int curved = 0, right_kind = 0, planes_as_curved = 0;
  for (const auto& gt : expected["gt"]) {
    const std::string type = surfaces[gt["label"].get<int>() - 1]["type"].get<std::string>();
    const bool correct = gt["outcome"] == "correct";
    const std::string found =
        correct ? segments[gt["partners"][0].get<int>() - 1]["surface"]["type"].get<std::string>()
                : "";
    if (type == "plane") {
      planes_as_curved += found == "cylinder" || found == "sphere" ? 1 : 0;
      continue;
    }
    ++curved;
    right_kind += found == type ? 1 : 0;
  }
  ASSERT_GT(curved, 0);
  EXPECT_EQ(row["curved"]["regions"].get<int>(), curved);
  EXPECT_EQ(row["curved"]["right_kind"].get<int>(), right_kind);
  EXPECT_EQ(row["curved"]["planes_as_curved"].get<int>(), planes_as_curved);
  if (right_kind > 0) {
    EXPECT_LT(row["curved"]["radius_error_max"].get<double>(), 0.05);
  }

  for (const char* bad : {"1-3,x", "5-2", "", "1,,2", "1-99999999"}) {
    const CliResult r = run(std::string("eval-synth --seeds '") + bad + "'");
    EXPECT_EQ(r.code, 2) << bad;
    EXPECT_NE(r.out.find("--seeds"), std::string::npos) << r.out;
  }
  EXPECT_EQ(run("eval-synth --scene nowhere").code, 2);
}

// --camera kinect:WxH renders the Kinect's field of view at another resolution: 320 pixels
// over the same 57 degrees make fx half of 525.
TEST(Cli, SynthRendersTheKinectAtAnotherResolution) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_synth_qvga");
  const CliResult synth =
      run("synth --camera kinect:320x240 --seed 2 -o " + (dir / "scene").string());
  ASSERT_EQ(synth.code, 0) << synth.out;
  const CliResult info = run("info " + (dir / "scene" / "cloud.pcd").string());
  EXPECT_NE(info.out.find("320 x 240"), std::string::npos) << info.out;
  // An organized cloud names no camera: the one fitted to its points gives the pixel angle.
  EXPECT_NE(info.out.find("fx 262.50 fy 262.50 cx 159.50 cy 119.50 (fitted to the points; the "
                          "smoothing's pixel angle 1 / fx = 0.00380952 rad)"),
            std::string::npos)
      << info.out;
  // ... and the smallest segment: the solid angle of the preset's 200 pixels at fx 525.
  EXPECT_NE(info.out.find("segments: at least 50 pixels with the kinect preset"), std::string::npos)
      << info.out;
  const CliResult laser = run("info " + (dir / "scene" / "cloud.pcd").string() + " --preset laser");
  EXPECT_TRUE(rangeseg::test::contains(
      laser.out, "segments: at least 50 pixels with the laser preset (the grid's own pixels)"))
      << laser.out;
  const nlohmann::json camera = read_json(dir / "scene" / "camera.json");
  EXPECT_EQ(camera["width"], 320);
  EXPECT_EQ(camera["intrinsic_matrix"][0].get<double>(), 262.5);
  EXPECT_EQ(camera["intrinsic_matrix"][6].get<double>(), 159.5);
  EXPECT_EQ(camera["intrinsic_matrix"][7].get<double>(), 119.5);

  for (const char* bad : {"kinect:320", "kinect:8x8", "kinect:320x240x", "kinect:320x240.5",
                          "kinect:99999x240", "kinect:"}) {
    const CliResult r = run(std::string("synth --camera ") + bad + " -o " + (dir / "bad").string());
    EXPECT_EQ(r.code, 2) << bad;
    EXPECT_NE(r.out.find("kinect:WIDTHxHEIGHT"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(dir / "bad")) << bad;
  }
}

namespace {

/// The totals of `eval-synth --seeds 1-8 ARGS` (its JSON written into `dir`).
nlohmann::json eval_synth_total(const fs::path& dir, const std::string& args) {
  const fs::path json = dir / "scores.json";
  const CliResult r = run("eval-synth --seeds 1-8 " + args + " --json " + json.string());
  EXPECT_EQ(r.code, 0) << r.out;
  return read_json(json)["total"];
}

}  // namespace

// The synthetic rows of the README's accuracy table (seeds 1-8, the development seeds) as lower
// bounds: a change that loses a region there fails here, and the README must say what it gained.
TEST(Cli, EvalSynthHoldsTheReadmeAccuracy) {
  RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS();
  const fs::path dir = rangeseg::test::scratch_dir("cli_eval_synth_readme");
  const auto total = [&](const std::string& args) { return eval_synth_total(dir, args); };
  const nlohmann::json boxes = total("--scene boxes");
  EXPECT_EQ(boxes["gt_regions"].get<int>(), 99);
  EXPECT_GE(boxes["correct"].get<int>(), 87);
  EXPECT_LE(boxes["noise"].get<int>(), 1);
  const nlohmann::json mixed = total("--scene mixed --model auto");
  EXPECT_EQ(mixed["gt_regions"].get<int>(), 134);
  EXPECT_GE(mixed["correct"].get<int>(), 117);
  EXPECT_GE(mixed["curved"]["within_5pct_3deg"].get<int>(), 18);
  EXPECT_EQ(mixed["curved"]["planes_as_curved"].get<int>(), 0);
  const nlohmann::json ideal_boxes = total("--scene boxes --noise none --preset ideal");
  EXPECT_GE(ideal_boxes["correct"].get<int>(), 94);
  const nlohmann::json ideal_mixed =
      total("--scene mixed --noise none --preset ideal --model auto");
  EXPECT_GE(ideal_mixed["correct"].get<int>(), 121);
  EXPECT_EQ(ideal_mixed["curved"]["within_1pct_1deg"].get<int>(), 21);
}

// The README's table of unorganized clouds (seeds 1-8, measured 2026-12-05): the valid points
// of each rendering shuffled into one row, segmented over k-nearest-neighbour rings (in the
// pipeline's spatial order, so any shuffle gives these counts).
TEST(Cli, EvalSynthHoldsTheReadmeUnorganizedAccuracy) {
  RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS();
  const fs::path dir = rangeseg::test::scratch_dir("cli_eval_synth_readme_unorganized");
  const auto total = [&](const std::string& args) {
    return eval_synth_total(dir, "--unorganized " + args);
  };
  const nlohmann::json boxes = total("--scene boxes");
  EXPECT_EQ(boxes["gt_regions"].get<int>(), 99);
  EXPECT_GE(boxes["correct"].get<int>(), 83);
  EXPECT_LE(boxes["noise"].get<int>(), 5);
  EXPECT_GE(total("--scene mixed")["correct"].get<int>(), 94);
  const nlohmann::json mixed = total("--scene mixed --model auto");
  EXPECT_GE(mixed["correct"].get<int>(), 107);
  EXPECT_LE(mixed["noise"].get<int>(), 7);
  EXPECT_GE(mixed["curved"]["within_5pct_3deg"].get<int>(), 18);
  EXPECT_GE(total("--scene boxes --noise none --preset ideal")["correct"].get<int>(), 92);
  EXPECT_GE(total("--scene mixed --model auto --noise none --preset ideal")["correct"].get<int>(),
            116);
}

/// --cloud: the smoothed points as an organized PCD with normals, curvature, label and the
/// label's colour, pixel for pixel where the input has its points and labels.png its labels.
TEST(Cli, CloudOptionWritesTheSmoothedLabelledPoints) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_cloud_option");
  write_small_pcd(dir / "in.pcd", 7);
  const rangeseg::OrganizedCloud input = rangeseg::io::read_pcd((dir / "in.pcd").string());
  const CliResult plain =
      run("segment " + (dir / "in.pcd").string() + " --no-mesh -o " + (dir / "plain").string());
  ASSERT_EQ(plain.code, 0) << plain.out;
  EXPECT_FALSE(fs::exists(dir / "plain" / "cloud.pcd"));
  const CliResult r = run("segment " + (dir / "in.pcd").string() + " --no-mesh --cloud -o " +
                          (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const rangeseg::OrganizedCloud cloud =
      rangeseg::io::read_pcd((dir / "out" / "cloud.pcd").string());
  ASSERT_EQ(cloud.width(), input.width());
  ASSERT_EQ(cloud.height(), input.height());
  ASSERT_TRUE(cloud.has_label() && cloud.has_rgb());
  const rangeseg::LabelImage labels =
      rangeseg::io::read_label_png((dir / "out" / "labels.png").string());
  std::size_t valid = 0, moved = 0, mismatches = 0;
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if (cloud.valid(u, v) != input.valid(u, v) || cloud.label(u, v) != labels(u, v)) {
        ++mismatches;
        continue;
      }
      if (!cloud.valid(u, v)) continue;
      ++valid;
      const float d = std::hypot(cloud.x(u, v) - input.x(u, v), cloud.y(u, v) - input.y(u, v),
                                 cloud.z(u, v) - input.z(u, v));
      if (d > 0) ++moved;
      // Smoothing moves a point by about its noise (sigma 5 cm at 5.5 m), on a surface seen at
      // grazing incidence also by up to the depth step to its neighbours (a sub-pixel shift
      // along the surface), not further.
      float step = INFINITY;
      for (const auto& [du, dv] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const int nu = u + du, nv = v + dv;
        if (nu >= 0 && nv >= 0 && nu < input.width() && nv < input.height() &&
            input.valid(nu, nv)) {
          step = std::min(step, std::abs(input.z(nu, nv) - input.z(u, v)));
        }
      }
      if (!std::isfinite(step)) step = 0;
      if (d > 5 * rangeseg::SensorNoise{}.sigma(input.z(u, v)) + step) ++mismatches;
      const int label = labels(u, v);
      const auto colour = label > 0 ? rangeseg::label_colour(label) : rangeseg::kNoLabelColour;
      if (cloud.r(u, v) != colour[0] || cloud.g(u, v) != colour[1] || cloud.b(u, v) != colour[2]) {
        ++mismatches;
      }
    }
  }
  EXPECT_EQ(mismatches, 0u);
  EXPECT_GT(valid, input.size() / 2);
  EXPECT_GT(moved, valid / 2) << "the points are the smoothed ones";
  rangeseg::test::expect_unit_normals(dir / "out" / "cloud.pcd", input.size(), valid);
}

TEST(Cli, SegcompEvaluationRuns) {
  RANGESEG_REQUIRE_DATA("segcomp_abw/abw.test.3.range");
  const CliResult r = run("eval " + (data_file.parent_path() / "abw.test.3.gt-seg").string() + " " +
                          (data_file.parent_path() / "abw.test.3.gt-seg").string());
  // A .gt-seg is not a machine segmentation format: a clear error, not a crash.
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("abw.test.3.gt-seg"), std::string::npos);
}

// eval-segcomp over several T, with JSON: the counts at each T, and the angle error with the
// ground truth's planes fitted robustly (abw.test.0 labels one pixel of another surface with a
// thin strip's label: plain least squares tilts that plane by 68 deg and the image's error is
// 5.99 deg).
TEST(Cli, SegcompOverSeveralTolerancesWithJson) {
  RANGESEG_REQUIRE_DATA("segcomp_abw/abw.test.0.range");
  RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS();
  const fs::path dir = rangeseg::test::scratch_dir("cli_segcomp_sweep");
  fs::create_directories(dir / "images");
  for (const char* ext : {".range", ".gt-seg"}) {
    fs::create_symlink(data_file.parent_path() / (std::string("abw.test.0") + ext),
                       dir / "images" / (std::string("abw.test.0") + ext));
  }
  const CliResult r = run("eval-segcomp " + (dir / "images").string() + " --T 0.8,0.95 --json " +
                          (dir / "scores.json").string() + " -o " + (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(rangeseg::test::contains(r.out, "averages per image over T")) << r.out;
  const auto j = nlohmann::json::parse(read_text(dir / "scores.json"));
  ASSERT_EQ(j["averages"].size(), 2U);
  ASSERT_EQ(j["images"].size(), 1U);
  const auto& at = j["images"][0]["results"];
  ASSERT_EQ(at.size(), 2U);
  EXPECT_EQ(at[0]["T"], 0.8);
  EXPECT_EQ(at[1]["T"], 0.95);
  EXPECT_EQ(at[0]["gt_regions"], 27);
  EXPECT_LE(at[1]["correct"].get<int>(), at[0]["correct"].get<int>());
  EXPECT_GE(at[0]["correct"].get<int>(), 20);
  ASSERT_GT(at[0]["angle_pairs"].get<int>(), 20);
  EXPECT_LT(at[0]["angle_mean_deg"].get<double>(), 1.0);
  EXPECT_EQ(j["averages"][0]["mean_correct"], at[0]["correct"]);
  // Every segment is counted: on ground-truth regions, or outside them.
  const auto segments = read_json(dir / "out" / "abw.test.0" / "segments.json")["segments"];
  EXPECT_EQ(at[0]["ms_regions"].get<std::size_t>() + at[0]["ms_regions_outside"].get<std::size_t>(),
            segments.size());

  // eval scores a .ms-seg with the normals of the .ms-nor beside it, as Hoover's tools do: the
  // written ones give the same error, a .ms-nor whose normals all point one way another.
  const std::string eval_args = "eval " + (dir / "images" / "abw.test.0.gt-seg").string() + " " +
                                (dir / "out" / "abw.test.0.ms-seg").string() + " --json " +
                                (dir / "eval.json").string();
  const CliResult reported = run(eval_args);
  ASSERT_EQ(reported.code, 0) << reported.out;
  EXPECT_TRUE(rangeseg::test::contains(reported.out, ".ms-nor's normals")) << reported.out;
  const auto e = nlohmann::json::parse(read_text(dir / "eval.json"));
  EXPECT_EQ(e["machine_planes"], "ms-nor");
  EXPECT_NEAR(e["angle_mean_deg"].get<double>(), at[0]["angle_mean_deg"].get<double>(), 0.05);
  std::string flat;
  std::istringstream lines(read_text(dir / "out" / "abw.test.0.ms-nor"));
  for (std::string line; std::getline(lines, line);) {
    flat += line.substr(0, line.find(' ')) + " 0 0 1\n";
  }
  std::ofstream(dir / "out" / "abw.test.0.ms-nor") << flat;
  ASSERT_EQ(run(eval_args).code, 0);
  EXPECT_GT(nlohmann::json::parse(read_text(dir / "eval.json"))["angle_mean_deg"].get<double>(),
            10.0);
  std::ofstream(dir / "out" / "abw.test.0.ms-nor") << "3 0 0 one\n";
  const CliResult bad = run(eval_args);
  EXPECT_EQ(bad.code, 2);
  EXPECT_TRUE(rangeseg::test::contains(bad.out, "abw.test.0.ms-nor:1:")) << bad.out;
}

TEST(Cli, ConfigFileOverridesAndRejectsUnknownKeys) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_config");
  ASSERT_EQ(run("synth -o " + dir.string() + " --noise none --scene boxes --seed 2").code, 0);
  std::ofstream(dir / "good.json") << R"({"noise": {"a": 0.002}, "mesh": {"jump_sigmas": 4},
      "smoothing": {"iterations": 1}, "segmentation": {"min_region_size": 50, "merge_rms_sigmas": 1.5,
      "boundary_refine_sigmas": 2}})";
  std::ofstream(dir / "bad.json") << R"({"segmentation": {"min_region_sise": 50}})";
  const CliResult good =
      run("segment " + (dir / "cloud.pcd").string() + " -o " + (dir / "g").string() +
          " --no-mesh --config " + (dir / "good.json").string());
  EXPECT_EQ(good.code, 0) << good.out;
  const CliResult bad = run("segment " + (dir / "cloud.pcd").string() + " -o " +
                            (dir / "b").string() + " --config " + (dir / "bad.json").string());
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.out.find("min_region_sise"), std::string::npos) << bad.out;
  EXPECT_FALSE(fs::exists(dir / "b" / "labels.png"));
  std::ofstream(dir / "negative.json") << R"({"segmentation": {"boundary_refine_sigmas": -1}})";
  const CliResult negative =
      run("segment " + (dir / "cloud.pcd").string() + " -o " + (dir / "n").string() + " --config " +
          (dir / "negative.json").string());
  EXPECT_EQ(negative.code, 2);
  EXPECT_NE(negative.out.find("boundary_refine_sigmas"), std::string::npos) << negative.out;
  EXPECT_FALSE(fs::exists(dir / "n" / "labels.png"));
  // Integer settings take integers only: no silent truncation or wrap-around.
  for (const char* value : {"2.5", "4294967298", "-3000000000", "\"2\""}) {
    std::ofstream(dir / "int.json") << R"({"segmentation": {"growth_bands": )" << value << "}}";
    const CliResult r = run("segment " + (dir / "cloud.pcd").string() + " -o " +
                            (dir / "i").string() + " --config " + (dir / "int.json").string());
    EXPECT_EQ(r.code, 2) << value;
    EXPECT_NE(r.out.find("growth_bands"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(dir / "i" / "labels.png")) << value;
  }
}

/// Synthetic boxes seed 6 (Kinect noise) has a box top seen 6 deg off the rays that only the
/// grazing-plane search finds: segments.json marks it, and the config key switches it off.
TEST(Cli, GrazingSearchIsMarkedAndConfigurable) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_grazing");
  ASSERT_EQ(run("synth -o " + dir.string() + " --noise kinect --scene boxes --seed 6").code, 0);
  const auto grazing_segments = [&](const fs::path& out) {
    const nlohmann::json j = read_json(out / "segments.json");
    int count = 0;
    for (const auto& s : j.at("segments")) count += s.at("grazing").get<bool>() ? 1 : 0;
    return count;
  };
  const std::string cloud = (dir / "cloud.pcd").string();
  ASSERT_EQ(run("segment " + cloud + " -o " + (dir / "on").string() + " --no-mesh").code, 0);
  EXPECT_GE(grazing_segments(dir / "on"), 1);
  std::ofstream(dir / "off.json") << R"({"segmentation": {"grazing_min_angle": 0}})";
  ASSERT_EQ(run("segment " + cloud + " -o " + (dir / "off").string() + " --no-mesh --config " +
                (dir / "off.json").string())
                .code,
            0);
  EXPECT_EQ(grazing_segments(dir / "off"), 0);
  std::ofstream(dir / "bad.json") << R"({"segmentation": {"grazing_max_angle": 2.0}})";
  const CliResult bad = run("segment " + cloud + " -o " + (dir / "bad").string() + " --config " +
                            (dir / "bad.json").string());
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.out.find("grazing_max_angle"), std::string::npos) << bad.out;
}

TEST(CliBatch, DirectorySkipsACorruptFrameAndCountsIt) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_batch_dir");
  write_small_pcd(dir / "in" / "a.pcd", 1);
  write_small_pcd(dir / "in" / "b.pcd", 2);
  write_truncated_pcd(dir / "in" / "c.pcd");
  std::ofstream(dir / "in" / "notes.txt") << "not a frame";
  const CliResult r = run("segment " + (dir / "in").string() + " -o " + (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(dir / "out" / "a" / "labels.png"));
  EXPECT_TRUE(fs::exists(dir / "out" / "b" / "segments.json"));
  EXPECT_TRUE(fs::exists(dir / "out" / "b" / "mesh.ply"));
  EXPECT_FALSE(fs::exists(dir / "out" / "c" / "labels.png"));
  EXPECT_FALSE(fs::exists(dir / "out" / "notes"));
  EXPECT_NE(r.out.find("c.pcd"), std::string::npos) << r.out;
  const auto summary = read_json(dir / "out" / "summary.json");
  EXPECT_EQ(summary["frames"], 3);
  EXPECT_EQ(summary["succeeded"], 2);
  EXPECT_EQ(summary["failed"], 1);
  ASSERT_EQ(summary["failures"].size(), 1u);
  EXPECT_EQ(fs::path(summary["failures"][0]["input"].get<std::string>()).filename(), "c.pcd");
  EXPECT_FALSE(summary["failures"][0]["error"].get<std::string>().empty());
  for (const char* key : {"mesh", "normals", "smoothing", "segmentation", "polygons", "total"}) {
    ASSERT_TRUE(summary["median_ms"].contains(key)) << key;
    EXPECT_GT(summary["median_ms"][key].get<double>(), 0.0) << key;
  }
  // The per-frame segment counts match the folders written.
  for (const auto& f : summary["per_frame"]) {
    if (!f["ok"].get<bool>()) continue;
    const auto seg = read_json(dir / "out" / f["name"].get<std::string>() / "segments.json");
    EXPECT_EQ(f["segments"].get<std::size_t>(), seg["segments"].size());
  }

  // --strict: one failed frame makes the batch exit with 2; the others are written all the same.
  const CliResult strict =
      run("segment " + (dir / "in").string() + " -o " + (dir / "strict").string() + " --strict");
  EXPECT_EQ(strict.code, 2) << strict.out;
  EXPECT_EQ(read_json(dir / "strict" / "summary.json")["succeeded"],
            summary["succeeded"].get<int>());

  // Nothing readable: exit code 2, but the failures are still listed.
  fs::create_directories(dir / "bad");
  write_truncated_pcd(dir / "bad" / "x.pcd");
  std::ofstream(dir / "bad" / "y.png") << "not a png";
  const CliResult bad = run("segment " + (dir / "bad").string() + " -o " + (dir / "out2").string());
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_NE(bad.out.find("x.pcd"), std::string::npos) << bad.out;
  EXPECT_NE(bad.out.find("y.png"), std::string::npos) << bad.out;
  EXPECT_EQ(read_json(dir / "out2" / "summary.json")["succeeded"], 0);
  // A directory without frames is an argument error.
  fs::create_directories(dir / "empty");
  EXPECT_EQ(run("segment " + (dir / "empty").string() + " -o " + (dir / "out3").string()).code, 2);
}

// --preset auto (the default of segment): SegComp images get their scanner's preset, other inputs
// kinect, per frame in a batch; an unknown preset fails before any input is read.
TEST(CliBatch, AutoPresetFollowsEachInputsSensor) {
  RANGESEG_REQUIRE_DATA("segcomp_abw/abw.test.3.range");
  const fs::path dir = rangeseg::test::scratch_dir("cli_batch_auto_preset");
  const std::string range = data_file.string();
  const CliResult automatic = run("segment " + range + " --no-mesh -o " + (dir / "auto").string());
  ASSERT_EQ(automatic.code, 0) << automatic.out;
  EXPECT_NE(automatic.out.find("preset abw"), std::string::npos) << automatic.out;
  for (const char* preset : {"abw", "kinect"}) {
    const CliResult r = run("segment " + range + " --no-mesh --preset " + preset + " -o " +
                            (dir / preset).string());
    ASSERT_EQ(r.code, 0) << r.out;
  }
  const std::string auto_labels = read_text(dir / "auto" / "labels.png");
  EXPECT_EQ(auto_labels, read_text(dir / "abw" / "labels.png"));
  EXPECT_NE(auto_labels, read_text(dir / "kinect" / "labels.png"));

  write_small_pcd(dir / "frame.pcd", 6);
  const CliResult batch = run("segment " + range + " " + (dir / "frame.pcd").string() +
                              " --no-mesh -o " + (dir / "batch").string());
  ASSERT_EQ(batch.code, 0) << batch.out;
  const auto summary = read_json(dir / "batch" / "summary.json");
  ASSERT_EQ(summary["per_frame"].size(), 2u);
  EXPECT_EQ(summary["per_frame"][0]["preset"], "abw");
  EXPECT_EQ(summary["per_frame"][1]["preset"], "kinect");
  EXPECT_EQ(read_text(dir / "batch" / "abw.test.3" / "labels.png"), auto_labels);
  // A tracked sequence is one sensor's: a frame of another is reported and skipped (before, it
  // ran on its own preset's pipeline, whose tracks gave ids the other's had given too).
  const CliResult tracked =
      run("segment " + (dir / "frame.pcd").string() + " " + range + " " +
          (dir / "frame.pcd").string() + " --track --no-mesh -o " + (dir / "tracked").string());
  ASSERT_EQ(tracked.code, 0) << tracked.out;
  EXPECT_TRUE(rangeseg::test::contains(tracked.out, "one sensor's")) << tracked.out;
  EXPECT_EQ(read_json(dir / "tracked" / "summary.json")["failed"], 1);
  // mesh: the ABW preset's depth-jump gate.
  for (const char* preset : {"auto", "abw", "kinect"}) {
    const CliResult r = run("mesh " + range + " --preset " + preset + " -o " +
                            (dir / (std::string(preset) + ".ply")).string());
    ASSERT_EQ(r.code, 0) << r.out;
  }
  EXPECT_EQ(read_text(dir / "auto.ply"), read_text(dir / "abw.ply"));
  EXPECT_NE(read_text(dir / "auto.ply"), read_text(dir / "kinect.ply"));

  const CliResult bad = run("segment " + (dir / "missing.range").string() + " --preset lidar -o " +
                            (dir / "bad").string());
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.out.find("lidar"), std::string::npos) << bad.out;
  EXPECT_EQ(bad.out.find("missing.range"), std::string::npos) << bad.out;
  // The commands that resolve auto list it among the valid presets.
  EXPECT_NE(bad.out.find("valid presets: auto, kinect"), std::string::npos) << bad.out;
}

TEST(CliBatch, ListOfFilesGetsUniqueFolderNames) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_batch_list");
  write_small_pcd(dir / "a.pcd", 3);
  write_small_pcd(dir / "b.pcd", 4);
  write_small_pcd(dir / "sub" / "a.pcd", 5);
  const CliResult r =
      run("segment " + (dir / "a.pcd").string() + " " + (dir / "b.pcd").string() + " " +
          (dir / "sub" / "a.pcd").string() + " " + (dir / "missing.pcd").string() +
          " --no-mesh -o " + (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* name : {"a", "b", "a_2"}) {
    EXPECT_TRUE(fs::exists(dir / "out" / name / "labels.png")) << name;
    EXPECT_FALSE(fs::exists(dir / "out" / name / "mesh.ply")) << name;
  }
  EXPECT_NE(r.out.find("missing.pcd"), std::string::npos) << r.out;
  const auto summary = read_json(dir / "out" / "summary.json");
  EXPECT_EQ(summary["frames"], 4);
  EXPECT_EQ(summary["failed"], 1);
  // Frames are listed in input order: sub/a.pcd is the third.
  EXPECT_EQ(summary["per_frame"][2]["name"], "a_2");
  EXPECT_EQ(fs::path(summary["per_frame"][2]["input"].get<std::string>()).parent_path().filename(),
            "sub");
}

TEST(CliBatch, TumSequenceUsesTimestampsAndFiveThousandUnitsPerMetre) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_batch_tum");
  const fs::path seq = dir / "rgbd_dataset_test";
  fs::create_directories(seq / "depth");
  std::ofstream list(seq / "depth.txt");
  list << "# depth maps\n# file: 'test.bag'\n# timestamp filename\n";
  double mean_z = 0;
  int valid = 0;
  const char* stamps[] = {"1305031102.160407", "1305031102.194330"};
  for (int i = 0; i < 2; ++i) {
    const rangeseg::OrganizedCloud cloud = small_frame(10 + static_cast<std::uint64_t>(i));
    rangeseg::io::write_depth_png((seq / "depth" / (std::string(stamps[i]) + ".png")).string(),
                                  rangeseg::cloud_to_depth(cloud, 1.0 / 5000.0).view());
    list << stamps[i] << " depth/" << stamps[i] << ".png\n";
    for (int v = 0; v < cloud.height(); ++v) {
      for (int u = 0; u < cloud.width(); ++u) {
        if (cloud.valid(u, v)) mean_z += cloud.z(u, v), ++valid;
      }
    }
  }
  mean_z /= valid;
  list << "1305031102.226738 depth/1305031102.226738.png\n";  // listed but absent
  list.close();
  // The frames were rendered with a 160x120 camera; the TUM default (525 pixels) is for 640x480.
  const CliResult r = run("segment " + seq.string() + " --fx 131.25 --fy 131.25 --no-mesh -o " +
                          (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("1305031102.226738.png"), std::string::npos) << r.out;
  double seg_z = 0, pixels = 0;
  for (const char* stamp : stamps) {
    const fs::path folder = dir / "out" / stamp;
    ASSERT_TRUE(fs::exists(folder / "labels.png")) << stamp;
    EXPECT_EQ(rangeseg::io::read_label_png((folder / "labels.png").string()).width(), 160);
    const auto json = read_json(folder / "segments.json");
    for (const auto& s : json["segments"]) {
      seg_z += s["centroid"][2].get<double>() * s["pixel_count"].get<double>();
      pixels += s["pixel_count"].get<double>();
    }
  }
  ASSERT_GT(pixels, 0.0);
  // Depth in metres only with 5000 units per metre; the millimetre default would give 5x.
  EXPECT_NEAR(seg_z / pixels, mean_z, 0.25 * mean_z);
  const auto summary = read_json(dir / "out" / "summary.json");
  EXPECT_EQ(summary["frames"], 3);
  EXPECT_EQ(summary["succeeded"], 2);
  // How the depth became points: TUM's scale, the camera the options gave.
  EXPECT_DOUBLE_EQ(summary["tum_depth_png"]["depth_scale_m_per_unit"].get<double>(), 1.0 / 5000.0);
  EXPECT_EQ(summary["tum_depth_png"]["camera"], "--fx / --fy / --cx / --cy");
  EXPECT_EQ(summary["tum_depth_png"]["fx"].get<double>(), 131.25);
  EXPECT_FALSE(summary.contains("depth_png"));  // no other depth image
}

TEST(CliBatch, TwoThreadsWriteTheSameBytesAsOne) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_batch_threads");
  for (int i = 0; i < 5; ++i) write_small_pcd(dir / "in" / (std::to_string(i) + ".pcd"), 20 + i);
  write_truncated_pcd(dir / "in" / "9.pcd");
  for (const std::string threads : {"1", "2"}) {
    const fs::path out = dir / ("out" + threads);
    const CliResult r = run("segment " + (dir / "in").string() + " --threads " + threads +
                            " --cloud -o " + out.string());
    ASSERT_EQ(r.code, 0) << r.out;
  }
  int compared = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir / "out1")) {
    if (!e.is_regular_file() || e.path().filename() == "summary.json") continue;
    const fs::path other = dir / "out2" / fs::relative(e.path(), dir / "out1");
    ASSERT_TRUE(fs::exists(other)) << other;
    EXPECT_EQ(read_text(e.path()), read_text(other)) << other;
    ++compared;
  }
  // labels, segments, overlay, types, mesh, cloud (+ polygons) per good frame
  EXPECT_GE(compared, 5 * 6);
  EXPECT_EQ(count_files(dir / "out1"), count_files(dir / "out2"));
  const auto s1 = read_json(dir / "out1" / "summary.json");
  const auto s2 = read_json(dir / "out2" / "summary.json");
  EXPECT_EQ(s2["threads"], 2);
  EXPECT_EQ(s1["failed"], 1);
  EXPECT_EQ(s2["failed"], 1);
  for (std::size_t i = 0; i < s1["per_frame"].size(); ++i) {
    EXPECT_EQ(s1["per_frame"][i]["name"], s2["per_frame"][i]["name"]);
    EXPECT_EQ(s1["per_frame"][i].value("segments", -1), s2["per_frame"][i].value("segments", -1));
  }
}

// --track: the frames run in order on one pipeline (threads inside each frame), a bad frame in
// between does not break a track, and the pictures colour a surface by its track.
TEST(CliBatch, TrackedSequenceKeepsIdsAndColoursAcrossFrames) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_batch_track");
  // In natural order, as frames are numbered: 1, 2, 10 (not 1, 10, 2).
  write_small_pcd(dir / "in" / "1.pcd", 7);
  write_truncated_pcd(dir / "in" / "2.pcd");
  write_small_pcd(dir / "in" / "10.pcd", 7);  // the same scene again
  const CliResult r =
      run("segment " + (dir / "in").string() + " --track --threads 2 -o " + (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(rangeseg::test::contains(r.out, "segments tracked")) << r.out;
  const auto first = read_json(dir / "out" / "1" / "segments.json")["segments"];
  const auto again = read_json(dir / "out" / "10" / "segments.json")["segments"];
  ASSERT_FALSE(first.empty());
  ASSERT_EQ(first.size(), again.size());
  std::set<std::uint32_t> ids;
  for (std::size_t i = 0; i < first.size(); ++i) {
    ASSERT_TRUE(first[i].contains("track_id"));
    EXPECT_EQ(first[i]["track_id"], again[i]["track_id"]);
    EXPECT_TRUE(ids.insert(first[i]["track_id"].get<std::uint32_t>()).second);
  }
  EXPECT_EQ(read_text(dir / "out" / "1" / "overlay.png"),
            read_text(dir / "out" / "10" / "overlay.png"));
  // polygons.obj names each plane's object by its segment and its track.
  const std::string obj = read_text(dir / "out" / "10" / "polygons.obj");
  for (const auto& s : again) {
    if (s["model"] != "plane") continue;
    const std::string name = "o segment_" + std::to_string(s["id"].get<int>()) + "_track_" +
                             std::to_string(s["track_id"].get<std::uint32_t>()) + "\n";
    EXPECT_TRUE(rangeseg::test::contains(obj, name)) << name << obj;
  }
  const auto summary = read_json(dir / "out" / "summary.json");
  ASSERT_EQ(summary["per_frame"].size(), 3U);
  EXPECT_EQ(summary["per_frame"][0]["name"], "1");
  EXPECT_EQ(summary["per_frame"][1]["name"], "2");
  EXPECT_EQ(summary["per_frame"][2]["name"], "10");
  EXPECT_EQ(summary["tracked"], true);
  EXPECT_EQ(summary["threads"], 2);
  EXPECT_EQ(summary["failed"], 1);
  EXPECT_GT(summary["median_ms"]["tracking"].get<double>(), 0.0);

  // The same from a config, and nothing of it without.
  std::ofstream(dir / "track.json") << R"({"track": true})";
  ASSERT_EQ(run("segment " + (dir / "in" / "1.pcd").string() + " --config " +
                (dir / "track.json").string() + " -o " + (dir / "config").string())
                .code,
            0);
  EXPECT_TRUE(read_json(dir / "config" / "segments.json")["segments"][0].contains("track_id"));
  ASSERT_EQ(run("segment " + (dir / "in").string() + " -o " + (dir / "plain").string()).code, 0);
  const auto plain = read_json(dir / "plain" / "1" / "segments.json");
  for (const auto& s : plain["segments"]) EXPECT_FALSE(s.contains("track_id"));
  EXPECT_FALSE(
      rangeseg::test::contains(read_text(dir / "plain" / "1" / "polygons.obj"), "_track_"));
  EXPECT_FALSE(read_json(dir / "plain" / "summary.json")["median_ms"].contains("tracking"));
}

TEST(CliBatch, BenchSizesJson) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_bench_sizes");
  write_small_pcd(dir / "f.pcd", 7);
  const CliResult r = run("bench " + (dir / "f.pcd").string() +
                          " --sizes 40x30,80x60,160x120 --repeat 2 --threads 2 --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto json = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  ASSERT_EQ(json["sizes"].size(), 3u) << json.dump();
  EXPECT_EQ(json["threads"], 2);
  const int widths[] = {40, 80, 160}, scales[] = {4, 2, 1};
  for (std::size_t i = 0; i < 3; ++i) {
    const auto& size = json["sizes"][i];
    EXPECT_EQ(size["width"], widths[i]);
    EXPECT_EQ(size["height"], widths[i] * 3 / 4);
    EXPECT_EQ(size["scale"], scales[i]);
    for (const char* key :
         {"mesh", "normals", "smoothing", "segmentation", "polygons", "total", "frames_per_second",
          "frames_per_second_threads", "in_frame_speedup", "throughput_speedup"}) {
      ASSERT_TRUE(size.contains(key)) << key;
      EXPECT_GE(size[key].get<double>(), 0.0) << key;
    }
    EXPECT_GT(size["frames_per_second"].get<double>(), 0.0);
    // Ratios of times, whatever the host does: positive and finite.
    for (const char* key : {"in_frame_speedup", "throughput_speedup"}) {
      EXPECT_GT(size[key].get<double>(), 0.0) << key;
      EXPECT_TRUE(std::isfinite(size[key].get<double>())) << key;
    }
  }
  // --scales gives the same sizes; a size that every-k-th-pixel cannot make is an error.
  const CliResult scales_run =
      run("bench " + (dir / "f.pcd").string() + " --scales 4,2,1 --repeat 1 --json");
  ASSERT_EQ(scales_run.code, 0) << scales_run.out;
  const auto by_scale = nlohmann::json::parse(scales_run.out.substr(scales_run.out.find('{')));
  ASSERT_EQ(by_scale["sizes"].size(), 3u);
  EXPECT_EQ(by_scale["sizes"][0]["size"], "40x30");
  EXPECT_EQ(run("bench " + (dir / "f.pcd").string() + " --sizes 50x50 --repeat 1").code, 2);
  EXPECT_EQ(run("bench " + (dir / "f.pcd").string() + " --sizes 40x30 --scales 2").code, 2);
}
