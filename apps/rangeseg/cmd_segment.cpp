#include <cstdio>
#include <memory>
#include <string>

#include "commands.hpp"
#include "input.hpp"
#include "names.hpp"
#include "output.hpp"
#include "segment_output.hpp"

namespace rangeseg::cli {
namespace {

struct SegmentOptions {
  InputOptions in;
  std::string out_dir;
  std::string model = "plane";
  std::string preset = "kinect";
  std::string config;
  bool no_smooth = false;
  bool no_mesh = false;
};

}  // namespace

PipelineSettings settings_from(const std::string& preset, const std::string& model,
                               const std::string& config, bool no_smooth) {
  PipelineSettings s = pipeline_preset(preset);
  if (model == "smooth") {
    s.segmentation.model = RegionModel::smooth;
  } else if (model != "plane") {
    throw std::invalid_argument("unknown model '" + model + "' (expected plane or smooth)");
  }
  if (!config.empty()) apply_config_file(config, s);
  if (no_smooth) s.smooth = false;
  return s;
}

void add_segment(CLI::App& app) {
  auto o = std::make_shared<SegmentOptions>();
  auto* cmd = app.add_subcommand(
      "segment",
      "Mesh, normals, smoothing and region-growing segmentation; writes labels.png, "
      "segments.json, overlay.png and mesh.ply into a folder");
  add_input_options(*cmd, o->in);
  cmd->add_option("-o,--output", o->out_dir, "Output directory")->required();
  cmd->add_option("--model", o->model, "Region model: plane or smooth")->capture_default_str();
  cmd->add_option("--preset", o->preset, "Sensor preset: kinect, abw or laser")
      ->capture_default_str();
  cmd->add_option("--config", o->config, "JSON file with settings overriding the preset");
  cmd->add_flag("--no-smooth", o->no_smooth, "Skip the bilateral filter");
  cmd->add_flag("--no-mesh", o->no_mesh, "Do not write mesh.ply");
  cmd->callback([o] {
    const LoadedInput in = load_input(o->in);
    Pipeline pipeline(settings_from(o->preset, o->model, o->config, o->no_smooth));
    pipeline.process(in.cloud);
    write_segmentation_folder(o->out_dir, in.cloud, pipeline, !o->no_mesh);
    const StageTimes& t = pipeline.times();
    std::printf(
        "%s: %zu segments in %.2f ms (mesh %.2f, normals %.2f, smoothing %.2f, segmentation %.2f, "
        "polygons %.2f)\n",
        o->in.path.c_str(), pipeline.segmentation().segments.size(), t.total, t.mesh, t.normals,
        t.smoothing, t.segmentation, t.polygons);
  });
}

}  // namespace rangeseg::cli
