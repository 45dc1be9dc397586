// PLY point clouds as PCL writes them: organized clouds with obj_info and a range_grid.
#include <stdexcept>
#include <string>
#include <vector>

#include "little_endian.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/ply.hpp"

namespace rangeseg::io {

using detail::append_le;

std::vector<std::uint8_t> encode_ply_cloud(const OrganizedCloud& cloud) {
  require_consistent(cloud, "encode_ply_cloud");
  const int w = cloud.width(), h = cloud.height();
  const bool organized = cloud.is_organized();
  std::size_t vertices = 0;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) vertices += !organized || cloud.valid(u, v);
  }
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment written by rangeseg\n";
  if (organized) {
    header += "obj_info num_cols " + std::to_string(w) + "\nobj_info num_rows " +
              std::to_string(h) + "\n";
  }
  header += "element vertex " + std::to_string(vertices) +
            "\nproperty float x\nproperty float y\nproperty float z\n";
  if (cloud.has_intensity()) header += "property float intensity\n";
  if (cloud.has_rgb()) header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (cloud.has_label()) header += "property int label\n";
  if (organized) {
    header += "element range_grid " + std::to_string(cloud.size()) +
              "\nproperty list uchar int vertex_indices\n";
  }
  header += "end_header\n";

  const std::size_t vertex_bytes = 12 + (cloud.has_intensity() ? 4 : 0) +
                                   (cloud.has_rgb() ? 3 : 0) + (cloud.has_label() ? 4 : 0);
  std::vector<std::uint8_t> out(header.begin(), header.end());
  out.reserve(out.size() + vertices * vertex_bytes + (organized ? cloud.size() + 4 * vertices : 0));
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      if (organized && !cloud.valid(u, v)) continue;
      append_le(out, cloud.x(u, v)), append_le(out, cloud.y(u, v)), append_le(out, cloud.z(u, v));
      if (cloud.has_intensity()) append_le(out, cloud.intensity(u, v));
      if (cloud.has_rgb()) {
        out.insert(out.end(), {cloud.r(u, v), cloud.g(u, v), cloud.b(u, v)});
      }
      if (cloud.has_label()) append_le(out, cloud.label(u, v));
    }
  }
  if (organized) {
    std::int32_t next = 0;
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        const bool valid = cloud.valid(u, v);
        out.push_back(valid ? 1 : 0);
        if (valid) append_le(out, next++);
      }
    }
  }
  return out;
}

void write_ply_cloud(const std::string& path, const OrganizedCloud& cloud) {
  write_file_atomic(path, encode_ply_cloud(cloud));
}

}  // namespace rangeseg::io
