// End-to-end tests of `rangeseg segment` over several frames: what the clean-up of result folders
// keeps, inputs that hold no frame or a dangling link, TUM sequences beside other depth images,
// an interrupted batch, more threads than cores.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "cli_util.hpp"
#include "rangeseg/camera.hpp"
#include "rangeseg/io/ply.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/version.hpp"
#include "test_util.hpp"

namespace fs = std::filesystem;

namespace {

using rangeseg::test::contains;
using rangeseg::test::read_json;
using rangeseg::test::read_text;
using rangeseg::test::run_cli;
using rangeseg::test::small_frame;
using rangeseg::test::write_small_pcd;

/// An input folder given as the output folder holds inputs with result names (cloud.pcd, a
/// mesh.ply that rangeseg wrote itself): the clean-up of an earlier run's results keeps them. A
/// file of a result's name that rangeseg did not write stays too, with a warning; one it wrote
/// goes.
TEST(CliBatch, CleanUpKeepsInputsAndFilesRangesegDidNotWrite) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_batch_keep");
  write_small_pcd(dir / "one" / "cloud.pcd", 3);
  const rangeseg::test::CliResult single =
      run_cli("segment " + (dir / "one" / "cloud.pcd").string() + " -o " + (dir / "one").string());
  ASSERT_EQ(single.code, 0) << single.out;
  EXPECT_TRUE(fs::exists(dir / "one" / "cloud.pcd")) << single.out;
  EXPECT_TRUE(fs::exists(dir / "one" / "labels.png"));

  write_small_pcd(dir / "many" / "cloud.pcd", 4);
  rangeseg::io::write_ply_cloud((dir / "many" / "mesh.ply").string(), small_frame(5));
  ASSERT_TRUE(contains(read_text(dir / "many" / "mesh.ply"), "rangeseg"));
  const rangeseg::test::CliResult batch =
      run_cli("segment " + (dir / "many").string() + " -o " + (dir / "many").string());
  ASSERT_EQ(batch.code, 0) << batch.out;
  EXPECT_TRUE(fs::exists(dir / "many" / "cloud.pcd")) << batch.out;
  EXPECT_TRUE(fs::exists(dir / "many" / "mesh.ply")) << batch.out;
  EXPECT_TRUE(fs::exists(dir / "many" / "mesh" / "labels.png")) << batch.out;

  // Results of an earlier run: mesh.ply (rangeseg's) goes with --no-mesh; a user's stays.
  const fs::path out = dir / "out";
  const std::string frame = (dir / "one" / "cloud.pcd").string();
  ASSERT_EQ(run_cli("segment " + frame + " -o " + out.string()).code, 0);
  ASSERT_TRUE(fs::exists(out / "mesh.ply"));
  rangeseg::test::CliResult again = run_cli("segment " + frame + " --no-mesh -o " + out.string());
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_FALSE(fs::exists(out / "mesh.ply")) << again.out;
  std::ofstream(out / "mesh.ply") << "a user's notes\n";
  again = run_cli("segment " + frame + " --no-mesh -o " + out.string());
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_TRUE(fs::exists(out / "mesh.ply")) << again.out;
  EXPECT_TRUE(contains(again.out, "kept")) << again.out;
}

/// An input folder without frames, or a depth.txt that lists none, is one failed frame of the
/// batch, as a missing file is, and so is a dangling symbolic link of a frame's name in a
/// scanned folder (a sequence whose files moved), which says where it points: the other inputs
/// are segmented.
TEST(CliBatch, AnInputWithoutFramesIsReportedAndSkipped) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_batch_empty");
  fs::create_directories(dir / "empty");
  fs::create_directories(dir / "tum");
  std::ofstream(dir / "tum" / "depth.txt") << "# depth maps\n";
  write_small_pcd(dir / "a.pcd", 6);
  write_small_pcd(dir / "seq" / "0001.pcd", 8);
  fs::create_symlink(dir / "moved" / "0002.pcd", dir / "seq" / "0002.pcd");
  fs::create_symlink(dir / "moved" / "notes.txt", dir / "seq" / "notes.txt");  // no frame
  const rangeseg::test::CliResult r = run_cli(
      "segment " + (dir / "empty").string() + " " + (dir / "tum").string() + " " +
      (dir / "seq").string() + " " + (dir / "a.pcd").string() + " -o " + (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(contains(r.out, "no .pcd")) << r.out;
  EXPECT_TRUE(contains(r.out, "lists no depth images")) << r.out;
  EXPECT_TRUE(contains(r.out, "0002.pcd: a symbolic link to")) << r.out;
  EXPECT_TRUE(contains(r.out, "which does not exist")) << r.out;
  EXPECT_TRUE(fs::exists(dir / "out" / "a" / "labels.png"));
  EXPECT_TRUE(fs::exists(dir / "out" / "0001" / "labels.png"));
  const nlohmann::json summary = read_json(dir / "out" / "summary.json");
  EXPECT_EQ(summary["rangeseg_version"], RANGESEG_VERSION_STRING);
  EXPECT_EQ(summary["frames"], 5);
  EXPECT_EQ(summary["failed"], 3);
  // No PNG among the frames: nothing to say about depth images.
  EXPECT_FALSE(summary.contains("depth_png"));
}

/// TUM's 5000 units per metre apply to the frames its depth.txt lists, not to a millimetre depth
/// image given beside the sequence (nor the other way round); a depth.txt with a byte order mark
/// names its first frame by the timestamp alone.
TEST(CliBatch, TumScaleAppliesOnlyToTheSequencesFrames) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_batch_tum_mix");
  const rangeseg::OrganizedCloud cloud = small_frame(7);
  fs::create_directories(dir / "seq" / "depth");
  rangeseg::io::write_depth_png((dir / "seq" / "depth" / "17.5.png").string(),
                                rangeseg::cloud_to_depth(cloud, 1.0 / 5000.0).view());
  std::ofstream(dir / "seq" / "depth.txt") << "\xEF\xBB\xBF# depth maps\n17.5 depth/17.5.png\n";
  rangeseg::io::write_depth_png((dir / "mm.png").string(),
                                rangeseg::cloud_to_depth(cloud, 0.001).view());
  const rangeseg::test::CliResult r =
      run_cli("segment " + (dir / "seq").string() + " " + (dir / "mm.png").string() +
              " --fx 131.25 --fy 131.25 --cx 79.5 --cy 59.5 -o " + (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto weighted_depth = [](const fs::path& folder) {
    double z = 0, n = 0;
    const nlohmann::json segments = read_json(folder / "segments.json");
    for (const auto& s : segments["segments"]) {
      z += s["centroid"][2].get<double>() * s["pixel_count"].get<double>();
      n += s["pixel_count"].get<double>();
    }
    return n > 0 ? z / n : 0.0;
  };
  ASSERT_TRUE(fs::exists(dir / "out" / "17.5" / "segments.json")) << r.out;
  const double tum = weighted_depth(dir / "out" / "17.5");
  const double mm = weighted_depth(dir / "out" / "mm");
  ASSERT_GT(tum, 0.0) << r.out;
  EXPECT_NEAR(mm, tum, 0.02 * tum) << r.out;
  const nlohmann::json summary = read_json(dir / "out" / "summary.json");
  EXPECT_DOUBLE_EQ(summary["tum_depth_png"]["depth_scale_m_per_unit"].get<double>(), 1.0 / 5000);
  EXPECT_DOUBLE_EQ(summary["depth_png"]["depth_scale_m_per_unit"].get<double>(), 0.001);

  // The sequence's depth/ folder given on its own is read in millimetres, with a warning.
  const rangeseg::test::CliResult sub =
      run_cli("segment " + (dir / "seq" / "depth").string() + " -o " + (dir / "sub").string());
  EXPECT_TRUE(contains(sub.out, "TUM RGB-D sequence")) << sub.out;
}

/// SIGINT stops a batch after the frames being processed: every frame folder it wrote is
/// complete, the summary names the signal and the frames that ran, and the process ends by the
/// signal.
TEST(CliBatch, SigintStopsAfterTheCurrentFrames) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_batch_sigint");
  constexpr int kFrames = 300;
  write_small_pcd(dir / "in" / "f0.pcd", 8);
  for (int i = 1; i < kFrames; ++i) {
    // (Appended: GCC 12 warns, wrongly, about "f" + std::to_string(i).)
    std::string name = "f";
    name.append(std::to_string(i)).append(".pcd");
    fs::copy_file(dir / "in" / "f0.pcd", dir / "in" / name);
  }
  const std::string out = (dir / "out").string();
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const std::string in = (dir / "in").string();
    ::freopen("/dev/null", "w", stdout);
    ::freopen("/dev/null", "w", stderr);
    ::execl(RANGESEG_CLI, RANGESEG_CLI, "segment", in.c_str(), "-o", out.c_str(),
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Once the first frame's folder is complete, the batch is under way.
  while (!fs::exists(dir / "out" / "f0" / "mesh.ply")) {
    if (::waitpid(pid, nullptr, WNOHANG) == pid) FAIL() << "the batch ended before a frame";
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ::kill(pid, SIGINT);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  const nlohmann::json summary = read_json(dir / "out" / "summary.json");
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0 && summary["run"] == kFrames) {
    GTEST_SKIP() << "all " << kFrames << " frames were done before the signal arrived";
  }
  ASSERT_TRUE(WIFSIGNALED(status)) << status;
  EXPECT_EQ(WTERMSIG(status), SIGINT);
  EXPECT_EQ(summary["stopped_by"], "SIGINT");
  const int run = summary["run"].get<int>();
  EXPECT_GE(run, 1);
  EXPECT_LT(run, kFrames);
  EXPECT_EQ(summary["per_frame"].size(), static_cast<std::size_t>(run));
  int folders = 0;
  for (const auto& e : fs::directory_iterator(dir / "out")) {
    if (!e.is_directory()) continue;
    ++folders;
    for (const char* name :
         {"labels.png", "segments.json", "overlay.png", "types.png", "mesh.ply"}) {
      EXPECT_TRUE(fs::exists(e.path() / name)) << e.path() << " lacks " << name;
    }
  }
  EXPECT_EQ(folders, run);
}

/// An output folder that cannot be written stops the batch before any frame is read (one error,
/// exit code 2).
TEST(CliBatch, UnwritableOutputFolderStopsBeforeAnyFrame) {
  if (::geteuid() == 0) GTEST_SKIP() << "root writes into any folder";
  const fs::path dir = rangeseg::test::scratch_dir("cli_batch_readonly");
  write_small_pcd(dir / "a.pcd", 9);
  write_small_pcd(dir / "b.pcd", 10);
  fs::create_directories(dir / "out");
  fs::permissions(dir / "out", fs::perms::owner_read | fs::perms::owner_exec);
  const rangeseg::test::CliResult r =
      run_cli("segment " + (dir / "a.pcd").string() + " " + (dir / "b.pcd").string() + " -o " +
              (dir / "out").string());
  fs::permissions(dir / "out", fs::perms::owner_all);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "cannot write into the output folder")) << r.out;
  EXPECT_FALSE(contains(r.out, "frames processed")) << r.out;
}

/// More threads than the cores the process may use (its affinity) are named, for one frame and
/// for a batch; as many as the cores are not. The results are those of one thread.
TEST(CliBatch, MoreThreadsThanCoresAreNamed) {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  ASSERT_EQ(sched_getaffinity(0, sizeof allowed, &allowed), 0);
  const int cores = CPU_COUNT(&allowed);
  if (cores >= 256) GTEST_SKIP() << cores << " cores: --threads cannot exceed them";
  const fs::path dir = rangeseg::test::scratch_dir("cli_threads_cores");
  write_small_pcd(dir / "in" / "a.pcd", 3);
  write_small_pcd(dir / "in" / "b.pcd", 4);
  const std::string warning =
      "warning: --threads " + std::to_string(cores + 1) + " on " + std::to_string(cores) + " core";
  const std::string frame = (dir / "in" / "a.pcd").string();
  const auto segment = [&](const std::string& input, int threads, const std::string& out) {
    return run_cli("segment " + input + " --threads " + std::to_string(threads) + " -o " +
                   (dir / out).string());
  };
  const auto one = segment(frame, 1, "one");
  ASSERT_EQ(one.code, 0) << one.out;
  EXPECT_FALSE(contains(one.out, "warning: --threads")) << one.out;
  const auto as_many = segment(frame, cores, "cores");
  ASSERT_EQ(as_many.code, 0) << as_many.out;
  EXPECT_FALSE(contains(as_many.out, "warning: --threads")) << as_many.out;
  const auto more = segment(frame, cores + 1, "more");
  ASSERT_EQ(more.code, 0) << more.out;
  EXPECT_TRUE(contains(more.out, warning)) << more.out;
  EXPECT_EQ(read_text(dir / "more" / "labels.png"), read_text(dir / "one" / "labels.png"));
  const auto batch = segment((dir / "in").string(), cores + 1, "batch");
  ASSERT_EQ(batch.code, 0) << batch.out;
  EXPECT_TRUE(contains(batch.out, warning)) << batch.out;
}

}  // namespace
