// rangeseg_open3d_segment: Open3D's planes (repeated RANSAC) of an organized cloud's valid points
// as a 16-bit label PNG of the cloud's grid, so that `rangeseg eval` scores Open3D and rangeseg
// by the same protocol. Exit code 2 on bad input.
#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "compare_tool.hpp"
#include "open3d_pipeline.hpp"
#include "rangeseg/io/png.hpp"

int main(int argc, char** argv) {
  namespace compare = rangeseg::compare;
  std::string input, output;
  compare::Open3dSettings settings;
  const auto options = [&](CLI::App& app) {
    app.add_option("input", input, "organized .pcd or ABW .range")->required();
    app.add_option("-o,--output", output, "16-bit label PNG to write")->required();
    app.add_option("--distance-threshold", settings.distance_threshold,
                   "inlier distance to a plane [m]")
        ->capture_default_str()
        ->check(compare::positive());
    app.add_option("--iterations", settings.iterations, "RANSAC iterations a plane")
        ->capture_default_str()
        ->check(compare::positive());
    app.add_option("--min-points", settings.min_points, "smallest plane [points]")
        ->capture_default_str()
        ->check(compare::positive());
    app.add_option("--cluster-radius", settings.cluster_radius,
                   "split each plane's inliers by DBSCAN with this radius [m]; 0: do not")
        ->capture_default_str()
        ->check(CLI::NonNegativeNumber);
  };
  return compare::run_tool(
      "rangeseg_open3d_segment",
      "Open3D planes (SegmentPlane, repeated) of a cloud's valid points, as a label PNG", argc,
      argv, options, [&] {
        const rangeseg::OrganizedCloud cloud = compare::read_organized(input);
        std::vector<std::size_t> pixels;
        const open3d::geometry::PointCloud points = compare::to_open3d(cloud, pixels);
        const std::vector<std::int32_t> labels = compare::segment_planes(points, settings);
        rangeseg::LabelImage image(cloud.width(), cloud.height(), 0);
        const auto width = static_cast<std::size_t>(cloud.width());
        for (std::size_t i = 0; i < labels.size(); ++i) {
          image(static_cast<int>(pixels[i] % width), static_cast<int>(pixels[i] / width)) =
              labels[i];
        }
        rangeseg::io::write_label_png(output, image);
      });
}
