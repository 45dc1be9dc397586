// CLI tests of the `auto` and `incremental_plane` region models: segments.json surface types.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_util.hpp"
#include "test_util.hpp"

namespace fs = std::filesystem;

namespace {

using rangeseg::test::CliResult;
CliResult run(const std::string& args) { return rangeseg::test::run_cli(args); }

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

TEST(CliPrimitives, AutoModelWritesSurfaceTypesAndParameters) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_primitives_auto");
  // Seed 1 of the mixed scene: two cylinders and a sphere on a floor, with boxes.
  ASSERT_EQ(run("synth --scene mixed --seed 1 --noise none -o " + (dir / "scene").string()).code,
            0);
  const CliResult r = run("segment " + (dir / "scene" / "cloud.pcd").string() +
                          " --model auto --no-mesh -o " + (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_TRUE(fs::exists(dir / "out" / "types.png"));
  const nlohmann::json segments = read_json(dir / "out" / "segments.json");
  const nlohmann::json surfaces = read_json(dir / "scene" / "surfaces.json");
  int cylinders = 0, spheres = 0;
  for (const auto& s : segments["segments"]) {
    const auto& surface = s["surface"];
    const std::string type = surface["type"];
    ASSERT_TRUE(surface.contains("rms_residual"));
    if (type == "sphere") {
      ++spheres;
      EXPECT_EQ(s["model"], "auto");
      EXPECT_EQ(surface["centre"].size(), 3u);
      EXPECT_GT(surface["radius"].get<double>(), 0.0);
    } else if (type == "cylinder") {
      ++cylinders;
      EXPECT_EQ(surface["axis"].size(), 3u);
      EXPECT_EQ(surface["axis_point"].size(), 3u);
      EXPECT_GT(surface["extent"].get<double>(), 0.0);
      // The radius is one of the scene's cylinder radii within 1%.
      bool matched = false;
      for (const auto& gt : surfaces["surfaces"]) {
        if (gt["type"] == "cylinder") {
          EXPECT_EQ(gt["axis_point"].size(), 3u);
          EXPECT_FALSE(gt.contains("centre"));
        }
        if (gt["type"] == "cylinder" &&
            std::abs(gt["radius"].get<double>() - surface["radius"].get<double>()) <
                0.01 * gt["radius"].get<double>()) {
          matched = true;
        }
      }
      EXPECT_TRUE(matched) << surface.dump();
    } else {
      EXPECT_EQ(type, "plane");
      EXPECT_EQ(s["model"], "plane");
    }
  }
  EXPECT_EQ(cylinders, 2);
  EXPECT_EQ(spheres, 1);
}

TEST(CliPrimitives, IncrementalPlaneModelAndBadModelName) {
  const fs::path dir = rangeseg::test::scratch_dir("cli_primitives_incremental");
  ASSERT_EQ(run("synth --scene boxes --seed 2 -o " + (dir / "scene").string()).code, 0);
  const CliResult r = run("segment " + (dir / "scene" / "cloud.pcd").string() +
                          " --model incremental_plane --no-mesh -o " + (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json segments = read_json(dir / "out" / "segments.json");
  ASSERT_FALSE(segments["segments"].empty());
  for (const auto& s : segments["segments"]) {
    EXPECT_EQ(s["model"], "incremental_plane");
    EXPECT_EQ(s["surface"]["type"], "plane");
  }
  const CliResult bad = run("segment " + (dir / "scene" / "cloud.pcd").string() +
                            " --model cones -o " + (dir / "bad").string());
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.out.find("auto"), std::string::npos) << bad.out;
}

}  // namespace
