// rangeseg_pcl_segment: PCL 1.13's plane segmentation of an organized cloud as a 16-bit label PNG,
// so that `rangeseg eval` scores PCL and rangeseg by the same protocol. Exit code 2 on bad input.
#include <CLI/CLI.hpp>

#include <memory>
#include <string>

#include "compare_tool.hpp"
#include "pcl_pipeline.hpp"
#include "rangeseg/io/png.hpp"

int main(int argc, char** argv) {
  namespace compare = rangeseg::compare;
  std::string input, output;
  compare::PclSettings settings;
  constexpr double kDegree = 3.14159265358979323846 / 180.0;
  double angular_deg = settings.angular_threshold / kDegree;
  bool smooth = false;
  const auto options = [&](CLI::App& app) {
    app.add_option("input", input, "organized .pcd or ABW .range")->required();
    app.add_option("-o,--output", output, "16-bit label PNG to write")->required();
    app.add_option("--min-inliers", settings.min_inliers, "smallest plane [points]")
        ->capture_default_str();
    app.add_option("--angular-threshold", angular_deg, "normal angle between neighbours [deg]")
        ->capture_default_str()
        ->check(compare::positive() & CLI::Range(0.0, 180.0));
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
  };
  return compare::run_tool(
      "rangeseg_pcl_segment",
      "PCL 1.13 OrganizedMultiPlaneSegmentation of an organized cloud, as a label PNG", argc, argv,
      options, [&] {
        settings.angular_threshold = angular_deg * kDegree;
        compare::PclCloud::Ptr points = compare::to_pcl(compare::read_organized(input));
        if (smooth) {
          auto filtered = std::make_shared<compare::PclCloud>();
          compare::bilateral_filter(points, *filtered);
          points = filtered;
        }
        const auto normals = std::make_shared<compare::PclNormals>();
        compare::estimate_normals(points, settings, *normals);
        rangeseg::io::write_label_png(output, compare::segment_planes(points, normals, settings));
      });
}
