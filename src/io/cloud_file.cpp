#include "rangeseg/io/cloud_file.hpp"

#include <stdexcept>
#include <string>

#include "rangeseg/io/file.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/perceptron.hpp"
#include "rangeseg/io/ply.hpp"
#include "rangeseg/io/xyz.hpp"

namespace rangeseg::io {

OrganizedCloud read_cloud(const std::string& path) {
  const std::string ext = extension(path);
  if (ext == ".pcd") return read_pcd(path);
  if (ext == ".ply") return read_ply_cloud(path);
  if (ext == ".range") return read_segcomp_range(path);
  if (is_text_cloud_extension(ext)) return read_text_cloud(path);
  if (ext == ".png") {
    throw std::runtime_error(path +
                             ": a depth image needs its camera: read it with read_depth_png "
                             "and depth_to_cloud");
  }
  throw std::runtime_error(path + ": unsupported point cloud file type '" + ext +
                           "' (expected .pcd, .ply, .range, .xyz, .xyzn, .xyzrgb or .pts)");
}

}  // namespace rangeseg::io
