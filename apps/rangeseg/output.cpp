#include "output.hpp"

#include <cstdio>
#include <stdexcept>

#include "rangeseg/io/file.hpp"
#include "rangeseg/io/ply.hpp"

namespace rangeseg::cli {

std::filesystem::path ensure_dir(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir)) {
    throw std::runtime_error(dir + ": cannot create output directory: " + ec.message());
  }
  return dir;
}

void write_mesh_ply(const std::string& path, const OrganizedCloud& cloud, const Mesh& mesh,
                    const NormalMap* normals, const RgbImage* colours) {
  TriangleList faces;
  extract_faces(mesh, /*remove_unused_vertices=*/true, faces);
  io::PlyMesh ply;
  ply.vertices_per_face = faces.vertices_per_face;
  ply.faces = std::move(faces.indices);
  const std::size_t n = faces.vertex_pixel.size();
  ply.xyz.reserve(n * 3);
  if (normals != nullptr) ply.normals.reserve(n * 3);
  const bool with_colour = colours != nullptr && !colours->rgb.empty();
  if (with_colour) ply.rgb.reserve(n * 3);
  const int w = cloud.width();
  for (const std::int32_t pixel : faces.vertex_pixel) {
    const int u = pixel % w, v = pixel / w;
    ply.xyz.insert(ply.xyz.end(), {cloud.x(u, v), cloud.y(u, v), cloud.z(u, v)});
    if (normals != nullptr) {
      ply.normals.insert(ply.normals.end(),
                         {normals->nx(u, v), normals->ny(u, v), normals->nz(u, v)});
    }
    if (with_colour) {
      const std::uint8_t* c = colours->pixel(u, v);
      ply.rgb.insert(ply.rgb.end(), {c[0], c[1], c[2]});
    }
  }
  io::write_ply(path, ply);
}

void write_json(const std::string& path, const nlohmann::json& value) {
  io::write_file_atomic(path, value.dump(2) + "\n");
}

void progress(const std::string& what) { std::fprintf(stderr, "rangeseg: %s\n", what.c_str()); }

}  // namespace rangeseg::cli
