// The CLI's options on inputs and outputs: smoothing passes, output types, intrinsics files.
#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "cli_util.hpp"
#include "rangeseg/camera.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/ply.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/synth.hpp"
#include "test_util.hpp"

namespace fs = std::filesystem;

namespace {

using rangeseg::test::CliResult;
CliResult run(const std::string& args) { return rangeseg::test::run_cli(args); }

using rangeseg::test::contains;

std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// A small noisy synthetic frame (160x120) so that the commands run in a fraction of a second.
fs::path write_small_pcd(const fs::path& dir) {
  const rangeseg::CameraIntrinsics camera{
      .fx = 131.25, .fy = 131.25, .cx = 79.5, .cy = 59.5, .width = 160, .height = 120};
  fs::path path = dir / "small.pcd";
  rangeseg::io::write_pcd(
      path.string(),
      rangeseg::synth::render(
          rangeseg::synth::random_scene(1, false),
          {.camera = camera, .noise = rangeseg::synth::Noise::kinect, .seed = 1})
          .cloud,
      {.encoding = rangeseg::io::PcdEncoding::binary_compressed});
  return path;
}

/// Runs `smooth INPUT -o DIR/NAME EXTRA` and returns the bytes written.
std::string smooth_bytes(const fs::path& input, const fs::path& dir, const std::string& name,
                         const std::string& extra) {
  const fs::path out = dir / name;
  const CliResult r = run("smooth " + input.string() + " -o " + out.string() + " " + extra);
  EXPECT_EQ(r.code, 0) << r.out;
  return read_bytes(out);
}

}  // namespace

// The ideal and abw presets turn the filter off; an explicit --iterations must still filter.
TEST(CliInputs, SmoothIterationsTurnTheFilterOnUnderAPresetWithoutIt) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_iterations");
  const fs::path pcd = write_small_pcd(dir);
  const std::string none = smooth_bytes(pcd, dir, "i0.pcd", "--preset ideal --iterations 0");
  const std::string two = smooth_bytes(pcd, dir, "i2.pcd", "--preset ideal --iterations 2");
  const std::string preset = smooth_bytes(pcd, dir, "preset.pcd", "--preset ideal");
  ASSERT_FALSE(none.empty());
  // Compared as booleans: a failure would otherwise print the whole files.
  EXPECT_TRUE(two != none) << "--iterations 2 wrote the unfiltered points";
  EXPECT_TRUE(preset == none) << "without --iterations the preset decides";
  // A preset that filters: --iterations 0 turns it off.
  EXPECT_TRUE(smooth_bytes(pcd, dir, "k.pcd", "--preset kinect") !=
              smooth_bytes(pcd, dir, "k0.pcd", "--preset kinect --iterations 0"))
      << "--iterations 0 still filtered";
}

TEST(CliInputs, SmoothIterationsFilterAnAbwImage) {
  RANGESEG_REQUIRE_DATA("segcomp_abw/abw.test.1.range");
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_abw");
  EXPECT_TRUE(smooth_bytes(data_file, dir, "a2.pcd", "--iterations 2") !=
              smooth_bytes(data_file, dir, "a0.pcd", "--iterations 0"))
      << "--iterations 2 wrote the unfiltered points";
}

// demo scores a SegComp image as eval does: a .gt-seg's labels 1 and 2 are unlabelled pixels,
// not regions (abw.test.0 has 27 regions and both values).
TEST(CliInputs, DemoScoresASegcompImageAsEvalDoes) {
  RANGESEG_REQUIRE_DATA("segcomp_abw/abw.test.0.range");
  RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS();
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_demo_segcomp");
  const CliResult demo = run("demo --input " + data_file.string() + " -o " + dir.string());
  ASSERT_EQ(demo.code, 0) << demo.out;
  const std::size_t at = demo.out.find("vs ground truth (T = 0.8): ");
  ASSERT_NE(at, std::string::npos) << demo.out;
  fs::path gt = data_file;
  gt.replace_extension(".gt-seg");
  const CliResult eval =
      run("eval " + gt.string() + " " + (dir / "segmentation" / "labels.png").string() +
          " --json " + (dir / "eval.json").string());
  ASSERT_EQ(eval.code, 0) << eval.out;
  std::ifstream json_file(dir / "eval.json");
  const std::string json((std::istreambuf_iterator<char>(json_file)),
                         std::istreambuf_iterator<char>());
  const std::size_t key = json.find("\"gt_regions\"");
  ASSERT_NE(key, std::string::npos) << json;
  const int regions = std::stoi(json.substr(json.find(':', key) + 1));
  EXPECT_EQ(regions, 27);
  EXPECT_TRUE(contains(demo.out, " of " + std::to_string(regions) + " regions correct"))
      << demo.out;
}

TEST(CliInputs, NegativeIterationsAreRejected) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_negative");
  const fs::path pcd = write_small_pcd(dir);
  const fs::path out = dir / "out.pcd";
  for (const char* value : {" -7", "=-1"}) {
    const CliResult r =
        run("smooth " + pcd.string() + " -o " + out.string() + " --iterations" + value);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_TRUE(contains(r.out, "--iterations")) << r.out;
    EXPECT_FALSE(fs::exists(out));
  }
}

TEST(CliInputs, SmoothAndMeshRejectAnOutputTypeTheyCannotWrite) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_ext");
  const std::string pcd = write_small_pcd(dir).string();
  struct Case {
    std::string args, path, expected;
  };
  const std::string ply = (dir / "points.ply").string(), txt = (dir / "mesh.txt").string(),
                    bare = (dir / "mesh").string(), jpg = (dir / "normals.jpg").string();
  const std::vector<Case> cases = {
      Case{"smooth " + pcd + " -o " + ply, ply, ".pcd"},
      Case{"mesh " + pcd + " -o " + txt, txt, ".ply"},
      Case{"mesh " + pcd + " -o " + bare, bare, ".ply"},
      Case{"mesh " + pcd + " -o " + (dir / "m.ply").string() + " --normal-png " + jpg, jpg,
           ".png"}};
  for (const Case& c : cases) {
    const CliResult r = run(c.args);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.out;
    EXPECT_TRUE(contains(r.out, c.path)) << r.out;
    EXPECT_TRUE(contains(r.out, "expected " + c.expected)) << r.out;
  }
  // Nothing was written: only the input is in the folder.
  int files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1);
  // The types they write still work, in any case.
  const CliResult smooth = run("smooth " + pcd + " -o " + (dir / "s.PCD").string());
  EXPECT_EQ(smooth.code, 0) << smooth.out;
  const CliResult mesh =
      run("mesh " + pcd + " -o " + (dir / "m.ply").string() + " --normal-png " +
          (dir / "n.png").string() + " --curvature-png " + (dir / "c.png").string());
  EXPECT_EQ(mesh.code, 0) << mesh.out;
  for (const char* f : {"s.PCD", "m.ply", "n.png", "c.png"}) EXPECT_TRUE(fs::exists(dir / f)) << f;
}

// Intrinsics stated for another resolution would give wrong points without a sign of it.
TEST(CliInputs, IntrinsicsMustFitTheDepthImage) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_intrinsics");
  rangeseg::DepthImage depth(8, 6, 1000);
  const fs::path png = dir / "depth.png";
  rangeseg::io::write_depth_png(png.string(), depth.view());
  const auto camera = [&dir](const std::string& name, const std::string& json) {
    std::ofstream((dir / name).string()) << json;
    return (dir / name).string();
  };
  const std::string matrix = R"("intrinsic_matrix": [6, 0, 0, 0, 6, 0, 3.5, 2.5, 1])";
  const std::string open3d_small =
      camera("small.json", R"({"width": 4, "height": 3, )" + matrix + "}");
  const std::string flat_wide =
      camera("wide.json", R"({"fx": 6, "fy": 6, "cx": 3.5, "cy": 2.5, "width": 16, "height": 6})");
  for (const std::string& json : {open3d_small, flat_wide}) {
    const CliResult r = run("info " + png.string() + " --intrinsics " + json);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_TRUE(contains(r.out, json)) << r.out;
    EXPECT_TRUE(contains(r.out, png.string())) << r.out;
    EXPECT_TRUE(contains(r.out, "8 x 6")) << r.out;
  }
  EXPECT_TRUE(contains(run("info " + png.string() + " --intrinsics " + open3d_small).out, "4 x 3"));
  const std::string open3d_fits =
      camera("fits.json", R"({"width": 8, "height": 6, )" + matrix + "}");
  const std::string flat_unsized =
      camera("unsized.json", R"({"fx": 6, "fy": 6, "cx": 3.5, "cy": 2.5})");
  for (const std::string& json : {open3d_fits, flat_unsized}) {
    const CliResult r = run("info " + png.string() + " --intrinsics " + json);
    EXPECT_EQ(r.code, 0) << r.out;
  }
}

TEST(CliInputs, IntrinsicsFileAndNumbersExcludeEachOther) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_exclude");
  rangeseg::DepthImage depth(8, 6, 1000);
  const fs::path png = dir / "depth.png";
  rangeseg::io::write_depth_png(png.string(), depth.view());
  const fs::path json = dir / "camera.json";
  std::ofstream(json) << R"({"fx": 6, "fy": 6, "cx": 3.5, "cy": 2.5})";
  for (const char* option : {"--fx", "--fy", "--cx", "--cy"}) {
    const CliResult r =
        run("info " + png.string() + " --intrinsics " + json.string() + " " + option + " 5");
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_TRUE(contains(r.out, "--intrinsics")) << r.out;
    EXPECT_TRUE(contains(r.out, option)) << r.out;
  }
  EXPECT_EQ(run("info " + png.string() + " --fx 6 --fy 6").code, 0);
}

TEST(CliInputs, DemoSaysWhenSmoothingIsOff) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_demo");
  const std::string pcd = write_small_pcd(dir).string();
  const CliResult off =
      run("demo --input " + pcd + " --preset ideal -o " + (dir / "ideal").string());
  ASSERT_EQ(off.code, 0) << off.out;
  EXPECT_TRUE(contains(off.out, "smoothing off")) << off.out;
  EXPECT_FALSE(contains(off.out, "iterations")) << off.out;
  const CliResult on =
      run("demo --input " + pcd + " --preset kinect -o " + (dir / "kinect").string());
  ASSERT_EQ(on.code, 0) << on.out;
  EXPECT_TRUE(contains(on.out, "(3 iterations)")) << on.out;
}

// A frame converted to PLY (organized, with its range_grid) segments as the PCD does, and a
// folder's .ply files are frames of a batch.
TEST(CliInputs, PlyOfAFrameSegmentsAsItsPcd) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_ply");
  const fs::path pcd = write_small_pcd(dir);
  fs::create_directories(dir / "frames");
  const fs::path ply = dir / "frames" / "small.ply";
  CliResult r = run("convert " + pcd.string() + " " + ply.string());
  ASSERT_EQ(r.code, 0) << r.out;
  r = run("info " + ply.string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(contains(r.out, "160 x 120 (organized)")) << r.out;
  EXPECT_TRUE(contains(r.out, "range_grid")) << r.out;
  r = run("segment " + pcd.string() + " -o " + (dir / "a").string() + " --no-mesh");
  ASSERT_EQ(r.code, 0) << r.out;
  r = run("segment " + (dir / "frames").string() + " -o " + (dir / "b").string() + " --no-mesh");
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* file : {"labels.png", "segments.json"}) {
    EXPECT_TRUE(read_bytes(dir / "a" / file) == read_bytes(dir / "b" / "small" / file))
        << file << " differs between the PCD and its PLY";
  }

  std::ofstream(dir / "bad.ply") << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                                    "property float y\nproperty float z\nend_header\n1 2 3\n";
  r = run("info " + (dir / "bad.ply").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "bad.ply")) << r.out;
}

// A PLY with a label property is ground truth or a segmentation for `eval`, as a PCD is.
TEST(CliInputs, EvalTakesLabelledPly) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_eval_ply");
  const rangeseg::CameraIntrinsics camera{
      .fx = 131.25, .fy = 131.25, .cx = 79.5, .cy = 59.5, .width = 160, .height = 120};
  const rangeseg::synth::Rendering scene = rangeseg::synth::render(
      rangeseg::synth::random_scene(2, false), {.camera = camera, .seed = 2});
  ASSERT_TRUE(scene.cloud.has_label());
  rangeseg::io::write_ply_cloud((dir / "truth.ply").string(), scene.cloud);
  rangeseg::io::write_label_png((dir / "labels.png").string(), scene.labels);
  const CliResult r = run("eval " + (dir / "truth.ply").string() + " " +
                          (dir / "labels.png").string() + " --json " + (dir / "e.json").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string json = read_bytes(dir / "e.json");
  EXPECT_TRUE(contains(json, "\"missed\": 0")) << json;
  EXPECT_TRUE(contains(json, "\"noise\": 0")) << json;
}

// A depth camera's points as text (.xyz, 9 significant digits: floats exactly) are put back on
// their pixel grid and segment as the same points in an unorganized PCD.
TEST(CliInputs, XyzTextOfAFrameSegmentsAsItsPoints) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_xyz");
  const fs::path pcd = write_small_pcd(dir);
  const fs::path points = dir / "points.pcd";
  CliResult r = run("convert " + pcd.string() + " " + points.string() + " --unorganized");
  ASSERT_EQ(r.code, 0) << r.out;
  const rangeseg::OrganizedCloud cloud = rangeseg::io::read_pcd(points.string());
  {
    std::ofstream xyz(dir / "points.xyz");
    char line[96];
    for (int i = 0; i < cloud.width(); ++i) {
      std::snprintf(line, sizeof line, "%.9g %.9g %.9g\n", cloud.x(i, 0), cloud.y(i, 0),
                    cloud.z(i, 0));
      xyz << line;
    }
  }
  r = run("segment " + points.string() + " -o " + (dir / "a").string());
  ASSERT_EQ(r.code, 0) << r.out;
  r = run("segment " + (dir / "points.xyz").string() + " -o " + (dir / "b").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(contains(r.out, "pixel grid")) << r.out;
  EXPECT_TRUE(read_bytes(dir / "a" / "segments.json") == read_bytes(dir / "b" / "segments.json"))
      << "segments.json differs between the PCD and the text file";
}

// A config's smoothing iterations turn the filter on as `--iterations` does, also under a
// preset without it, unless the config also says "smooth".
TEST(CliInputs, ConfigIterationsTurnTheFilterOn) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_config_iterations");
  const fs::path pcd = write_small_pcd(dir);
  std::ofstream(dir / "two.json") << R"({"smoothing": {"iterations": 2}})";
  std::ofstream(dir / "off.json") << R"({"smooth": false, "smoothing": {"iterations": 2}})";
  const std::string plain = smooth_bytes(pcd, dir, "plain.pcd", "--preset ideal");
  ASSERT_FALSE(plain.empty());
  EXPECT_TRUE(smooth_bytes(pcd, dir, "two.pcd",
                           "--preset ideal --config " + (dir / "two.json").string()) != plain)
      << "the config's iterations did not filter";
  EXPECT_TRUE(smooth_bytes(pcd, dir, "off.pcd",
                           "--preset ideal --config " + (dir / "off.json").string()) == plain)
      << "\"smooth\": false was overridden";
}

// Without smoothing the demo writes no "smoothed" normals (they would be the raw ones).
TEST(CliInputs, DemoWithoutSmoothingWritesNoSmoothedNormals) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_demo_ideal");
  std::ofstream(dir / "normals_smoothed.png") << "an earlier run's";
  const CliResult r = run("demo -o " + dir.string() + " --preset ideal");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(contains(r.out, "smoothing off")) << r.out;
  EXPECT_TRUE(fs::exists(dir / "normals_raw.png"));
  EXPECT_FALSE(fs::exists(dir / "normals_smoothed.png"));
}

// `noise` over several frames skips a bad one, as a segment batch does.
TEST(CliInputs, NoiseSkipsABadFrameAmongSeveral) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_noise_skip");
  ASSERT_EQ(run("synth -o " + (dir / "scene").string() + " --scene boxes --seed 1").code, 0);
  fs::create_directories(dir / "frames");
  fs::copy_file(dir / "scene" / "cloud.pcd", dir / "frames" / "a.pcd");
  std::ofstream(dir / "frames" / "b.xyz") << "";  // no points
  const CliResult r = run("noise " + (dir / "frames").string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(contains(r.out, "skipped")) << r.out;
  EXPECT_TRUE(contains(r.out, "b.xyz")) << r.out;
  EXPECT_TRUE(contains(r.out, "sigma(z)")) << r.out;
  EXPECT_TRUE(contains(r.out, "1 frame(s) (1 skipped),")) << r.out;  // the frames used
  const CliResult alone = run("noise " + (dir / "frames" / "b.xyz").string());
  EXPECT_EQ(alone.code, 2) << alone.out;
}

// ROS camera_info YAML describes the camera as Open3D's JSON does: the same segmentation; a
// lens distortion it states is named once per batch, not applied.
TEST(CliInputs, RosCameraInfoYamlSegmentsAsTheJson) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_camera_yaml");
  const rangeseg::CameraIntrinsics camera{
      .fx = 131.25, .fy = 131.5, .cx = 80.25, .cy = 59.75, .width = 160, .height = 120};
  const rangeseg::synth::Rendering scene = rangeseg::synth::render(
      rangeseg::synth::random_scene(3, false), {.camera = camera, .seed = 3});
  rangeseg::DepthImage depth(160, 120, 0);
  for (int v = 0; v < 120; ++v) {
    for (int u = 0; u < 160; ++u) {
      const float z = scene.cloud.z(u, v);
      if (std::isfinite(z)) depth(u, v) = static_cast<std::uint16_t>(std::lround(z * 1000));
    }
  }
  for (const char* name : {"a.png", "b.png"}) {
    rangeseg::io::write_depth_png((dir / name).string(), depth.view());
  }
  std::ofstream(dir / "camera.json") << R"({"width": 160, "height": 120, "intrinsic_matrix": )"
                                     << R"([131.25, 0, 0, 0, 131.5, 0, 80.25, 59.75, 1]})";
  const std::string k = "[131.25, 0.0, 80.25, 0.0, 131.5, 59.75, 0.0, 0.0, 1.0]";
  std::ofstream(dir / "info.yaml") << "height: 120\nwidth: 160\ndistortion_model: plumb_bob\n"
                                   << "d: [0.0, 0.0, 0.0, 0.0, 0.0]\nk: " << k << "\n---\n";
  std::ofstream(dir / "distorted.yaml") << "height: 120\nwidth: 160\ndistortion_model: plumb_bob\n"
                                        << "d: [0.1, 0.0, 0.0, 0.0, 0.0]\nk: " << k << "\n";
  const auto segment = [&](const std::string& inputs, const std::string& camera_file,
                           const std::string& out) {
    return run("segment " + inputs + " --intrinsics " + (dir / camera_file).string() + " -o " +
               (dir / out).string());
  };
  const std::string a = (dir / "a.png").string();
  CliResult r = segment(a, "camera.json", "json");
  ASSERT_EQ(r.code, 0) << r.out;
  r = segment(a, "info.yaml", "yaml");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_FALSE(contains(r.out, "distortion")) << r.out;
  EXPECT_TRUE(read_bytes(dir / "json" / "segments.json") ==
              read_bytes(dir / "yaml" / "segments.json"));
  EXPECT_TRUE(read_bytes(dir / "json" / "labels.png") == read_bytes(dir / "yaml" / "labels.png"));

  r = segment(a + " " + (dir / "b.png").string(), "distorted.yaml", "batch");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string warning = "distortion (plumb_bob [0.1, 0, 0, 0, 0]) is not applied";
  const std::size_t first = r.out.find(warning);
  ASSERT_NE(first, std::string::npos) << r.out;
  EXPECT_EQ(r.out.find(warning, first + 1), std::string::npos) << "warned twice:\n" << r.out;
  EXPECT_TRUE(read_bytes(dir / "json" / "labels.png") ==
              read_bytes(dir / "batch" / "a" / "labels.png"));

  // `info` fits the camera back to the points.
  r = run("info " + a + " --intrinsics " + (dir / "info.yaml").string());
  EXPECT_TRUE(contains(r.out, "camera:   fx 131.25 fy 131.50 cx 80.25 cy 59.75")) << r.out;

  std::ofstream(dir / "bad.yaml") << "k: [131.25, 0, 80.25]\n";
  r = segment(a, "bad.yaml", "bad");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "bad.yaml")) << r.out;
  EXPECT_TRUE(contains(r.out, "9 numbers")) << r.out;

  // A calibration's projection matrix P is the rectified images' camera (ROS's depth_image_proc
  // takes P): it is used, and the note names both.
  std::ofstream(dir / "with_p.yaml")
      << "height: 120\nwidth: 160\nd: [0.1, 0.0, 0.0, 0.0, 0.0]\nk: " << k
      << "\np: [131.0, 0.0, 80.5, 0.0, 0.0, 131.0, 60.0, 0.0, 0.0, 0.0, 1.0, 0.0]\n";
  r = run("info " + a + " --intrinsics " + (dir / "with_p.yaml").string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(contains(r.out, "camera:   fx 131.00 fy 131.00 cx 80.50 cy 60.00")) << r.out;
  EXPECT_TRUE(contains(r.out, "projection matrix P")) << r.out;
  EXPECT_TRUE(contains(r.out, "K (fx 131.25, fy 131.50")) << r.out;
}

// A depth image without a camera, with one focal length, or whose depths are implausible for a
// depth camera under the scale given is named on stderr; camera options on a point cloud too.
TEST(CliInputs, DepthImageCameraAndScaleAreChecked) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_depth_checks");
  rangeseg::DepthImage depth(64, 48, 0);
  for (int v = 0; v < 48; ++v) {
    for (int u = 0; u < 64; ++u) depth(u, v) = static_cast<std::uint16_t>(1500 + u);
  }
  const std::string png = (dir / "d.png").string();
  rangeseg::io::write_depth_png(png, depth.view());
  CliResult r = run("info " + png);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(contains(r.out, "no camera given")) << r.out;
  EXPECT_TRUE(contains(r.out, "the default, a Kinect's")) << r.out;
  EXPECT_FALSE(contains(r.out, "is the scale right")) << r.out;
  // Only a file that reads as a camera for this image's size is suggested: not a settings
  // file, nor another camera's intrinsics.
  std::ofstream(dir / "params.json") << R"({"smooth": false})";
  std::ofstream(dir / "vga.json") << R"({"width": 640, "height": 480, "fx": 525, "fy": 525,
                                         "cx": 319.5, "cy": 239.5})";
  r = run("info " + png);
  EXPECT_TRUE(contains(r.out, "no camera given")) << r.out;
  EXPECT_FALSE(contains(r.out, "beside it")) << r.out;
  std::ofstream(dir / "camera.json") << R"({"fx": 60, "fy": 60, "cx": 31.5, "cy": 23.5})";
  r = run("info " + png);
  EXPECT_TRUE(contains(r.out, "camera.json beside it is a camera file")) << r.out;

  // One focal length is both (square pixels).
  r = run("info " + png + " --fx 600");
  EXPECT_TRUE(contains(r.out, "camera:   fx 600.00 fy 600.00")) << r.out;
  EXPECT_FALSE(contains(r.out, "no camera given")) << r.out;
  r = run("info " + png + " --fy 610");
  EXPECT_TRUE(contains(r.out, "camera:   fx 610.00 fy 610.00")) << r.out;

  // Millimetres taken as metres, and as tenths of a micrometre.
  for (const char* scale : {"1", "0.00001"}) {
    r = run("info " + png + " --fx 60 --depth-scale " + scale);
    EXPECT_EQ(r.code, 0) << r.out;
    EXPECT_TRUE(contains(r.out, "is the scale right")) << scale << r.out;
  }
  r = run("info " + png + " --fx 60 --depth-scale inf");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "finite number > 0")) << r.out;
  // Finite options whose points are not (beyond float's range) are named, not an empty cloud.
  for (const char* options :
       {"--fx 60 --depth-scale 1e300", "--fx 60 --depth-scale 1e-300", "--fx 1e-300"}) {
    r = run("info " + png + " " + options);
    EXPECT_EQ(r.code, 2) << options << r.out;
    EXPECT_TRUE(contains(r.out, "d.png: 3072 of 3072 depth readings give no finite point"))
        << options << r.out;
  }

  // An 8-bit PNG (here by libpng's simplified API, as a picture would be written) is read, and
  // named.
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = 8;
  image.height = 8;
  image.format = PNG_FORMAT_GRAY;
  const std::vector<std::uint8_t> grey(64, 200);
  const std::string eight = (dir / "eight.png").string();
  ASSERT_TRUE(png_image_write_to_file(&image, eight.c_str(), 0, grey.data(), 0, nullptr));
  r = run("info " + eight + " --fx 60");
  EXPECT_TRUE(contains(r.out, "an 8-bit PNG")) << r.out;

  const std::string pcd = (dir / "c.pcd").string();
  r = run("convert " + png + " --fx 60 " + pcd);
  ASSERT_EQ(r.code, 0) << r.out;
  r = run("info " + pcd + " --depth-scale 0.0001");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(contains(r.out, "apply to depth PNGs only")) << r.out;
}

// --preset auto on an organized grid that no pinhole camera explains (a scanner's: equal steps
// in azimuth and elevation) notes that it took the kinect preset and names --preset laser; a
// depth camera's grid gets no such note, nor does an explicit preset.
TEST(CliInputs, AutoPresetNotesAScannersGrid) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_scanner_grid");
  rangeseg::OrganizedCloud scan(80, 60);
  constexpr double kStep = 0.01;  // [rad]
  for (int v = 0; v < 60; ++v) {
    for (int u = 0; u < 80; ++u) {
      const double az = (u - 40) * kStep, el = (v - 30) * kStep;
      const double d[3] = {std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el)};
      const double range = 2.0 / d[2];  // the wall z = 2 m
      scan.x(u, v) = static_cast<float>(d[0] * range);
      scan.y(u, v) = static_cast<float>(d[1] * range);
      scan.z(u, v) = static_cast<float>(d[2] * range);
    }
  }
  const fs::path scan_path = dir / "scan.pcd";
  rangeseg::io::write_pcd(scan_path.string(), scan);
  const CliResult noted = run("segment " + scan_path.string() + " -o " + (dir / "a").string());
  ASSERT_EQ(noted.code, 0) << noted.out;
  EXPECT_TRUE(contains(noted.out, "no pinhole camera explains this grid")) << noted.out;
  EXPECT_TRUE(contains(noted.out, "--preset laser")) << noted.out;
  const CliResult given =
      run("segment " + scan_path.string() + " --preset kinect -o " + (dir / "b").string());
  ASSERT_EQ(given.code, 0) << given.out;
  EXPECT_FALSE(contains(given.out, "no pinhole camera")) << given.out;
  const CliResult camera =
      run("segment " + write_small_pcd(dir).string() + " -o " + (dir / "c").string());
  ASSERT_EQ(camera.code, 0) << camera.out;
  EXPECT_FALSE(contains(camera.out, "no pinhole camera")) << camera.out;
}

// Floats in a map's frame (UTM) keep their 0.5 m steps when --apply-viewpoint moves them into
// the sensor's frame, where the cloud no longer looks far from its origin: named on stderr.
// Doubles keep the map's millimetres and are not.
TEST(CliInputs, FloatPointsInAMapsFrameAreNamedWhenMovedToTheSensor) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_utm_float");
  for (const int size : {4, 8}) {
    const fs::path path = dir / ("utm" + std::to_string(size) + ".pcd");
    std::ofstream out(path);
    out << "VERSION .7\nFIELDS x y z\nSIZE " << size << ' ' << size << ' ' << size
        << "\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 8\nHEIGHT 6\n"
           "VIEWPOINT 500000 5000000 100 1 0 0 0\nPOINTS 48\nDATA ascii\n";
    out.precision(12);
    for (int v = 0; v < 6; ++v) {
      for (int u = 0; u < 8; ++u) {
        out << 500000 + (u - 3.5) / 60 * 2 << ' ' << 5000000 + (v - 2.5) / 60 * 2 << " 102\n";
      }
    }
    out.close();
    const CliResult r = run("info " + path.string() + " --apply-viewpoint");
    EXPECT_EQ(r.code, 0) << r.out;
    EXPECT_EQ(contains(r.out,
                       "x y z are stored as float near the VIEWPOINT's coordinates (up to "
                       "5e+06 m), where floats lie 0.5 m apart"),
              size == 4)
        << r.out;
  }
}

// A depth image of one row reads as an unorganized cloud (height 1); what needs a grid says so
// rather than that its points lie on no camera's grid.
TEST(CliInputs, AOneRowDepthImageIsNamedAsSuch) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_inputs_one_row");
  const rangeseg::DepthImage depth(5, 1, 1000);
  const std::string png = (dir / "row.png").string();
  rangeseg::io::write_depth_png(png, depth.view());
  for (const std::string& command : {"mesh " + png + " --fx 5 -o " + (dir / "m.ply").string(),
                                     "convert " + png + " --fx 5 " + (dir / "d.png").string()}) {
    const CliResult r = run(command);
    EXPECT_EQ(r.code, 2) << command << r.out;
    EXPECT_TRUE(contains(r.out, "row.png: a depth image of one row (5 x 1 pixels)"))
        << command << r.out;
  }
}
