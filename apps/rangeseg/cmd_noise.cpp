#include <nlohmann/json.hpp>

#include <cstdio>
#include <exception>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "commands.hpp"
#include "input.hpp"
#include "output.hpp"
#include "rangeseg/cloud.hpp"
#include "rangeseg/sensor.hpp"

namespace rangeseg::cli {
namespace {

struct NoiseOptions {
  std::vector<std::string> inputs;
  InputOptions input;
  NoiseEstimateSettings settings;
  std::string output;
  bool json = false;
};

nlohmann::json noise_json(const SensorNoise& n) { return {{"a", n.a}, {"b", n.b}, {"z0", n.z0}}; }

void run_noise(const NoiseOptions& o) {
  NoiseEstimator estimator(o.settings);
  const FrameList list = gather_frames(o.inputs, o.input);
  // As in a segment batch, a bad frame among several is reported and skipped.
  const bool batch = list.frames.size() > 1;
  std::size_t used = 0;
  for (const FrameSource& frame : list.frames) {
    try {
      if (!frame.error.empty()) throw std::runtime_error(frame.error);
      InputOptions in = list.options_for(frame);
      in.path = frame.path;
      LoadedInput loaded = load_input(in);
      require_grid(loaded.cloud, frame.path, "a pixel grid to fit blocks on",
                   "estimate the noise from the organized frames of the same sensor");
      estimator.add(loaded.cloud);
      ++used;
    } catch (const std::exception& error) {
      if (!batch) throw;
      std::fprintf(stderr, "rangeseg: noise: skipped %s\n", error.what());
    }
  }
  if (used == 0) {
    throw std::runtime_error("none of the " + std::to_string(list.frames.size()) +
                             " frames could be used");
  }
  NoiseEstimate e;
  try {
    e = estimator.estimate();
  } catch (const std::runtime_error& error) {
    const std::string files =
        list.frames.size() == 1 ? list.frames.front().path : std::to_string(used) + " frames";
    throw std::runtime_error(files + ": " + error.what());
  }
  const nlohmann::json config = {{"noise", noise_json(e.noise)}};
  if (!o.output.empty()) write_json(o.output, config);
  if (o.json) {
    nlohmann::json bins = nlohmann::json::array();
    for (const auto& b : e.bins) {
      bins.push_back({{"z", b.z}, {"sigma", b.sigma}, {"blocks", b.blocks}});
    }
    const nlohmann::json out = {{"noise", noise_json(e.noise)},
                                {"bins", bins},
                                {"blocks_used", e.blocks_used},
                                {"max_relative_misfit", e.max_relative_misfit}};
    std::printf("%s\n", json_text(out, 2).c_str());
    return;
  }
  const std::size_t skipped = list.frames.size() - used;
  std::printf("%zu frame(s)%s, %zu blocks of %dx%d pixels used\n", used,
              skipped > 0 ? (" (" + std::to_string(skipped) + " skipped)").c_str() : "",
              e.blocks_used, o.settings.block, o.settings.block);
  std::printf("%10s %12s %12s %8s\n", "depth [m]", "sigma [mm]", "model [mm]", "blocks");
  for (const auto& b : e.bins) {
    std::printf("%10.2f %12.2f %12.2f %8d\n", b.z, 1e3 * b.sigma, 1e3 * e.noise.sigma(b.z),
                b.blocks);
  }
  std::printf(
      "sigma(z) = a + b (z - z0)^2: a = %.6g m, b = %.6g 1/m, z0 = %.4g m "
      "(largest misfit %.0f %%, over %.2f-%.2f m)\n",
      e.noise.a, e.noise.b, e.noise.z0, 100 * e.max_relative_misfit, e.bins.front().z,
      e.bins.back().z);
  if (!o.output.empty()) {
    std::printf("wrote %s: use it with `rangeseg segment IN --config %s`\n", o.output.c_str(),
                o.output.c_str());
  } else {
    std::printf("as --config: %s\n", json_text(config).c_str());
  }
}

}  // namespace

void add_noise(CLI::App& app) {
  auto o = std::make_shared<NoiseOptions>();
  auto* cmd = app.add_subcommand(
      "noise",
      "Estimate the sensor's depth noise sigma(z) from frames of ordinary scenes (raw, "
      "unsmoothed), for a sensor that no preset describes; writes it as a --config file");
  cmd->add_option(
         "inputs", o->inputs,
         "Frames of one sensor (.pcd, .ply, 16-bit depth .png, .range, .xyz/.xyzn/.xyzrgb/.pts "
         "on a pixel grid), folders of them or a TUM RGB-D sequence, as for segment (a bad "
         "frame among several is reported and skipped); their blocks are pooled. Planar "
         "surfaces at several depths (floor, walls, a table) are what the estimate needs")
      ->required();
  add_input_options(*cmd, o->input, false);
  cmd->add_option("-o,--output", o->output,
                  "Write {\"noise\": {a, b, z0}} to this JSON file, for --config of the other "
                  "commands");
  cmd->add_option("--block", o->settings.block, "Side of the pixel blocks fitted with planes")
      ->capture_default_str()
      ->check(CLI::Range(4, 256));
  cmd->add_flag("--json", o->json, "Print the model and the per-depth measurements as JSON");
  cmd->footer(
      "Every block (at most 10 % of its pixels invalid) is fitted with a plane in inverse depth; "
      "the lower quartile of the blocks' residuals per depth bin (creases, steps and curved "
      "surfaces fit worse than noise alone), converted to depth noise, is fitted with sigma(z) = "
      "a + b (z - z0)^2.");
  cmd->callback([o] { run_noise(*o); });
}

}  // namespace rangeseg::cli
