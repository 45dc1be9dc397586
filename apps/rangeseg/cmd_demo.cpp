#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "input.hpp"
#include "names.hpp"
#include "output.hpp"
#include "rangeseg/colorize.hpp"
#include "rangeseg/eval.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/synth.hpp"
#include "segment_output.hpp"

namespace rangeseg::cli {
namespace {

struct DemoOptions {
  std::string out_dir = "out";
  InputOptions in;
  std::string preset = "auto";
  std::uint64_t seed = 1;
};

/// The panels side by side at half resolution: the picture at the top of the README.
RgbImage montage(const std::vector<const RgbImage*>& panels) {
  const int h = panels.front()->height / 2, w = panels.front()->width / 2;
  RgbImage out = RgbImage::black(w * static_cast<int>(panels.size()), h);
  for (std::size_t k = 0; k < panels.size(); ++k) {
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        std::uint8_t* dst = out.pixel(static_cast<int>(k) * w + x, y);
        for (int c = 0; c < 3; ++c) {
          int sum = 0;
          for (int dy = 0; dy < 2; ++dy) {
            for (int dx = 0; dx < 2; ++dx) sum += panels[k]->pixel(2 * x + dx, 2 * y + dy)[c];
          }
          dst[c] = static_cast<std::uint8_t>((sum + 2) / 4);
        }
      }
    }
  }
  return out;
}

void print_surface_types(const Segmentation& seg) {
  int counts[4] = {0, 0, 0, 0};
  for (const Segment& s : seg.segments) {
    ++counts[static_cast<int>(s.kind)];
    if (s.kind == SurfaceKind::sphere) {
      std::printf("  segment %d: sphere, radius %.3f m, centre (%.2f, %.2f, %.2f) m\n", s.label,
                  s.radius, s.centre[0], s.centre[1], s.centre[2]);
    } else if (s.kind == SurfaceKind::cylinder) {
      std::printf("  segment %d: cylinder, radius %.3f m, axis (%.2f, %.2f, %.2f), extent %.2f m\n",
                  s.label, s.radius, s.axis[0], s.axis[1], s.axis[2], s.extent);
    }
  }
  std::printf("surface types: planes %d, cylinders %d, spheres %d, smooth %d\n", counts[0],
              counts[1], counts[2], counts[3]);
}

void run_demo(const DemoOptions& o) {
  pipeline_preset(resolve_preset(o.preset, ""));  // an unknown preset fails before any work
  const auto dir = ensure_dir(o.out_dir);
  LoadedInput in;
  if (o.in.path.empty()) {
    progress("rendering the built-in demo scene (Kinect-like noise, seed " +
             std::to_string(o.seed) + ")");
    synth::Rendering r = synth::render(scene_by_name("demo", o.seed),
                                       {.noise = synth::Noise::kinect, .seed = o.seed});
    in.cloud = std::move(r.cloud);
    in.ground_truth = std::move(r.labels);
    io::write_rgb_png((dir / "ground_truth.png").string(),
                      colorize_labels(in.ground_truth, &in.cloud));
    io::write_pcd((dir / "cloud.pcd").string(), in.cloud,
                  {.encoding = io::PcdEncoding::binary_compressed});
  } else {
    in = load_input(o.in);
    require_grid(in.cloud, o.in.path, "the demo (pictures of the grid)",
                 "`rangeseg segment` segments it (segments.json and a labelled cloud.pcd)");
  }
  PipelineSettings settings = pipeline_preset(resolve_preset(o.preset, in.sensor_preset));
  settings.segmentation.model = RegionModel::automatic;
  Pipeline pipeline(settings);
  // The first frame allocates and first-touches every buffer; a stream pays that once, so the
  // times printed are those of a second run with the buffers reused (same results).
  pipeline.process(in.cloud, in.camera_fx);
  pipeline.process(in.cloud, in.camera_fx);
  const OrganizedCloud& input = in.cloud;
  const RgbImage depth = colorize_depth(input);
  io::write_rgb_png((dir / "depth.png").string(), depth);
  const NormalMap& raw = pipeline.raw_normals();
  const RgbImage normal_colours = colorize_normals(raw.nx.view(), raw.ny.view(), raw.nz.view());
  io::write_rgb_png((dir / "normals_raw.png").string(), normal_colours);
  const NormalMap& smooth = pipeline.normals();
  const RgbImage smooth_colours =
      colorize_normals(smooth.nx.view(), smooth.ny.view(), smooth.nz.view());
  // Without smoothing these would be the raw normals again under a misleading name.
  if (settings.smooth) {
    io::write_rgb_png((dir / "normals_smoothed.png").string(), smooth_colours);
  } else {
    std::filesystem::remove(dir / "normals_smoothed.png");  // of an earlier run
  }
  io::write_rgb_png((dir / "curvature.png").string(),
                    colorize_scalar_auto(pipeline.raw_normals().curvature.view()));
  write_mesh_ply((dir / "mesh.ply").string(), input, pipeline.mesh(), &raw, &normal_colours);
  write_segmentation_folder((dir / "segmentation").string(), input, pipeline, {});
  const RgbImage overlay = colorize_labels(pipeline.segmentation().labels, &input);
  const RgbImage types = colorize_surface_types(pipeline.segmentation(), overlay);
  io::write_rgb_png((dir / "summary.png").string(),
                    montage({&depth, &normal_colours, &smooth_colours, &overlay, &types}));
  const StageTimes& t = pipeline.times();
  std::printf("demo: %d x %d, %zu valid points, %zu mesh faces, %zu segments\n", input.width(),
              input.height(), input.count_valid(), count_faces(pipeline.mesh()),
              pipeline.segmentation().segments.size());
  char smoothing[64] = "smoothing off";
  if (settings.smooth) {
    std::snprintf(smoothing, sizeof smoothing, "smoothing %.2f ms (%d iterations)", t.smoothing,
                  settings.smoothing.iterations);
  }
  std::printf(
      "time (buffers reused): mesh %.2f ms, normals %.2f ms, %s, segmentation %.2f ms, polygons "
      "%.2f ms, total %.2f ms\n",
      t.mesh, t.normals, smoothing, t.segmentation, t.polygons, t.total);
  print_surface_types(pipeline.segmentation());
  if (!in.ground_truth.empty()) {
    const eval::EvalResult r =
        eval::evaluate(in.ground_truth, pipeline.segmentation().labels,
                       {.tolerance = 0.8, .min_gt_label = in.ground_truth_min_label});
    std::printf(
        "vs ground truth (T = 0.8): %d of %d regions correct, %d over, %d under, %d missed, %d "
        "noise\n",
        r.correct, r.gt_regions, r.over, r.under, r.missed, r.noise);
  }
  progress("wrote pictures and files to " + dir.string() + "/");
}

}  // namespace

void add_demo(CLI::App& app) {
  auto o = std::make_shared<DemoOptions>();
  auto* cmd = app.add_subcommand(
      "demo",
      "Run every stage (region model auto) on the built-in scene (or --input) and write "
      "pictures; summary.png ends with the segments coloured by surface type");
  cmd->add_option("-o,--output", o->out_dir, "Output directory")->capture_default_str();
  cmd->add_option("--input", o->in.path,
                  "Use this file instead of the built-in scene (.pcd, .ply, 16-bit depth .png, "
                  ".range, .xyz/.xyzn/.xyzrgb/.pts; a cloud with a pixel grid)");
  add_input_options(*cmd, o->in, false);
  cmd->add_option("--preset", o->preset, kAutoPresetHelp)->capture_default_str();
  cmd->add_option("--seed", o->seed, "Noise seed of the built-in scene")->capture_default_str();
  cmd->callback([o] { run_demo(*o); });
}

}  // namespace rangeseg::cli
