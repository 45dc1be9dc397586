// rangeseg_pcl_segment: PCL 1.13's plane segmentation of an organized cloud as a 16-bit label PNG,
// so that `rangeseg eval` scores PCL and rangeseg by the same protocol. Exit code 2 on bad input.
#include <CLI/CLI.hpp>

#include <cmath>
#include <exception>
#include <filesystem>
#include <iostream>
#include <string>

#include "pcl_pipeline.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/io/rasterfile.hpp"

namespace {

rangeseg::OrganizedCloud read_input(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".range") return rangeseg::io::read_abw_range(path);
  if (ext == ".pcd") return rangeseg::io::read_pcd(path);
  throw std::invalid_argument(path + ": unknown input type '" + ext + "' (.pcd or ABW .range)");
}

int run(int argc, char** argv) {
  CLI::App app{"PCL 1.13 OrganizedMultiPlaneSegmentation of an organized cloud, as a label PNG"};
  std::string input, output;
  rangeseg::compare::PclSettings settings;
  double angular_deg = settings.angular_threshold * 180.0 / 3.14159265358979323846;
  bool smooth = false;
  app.add_option("input", input, "organized .pcd or ABW .range")->required();
  app.add_option("-o,--output", output, "16-bit label PNG to write")->required();
  app.add_option("--min-inliers", settings.min_inliers, "smallest plane [points]")
      ->capture_default_str();
  app.add_option("--angular-threshold", angular_deg, "normal angle between neighbours [deg]")
      ->capture_default_str();
  app.add_option("--distance-threshold", settings.distance_threshold,
                 "distance between neighbours' planes [m]")
      ->capture_default_str();
  app.add_option("--max-depth-change", settings.max_depth_change_factor,
                 "normals: depth change factor")
      ->capture_default_str();
  app.add_option("--normal-smoothing", settings.normal_smoothing_size,
                 "normals: smoothing window [pixels]")
      ->capture_default_str();
  app.add_flag("--smooth", smooth, "FastBilateralFilter the depth first");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help is 0
  }
  try {
    if (!(angular_deg > 0 && angular_deg < 180)) {
      throw std::invalid_argument("--angular-threshold " + std::to_string(angular_deg) +
                                  " must be in (0, 180) deg");
    }
    settings.angular_threshold = angular_deg * 3.14159265358979323846 / 180.0;
    const rangeseg::OrganizedCloud cloud = read_input(input);
    if (!cloud.is_organized()) throw std::invalid_argument(input + ": not an organized cloud");
    rangeseg::compare::PclCloud::Ptr points = rangeseg::compare::to_pcl(cloud);
    if (smooth) {
      auto filtered = std::make_shared<rangeseg::compare::PclCloud>();
      rangeseg::compare::bilateral_filter(points, *filtered);
      points = filtered;
    }
    const auto normals = std::make_shared<rangeseg::compare::PclNormals>();
    rangeseg::compare::estimate_normals(points, settings, *normals);
    rangeseg::io::write_label_png(output,
                                  rangeseg::compare::segment_planes(points, normals, settings));
  } catch (const std::exception& e) {
    std::cerr << "rangeseg_pcl_segment: " << e.what() << "\n";
    return 2;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (...) {
    std::cerr << "rangeseg_pcl_segment: unexpected error\n";
    return 2;
  }
}
