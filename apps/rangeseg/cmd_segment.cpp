#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "batch.hpp"
#include "commands.hpp"
#include "input.hpp"
#include "names.hpp"
#include "output.hpp"
#include "rangeseg/io/settings_json.hpp"
#include "segment_output.hpp"

namespace rangeseg::cli {
namespace {

struct SegmentOptions {
  InputOptions in;
  std::vector<std::string> inputs;
  std::string out_dir;
  int threads = 1;
  std::string model = "plane";
  std::string preset = "auto";
  std::string config;
  bool no_smooth = false;
  bool no_mesh = false;
  bool cloud = false;
  bool track = false;
  bool strict = false;
};

}  // namespace

PipelineSettings settings_from(const std::string& preset, const std::string& model,
                               const std::string& config, bool no_smooth) {
  PipelineSettings s = pipeline_preset(preset);
  s.segmentation.model = region_model_from_string(model);
  if (!config.empty()) io::apply_settings_file(config, s);
  if (no_smooth) s.smooth = false;
  return s;
}

void require_model_for(const OrganizedCloud& cloud, const PipelineSettings& settings,
                       const std::string& path) {
  const RegionModel model = settings.segmentation.model;
  if (cloud.is_organized() || !settings.segment || model != RegionModel::incremental_plane) {
    return;
  }
  PixelGrid grid;
  if (settings.restore_grid && find_pixel_grid(cloud, grid)) return;  // run on the grid
  throw std::invalid_argument(path + ": an unorganized cloud (height 1) whose points do not lie " +
                              "on a camera's pixel grid is segmented over nearest-neighbour " +
                              "rings, with --model plane, smooth or auto (not " + to_string(model) +
                              ")");
}

std::string resolve_preset(const std::string& preset, const std::string& sensor_preset) {
  if (preset != "auto") {
    for (const char* known : {"kinect", "abw", "laser", "perceptron", "ideal"}) {
      if (preset == known) return preset;
    }
    throw std::invalid_argument("--preset '" + preset +
                                "' is unknown; valid presets: auto, kinect, abw, laser, "
                                "perceptron, ideal");
  }
  return sensor_preset.empty() ? "kinect" : sensor_preset;
}

const char* const kAutoPresetHelp =
    "Sensor preset: kinect, abw, laser, perceptron (SegComp Perceptron images), ideal "
    "(noise-free or simulated depth), or auto: abw or perceptron for SegComp images (.range), "
    "laser for an unorganized cloud whose points surround the sensor (a spinning lidar's "
    "scan), kinect for any other input";

void add_settings_options(CLI::App& cmd, std::string& model, std::string& preset,
                          std::string& config, bool& no_smooth, bool auto_preset) {
  cmd.add_option("--model", model,
                 "Region model: plane, smooth, incremental_plane or auto (per segment: plane, "
                 "cylinder, sphere or smooth surface)")
      ->capture_default_str();
  cmd.add_option("--preset", preset,
                 auto_preset ? kAutoPresetHelp
                             : "Sensor preset: kinect, abw, laser, perceptron (SegComp Perceptron "
                               "images) or ideal (noise-free or simulated depth)")
      ->capture_default_str();
  cmd.add_option(
      "--config", config,
      "JSON file with settings overriding the preset: objects noise, mesh, smoothing, "
      "segmentation, rings (k-nearest-neighbour rings of unorganized clouds: k, "
      "max_distance, eps_theta, jump_sigmas, by_direction, balanced), smooth (true/false), "
      "restore_grid (true/false: an unorganized cloud on a camera's pixel grid runs on "
      "that grid), polygons (true/false), polygon (simplify_tolerance [m], "
      "simplify_tolerance_pixels, simplify_inradius_fraction, ...), track (true/false: segment "
      "tracks across frames) and tracking (min_overlap, max_normal_angle, max_distance); "
      "`rangeseg settings` prints them all");
  cmd.add_flag("--no-smooth", no_smooth, "Skip the bilateral filter");
}

void add_segment(CLI::App& app) {
  auto o = std::make_shared<SegmentOptions>();
  auto* cmd = app.add_subcommand(
      "segment",
      "Mesh, normals, smoothing, region-growing segmentation and plane polygons; writes "
      "labels.png, segments.json, polygons.obj, overlay.png, types.png and mesh.ply (and with "
      "--cloud cloud.pcd) into a folder (an unorganized cloud: segments.json, polygons.obj and "
      "cloud.pcd)");
  cmd->add_option(
         "input", o->inputs,
         "Input file (.pcd, .ply, 16-bit depth .png, SegComp .range, .xyz/.xyzn/.xyzrgb/.pts), "
         "several files, a directory of them, or a TUM RGB-D sequence folder (with "
         "depth.txt)")
      ->required();
  add_input_options(*cmd, o->in, /*positional=*/false);
  cmd->add_option("-o,--output", o->out_dir,
                  "Output directory (one input file: the results; otherwise one folder per frame "
                  "and summary.json)")
      ->required();
  cmd->add_option("--threads", o->threads,
                  "A batch: frames processed in parallel (one pipeline each; with --track one "
                  "frame after another, N threads inside each); one input: threads inside the "
                  "frame (every stage's passes over row bands)")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  add_settings_options(*cmd, o->model, o->preset, o->config, o->no_smooth,
                       /*auto_preset=*/true);
  cmd->add_flag("--track", o->track,
                "A sequence: give the segments track ids that persist from frame to frame "
                "(segments.json: track_id; the pictures, mesh.ply and cloud.pcd coloured by "
                "track); the frames then run one after another in input order, --threads "
                "inside each frame (also config key \"track\")");
  cmd->add_flag("--strict", o->strict,
                "A batch exits with code 2 when any frame failed (by default only when none "
                "succeeded; the failures are listed either way)");
  cmd->add_flag("--no-mesh", o->no_mesh, "Do not write mesh.ply");
  cmd->add_flag("--cloud", o->cloud,
                "Also write cloud.pcd for an organized input: the smoothed points, organized as "
                "the input, with normals, curvature, label and rgb (an unorganized cloud's "
                "results are always in it)");
  cmd->footer(
      "Several inputs, a directory or a TUM sequence run as a batch: a frame that cannot be read "
      "or processed is reported and skipped. Folders are named after the file stem (TUM: the "
      "timestamp; a name two inputs share gets _2, _3, ... in input order). Ctrl-C stops a "
      "batch after the frames being processed, with its summary. TUM depth PNGs default to 5000 "
      "units per metre and fx = fy = 525, cx = 319.5, "
      "cy = 239.5.\ncloud.pcd holds the processed (smoothed) points, organized as the input, with "
      "normal_x normal_y normal_z curvature, label and rgb (the label's colour); it takes ~0.15 "
      "s and ~20 MB more for a 640x480 frame.\nAn unorganized "
      "cloud (a PCD of height 1) is segmented on the pixel grid its points lie on when they "
      "come from a camera's image (the grid's size and focal lengths are printed), else over "
      "the k nearest neighbours of each point (--config \"rings\"; \"restore_grid\": false "
      "always), with --model plane, smooth or auto; its folder holds segments.json, "
      "polygons.obj and cloud.pcd.\nFiles of an earlier run in the output folder that this run "
      "does not write are removed (only files rangeseg wrote, never an input).\nExit codes: 0 = "
      "done (a batch with at least "
      "one frame written; failed frames are listed), 2 = bad arguments, unreadable single input, "
      "or no frame of a batch succeeded (with --strict: any frame failed).");
  cmd->callback([o] {
    const auto settings_for = [o](const std::string& preset) {
      PipelineSettings s = settings_from(preset, o->model, o->config, o->no_smooth);
      s.track = s.track || o->track;
      return s;
    };
    // Bad options (an unknown preset or model, a bad --config) fail before any input is read.
    settings_for(resolve_preset(o->preset, ""));
    if (o->inputs.size() > 1 || is_batch_input(o->inputs.front())) {
      const FrameList frames = gather_frames(o->inputs, o->in);
      const std::size_t ok =
          segment_batch(frames, {.preset = o->preset, .settings_for = settings_for},
                        {.out_dir = o->out_dir,
                         .files = {.mesh = !o->no_mesh, .cloud = o->cloud},
                         .threads = o->threads});
      if (ok == 0 || (o->strict && ok < frames.frames.size())) set_exit_code(kExitInput);
      return;
    }
    o->in.path = o->inputs.front();
    const LoadedInput in = load_input(o->in);
    note_auto_preset(o->preset, in, o->in.path);
    const std::string preset = resolve_preset(o->preset, in.sensor_preset);
    PipelineSettings settings = settings_for(preset);
    settings.threads = o->threads;
    warn_if_more_threads_than_cores(o->threads);
    require_model_for(in.cloud, settings, o->in.path);
    check_noise_scale(o->in.path, in.cloud, settings.segmentation.noise);
    Pipeline pipeline(settings);
    pipeline.process(in.cloud, in.camera_fx);
    warn_if_no_segments(pipeline, o->in.path);
    const InputFiles inputs({o->in.path});
    const std::string files = write_segmentation_folder(
        o->out_dir, in.cloud, pipeline,
        {.mesh = !o->no_mesh, .cloud = o->cloud, .pose = in.pose, .inputs = &inputs});
    const StageTimes& t = pipeline.times();
    const std::size_t segments = pipeline.segmentation().segments.size();
    char tracking[48] = "";
    if (t.tracking > 0) std::snprintf(tracking, sizeof tracking, ", tracking %.2f", t.tracking);
    if (!in.cloud.is_organized()) {
      const PixelGrid& grid = pipeline.pixel_grid();
      char where[128] = "over rings";
      if (grid.found()) {
        std::snprintf(where, sizeof where, "on its %d x %d pixel grid, fx %.1f fy %.1f px",
                      grid.width, grid.height, grid.fx, grid.fy);
      }
      std::printf(
          "%s: %zu segments of %zu points (unorganized, %zu valid, %s) in %.2f ms (preset %s; "
          "order %.2f, %s %.2f, normals %.2f, smoothing %.2f, segmentation %.2f, polygons "
          "%.2f%s); wrote %s\n",
          o->in.path.c_str(), segments, in.cloud.size(), in.cloud.count_valid(), where, t.total,
          preset.c_str(), t.input, grid.found() ? "mesh" : "rings", t.mesh, t.normals, t.smoothing,
          t.segmentation, t.polygons, tracking, files.c_str());
      return;
    }
    std::printf(
        "%s: %zu segments in %.2f ms (preset %s; mesh %.2f, normals %.2f, smoothing %.2f, "
        "segmentation %.2f, polygons %.2f%s; a first frame, which allocates the buffers: "
        "`rangeseg bench` times frames that reuse them)\n",
        o->in.path.c_str(), segments, t.total, preset.c_str(), t.mesh, t.normals, t.smoothing,
        t.segmentation, t.polygons, tracking);
  });
}

}  // namespace rangeseg::cli
