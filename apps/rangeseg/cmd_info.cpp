#include <cstdio>
#include <memory>
#include <string>

#include "commands.hpp"
#include "input.hpp"
#include "names.hpp"
#include "rangeseg/camera.hpp"
#include "rangeseg/cloud.hpp"
#include "rangeseg/pixel_grid.hpp"
#include "rangeseg/segmentation.hpp"

namespace rangeseg::cli {
namespace {

struct InfoOptions {
  InputOptions in;
  std::string preset = "auto";
  std::string config;
};

/// The smallest segment the pipeline takes for this file under --preset and --config, with its
/// camera's focal length fx [pixel] (0: none fits, the grid's own pixels).
void print_min_region_size(const SegmentationSettings& settings, const std::string& preset,
                           double fx) {
  const int count = min_region_size_for(settings, fx);
  if (!(fx > 0) || !(settings.min_region_fx > 0)) {
    std::printf("segments: at least %d pixels with the %s preset (the grid's own pixels)\n", count,
                preset.c_str());
  } else {
    std::printf(
        "segments: at least %d pixels with the %s preset (%d from fx %.0f on, the same solid "
        "angle below)\n",
        count, preset.c_str(), settings.min_region_size, settings.min_region_fx);
  }
}

}  // namespace

void add_info(CLI::App& app) {
  auto o = std::make_shared<InfoOptions>();
  auto* cmd =
      app.add_subcommand("info", "Print size, fields, valid points and depth range of a file");
  add_input_options(*cmd, o->in);
  cmd->add_option("--preset", o->preset,
                  std::string(kAutoPresetHelp) + "; for the smallest segment it prints")
      ->capture_default_str();
  cmd->add_option("--config", o->config, "JSON settings overriding the preset, as for segment");
  cmd->callback([o] {
    settings_from(resolve_preset(o->preset, ""), "plane", o->config, false);  // bad options first
    const LoadedInput in = load_input(o->in);
    const std::string preset = resolve_preset(o->preset, in.sensor_preset);
    const PipelineSettings settings = settings_from(preset, "plane", o->config, false);
    const int stride = settings.mesh.pixel_stride;
    const CloudStats s = cloud_stats(in.cloud);
    std::printf("file:     %s\nformat:   %s\nsize:     %d x %d (%s)\nfields:   %s\n",
                o->in.path.c_str(), in.format.c_str(), in.cloud.width(), in.cloud.height(),
                in.cloud.is_organized() ? "organized" : "unorganized", in.fields.c_str());
    std::printf("valid:    %zu of %zu points (%.1f%%)\n", s.valid, in.cloud.size(),
                in.cloud.empty()
                    ? 0.0
                    : 100.0 * static_cast<double>(s.valid) / static_cast<double>(in.cloud.size()));
    if (s.valid > 0) {
      std::printf("depth:    z %.4f .. %.4f %s, range %.4f .. %.4f %s\n", s.min_z, s.max_z,
                  in.units.c_str(), s.min_range, s.max_range, in.units.c_str());
    }
    if (in.cloud.has_label()) std::printf("labels:   yes\n");
    if (!in.viewpoint.empty()) {
      std::printf("viewpoint: %s (tx ty tz qw qx qy qz; %s)\n", in.viewpoint.c_str(),
                  o->in.apply_viewpoint ? "the points moved into this sensor's frame"
                                        : "not applied: --apply-viewpoint moves the points into "
                                          "this sensor's frame");
    }
    if (!in.camera_source.empty()) {
      const CameraIntrinsics& c = in.camera;
      std::printf(
          "camera:   fx %.2f fy %.2f cx %.2f cy %.2f (%s; the smoothing's pixel angle 1 / fx = "
          "%.6g rad)\n",
          c.fx, c.fy, c.cx, c.cy, in.camera_source.c_str(), 1.0 / c.fx);
      print_min_region_size(settings.segmentation, preset, c.fx / stride);
    } else if (in.cloud.is_organized() && s.valid > 0) {
      // The smoothing's pixel angle is 1 / fx of this camera, which the pipeline fits as here.
      CameraIntrinsics camera;
      if (fit_intrinsics(in.cloud, camera)) {
        const double angle = 1.0 / camera.fx;
        std::printf(
            "camera:   fx %.2f fy %.2f cx %.2f cy %.2f (fitted to the points; the smoothing's "
            "pixel angle 1 / fx = %.6g rad)\n",
            camera.fx, camera.fy, camera.cx, camera.cy, angle);
        print_min_region_size(settings.segmentation, preset, camera.fx / stride);
      } else {
        std::printf(
            "camera:   none fits (not a pinhole camera's image: a scanner's grid, or "
            "points moved out of the camera's frame; the smoothing's pixel angle is then 1 / 525 "
            "rad unless the config sets \"smoothing\": {\"pixel_angle\": ...})\n");
        print_min_region_size(settings.segmentation, preset, 0);
      }
    }
    if (!in.cloud.is_organized()) {
      PixelGrid grid;
      if (find_pixel_grid(in.cloud, grid)) {
        std::printf(
            "grid:     %d x %d pixels, fx %.2f fy %.2f cx %.2f cy %.2f (a camera's "
            "points: segmented on this grid)\n",
            grid.width, grid.height, grid.fx, grid.fy, grid.cx, grid.cy);
      } else {
        std::printf("grid:     none (segmented over k-nearest-neighbour rings)\n");
      }
    }
  });
}

}  // namespace rangeseg::cli
