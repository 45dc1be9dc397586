// End-to-end tests of the rangeseg command-line tool: outputs, exit codes, error messages.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/png.hpp"
#include "test_util.hpp"

namespace fs = std::filesystem;

namespace {

struct CliResult {
  int code = -1;
  std::string out;  ///< stdout and stderr together
};

CliResult run(const std::string& args) {
  const std::string cmd = std::string(RANGESEG_CLI) + " " + args + " 2>&1";
  CliResult r;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (pipe == nullptr) return r;
  char buffer[4096];
  while (const std::size_t n = fread(buffer, 1, sizeof buffer, pipe)) r.out.append(buffer, n);
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

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
  ASSERT_FALSE(json["segments"].empty());
  int max_label = 0;
  for (int v = 0; v < labels.height(); ++v)
    for (int u = 0; u < labels.width(); ++u) max_label = std::max(max_label, labels(u, v));
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

  const CliResult eval = run("eval " + (dir / "scene" / "labels.png").string() + " " +
                             (dir / "seg" / "labels.png").string());
  ASSERT_EQ(eval.code, 0) << eval.out;
  EXPECT_NE(eval.out.find("correct"), std::string::npos);

  // The depth PNG with the camera file gives the same grid as the PCD.
  const CliResult info = run("info " + (dir / "scene" / "depth.png").string() + " --intrinsics " +
                             (dir / "scene" / "camera.json").string());
  ASSERT_EQ(info.code, 0) << info.out;
  EXPECT_NE(info.out.find("640 x 480"), std::string::npos) << info.out;
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

TEST(Cli, SegcompEvaluationRuns) {
  RANGESEG_REQUIRE_DATA("segcomp_abw/abw.test.3.range");
  const CliResult r = run("eval " + (data_file.parent_path() / "abw.test.3.gt-seg").string() + " " +
                          (data_file.parent_path() / "abw.test.3.gt-seg").string());
  // A .gt-seg is not a machine segmentation format: a clear error, not a crash.
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("abw.test.3.gt-seg"), std::string::npos);
}

TEST(Cli, ConfigFileOverridesAndRejectsUnknownKeys) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_config");
  ASSERT_EQ(run("synth -o " + dir.string() + " --noise none --scene boxes --seed 2").code, 0);
  std::ofstream(dir / "good.json") << R"({"noise": {"a": 0.002}, "mesh": {"jump_sigmas": 4},
      "smoothing": {"iterations": 1}, "segmentation": {"min_region_size": 50, "merge_rms_sigmas": 1.5}})";
  std::ofstream(dir / "bad.json") << R"({"segmentation": {"min_region_sise": 50}})";
  const CliResult good = run("segment " + (dir / "cloud.pcd").string() + " -o " + (dir / "g").string() +
                             " --no-mesh --config " + (dir / "good.json").string());
  EXPECT_EQ(good.code, 0) << good.out;
  const CliResult bad = run("segment " + (dir / "cloud.pcd").string() + " -o " + (dir / "b").string() +
                            " --config " + (dir / "bad.json").string());
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.out.find("min_region_sise"), std::string::npos) << bad.out;
  EXPECT_FALSE(fs::exists(dir / "b" / "labels.png"));
}
