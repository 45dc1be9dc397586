#include "segment_output.hpp"

#include "output.hpp"
#include "rangeseg/colorize.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/io/rasterfile.hpp"

namespace rangeseg::cli {

nlohmann::json segments_json(const Segmentation& seg) {
  nlohmann::json list = nlohmann::json::array();
  for (const Segment& s : seg.segments) {
    list.push_back({{"id", s.label},
                    {"model", s.model == RegionModel::plane ? "plane" : "smooth"},
                    {"pixel_count", s.pixel_count},
                    {"area_m2", s.area_m2},
                    {"centroid", s.centroid},
                    {"normal", s.normal},
                    {"offset", s.offset},
                    {"rms_residual", s.rms_residual}});
  }
  return {{"plane_equation", "normal . x + offset = 0, camera frame, metres"},
          {"width", seg.labels.width()},
          {"height", seg.labels.height()},
          {"segments", list}};
}

void write_segmentation_folder(const std::string& dir_name, const OrganizedCloud& input,
                               const Pipeline& pipeline, bool write_mesh) {
  const auto dir = ensure_dir(dir_name);
  const Segmentation& seg = pipeline.segmentation();
  io::write_label_png((dir / "labels.png").string(), seg.labels);
  write_json((dir / "segments.json").string(), segments_json(seg));
  const RgbImage overlay = colorize_labels(seg.labels, &input);
  io::write_rgb_png((dir / "overlay.png").string(), overlay);
  if (write_mesh) {
    const RgbImage flat = colorize_labels(seg.labels);
    write_mesh_ply((dir / "mesh.ply").string(), pipeline.cloud(), pipeline.mesh(), &pipeline.normals(), &flat);
  }
}

}  // namespace rangeseg::cli
