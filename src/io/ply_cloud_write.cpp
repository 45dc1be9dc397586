// PLY point clouds as PCL writes them: organized clouds with obj_info and a range_grid, the
// sensor's pose in a camera element.
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "detail/number_text.hpp"
#include "little_endian.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/ply.hpp"

namespace rangeseg::io {

using detail::append_le;

namespace {

constexpr std::array<double, 7> kIdentity{0, 0, 0, 1, 0, 0, 0};

// PCL's camera element: the sensor's position, the rows of its orientation's rotation matrix,
// no intrinsics, the viewport (PCL's reader takes the cloud's size from it) and no distortion.
void append_camera(std::string& header, std::vector<std::uint8_t>& out,
                   const std::array<double, 7>& pose, int width, int height) {
  header += "element camera 1\n";
  for (const char* name : {"view_px", "view_py", "view_pz", "x_axisx", "x_axisy", "x_axisz",
                           "y_axisx", "y_axisy", "y_axisz", "z_axisx", "z_axisy", "z_axisz",
                           "focal", "scalex", "scaley", "centerx", "centery"}) {
    header += std::string("property float ") + name + "\n";
  }
  header +=
      "property int viewportx\nproperty int viewporty\nproperty float k1\nproperty float k2\n";
  Eigen::Quaterniond q(pose[3], pose[4], pose[5], pose[6]);
  const Eigen::Matrix3d r = q.normalized().toRotationMatrix();
  for (int k = 0; k < 3; ++k) append_le(out, static_cast<float>(pose[k]));
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) append_le(out, static_cast<float>(r(i, j)));
  }
  for (int k = 0; k < 5; ++k) append_le(out, 0.0f);
  append_le(out, std::int32_t{width}), append_le(out, std::int32_t{height});
  append_le(out, 0.0f), append_le(out, 0.0f);
}

}  // namespace

std::vector<std::uint8_t> encode_ply_cloud(const OrganizedCloud& cloud,
                                           const std::array<double, 7>& viewpoint) {
  require_consistent(cloud, "encode_ply_cloud");
  for (const double c : viewpoint) {
    if (!std::isfinite(c)) {
      throw std::invalid_argument("encode_ply_cloud: viewpoint with a non-finite value " +
                                  rangeseg::detail::number_text(c));
    }
  }
  const double norm = std::sqrt(viewpoint[3] * viewpoint[3] + viewpoint[4] * viewpoint[4] +
                                viewpoint[5] * viewpoint[5] + viewpoint[6] * viewpoint[6]);
  if (!(norm >= 1e-6)) {
    throw std::invalid_argument("encode_ply_cloud: viewpoint quaternion of norm " +
                                rangeseg::detail::number_text(norm) + ", expected about 1");
  }
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
  if (cloud.has_label()) header += "property uint label\n";  // PCL's type; the int32 bits
  if (organized) {
    header += "element range_grid " + std::to_string(cloud.size()) +
              "\nproperty list uchar int vertex_indices\n";
  }
  std::vector<std::uint8_t> camera;
  if (viewpoint != kIdentity) append_camera(header, camera, viewpoint, w, h);
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
  out.insert(out.end(), camera.begin(), camera.end());
  return out;
}

void write_ply_cloud(const std::string& path, const OrganizedCloud& cloud,
                     const std::array<double, 7>& viewpoint) {
  write_file_atomic(path, encode_ply_cloud(cloud, viewpoint));
}

}  // namespace rangeseg::io
