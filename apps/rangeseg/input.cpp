#include "input.hpp"

#include <stdexcept>

#include "rangeseg/io/file.hpp"

namespace rangeseg::cli {

void add_input_options(CLI::App& cmd, InputOptions& o, bool positional) {
  if (positional) cmd.add_option("input", o.path, "Input file: .pcd, 16-bit depth .png, SegComp .range")->required();
  cmd.add_option("--intrinsics", o.intrinsics, "Camera intrinsics JSON (Open3D camera_*.json layout) for depth PNGs");
  cmd.add_option("--fx", o.fx, "Focal length x [pixel] for depth PNGs")->capture_default_str();
  cmd.add_option("--fy", o.fy, "Focal length y [pixel] for depth PNGs")->capture_default_str();
  cmd.add_option("--cx", o.cx, "Principal point x [pixel] (default: (width-1)/2)");
  cmd.add_option("--cy", o.cy, "Principal point y [pixel] (default: (height-1)/2)");
  cmd.add_option("--depth-scale", o.depth_scale, "Metres per depth PNG unit")->capture_default_str();
}

LoadedInput load_input(const InputOptions& o) {
  throw std::runtime_error(o.path + ": unsupported file type '" + io::extension(o.path) + "'");
}

}  // namespace rangeseg::cli
