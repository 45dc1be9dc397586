// Reading a point cloud file of any supported format, chosen by its extension.
#pragma once

#include <string>

#include "rangeseg/cloud.hpp"

namespace rangeseg::io {

/// Reads a point cloud by its file's extension (any case): .pcd (read_pcd), .ply
/// (read_ply_cloud), .xyz / .xyzn / .xyzrgb / .pts (read_text_cloud) and SegComp .range
/// (read_segcomp_range). The points are returned as stored. A depth PNG needs its camera: read
/// it with read_depth_png and turn it into points with depth_to_cloud. Throws
/// std::runtime_error naming the file for any other extension, and the readers' errors.
OrganizedCloud read_cloud(const std::string& path);

}  // namespace rangeseg::io
