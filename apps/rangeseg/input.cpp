#include "input.hpp"

#include <filesystem>
#include <stdexcept>

#include "rangeseg/camera.hpp"
#include "rangeseg/io/camera_json.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/io/rasterfile.hpp"

namespace rangeseg::cli {

void add_input_options(CLI::App& cmd, InputOptions& o, bool positional) {
  if (positional) {
    cmd.add_option("input", o.path, "Input file: .pcd, 16-bit depth .png, SegComp .range")
        ->required();
  }
  cmd.add_option("--intrinsics", o.intrinsics,
                 "Camera intrinsics JSON for depth PNGs (Open3D camera_*.json layout, or "
                 "{fx, fy, cx, cy})");
  cmd.add_option("--fx", o.fx, "Focal length x [pixel] for depth PNGs")->capture_default_str();
  cmd.add_option("--fy", o.fy, "Focal length y [pixel] for depth PNGs")->capture_default_str();
  cmd.add_option("--cx", o.cx, "Principal point x [pixel] for depth PNGs (default (width-1)/2)")
      ->each([&o](const std::string&) { o.cx_given = true; });
  cmd.add_option("--cy", o.cy, "Principal point y [pixel] for depth PNGs (default (height-1)/2)")
      ->each([&o](const std::string&) { o.cy_given = true; });
  cmd.add_option("--depth-scale", o.depth_scale, "Metres per depth PNG unit (0.001 = millimetres)")
      ->capture_default_str();
}

CameraIntrinsics intrinsics_for(const InputOptions& o, int width, int height) {
  if (!o.intrinsics.empty()) return io::read_camera_json(o.intrinsics);
  CameraIntrinsics cam{.fx = o.fx,
                       .fy = o.fy,
                       .cx = o.cx_given ? o.cx : (width - 1) / 2.0,
                       .cy = o.cy_given ? o.cy : (height - 1) / 2.0,
                       .width = width,
                       .height = height};
  validate(cam);
  return cam;
}

LoadedInput load_input(const InputOptions& o) {
  LoadedInput in;
  const std::string ext = io::extension(o.path);
  if (ext == ".pcd") {
    io::PcdInfo info;
    in.cloud = io::read_pcd(o.path, &info);
    static const char* const names[] = {"ascii", "binary", "binary_compressed"};
    in.format = std::string("PCD ") + names[static_cast<int>(info.encoding)];
    in.fields = info.fields_summary;
    if (in.cloud.has_label()) in.ground_truth = in.cloud.label;
  } else if (ext == ".png") {
    const DepthImage depth = io::read_depth_png(o.path);
    const CameraIntrinsics cam = intrinsics_for(o, depth.width(), depth.height());
    in.cloud = depth_to_cloud(depth.view(), cam, o.depth_scale);
    in.format = "16-bit depth PNG";
    in.fields = "depth (scale " + std::to_string(o.depth_scale) + " m/unit)";
  } else if (ext == ".range") {
    in.cloud = io::read_abw_range(o.path);
    in.format = "SegComp ABW rasterfile";
    in.fields = "range (8 bit)";
    std::filesystem::path gt = o.path;
    gt.replace_extension(".gt-seg");
    if (std::filesystem::exists(gt)) in.ground_truth = io::read_segcomp_gt(gt.string());
  } else {
    throw std::runtime_error(o.path + ": unsupported file type '" + ext +
                             "' (expected .pcd, .png or .range)");
  }
  if (in.cloud.empty()) throw std::runtime_error(o.path + ": the cloud has no points");
  return in;
}

}  // namespace rangeseg::cli
