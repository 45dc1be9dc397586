// Error messages and exit codes of the rangeseg command-line tool for bad --config files, folders
// and options of the eval commands, which must stop before any work.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "cli_util.hpp"
#include "rangeseg/io/png.hpp"
#include "test_util.hpp"

namespace fs = std::filesystem;

namespace {

using rangeseg::test::CliResult;
CliResult run(const std::string& args) { return rangeseg::test::run_cli(args); }

using rangeseg::test::contains;

/// A folder with SegComp ABW image `n` (linked) and its ground truth: one image scores fast.
fs::path one_abw_image(const fs::path& dir, const fs::path& data, int n) {
  const std::string stem = "abw.test." + std::to_string(n);
  for (const char* ext : {".range", ".gt-seg"}) {
    fs::create_symlink(data / (stem + ext), dir / (stem + ext));
  }
  return dir;
}

}  // namespace

// eval-synth reads the config file before it renders anything.
TEST(CliErrors, ConfigErrorsNameTheFileAndTheKey) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_errors_config");
  const fs::path config = dir / "my_settings.json";
  const struct {
    const char* json;
    const char* key;
  } cases[] = {
      {R"({"mesh": {"type": "triangle"}})", "key 'type'"},
      {R"({"mesh": {"type": 3}})", "key 'type'"},
      {R"({"segmentation": {"model": 5}})", "key 'model'"},
      {R"({"noise": {"a": -1}})", "[noise]: key 'a' = -1"},
      {R"({"segmentation": {"min_region_size": -5}})",
       "[segmentation]: key 'min_region_size' = -5"},
      {R"({"mesh": {"eps_theta": 7}})", "[mesh]: key 'eps_theta' = 7"},
      {R"({"smoothing": {"iterations": -1}})", "[smoothing]: key 'iterations' = -1"},
      {R"({"rings": {"k": 1}})", "[rings]: key 'k' = 1"},
      // Two invalid keys: the error is about the first.
      {R"({"segmentation": {"min_region_size": -5, "growth_bands": 0}})",
       "[segmentation]: key 'min_region_size' = -5"},
  };
  for (const auto& c : cases) {
    std::ofstream(config) << c.json;
    const CliResult r =
        run("eval-synth --seeds 1 --config " + config.string() + " -o " + (dir / "out").string());
    EXPECT_EQ(r.code, 2) << c.json;
    EXPECT_TRUE(contains(r.out, config.string() + " [")) << c.json << "\n" << r.out;
    EXPECT_TRUE(contains(r.out, c.key)) << c.json << "\n" << r.out;
    EXPECT_FALSE(contains(r.out, "image ")) << "no table before the error: " << r.out;
    EXPECT_FALSE(fs::exists(dir / "out")) << c.json;
  }
}

// Before the fix the segmentation settings were checked image by image ("skipped: ...").
TEST(CliErrors, SegcompConfigErrorStopsBeforeAnyImage) {
  RANGESEG_REQUIRE_DATA("segcomp_abw/abw.test.9.range");
  const fs::path dir = rangeseg::test::scratch_dir("cli_errors_segcomp_config");
  fs::create_directories(dir / "images");
  one_abw_image(dir / "images", data_file.parent_path(), 9);
  std::ofstream(dir / "bad.json") << R"({"segmentation": {"min_region_size": -5}})";
  const CliResult r =
      run("eval-segcomp " + (dir / "images").string() + " --config " + (dir / "bad.json").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(
      contains(r.out, (dir / "bad.json").string() + " [segmentation]: key 'min_region_size'"))
      << r.out;
  EXPECT_FALSE(contains(r.out, "skipped")) << r.out;
}

TEST(CliErrors, SegcompFolderThatCannotBeReadOrHoldsNoImages) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_errors_segcomp_dir");
  const std::string missing = (dir / "nowhere").string();
  const CliResult r = run("eval-segcomp " + missing);
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(contains(r.out, missing + ": cannot open the folder: No such file or directory"))
      << r.out;
  EXPECT_FALSE(contains(r.out, "filesystem error")) << r.out;

  std::ofstream(dir / "notes.txt") << "not a folder";
  const CliResult file = run("eval-segcomp " + (dir / "notes.txt").string());
  EXPECT_EQ(file.code, 2);
  EXPECT_TRUE(contains(file.out, (dir / "notes.txt").string() + ": cannot open the folder"))
      << file.out;

  fs::create_directories(dir / "empty");
  const CliResult empty = run("eval-segcomp " + (dir / "empty").string());
  EXPECT_EQ(empty.code, 2);
  EXPECT_TRUE(contains(empty.out, (dir / "empty").string() + ": no .range file")) << empty.out;
}

TEST(CliErrors, ToleranceOutsideItsRangeStopsBeforeAnyWork) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_errors_tolerance");
  rangeseg::LabelImage labels(4, 4, 1);
  rangeseg::io::write_label_png((dir / "labels.png").string(), labels);
  const std::string png = (dir / "labels.png").string();

  const CliResult synth = run("eval-synth --seeds 1 --T 1.5 -o " + (dir / "out").string());
  EXPECT_EQ(synth.code, 2);
  EXPECT_TRUE(contains(synth.out, "--T 1.5: the overlap tolerance must be in (0.5, 1]"))
      << synth.out;
  EXPECT_FALSE(contains(synth.out, "image ")) << "nothing rendered: " << synth.out;
  EXPECT_FALSE(fs::exists(dir / "out"));

  // The files are read after the check: a missing one does not hide the bad --T.
  const CliResult eval = run("eval " + png + " " + (dir / "missing.png").string() + " --T 0.5");
  EXPECT_EQ(eval.code, 2);
  EXPECT_TRUE(contains(eval.out, "--T 0.5: the overlap tolerance must be in (0.5, 1]")) << eval.out;
  EXPECT_EQ(run("eval " + png + " " + png + " --T 1").code, 0);

  for (const char* command : {"eval", "eval-segcomp", "eval-synth"}) {
    const CliResult help = run(std::string(command) + " --help");
    EXPECT_TRUE(contains(help.out, "0.5 < T <= 1")) << command << "\n" << help.out;
  }
}

TEST(CliErrors, SegcompToleranceIsCheckedBeforeTheImages) {
  RANGESEG_REQUIRE_DATA("segcomp_abw/abw.test.9.range");
  const fs::path dir = rangeseg::test::scratch_dir("cli_errors_segcomp_tolerance");
  const fs::path images = one_abw_image(dir, data_file.parent_path(), 9);
  const CliResult r = run("eval-segcomp " + images.string() + " --T 0.3");
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(contains(r.out, "--T 0.3: the overlap tolerance must be in (0.5, 1]")) << r.out;
  EXPECT_FALSE(contains(r.out, "skipped")) << r.out;
}

// abw.test.9 scores differently with the plane and the auto model (15 and 13 regions correct).
TEST(CliErrors, SegcompTakesTheModelOption) {
  RANGESEG_REQUIRE_DATA("segcomp_abw/abw.test.9.range");
  const fs::path dir = rangeseg::test::scratch_dir("cli_errors_segcomp_model");
  fs::create_directories(dir / "images");
  const std::string images = one_abw_image(dir / "images", data_file.parent_path(), 9).string();
  std::ofstream(dir / "auto.json") << R"({"segmentation": {"model": "auto"}})";
  const CliResult plane = run("eval-segcomp " + images);
  const CliResult automatic = run("eval-segcomp " + images + " --model auto");
  const CliResult configured =
      run("eval-segcomp " + images + " --config " + (dir / "auto.json").string());
  ASSERT_EQ(plane.code, 0) << plane.out;
  ASSERT_EQ(automatic.code, 0) << automatic.out;
  ASSERT_EQ(configured.code, 0) << configured.out;
  EXPECT_EQ(automatic.out, configured.out);
  EXPECT_NE(automatic.out, plane.out);
  const CliResult bad = run("eval-segcomp " + images + " --model cone");
  EXPECT_EQ(bad.code, 2);
  EXPECT_TRUE(contains(bad.out, "unknown model 'cone'")) << bad.out;
  EXPECT_FALSE(contains(bad.out, "skipped")) << bad.out;
}

// A usage error reads as every other error: prefixed, exit code 2, with a pointer to --help.
TEST(CliErrors, UsageErrorsNameTheProgram) {
  for (const char* args : {"segment", "segment a.pcd --no-such-option", "no-such-command",
                           "segment a.pcd --threads many"}) {
    const CliResult r = run(args);
    EXPECT_EQ(r.code, 2) << args;
    EXPECT_TRUE(r.out.starts_with("rangeseg: error: ")) << args << ": " << r.out;
    EXPECT_TRUE(contains(r.out, "--help")) << args << ": " << r.out;
  }
}

// A file whose name starts with '-' is read as an option; before, the error said only "input is
// required".
TEST(CliErrors, AFileNamedLikeAnOptionGetsANote) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_errors_dash");
  rangeseg::test::write_small_pcd(dir / "-frame.pcd", 3);
  const std::string cd = "cd " + dir.string() + " && " + RANGESEG_CLI;
  CliResult r = rangeseg::test::run_shell(cd + " segment -frame.pcd -o out 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out,
                       "'-frame.pcd' is a file, read as an option here; name it "
                       "./-frame.pcd"))
      << r.out;
  r = rangeseg::test::run_shell(cd + " segment ./-frame.pcd -o out 2>&1");
  EXPECT_EQ(r.code, 0) << r.out;
  r = run("segment a.pcd --no-such-option");  // no such file: no note
  EXPECT_FALSE(contains(r.out, "note:")) << r.out;
}

// Label PNGs bring no points: no plane pair, no angle error.
TEST(CliErrors, EvalWithoutPlanePairsPrintsNoNan) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_errors_nan");
  rangeseg::LabelImage labels(8, 8, 1);
  for (int v = 4; v < 8; ++v) {
    for (int u = 0; u < 8; ++u) labels(u, v) = 2;
  }
  const std::string png = (dir / "labels.png").string();
  rangeseg::io::write_label_png(png, labels);
  const CliResult r = run("eval " + png + " " + png);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_FALSE(contains(r.out, "nan")) << r.out;
  std::istringstream lines(r.out);
  std::string line;
  std::getline(lines, line);  // T and the ground truth's labels
  std::getline(lines, line);  // header
  std::getline(lines, line);
  EXPECT_EQ(line.substr(0, 10), "labels.png") << r.out;
  EXPECT_EQ(line.back(), '-') << r.out;
}

// `settings` prints every key of a config; given back as --config it gives the same settings,
// also under another preset, and a bad config is an error of its own.
TEST(CliConfig, SettingsPrintAConfigThatGivesThemBack) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_settings");
  const fs::path file = dir / "abw.json";
  ASSERT_EQ(run("settings --preset abw --model auto -o " + file.string()).code, 0);
  std::stringstream text;
  text << std::ifstream(file).rdbuf();
  EXPECT_TRUE(contains(text.str(), "\"model\": \"auto\"")) << text.str();
  EXPECT_TRUE(contains(text.str(), "\"smooth\": false")) << text.str();
  const CliResult back = run("settings --preset kinect --config " + file.string());
  ASSERT_EQ(back.code, 0) << back.out;
  EXPECT_EQ(back.out, text.str());
  std::ofstream(dir / "bad.json") << R"({"segmentation": {"growth_bands": 0}})";
  const CliResult bad = run("settings --config " + (dir / "bad.json").string());
  EXPECT_EQ(bad.code, 2);
  EXPECT_TRUE(contains(bad.out, "key 'growth_bands' = 0 is invalid")) << bad.out;
}
