#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "input.hpp"
#include "names.hpp"
#include "output.hpp"

namespace rangeseg::cli {
namespace {

struct BenchOptions {
  InputOptions in;
  std::string preset = "kinect";
  std::string config;
  int repeat = 50;
  bool json = false;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? 0.0 : (n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

}  // namespace

void add_bench(CLI::App& app) {
  auto o = std::make_shared<BenchOptions>();
  auto* cmd = app.add_subcommand(
      "bench", "Median milliseconds per stage over repeated runs (single thread)");
  add_input_options(*cmd, o->in);
  cmd->add_option("--preset", o->preset, "Sensor preset")->capture_default_str();
  cmd->add_option("--config", o->config, "JSON settings overriding the preset");
  cmd->add_option("--repeat", o->repeat, "Number of timed runs (after one warm-up run)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  cmd->add_flag("--json", o->json, "Print one JSON object {stage: median ms} on stdout");
  cmd->callback([o] {
    const LoadedInput in = load_input(o->in);
    PipelineSettings settings = settings_from(o->preset, "plane", o->config, false);
    // One smoothing iteration is the unit the stage is measured in.
    settings.smoothing.iterations = 1;
    Pipeline pipeline(settings);
    pipeline.process(in.cloud);  // warm-up: buffers are allocated here
    std::vector<double> mesh, normals, smoothing, segmentation, polygons, total;
    for (int i = 0; i < o->repeat; ++i) {
      pipeline.process(in.cloud);
      const StageTimes& t = pipeline.times();
      mesh.push_back(t.mesh);
      normals.push_back(t.normals);
      smoothing.push_back(t.smoothing);
      segmentation.push_back(t.segmentation);
      polygons.push_back(t.polygons);
      total.push_back(t.total);
    }
    const nlohmann::json result{
        {"mesh", median(mesh)},           {"normals", median(normals)},
        {"smoothing", median(smoothing)}, {"segmentation", median(segmentation)},
        {"polygons", median(polygons)},   {"total", median(total)}};
    if (o->json) {
      std::printf("%s\n", result.dump().c_str());
      return;
    }
    std::printf("%s: %d x %d, median of %d runs, single thread\n", o->in.path.c_str(),
                in.cloud.width(), in.cloud.height(), o->repeat);
    for (const char* stage :
         {"mesh", "normals", "smoothing", "segmentation", "polygons", "total"}) {
      std::printf("  %-13s %8.3f ms\n", stage, result[stage].get<double>());
    }
  });
}

}  // namespace rangeseg::cli
