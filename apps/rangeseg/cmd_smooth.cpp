#include <memory>
#include <optional>
#include <string>

#include "commands.hpp"
#include "input.hpp"
#include "names.hpp"
#include "output.hpp"
#include "rangeseg/smoothing.hpp"

namespace rangeseg::cli {
namespace {

struct SmoothOptions {
  InputOptions in;
  std::string out;
  std::string preset = "auto";
  std::string config;
  std::optional<int> iterations;
};

}  // namespace

void add_smooth(CLI::App& app) {
  auto o = std::make_shared<SmoothOptions>();
  auto* cmd = app.add_subcommand(
      "smooth",
      "Bilateral filter of points and normals over the mesh (an unorganized cloud: over the k "
      "nearest neighbours of each point); writes a PCD with normals");
  add_input_options(*cmd, o->in);
  cmd->add_option("-o,--output", o->out,
                  "Output .pcd (x y z [intensity] [rgb] normal_x normal_y normal_z curvature)")
      ->required();
  cmd->add_option("--preset", o->preset, kAutoPresetHelp)->capture_default_str();
  cmd->add_option("--config", o->config, "JSON settings overriding the preset");
  cmd->add_option("--iterations", o->iterations,
                  "Filter passes, 0 = none (default: the preset's; abw and ideal do not filter)")
      ->check(CLI::Range(0, kMaxSmoothingIterations));
  cmd->callback([o] {
    require_output_extension(o->out, {".pcd"}, "smooth");
    require_distinct_outputs(o->in.path, {o->out}, "smooth");
    settings_from(resolve_preset(o->preset, ""), "plane", o->config, false);  // bad options first
    const LoadedInput in = load_input(o->in);
    PipelineSettings s =
        settings_from(resolve_preset(o->preset, in.sensor_preset), "plane", o->config, false);
    if (o->iterations) {
      // The abw and ideal presets turn the filter off; passes asked for by number must run.
      s.smoothing.iterations = *o->iterations;
      s.smooth = *o->iterations > 0;
    }
    s.segment = false;
    check_noise_scale(o->in.path, in.cloud, s.smoothing.noise);
    Pipeline pipeline(s);
    pipeline.process(in.cloud, in.camera_fx);
    write_pcd_with_normals(o->out, pipeline.cloud(), pipeline.normals(), in.pose);
    remove_stale_temporaries(o->out);
    progress("wrote " + o->out +
             (s.smooth ? ""
                       : " (not filtered: the input's points with their raw normals; --iterations "
                         "N > 0 filters)"));
  });
}

}  // namespace rangeseg::cli
