// What the rangeseg command-line tool leaves when a run cannot write what it was asked for: it
// never writes a result over its own input, a failed command leaves none of its outputs, a
// redirected stdout that cannot be written is an error, and names that are not UTF-8 reach the
// batch summary. (Running out of memory: Pipeline.AFrameThatRunsOutOfMemoryLeavesThePipeline...
// fails every allocation of a frame in turn; an address-space limit fails at points that vary
// from run to run, so it makes no repeatable test.)
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "cli_util.hpp"
#include "test_util.hpp"

namespace fs = std::filesystem;

namespace {

using rangeseg::test::CliResult;
using rangeseg::test::contains;
using rangeseg::test::read_text;
using rangeseg::test::run_cli;
using rangeseg::test::run_shell;
using rangeseg::test::write_small_pcd;

}  // namespace

// Before: `segment cloud.pcd -o . --cloud` replaced the user's cloud.pcd with its result (and a
// later run removed it as "an earlier run's"); `smooth a.pcd -o a.pcd` smoothed it in place.
TEST(CliOutputs, ARunNeverWritesOverItsInput) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_outputs_input");
  const fs::path cloud = dir / "cloud.pcd";
  write_small_pcd(cloud, 3);
  const std::string before = read_text(cloud);

  CliResult r = run_cli("segment " + cloud.string() + " -o " + dir.string() + " --cloud");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, cloud.string() + ": an input of this run")) << r.out;
  EXPECT_FALSE(fs::exists(dir / "labels.png")) << "no half result set: " << r.out;
  // The same folder without --cloud writes no cloud.pcd, so it may hold the input.
  r = run_cli("segment " + cloud.string() + " -o " + dir.string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(dir / "labels.png")) << r.out;

  // Another spelling of the same file, and a hard link to it.
  fs::create_hard_link(cloud, dir / "link.pcd");
  for (const std::string& args :
       {"smooth " + cloud.string() + " -o " + (dir / "." / "cloud.pcd").string(),
        "convert " + cloud.string() + " " + (dir / "link.pcd").string(),
        "mesh " + cloud.string() + " -o " + (dir / "m.ply").string() + " --normal-png " +
            (dir / "n.png").string() + " --curvature-png " + (dir / "." / "n.png").string()}) {
    r = run_cli(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_TRUE(contains(r.out, "would write")) << args << "\n" << r.out;
  }
  EXPECT_EQ(read_text(cloud), before);
  EXPECT_FALSE(fs::exists(dir / "m.ply"));
  EXPECT_FALSE(fs::exists(dir / "n.png"));
}

// Before: `mesh -o m.ply --normal-png unwritable/n.png` exited 2 with m.ply written, and
// `convert x.pcd d.png` without room for d.json left the PNG without its intrinsics. Later, a
// failed command removed what it had written, so an earlier run's m.ply was lost with it.
TEST(CliOutputs, AFailedCommandLeavesItsOutputsAsTheyWere) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_outputs_failed");
  const fs::path cloud = dir / "frame.pcd";
  write_small_pcd(cloud, 4);
  std::ofstream(dir / "not_a_folder") << "x";
  CliResult r = run_cli("mesh " + cloud.string() + " -o " + (dir / "m.ply").string() +
                        " --normal-png " + (dir / "not_a_folder" / "n.png").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_FALSE(fs::exists(dir / "m.ply")) << r.out;
  std::ofstream(dir / "m.ply") << "an earlier run's";
  r = run_cli("mesh " + cloud.string() + " -o " + (dir / "m.ply").string() + " --normal-png " +
              (dir / "not_a_folder" / "n.png").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_EQ(read_text(dir / "m.ply"), "an earlier run's") << r.out;

  fs::create_directory(dir / "d.json");  // where convert writes the PNG's intrinsics
  r = run_cli("convert " + cloud.string() + " " + (dir / "d.png").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, (dir / "d.json").string() + ": cannot be written: a folder"))
      << r.out;
  EXPECT_FALSE(fs::exists(dir / "d.png")) << r.out;
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 4)
      << "a temporary was left behind";
}

// A result folder is replaced as a unit: a run that fails at its last file leaves the earlier
// run's labels, segments and pictures, not a mixture of two frames' results.
TEST(CliOutputs, AResultFolderIsReplacedWhollyOrNotAtAll) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_outputs_unit");
  const fs::path first = dir / "first.pcd", second = dir / "second.pcd";
  write_small_pcd(first, 4);
  write_small_pcd(second, 6);
  const fs::path out = dir / "out";
  CliResult r = run_cli("segment " + first.string() + " -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string labels = read_text(out / "labels.png");
  const std::string segments = read_text(out / "segments.json");
  // mesh.ply, the last file written, cannot replace a folder of that name.
  fs::remove(out / "mesh.ply");
  fs::create_directory(out / "mesh.ply");
  r = run_cli("segment " + second.string() + " -o " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "mesh.ply: cannot be written: a folder of that name exists"))
      << r.out;
  EXPECT_EQ(read_text(out / "labels.png"), labels);
  EXPECT_EQ(read_text(out / "segments.json"), segments);
  for (const auto& entry : fs::directory_iterator(out)) {
    EXPECT_FALSE(contains(entry.path().filename().string(), ".tmp.")) << entry.path();
  }
  fs::remove(out / "mesh.ply");
  r = run_cli("segment " + second.string() + " -o " + out.string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(read_text(out / "segments.json"), segments) << "the frames should differ";
}

// Before: a file size limit (ulimit -f) ended the run by SIGXFSZ with a core dump, leaving its
// temporaries; now the write fails with an error that names the file, and nothing is left.
TEST(CliOutputs, AFileSizeLimitIsAnErrorNamingTheFile) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_outputs_fsize");
  const fs::path cloud = dir / "frame.pcd";
  write_small_pcd(cloud, 4);
  const fs::path out = dir / "out";
  // 1 KiB: more than the first file's header, less than any of the results.
  const CliResult r = run_shell("ulimit -f 1 && " + std::string(RANGESEG_CLI) + " segment " +
                                cloud.string() + " -o " + out.string() + " 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "write error: File too large")) << r.out;
  EXPECT_TRUE(fs::is_empty(out)) << r.out;
}

// An output folder that cannot be made says why; create_directories' own words were "File
// exists" for a link to nothing and for a file of that name.
TEST(CliOutputs, AnOutputFolderThatCannotBeMadeSaysWhy) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_outputs_folder");
  const fs::path cloud = dir / "frame.pcd";
  write_small_pcd(cloud, 4);
  fs::create_directory_symlink(dir / "gone", dir / "link");
  std::ofstream(dir / "file") << "x";
  CliResult r = run_cli("segment " + cloud.string() + " -o " + (dir / "link").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(
      r.out, "a symbolic link to '" + (dir / "gone").string() + "', which is no directory"))
      << r.out;
  r = run_cli("segment " + cloud.string() + " -o " + (dir / "file").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "a file of that name exists")) << r.out;
  EXPECT_FALSE(fs::exists(dir / "gone"));
}

// Temporaries NAME.tmp.PID of a killed process (no handler ran) go when a later run writes NAME;
// before, only `segment`'s own result names were cleaned.
TEST(CliOutputs, AKilledRunsTemporaryGoesWhenItsFileIsWrittenAgain) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_outputs_stale");
  const fs::path cloud = dir / "frame.pcd";
  write_small_pcd(cloud, 5);
  // A PID above any this system hands out (pid_max is at most 2^22).
  const fs::path stale = dir / "out.pcd.tmp.999999999";
  const fs::path running = dir / ("out.pcd.tmp." + std::to_string(::getpid()));
  std::ofstream(stale) << "half";
  std::ofstream(running) << "being written";
  const CliResult r = run_cli("convert " + cloud.string() + " " + (dir / "out.pcd").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_FALSE(fs::exists(stale)) << r.out;
  EXPECT_TRUE(fs::exists(running)) << "its writer still runs: " << r.out;
}

// Before: `rangeseg settings > /dev/full` exited 0, leaving an empty file where JSON was due.
TEST(CliOutputs, StdoutThatCannotBeWrittenIsAnError) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full on this system";
  std::string command = RANGESEG_CLI;
  command.append(" settings 2>&1 > /dev/full");
  const CliResult r = run_shell(command);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "cannot write standard output")) << r.out;
}

// Before: a frame named in Latin-1 was segmented, then writing summary.json failed on its name
// ("invalid UTF-8 byte"), so the batch exited 2 without a summary.
TEST(CliOutputs, AFrameNameThatIsNotUtf8ReachesTheSummary) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_outputs_latin1");
  write_small_pcd(dir / "in" / "fr\xe9me.pcd", 6);
  write_small_pcd(dir / "in" / "ok.pcd", 7);
  const CliResult r = run_cli("segment " + (dir / "in").string() + " -o " + (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json summary = rangeseg::test::read_json(dir / "out" / "summary.json");
  ASSERT_EQ(summary["per_frame"].size(), 2U);
  EXPECT_TRUE(contains(summary["per_frame"][0]["input"].get<std::string>(), "fr\xef\xbf\xbdme"))
      << summary.dump();
}
