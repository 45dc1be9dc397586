// Loading any supported input file into an organized cloud, with the options every command shares.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"

namespace rangeseg::cli {

struct InputOptions {
  std::string path;
  std::string intrinsics;  ///< JSON file (Open3D camera_*.json layout) for depth PNGs
  double fx = 525, fy = 525, cx = 319.5, cy = 239.5;
  bool cx_given = false, cy_given = false;
  double depth_scale = 0.001;  ///< metres per raw depth unit
};

struct LoadedInput {
  OrganizedCloud cloud;
  std::string format;  ///< e.g. "PCD binary_compressed"
  std::string fields;  ///< e.g. "x y z rgba"
  std::string units = "m";
  LabelImage ground_truth;  ///< from a SegComp .gt-seg beside a .range, or a PCD label field
};

void add_input_options(CLI::App& cmd, InputOptions& opts, bool positional = true);
LoadedInput load_input(const InputOptions& opts);

}  // namespace rangeseg::cli
