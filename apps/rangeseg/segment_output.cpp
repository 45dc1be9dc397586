#include "segment_output.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "output.hpp"
#include "rangeseg/colorize.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/version.hpp"

namespace rangeseg::cli {

namespace {

nlohmann::json loop_json(const PolygonSet& set, const PolygonLoop& loop) {
  nlohmann::json points3d = nlohmann::json::array(), points2d = nlohmann::json::array();
  for (int i = loop.first; i < loop.first + loop.count; ++i) {
    points3d.push_back(set.points3d[static_cast<std::size_t>(i)]);
    points2d.push_back(set.points2d[static_cast<std::size_t>(i)]);
  }
  return {{"hole", loop.is_hole},
          {"area_m2", loop.area},
          {"perimeter_m", loop.perimeter},
          {"points", points3d},
          {"points_2d", points2d}};
}

nlohmann::json polygon_json(const PolygonSet& set, const SegmentPolygons& sp) {
  nlohmann::json loops = nlohmann::json::array();
  for (int l = sp.first_loop; l < sp.first_loop + sp.loop_count; ++l) {
    loops.push_back(loop_json(set, set.loops[static_cast<std::size_t>(l)]));
  }
  nlohmann::json hull = nlohmann::json::array();
  for (int i = sp.hull_first; i < sp.hull_first + sp.hull_count; ++i) {
    hull.push_back(set.hull_points3d[static_cast<std::size_t>(i)]);
  }
  return {{"frame", {{"origin", sp.frame.origin}, {"e1", sp.frame.e1}, {"e2", sp.frame.e2}}},
          {"area_m2", sp.area},
          {"perimeter_m", sp.perimeter},
          {"loops", loops},
          {"convex_hull",
           {{"area_m2", sp.hull_area}, {"perimeter_m", sp.hull_perimeter}, {"points", hull}}}};
}

void draw_polygons(RgbImage& image, const PolygonSet& set) {
  std::vector<std::array<float, 2>> pixels;
  for (std::size_t l = 0; l < set.loops.size(); ++l) {
    loop_pixels(set, static_cast<int>(l), pixels);
    const std::array<std::uint8_t, 3> colour = set.loops[l].is_hole
                                                   ? std::array<std::uint8_t, 3>{255, 64, 64}
                                                   : std::array<std::uint8_t, 3>{255, 255, 255};
    draw_polyline(image, pixels, colour, true);
  }
}

/// The fitted surface of a segment: type, RMS residual and the type's parameters.
nlohmann::json surface_json(const Segment& s) {
  nlohmann::json j{{"type", to_string(s.kind)}, {"rms_residual", s.surface_rms}};
  if (s.kind == SurfaceKind::sphere) {
    j["centre"] = s.centre;
    j["radius"] = s.radius;
  } else if (s.kind == SurfaceKind::cylinder) {
    j["axis_point"] = s.centre;
    j["axis"] = s.axis;
    j["radius"] = s.radius;
    j["extent"] = s.extent;
  }
  return j;
}

/// What the pictures colour a pixel by: its segment's track id when the segments are tracked
/// (PipelineSettings::track), so that a surface keeps its colour from frame to frame, put into
/// `ids`; else its label (seg.labels itself: no copy of the frame's labels).
const LabelImage& colour_ids(const Segmentation& seg, LabelImage& ids) {
  const bool tracked = std::any_of(seg.segments.begin(), seg.segments.end(),
                                   [](const Segment& s) { return s.track_id != 0; });
  if (!tracked) return seg.labels;
  std::vector<std::int32_t> id_of(seg.segments.size() + 1, 0);
  for (const Segment& s : seg.segments) {
    // Colours repeat after 2^31 tracks; label_colour takes positive ids.
    id_of[static_cast<std::size_t>(s.label)] = static_cast<std::int32_t>(s.track_id & 0x7fffffffU);
  }
  ids.resize(seg.labels.width(), seg.labels.height());
  for (int v = 0; v < ids.height(); ++v) {
    for (int u = 0; u < ids.width(); ++u) {
      ids(u, v) = id_of[static_cast<std::size_t>(seg.labels(u, v))];
    }
  }
  return ids;
}

/// The processed points with normals, curvature, labels and the labels' colours
/// (colorize_labels of colour_ids without shading; black where there is no point).
void write_labelled_cloud(const std::string& path, const Pipeline& pipeline,
                          const std::array<double, 7>& pose) {
  OrganizedCloud cloud = pipeline.cloud();
  cloud.label = pipeline.segmentation().labels;
  cloud.add_rgb();
  {  // the colour images are gone before the file is encoded (peak memory)
    LabelImage ids;
    const RgbImage colours = colorize_labels(colour_ids(pipeline.segmentation(), ids));
    for (int v = 0; v < cloud.height(); ++v) {
      for (int u = 0; u < cloud.width(); ++u) {
        if (!cloud.valid(u, v)) continue;  // black
        const std::uint8_t* c = colours.pixel(u, v);
        cloud.r(u, v) = c[0];
        cloud.g(u, v) = c[1];
        cloud.b(u, v) = c[2];
      }
    }
  }
  write_pcd_with_normals(path, cloud, pipeline.normals(), pose);
}

}  // namespace

RgbImage colorize_surface_types(const Segmentation& seg, RgbImage image) {
  if (image.width != seg.labels.width() || image.height != seg.labels.height()) {
    throw std::invalid_argument("colorize_surface_types: the picture is " +
                                std::to_string(image.width) + " x " + std::to_string(image.height) +
                                " but the labels are " + std::to_string(seg.labels.width()) +
                                " x " + std::to_string(seg.labels.height()));
  }
  // Per type a tint, scaled by the shaded segment colour's brightness: planes grey, cylinders
  // blue, spheres red, smooth surfaces green.
  constexpr std::array<std::array<float, 3>, 4> tint{
      {{0.8f, 0.8f, 0.8f}, {0.3f, 0.6f, 1.0f}, {1.0f, 0.35f, 0.25f}, {0.35f, 1.0f, 0.35f}}};
  for (int v = 0; v < image.height; ++v) {
    for (int u = 0; u < image.width; ++u) {
      const int label = seg.labels(u, v);
      if (label <= 0 || static_cast<std::size_t>(label) > seg.segments.size()) continue;
      const auto kind = static_cast<std::size_t>(seg.segments[label - 1].kind);
      std::uint8_t* px = image.pixel(u, v);
      const float luma = 0.299f * px[0] + 0.587f * px[1] + 0.114f * px[2];
      const float level = std::min(255.0f, 60.0f + 1.2f * luma);
      for (int c = 0; c < 3; ++c) px[c] = static_cast<std::uint8_t>(level * tint[kind][c]);
    }
  }
  return image;
}

nlohmann::json segments_json(const Segmentation& seg, const PolygonSet* polygons,
                             const SegmentationSettings& settings) {
  const std::vector<int> groups = coplanar_groups(seg, settings);
  std::vector<const SegmentPolygons*> by_label(seg.segments.size() + 1, nullptr);
  if (polygons != nullptr) {
    for (const SegmentPolygons& sp : polygons->segments) {
      if (sp.label > 0 && static_cast<std::size_t>(sp.label) < by_label.size()) {
        by_label[static_cast<std::size_t>(sp.label)] = &sp;
      }
    }
  }
  nlohmann::json list = nlohmann::json::array();
  for (const Segment& s : seg.segments) {
    nlohmann::json& item = list.emplace_back();
    if (const SegmentPolygons* sp = by_label[static_cast<std::size_t>(s.label)]) {
      item["polygon"] = polygon_json(*polygons, *sp);
    }
    item.update({{"id", s.label},
                 {"model", to_string(s.model)},
                 {"pixel_count", s.pixel_count},
                 {"area_m2", s.area_m2},
                 {"centroid", s.centroid},
                 {"normal", s.normal},
                 {"offset", s.offset},
                 {"rms_residual", s.rms_residual},
                 {"grazing", s.grazing},
                 {"surface", surface_json(s)}});
    if (const int group = groups[static_cast<std::size_t>(s.label - 1)]; group != 0) {
      item["plane_group"] = group;
    }
    if (s.track_id != 0) item["track_id"] = s.track_id;
  }
  return {{"rangeseg_version", RANGESEG_VERSION_STRING},
          {"plane_equation", "normal . x + offset = 0, camera frame, metres"},
          {"surface",
           "type plane, cylinder, sphere or smooth; rms_residual: RMS distance to it [m]; "
           "sphere: centre, radius; cylinder: axis_point (start of the extent), unit axis, "
           "radius, extent along the axis [m]"},
          {"width", seg.labels.width()},
          {"height", seg.labels.height()},
          {"segments", list}};
}

namespace {

/// Every file a result folder may hold (summary.json: a batch's).
constexpr std::array<const char*, 8> kFolderFiles = {"labels.png", "segments.json", "polygons.obj",
                                                     "types.png",  "overlay.png",   "mesh.ply",
                                                     "cloud.pcd",  "summary.json"};

std::string joined(const std::vector<std::string>& paths) {
  std::string all;
  for (const std::string& p : paths) all += (all.empty() ? "" : ", ") + p;
  return all;
}

}  // namespace

InputFiles::InputFiles(const std::vector<std::string>& paths) {
  for (const std::string& path : paths) {
    struct stat info {};
    if (::stat(path.c_str(), &info) == 0) ids_.emplace_back(info.st_dev, info.st_ino);
  }
  std::sort(ids_.begin(), ids_.end());
}

bool InputFiles::contains(const std::filesystem::path& path) const {
  struct stat info {};
  if (ids_.empty() || ::stat(path.c_str(), &info) != 0) return false;
  return std::binary_search(ids_.begin(), ids_.end(),
                            std::pair<std::uint64_t, std::uint64_t>(info.st_dev, info.st_ino));
}

bool written_by_rangeseg(const std::filesystem::path& path) {
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) return false;
  const bool json = path.extension() == ".json";
  // The marker is in the first lines of a header; a summary's keys may follow a long list.
  std::string text(json ? std::size_t{1} << 20 : 4096, '\0');
  text.resize(std::fread(text.data(), 1, text.size(), file));
  std::fclose(file);
  if (json) {
    return text.find("\"per_frame\"") != std::string::npos &&
           text.find("\"median_ms\"") != std::string::npos;
  }
  return text.find("rangeseg") != std::string::npos;
}

void remove_earlier_results(const std::filesystem::path& dir,
                            const std::vector<std::string>& written, const InputFiles* inputs) {
  remove_stale_temporaries(dir, [](const std::string& name) {
    return std::find_if(kFolderFiles.begin(), kFolderFiles.end(),
                        [&](const char* f) { return name == f; }) != kFolderFiles.end();
  });
  for (const char* name : kFolderFiles) {
    const std::filesystem::path path = dir / name;
    if (std::find(written.begin(), written.end(), path.string()) == written.end()) {
      remove_earlier_result(path, inputs);
    }
  }
}

void remove_earlier_result(const std::filesystem::path& path, const InputFiles* inputs) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) return;
  if (inputs != nullptr && inputs->contains(path)) return;  // this run's input
  if (!written_by_rangeseg(path)) {
    note("warning: kept %s: a result's name, but rangeseg did not write it", path.c_str());
    return;
  }
  if (std::filesystem::remove(path, error)) {
    note("removed %s of an earlier run", path.c_str());
  } else if (error) {
    throw std::runtime_error(path.string() + ": cannot remove the earlier run's file (" +
                             error.message() + ")");
  }
}

std::string write_segmentation_folder(const std::string& dir_name, const OrganizedCloud& input,
                                      const Pipeline& pipeline, FolderFiles files) {
  const auto dir = ensure_dir(dir_name);
  const Segmentation& seg = pipeline.segmentation();
  const bool organized = input.is_organized();
  const bool polygons = !pipeline.polygons().segments.empty();
  if (files.inputs != nullptr) {
    // Checked before any file is written, so that the folder does not get half a result set.
    for (const auto& [name, writes] :
         {std::pair{"labels.png", organized}, std::pair{"segments.json", true},
          std::pair{"polygons.obj", polygons}, std::pair{"types.png", organized},
          std::pair{"overlay.png", organized}, std::pair{"mesh.ply", organized && files.mesh},
          std::pair{"cloud.pcd", !organized || files.cloud}}) {
      if (writes && files.inputs->contains(dir / name)) {
        throw std::runtime_error((dir / name).string() +
                                 ": an input of this run, which its result " + name +
                                 " would replace: write the results into another folder (-o)");
      }
    }
  }
  std::vector<std::string> written;
  // The folder's files replace an earlier run's together, or not at all.
  io::FileGroup group;
  const auto file = [&](const char* name) {
    written.push_back((dir / name).string());
    return written.back();
  };
  if (!organized) {
    write_json(file("segments.json"),
               segments_json(seg, &pipeline.polygons(), pipeline.settings().segmentation));
    if (polygons) {
      write_polygons_obj(file("polygons.obj"), pipeline.polygons(), &seg);
    }
    write_labelled_cloud(file("cloud.pcd"), pipeline, files.pose);
    group.commit();
    remove_earlier_results(dir, written, files.inputs);
    return joined(written);
  }
  io::write_label_png(file("labels.png"), seg.labels);
  write_json(file("segments.json"),
             segments_json(seg, &pipeline.polygons(), pipeline.settings().segmentation));
  if (polygons) {
    write_polygons_obj(file("polygons.obj"), pipeline.polygons(), &seg);
  }
  LabelImage ids;
  const LabelImage& colour_by = colour_ids(seg, ids);
  RgbImage overlay = colorize_labels(colour_by, &input);
  io::write_rgb_png(file("types.png"), colorize_surface_types(seg, overlay));
  draw_polygons(overlay, pipeline.polygons());
  io::write_rgb_png(file("overlay.png"), overlay);
  if (files.mesh) {
    const RgbImage flat = colorize_labels(colour_by);
    write_mesh_ply(file("mesh.ply"), pipeline.cloud(), pipeline.mesh(), &pipeline.normals(), &flat);
  }
  if (files.cloud) write_labelled_cloud(file("cloud.pcd"), pipeline, files.pose);
  group.commit();
  remove_earlier_results(dir, written, files.inputs);
  return joined(written);
}

void warn_if_no_segments(const Pipeline& pipeline, const std::string& path) {
  const std::string why = pipeline.why_no_segments();
  if (why.empty()) return;
  // A batch's frames may run on several threads; one such note says it for all.
  static std::once_flag flag;
  std::call_once(flag, [&] { note("warning: %s: no segments: %s", path.c_str(), why.c_str()); });
}

}  // namespace rangeseg::cli
