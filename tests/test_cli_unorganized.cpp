// End-to-end tests of the rangeseg command-line tool on unorganized clouds (PCD of height 1):
// segment, smooth, bench, config, and the commands that need a pixel grid.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "cli_util.hpp"
#include "rangeseg/camera.hpp"
#include "rangeseg/colorize.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/sensor.hpp"
#include "rangeseg/synth.hpp"
#include "test_util.hpp"

namespace fs = std::filesystem;

namespace {

using rangeseg::OrganizedCloud;
using rangeseg::test::CliResult;
CliResult run(const std::string& args) { return rangeseg::test::run_cli(args); }

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

nlohmann::json read_json(const fs::path& p) { return nlohmann::json::parse(read_text(p)); }

/// A quarter-size Kinect view (fx = fy = 525 / 4), so that every command takes milliseconds.
constexpr rangeseg::CameraIntrinsics kQuarterKinect{
    .fx = 131.25, .fy = 131.25, .cx = 79.5, .cy = 59.5, .width = 160, .height = 120};

/// A synthetic box scene with Kinect noise, its ground truth in the label plane.
OrganizedCloud organized_frame(std::uint64_t seed) {
  namespace synth = rangeseg::synth;
  const synth::RenderSettings render{
      .camera = kQuarterKinect, .noise = synth::Noise::kinect, .seed = seed};
  return synth::render(synth::random_scene(seed, false), render).cloud;
}

/// The valid points of organized_frame(seed) as one row (an unorganized cloud, as PCL writes a
/// filtered cloud), labels kept, each moved sideways by up to 0.3 pixel (as a stereo camera's
/// sub-pixel matches lie): not on a pixel grid, so they run over rings.
OrganizedCloud unorganized_frame(std::uint64_t seed) {
  OrganizedCloud cloud = rangeseg::valid_points(organized_frame(seed));
  std::mt19937 random(static_cast<unsigned>(seed));
  std::uniform_real_distribution<float> offset(-0.3f, 0.3f);
  for (int i = 0; i < cloud.width(); ++i) {
    cloud.x(i, 0) += offset(random) * cloud.z(i, 0) / static_cast<float>(kQuarterKinect.fx);
  }
  return cloud;
}

/// The valid points of organized_frame(seed) as they are: on the frame's pixel grid.
OrganizedCloud grid_points(std::uint64_t seed) {
  return rangeseg::valid_points(organized_frame(seed));
}

/// Writes unorganized_frame(seed) to `path` and returns it.
OrganizedCloud write_unorganized(const fs::path& path, std::uint64_t seed = 1) {
  fs::create_directories(path.parent_path());
  OrganizedCloud cloud = unorganized_frame(seed);
  rangeseg::io::write_pcd(path.string(), cloud,
                          {.encoding = rangeseg::io::PcdEncoding::binary_compressed});
  return cloud;
}

}  // namespace

TEST(CliUnorganized, SegmentWritesSegmentsAndALabelledCloud) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_unorganized_segment");
  const OrganizedCloud input = write_unorganized(dir / "scan.pcd");
  const CliResult r =
      run("segment " + (dir / "scan.pcd").string() + " -o " + (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string n = std::to_string(input.size());
  EXPECT_NE(r.out.find("segments of " + n + " points (unorganized"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find((dir / "out" / "cloud.pcd").string()), std::string::npos) << r.out;
  EXPECT_NE(r.out.find((dir / "out" / "segments.json").string()), std::string::npos) << r.out;
  EXPECT_NE(r.out.find((dir / "out" / "polygons.obj").string()), std::string::npos) << r.out;
  for (const char* grid_only : {"labels.png", "overlay.png", "types.png", "mesh.ply"}) {
    EXPECT_FALSE(fs::exists(dir / "out" / grid_only)) << grid_only;
  }

  const nlohmann::json segments = read_json(dir / "out" / "segments.json");
  EXPECT_EQ(segments["width"], input.size());
  EXPECT_EQ(segments["height"], 1);
  ASSERT_GE(segments["segments"].size(), 3u) << "a box scene has several planes";
  const OrganizedCloud cloud = rangeseg::io::read_pcd((dir / "out" / "cloud.pcd").string());
  ASSERT_EQ(cloud.size(), input.size());
  ASSERT_EQ(cloud.height(), 1);
  ASSERT_TRUE(cloud.has_label() && cloud.has_rgb());
  // Every label is a segment id, its point count is the segment's pixel_count, and its colour
  // is the label's colour of the pictures.
  std::map<int, int> counts;
  std::size_t wrong_colour = 0;
  for (int i = 0; i < cloud.width(); ++i) {
    const int label = cloud.label(i, 0);
    ++counts[label];
    const auto colour = label > 0 ? rangeseg::label_colour(label) : rangeseg::kNoLabelColour;
    if (cloud.r(i, 0) != colour[0] || cloud.g(i, 0) != colour[1] || cloud.b(i, 0) != colour[2]) {
      ++wrong_colour;
    }
  }
  EXPECT_EQ(wrong_colour, 0u);
  int outlined = 0;
  for (const auto& s : segments["segments"]) {
    const int id = s["id"].get<int>();
    EXPECT_EQ(counts[id], s["pixel_count"].get<int>()) << "segment " << id;
    counts.erase(id);
    // Plane segments have their outline, with an area near the segment's.
    ASSERT_EQ(s.contains("polygon"), s["model"] == "plane") << "segment " << id;
    if (!s.contains("polygon")) continue;
    ++outlined;
    const double area = s["polygon"]["area_m2"].get<double>();
    EXPECT_NEAR(area, s["area_m2"].get<double>(), 0.25 * s["area_m2"].get<double>())
        << "segment " << id;
    EXPECT_GE(s["polygon"]["loops"].size(), 1u);
    EXPECT_GE(s["polygon"]["convex_hull"]["area_m2"].get<double>(), area * 0.999);
  }
  EXPECT_GE(outlined, 3);
  // One OBJ object per outlined segment.
  std::ifstream obj(dir / "out" / "polygons.obj");
  std::string line;
  int objects = 0;
  while (std::getline(obj, line)) objects += line.starts_with("o ") ? 1 : 0;
  EXPECT_EQ(objects, outlined);
  counts.erase(0);
  EXPECT_TRUE(counts.empty()) << "labels without a segment: " << counts.size();
  rangeseg::test::expect_unit_normals(dir / "out" / "cloud.pcd", input.size(), input.size());

  // The labelled cloud scores against the ground truth as a label image would.
  const CliResult eval =
      run("eval " + (dir / "scan.pcd").string() + " " + (dir / "out" / "cloud.pcd").string() +
          " --json " + (dir / "eval.json").string());
  ASSERT_EQ(eval.code, 0) << eval.out;
  EXPECT_GE(read_json(dir / "eval.json")["correct"].get<int>(), 2) << eval.out;
}

TEST(CliUnorganized, IncrementalPlaneModelExitsTwoNamingTheFile) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_unorganized_models");
  write_unorganized(dir / "scan.pcd");
  std::ofstream(dir / "incremental.json") << R"({"segmentation": {"model": "incremental_plane"}})";
  for (const std::string& options : std::vector<std::string>{
           "--model incremental_plane", "--config " + (dir / "incremental.json").string()}) {
    const CliResult r = run("segment " + (dir / "scan.pcd").string() + " -o " +
                            (dir / "out").string() + " " + options);
    EXPECT_EQ(r.code, 2) << options << "\n" << r.out;
    EXPECT_NE(r.out.find("scan.pcd"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("plane, smooth or auto"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(dir / "out" / "segments.json")) << options;
  }
  for (const char* model : {"smooth", "auto"}) {
    const CliResult r = run("segment " + (dir / "scan.pcd").string() + " -o " +
                            (dir / model).string() + " --model " + model);
    EXPECT_EQ(r.code, 0) << model << "\n" << r.out;
    EXPECT_TRUE(fs::exists(dir / model / "cloud.pcd")) << model;
    const nlohmann::json segments = read_json(dir / model / "segments.json")["segments"];
    EXPECT_FALSE(segments.empty()) << model;
    for (const auto& s : segments) {
      const std::string type = s["surface"]["type"].get<std::string>();
      EXPECT_EQ(type, std::string(model) == "smooth" ? "smooth" : "plane") << s.dump();
    }
  }
}

TEST(CliUnorganized, BatchMixesOrganizedAndUnorganizedFrames) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_unorganized_batch");
  rangeseg::io::write_pcd((dir / "grid.pcd").string(), organized_frame(2));
  write_unorganized(dir / "scan.pcd", 3);
  const std::string inputs = (dir / "grid.pcd").string() + " " + (dir / "scan.pcd").string();
  const CliResult r = run("segment " + inputs + " --threads 2 -o " + (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(dir / "out" / "grid" / "labels.png"));
  EXPECT_FALSE(fs::exists(dir / "out" / "grid" / "cloud.pcd"));
  EXPECT_TRUE(fs::exists(dir / "out" / "scan" / "segments.json"));
  EXPECT_TRUE(fs::exists(dir / "out" / "scan" / "cloud.pcd"));
  EXPECT_FALSE(fs::exists(dir / "out" / "scan" / "labels.png"));
  const nlohmann::json summary = read_json(dir / "out" / "summary.json");
  EXPECT_EQ(summary["succeeded"], 2);
  ASSERT_EQ(summary["per_frame"].size(), 2u);
  const auto& grid = summary["per_frame"][0];
  const auto& scan = summary["per_frame"][1];
  EXPECT_TRUE(grid["organized"].get<bool>());
  EXPECT_FALSE(scan["organized"].get<bool>());
  EXPECT_TRUE(grid["ms"].contains("mesh") && !grid["ms"].contains("rings")) << grid.dump();
  EXPECT_TRUE(scan["ms"].contains("rings") && !scan["ms"].contains("mesh")) << scan.dump();
  EXPECT_TRUE(scan["ms"].contains("order") && !grid["ms"].contains("order")) << scan.dump();
  EXPECT_GT(scan["ms"]["polygons"].get<double>(), 0.0) << scan.dump();
  for (const char* stage :
       {"mesh", "order", "rings", "normals", "segmentation", "polygons", "total"}) {
    ASSERT_TRUE(summary["median_ms"].contains(stage)) << stage;
    EXPECT_GT(summary["median_ms"][stage].get<double>(), 0.0) << stage;
  }
  EXPECT_EQ(scan["segments"].get<std::size_t>(),
            read_json(dir / "out" / "scan" / "segments.json")["segments"].size());

  // --model incremental_plane: the unorganized frame is reported and skipped, the organized
  // one written.
  const CliResult incremental =
      run("segment " + inputs + " --model incremental_plane -o " + (dir / "inc").string());
  ASSERT_EQ(incremental.code, 0) << incremental.out;
  EXPECT_TRUE(fs::exists(dir / "inc" / "grid" / "labels.png"));
  EXPECT_FALSE(fs::exists(dir / "inc" / "scan"));
  const nlohmann::json failed = read_json(dir / "inc" / "summary.json");
  EXPECT_EQ(failed["succeeded"], 1);
  ASSERT_EQ(failed["failures"].size(), 1u);
  const std::string error = failed["failures"][0]["error"].get<std::string>();
  EXPECT_NE(error.find("scan.pcd"), std::string::npos) << error;
  EXPECT_NE(error.find("plane, smooth or auto"), std::string::npos) << error;
}

// A cloud in millimetres, one in map coordinates far from the origin (as float: steps of 0.5 m
// at 5000 km), and one whose noise model cannot tell its surfaces apart are named on stderr; a
// cloud in metres near its sensor is not.
TEST(CliUnorganized, CloudsInMillimetresOrFarFromTheOriginAreNamed) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_unorganized_scale");
  const auto write = [&](const std::string& name, double scale, double offset) {
    std::ofstream out(dir / name);
    out.precision(12);
    std::mt19937 random(3);
    std::uniform_real_distribution<double> along(-1.0, 1.0);
    for (int i = 0; i < 500; ++i) {
      out << offset + scale * along(random) << ' ' << offset + scale * along(random) << ' '
          << scale * 2.0 << '\n';
    }
    return (dir / name).string();
  };
  CliResult r = run("info " + write("metres.xyz", 1.0, 0.0));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("warning"), std::string::npos) << r.out;
  r = run("info " + write("millimetres.xyz", 1000.0, 0.0));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("scale it by 0.001"), std::string::npos) << r.out;
  r = run("info " + write("utm.xyz", 1.0, 5.0e6));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("subtract a UTM offset"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("millimetres"), std::string::npos) << r.out;
  // 30 m from the origin, where the Kinect's noise model gives sigma = 3.3 m for points that
  // span 2.8 m (a map's frame); a constant sigma is right for them.
  const std::string moved = write("moved.xyz", 1.0, 30.0);
  const std::string out = (dir / "out").string();
  r = run("segment " + moved + " -o " + out);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("warning: " + moved + ": at the points' median distance"), std::string::npos)
      << r.out;
  r = run("segment " + moved + " -o " + out + " --preset laser");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("warning"), std::string::npos) << r.out;
}

// `--preset auto` takes a cloud whose points surround its sensor for a laser scanner's (a
// spinning lidar), and one in front of it for a camera's.
TEST(CliUnorganized, AutoPresetTellsAScanAroundTheSensor) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_unorganized_surround");
  const auto write = [&](const std::string& name, double max_azimuth) {
    std::ofstream out(dir / name);
    std::mt19937 random(5);
    std::uniform_real_distribution<double> azimuth(-max_azimuth, max_azimuth), height(-1, 1);
    for (int i = 0; i < 2000; ++i) {  // a cylinder wall of radius 4 m about the y axis
      const double a = azimuth(random);
      out << 4 * std::sin(a) << ' ' << height(random) << ' ' << 4 * std::cos(a) << '\n';
    }
    return (dir / name).string();
  };
  const CliResult around =
      run("segment " + write("around.xyz", 3.14159) + " -o " + (dir / "a").string());
  ASSERT_EQ(around.code, 0) << around.out;
  EXPECT_NE(around.out.find("preset laser"), std::string::npos) << around.out;
  const CliResult ahead = run("segment " + write("ahead.xyz", 0.5) + " -o " + (dir / "b").string());
  ASSERT_EQ(ahead.code, 0) << ahead.out;
  EXPECT_NE(ahead.out.find("preset kinect"), std::string::npos) << ahead.out;
}

TEST(CliUnorganized, SmoothWritesPointsWithNormals) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_unorganized_smooth");
  const OrganizedCloud input = write_unorganized(dir / "scan.pcd");
  const CliResult r =
      run("smooth " + (dir / "scan.pcd").string() + " -o " + (dir / "smoothed.pcd").string());
  ASSERT_EQ(r.code, 0) << r.out;
  rangeseg::io::PcdInfo info;
  const OrganizedCloud smoothed = rangeseg::io::read_pcd((dir / "smoothed.pcd").string(), &info);
  EXPECT_NE(info.fields_summary.find("normal_x normal_y normal_z curvature"), std::string::npos)
      << info.fields_summary;
  ASSERT_EQ(smoothed.size(), input.size());
  // The Kinect preset's filter moves the noisy points along their rays, by at most sigma per
  // pass. Points inside a terrace of the disparity quantisation stay (measured: 12573 of
  // 18934): their ring is flat, and so is the plane they are moved to.
  std::size_t moved = 0;
  double most = 0;  // [sigma]
  const rangeseg::SensorNoise kinect{};
  for (int i = 0; i < input.width(); ++i) {
    moved += smoothed.z(i, 0) != input.z(i, 0) ? 1 : 0;
    const double r = std::hypot(input.x(i, 0), input.y(i, 0), input.z(i, 0));
    const double d = std::hypot(smoothed.x(i, 0) - input.x(i, 0), smoothed.y(i, 0) - input.y(i, 0),
                                smoothed.z(i, 0) - input.z(i, 0));
    most = std::max(most, d / kinect.sigma(r));
  }
  EXPECT_GT(moved, input.size() / 5);
  // sigma at each pass's range, which moves with the point (3.03 here).
  EXPECT_LE(most, 3.2);
  rangeseg::test::expect_unit_normals(dir / "smoothed.pcd", input.size(), input.size());
}

TEST(CliUnorganized, BenchTimesTheRingsAndRejectsSizes) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_unorganized_bench");
  write_unorganized(dir / "scan.pcd");
  const std::string scan = (dir / "scan.pcd").string();
  const CliResult text = run("bench " + scan + " --repeat 1");
  ASSERT_EQ(text.code, 0) << text.out;
  EXPECT_NE(text.out.find("(unorganized, over rings)"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("  rings "), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("  polygons "), std::string::npos) << text.out;
  EXPECT_EQ(text.out.find("  mesh "), std::string::npos) << text.out;
  const CliResult json = run("bench " + scan + " --repeat 1 --threads 2 --json");
  ASSERT_EQ(json.code, 0) << json.out;
  const auto stages = nlohmann::json::parse(json.out.substr(json.out.find('{')));
  for (const char* key : {"rings", "normals", "smoothing", "segmentation", "polygons", "total"}) {
    ASSERT_TRUE(stages.contains(key)) << key;
    EXPECT_GT(stages[key].get<double>(), 0.0) << key;
  }
  EXPECT_FALSE(stages.contains("mesh"));
  EXPECT_TRUE(stages["in_frame"].contains("rings"));
  EXPECT_GT(stages["in_frame_speedup"].get<double>(), 0.0);
  EXPECT_GT(stages["throughput_speedup"].get<double>(), 0.0);
  for (const char* sizes : {"--sizes 40x30", "--scales 2,1"}) {
    const CliResult r = run("bench " + scan + " --repeat 1 " + sizes);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_NE(r.out.find("scan.pcd"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("unorganized"), std::string::npos) << r.out;
  }
}

TEST(CliUnorganized, GridCommandsExitTwoNamingTheFile) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_unorganized_grid");
  write_unorganized(dir / "scan.pcd");
  const std::string scan = (dir / "scan.pcd").string();
  for (const std::string& command : {"mesh " + scan + " -o " + (dir / "mesh.ply").string(),
                                     "convert " + scan + " " + (dir / "depth.png").string(),
                                     "demo --input " + scan + " -o " + (dir / "demo").string()}) {
    const CliResult r = run(command);
    EXPECT_EQ(r.code, 2) << command << "\n" << r.out;
    EXPECT_NE(r.out.find("scan.pcd: an unorganized cloud"), std::string::npos) << r.out;
  }
  EXPECT_FALSE(fs::exists(dir / "mesh.ply"));
  EXPECT_FALSE(fs::exists(dir / "depth.png"));
  EXPECT_EQ(run("convert " + scan + " " + (dir / "points.ply").string()).code, 0);
}

TEST(CliUnorganized, ConvertKeepsTheValidPointsInOrderOrShuffled) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_unorganized_convert");
  fs::create_directories(dir);
  const OrganizedCloud grid = organized_frame(2);
  const std::string in = (dir / "grid.pcd").string();
  rangeseg::io::write_pcd(in, grid);
  const auto convert = [&](const std::string& name, const std::string& options) {
    const CliResult r = run("convert " + in + " " + (dir / name).string() + " " + options);
    EXPECT_EQ(r.code, 0) << r.out;
    return rangeseg::io::read_pcd((dir / name).string());
  };
  const OrganizedCloud rows = convert("rows.pcd", "--unorganized");
  ASSERT_EQ(rows.height(), 1);
  ASSERT_EQ(rows.size(), grid.count_valid());
  ASSERT_TRUE(rows.has_label());  // the optional fields come along
  // Row-major order: point i is the i-th valid pixel.
  int i = 0;
  for (int v = 0; v < grid.height(); ++v) {
    for (int u = 0; u < grid.width(); ++u) {
      if (!grid.valid(u, v)) continue;
      ASSERT_EQ(rows.z(i, 0), grid.z(u, v)) << i;
      ASSERT_EQ(rows.label(i, 0), grid.label(u, v)) << i;
      ++i;
    }
  }
  // Shuffled: the same points in another order, the same order for the same seed.
  const OrganizedCloud a = convert("a.pcd", "--shuffle 7");
  const OrganizedCloud b = convert("b.pcd", "--shuffle 7");
  const OrganizedCloud c = convert("c.pcd", "--shuffle 8");
  ASSERT_EQ(a.size(), rows.size());
  std::vector<float> za, zr, zc;
  int moved = 0, differ = 0;
  for (int k = 0; k < a.width(); ++k) {
    za.push_back(a.z(k, 0));
    zr.push_back(rows.z(k, 0));
    zc.push_back(c.z(k, 0));
    EXPECT_EQ(a.x(k, 0), b.x(k, 0));
    // Many points share a quantised depth: compare x too.
    moved += a.x(k, 0) != rows.x(k, 0) || a.z(k, 0) != rows.z(k, 0) ? 1 : 0;
    differ += a.x(k, 0) != c.x(k, 0) || a.z(k, 0) != c.z(k, 0) ? 1 : 0;
  }
  std::sort(za.begin(), za.end());
  std::sort(zr.begin(), zr.end());
  std::sort(zc.begin(), zc.end());
  EXPECT_EQ(za, zr);
  EXPECT_EQ(zc, zr);
  EXPECT_GT(moved, a.width() / 2);
  EXPECT_GT(differ, a.width() / 2);
  // A depth PNG needs the grid these options remove.
  const CliResult png = run("convert " + in + " " + (dir / "d.png").string() + " --unorganized");
  EXPECT_EQ(png.code, 2) << png.out;
  EXPECT_NE(png.out.find("d.png"), std::string::npos) << png.out;
  EXPECT_FALSE(fs::exists(dir / "d.png"));
  EXPECT_EQ(run("convert " + in + " " + (dir / "e.pcd").string() + " --shuffle x").code, 2);
}

// A depth camera's valid points (PCL's removeNaNFromPointCloud, in any order) lie on its pixel
// grid: segment and bench find it and run the grid stages; "restore_grid": false keeps the rings.
TEST(CliUnorganized, PointsOnAPixelGridRunTheGridStages) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_unorganized_pixel_grid");
  fs::create_directories(dir);
  const OrganizedCloud points = grid_points(2);
  const std::string rows = (dir / "rows.pcd").string(), shuffled = (dir / "shuffled.pcd").string();
  rangeseg::io::write_pcd(rows, points, {});
  ASSERT_EQ(run("convert " + rows + " " + shuffled + " --shuffle 5").code, 0);
  for (const std::string& in : {rows, shuffled}) {
    const std::string name = fs::path(in).stem().string();
    const CliResult r = run("segment " + in + " -o " + (dir / name).string());
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_NE(
        r.out.find("points (unorganized, " + std::to_string(points.size()) + " valid, on its "),
        std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("fx 131."), std::string::npos) << r.out;  // 525 / 4
    EXPECT_NE(r.out.find(" mesh "), std::string::npos) << r.out;
  }
  // The same grid in either order: the same segments.
  const std::string segments = read_text(dir / "rows" / "segments.json");
  EXPECT_EQ(segments, read_text(dir / "shuffled" / "segments.json"));
  EXPECT_GE(read_json(dir / "rows" / "segments.json")["segments"].size(), 3u);
  // Labels per point: equal for points at equal coordinates.
  const OrganizedCloud a = rangeseg::io::read_pcd((dir / "rows" / "cloud.pcd").string());
  const OrganizedCloud b = rangeseg::io::read_pcd((dir / "shuffled" / "cloud.pcd").string());
  ASSERT_TRUE(a.has_label() && b.has_label());
  std::map<std::array<float, 3>, int> label_at;
  const OrganizedCloud in_a = rangeseg::io::read_pcd(rows);
  const OrganizedCloud in_b = rangeseg::io::read_pcd(shuffled);
  for (int i = 0; i < in_a.width(); ++i) {
    label_at[{in_a.x(i, 0), in_a.y(i, 0), in_a.z(i, 0)}] = a.label(i, 0);
  }
  int labelled = 0;
  for (int i = 0; i < in_b.width(); ++i) {
    const auto found = label_at.find({in_b.x(i, 0), in_b.y(i, 0), in_b.z(i, 0)});
    ASSERT_NE(found, label_at.end()) << i;
    EXPECT_EQ(found->second, b.label(i, 0)) << i;
    labelled += b.label(i, 0) > 0 ? 1 : 0;
  }
  EXPECT_GT(labelled, in_b.width() / 2);

  const CliResult bench = run("bench " + shuffled + " --repeat 1");
  ASSERT_EQ(bench.code, 0) << bench.out;
  EXPECT_NE(bench.out.find("pixel grid)"), std::string::npos) << bench.out;
  EXPECT_NE(bench.out.find("  mesh "), std::string::npos) << bench.out;
  EXPECT_NE(bench.out.find("  order "), std::string::npos) << bench.out;
  EXPECT_EQ(bench.out.find("  rings "), std::string::npos) << bench.out;

  std::ofstream(dir / "rings.json") << R"({"restore_grid": false})";
  const CliResult rings = run("segment " + shuffled + " -o " + (dir / "rings").string() +
                              " --config " + (dir / "rings.json").string());
  ASSERT_EQ(rings.code, 0) << rings.out;
  EXPECT_NE(rings.out.find("over rings"), std::string::npos) << rings.out;
  EXPECT_NE(rings.out.find(" rings "), std::string::npos) << rings.out;

  std::ofstream(dir / "bad.json") << R"({"restore_grid": "yes"})";
  const CliResult bad = run("segment " + shuffled + " -o " + (dir / "bad").string() + " --config " +
                            (dir / "bad.json").string());
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_NE(bad.out.find("restore_grid"), std::string::npos) << bad.out;

  // incremental_plane, which the rings do not support, runs on the grid.
  const CliResult incremental =
      run("segment " + shuffled + " -o " + (dir / "inc").string() + " --model incremental_plane");
  EXPECT_EQ(incremental.code, 0) << incremental.out;

  // The commands that need a grid take it; info names it.
  const CliResult info = run("info " + shuffled);
  ASSERT_EQ(info.code, 0) << info.out;
  EXPECT_NE(info.out.find("grid:     160 x 120 pixels, fx 131.25 fy 131.25"), std::string::npos)
      << info.out;
  const CliResult mesh = run("mesh " + shuffled + " -o " + (dir / "mesh.ply").string());
  ASSERT_EQ(mesh.code, 0) << mesh.out;
  EXPECT_NE(mesh.out.find("on a 160 x 120 pixel grid"), std::string::npos) << mesh.out;
  EXPECT_TRUE(fs::exists(dir / "mesh.ply"));
  ASSERT_EQ(run("convert " + shuffled + " " + (dir / "depth.png").string()).code, 0);
  const CliResult back = run("info " + (dir / "depth.png").string() + " --fx 131.25 --fy 131.25 " +
                             "--cx 79.5 --cy 59.5");
  EXPECT_NE(back.out.find("160 x 120 (organized)"), std::string::npos) << back.out;
  EXPECT_NE(back.out.find("valid:    " + std::to_string(points.size()) + " of"), std::string::npos)
      << back.out;

  // A batch records which frames ran on their grid.
  const CliResult batch = run("segment " + rows + " " + (dir / "rings" / "cloud.pcd").string() +
                              " -o " + (dir / "batch").string());
  ASSERT_EQ(batch.code, 0) << batch.out;
  const auto summary = read_json(dir / "batch" / "summary.json");
  ASSERT_EQ(summary["per_frame"].size(), 2u);
  EXPECT_TRUE(summary["per_frame"][0]["pixel_grid"].get<bool>());
  EXPECT_TRUE(summary["median_ms"].contains("mesh"));
}

TEST(CliUnorganized, ConfigRingsAreAppliedAndChecked) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_unorganized_config");
  write_unorganized(dir / "scan.pcd");
  const std::string scan = (dir / "scan.pcd").string();
  const auto segment = [&](const std::string& name, const std::string& config) {
    std::ofstream(dir / (name + ".json")) << config;
    return run("segment " + scan + " -o " + (dir / name).string() + " --config " +
               (dir / (name + ".json")).string());
  };
  const CliResult defaults = segment("defaults", "{}");
  ASSERT_EQ(defaults.code, 0) << defaults.out;
  const CliResult k16 = segment("k16", R"({"rings": {"k": 16}})");
  ASSERT_EQ(k16.code, 0) << k16.out;
  // Larger rings give other normals, smoothing and areas.
  EXPECT_NE(read_text(dir / "defaults" / "segments.json"),
            read_text(dir / "k16" / "segments.json"));
  EXPECT_NE(read_text(dir / "defaults" / "cloud.pcd"), read_text(dir / "k16" / "cloud.pcd"));
  const CliResult all = segment("all", R"({"rings": {"k": 8, "max_distance": 0.5,
      "eps_theta": 0.2, "jump_sigmas": 4, "by_direction": true, "balanced": false}})");
  EXPECT_EQ(all.code, 0) << all.out;

  for (const auto& [config, needle] : std::vector<std::pair<std::string, std::string>>{
           {R"({"rings": {"bogus": 1}})", "bogus"},
           {R"({"rings": {"k": 1}})", "k = 1"},
           {R"({"rings": {"k": 2.5}})", "'k'"},
           {R"({"rings": 3})", "rings"},
           {R"({"rings": {"balanced": 1}})", "balanced"}}) {
    const CliResult r = segment("bad", config);
    EXPECT_EQ(r.code, 2) << config << "\n" << r.out;
    EXPECT_NE(r.out.find("bad.json"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find(needle), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(dir / "bad" / "segments.json")) << config;
  }
}
