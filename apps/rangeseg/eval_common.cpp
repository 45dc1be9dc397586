#include "eval_common.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "rangeseg/eval.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/ply.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/io/rasterfile.hpp"

namespace rangeseg::cli {
namespace {

namespace fs = std::filesystem;

/// A PCD or PLY with a label field: ground truth (e.g. an OSD scene) or a segmentation
/// (`rangeseg segment`'s cloud.pcd of an unorganized cloud).
OrganizedCloud read_labelled_cloud(const std::string& path) {
  const bool ply = io::extension(path) == ".ply";
  OrganizedCloud cloud = ply ? io::read_ply_cloud(path) : io::read_pcd(path);
  if (!cloud.has_label()) {
    throw std::runtime_error(path + (ply ? ": the PLY file has no 'label' vertex property"
                                         : ": the PCD file has no 'label' field"));
  }
  // Unsigned labels from 2^31 on keep their bits in the int32 label plane (so that a PCD
  // round-trips); scored, they would read as unlabelled.
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      const std::int32_t l = cloud.label(u, v);
      if (l >= 0) continue;
      throw std::runtime_error(path + ": label " + std::to_string(static_cast<std::uint32_t>(l)) +
                               " (as unsigned; " + std::to_string(l) + " as signed) at point " +
                               std::to_string(static_cast<std::int64_t>(v) * cloud.width() + u) +
                               ": eval scores labels 0 (unlabelled) to 2147483647");
    }
  }
  return cloud;
}

/// A 16-bit depth PNG read as labels would be scored without a word (eval::depth_likeness).
void warn_if_depth_like(const std::string& path, const LabelImage& labels) {
  const eval::DepthLikeness d = eval::depth_likeness(labels);
  if (d.likely) {
    std::fprintf(stderr, "rangeseg: warning: %s: %s (`segment` writes its labels to labels.png)\n",
                 path.c_str(), eval::describe(d).c_str());
  }
}

}  // namespace

GroundTruth load_ground_truth(const std::string& path) {
  GroundTruth gt;
  const std::string ext = io::extension(path);
  if (ext == ".gt-seg") {
    gt.labels = io::read_segcomp_gt(path);
    gt.min_label = 10;
    fs::path range = path;
    range.replace_extension(".range");
    if (fs::exists(range)) {
      // Only the angle error needs the points: a range image that cannot be read leaves the
      // regions' scores.
      try {
        gt.cloud = io::read_segcomp_range(range.string(), &gt.sensor);
      } catch (const std::exception& e) {
        gt.range_error = e.what();
      }
    }
  } else if (ext == ".png") {
    gt.labels = io::read_label_png(path);
    warn_if_depth_like(path, gt.labels);
  } else if (ext == ".pcd" || ext == ".ply") {
    OrganizedCloud cloud = read_labelled_cloud(path);
    gt.labels = cloud.label;
    gt.cloud = std::move(cloud);
  } else {
    throw std::runtime_error(
        path + ": unsupported ground truth type '" + ext +
        "' (expected .gt-seg, 16-bit label .png, or .pcd or .ply with a label field)");
  }
  return gt;
}

LabelImage load_machine(const std::string& path) {
  const std::string ext = io::extension(path);
  if (ext == ".png") {
    LabelImage labels = io::read_label_png(path);
    warn_if_depth_like(path, labels);
    return labels;
  }
  if (ext == ".pcd" || ext == ".ply") return std::move(read_labelled_cloud(path).label);
  if (ext == ".ms-seg") {
    const BytePlane raw = io::read_rasterfile(path);
    LabelImage labels(raw.width(), raw.height(), 0);
    for (int v = 0; v < raw.height(); ++v) {
      for (int u = 0; u < raw.width(); ++u) labels(u, v) = raw(u, v);
    }
    return labels;
  }
  throw std::runtime_error(path + ": unsupported segmentation type '" + ext +
                           "' (expected a 16-bit label .png, a SegComp .ms-seg, or a .pcd or .ply "
                           "with a label field)");
}

std::vector<int> curved_labels(const std::string& path) {
  const std::vector<std::uint8_t> bytes = io::read_file(path, 64 << 20);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(bytes.begin(), bytes.end());
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": invalid JSON: " + e.what());
  }
  if (!j.is_object() || !j.contains("surfaces") || !j["surfaces"].is_array()) {
    throw std::runtime_error(path +
                             ": expected an object with a 'surfaces' array (synth's "
                             "surfaces.json)");
  }
  std::vector<int> curved;
  for (const nlohmann::json& surface : j["surfaces"]) {
    if (!surface.is_object() || !surface.contains("label") ||
        !surface["label"].is_number_integer() || surface["label"].get<std::int64_t>() < 1 ||
        surface["label"].get<std::int64_t>() > 65535 || !surface.contains("type") ||
        !surface["type"].is_string()) {
      throw std::runtime_error(path +
                               ": every surface needs an integer 'label' in 1..65535 and "
                               "a string 'type'; got " +
                               surface.dump());
    }
    if (surface["type"].get<std::string>() != "plane") {
      curved.push_back(surface["label"].get<int>());
    }
  }
  return curved;
}

std::optional<PlaneTable> reported_planes(const std::string& ms_path, const LabelImage& ms,
                                          const OrganizedCloud& cloud, io::SegcompSensor sensor) {
  fs::path nor = ms_path;
  nor.replace_extension(".ms-nor");
  if (io::extension(ms_path) != ".ms-seg" || !fs::exists(nor)) return std::nullopt;
  const std::vector<std::uint8_t> bytes = io::read_file(nor.string(), 1 << 20);
  std::istringstream text(std::string(bytes.begin(), bytes.end()));
  PlaneTable planes(256);
  std::array<std::array<double, 4>, 256> sums{};  // x, y, z, count per label
  for (int v = 0; v < ms.height(); ++v) {
    for (int u = 0; u < ms.width(); ++u) {
      const std::int32_t l = ms(u, v);
      const float x = cloud.x(u, v), y = cloud.y(u, v), z = cloud.z(u, v);
      if (l < 1 || l > 255 || !std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) continue;
      auto& sum = sums[static_cast<std::size_t>(l)];
      sum[0] += x;
      sum[1] += y;
      sum[2] += z;
      sum[3] += 1;
    }
  }
  const bool abw = sensor == io::SegcompSensor::abw;
  std::string line;
  for (int number = 1; std::getline(text, line); ++number) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream fields(line);
    long label = 0;
    double n[3] = {0, 0, 0};
    std::string rest;
    const bool parsed =
        static_cast<bool>(fields >> label >> n[0] >> n[1] >> n[2]) && !(fields >> rest);
    if (!parsed || label < 1 || label > 255 || !std::isfinite(n[0]) || !std::isfinite(n[1]) ||
        !std::isfinite(n[2]) || n[0] * n[0] + n[1] * n[1] + n[2] * n[2] == 0.0) {
      throw std::runtime_error(nor.string() + ":" + std::to_string(number) +
                               ": expected 'label nx ny nz' with a label 1-255 and a non-zero "
                               "normal, got '" +
                               line + "'");
    }
    const auto& sum = sums[static_cast<std::size_t>(label)];
    if (sum[3] == 0) continue;  // a region with no valid point has no plane to place
    // SegComp's axes: ABW x right, y up, z towards the sensor; Perceptron x left, y up, z away.
    const std::array<double, 3> normal{abw ? n[0] : -n[0], -n[1], abw ? -n[2] : n[2]};
    const double offset = -(normal[0] * sum[0] + normal[1] * sum[1] + normal[2] * sum[2]) / sum[3];
    planes[static_cast<std::size_t>(label)] = eval::PlaneParams{normal, offset};
  }
  return planes;
}

AnglePlanes angle_planes(const GroundTruth& gt, const LabelImage& ms,
                         const std::vector<int>& curved, const PlaneTable* reported) {
  if (!gt.cloud) return {};
  AnglePlanes planes;
  planes.gt = eval::fit_planes(*gt.cloud, gt.labels, gt.min_label, eval::kGroundTruthTrimSigmas);
  for (const int label : curved) {
    if (static_cast<std::size_t>(label) < planes.gt.size()) {
      planes.gt[static_cast<std::size_t>(label)].reset();
    }
  }
  planes.ms = reported != nullptr ? *reported : eval::fit_planes(*gt.cloud, ms, 1);
  return planes;
}

eval::AngleStats angles_for(const eval::EvalResult& r, const GroundTruth& gt,
                            const AnglePlanes& planes) {
  if (!gt.cloud) return {};
  return eval::angle_error(r, gt.labels, planes.gt, planes.ms);
}

nlohmann::json number_or_null(double x) {
  return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
}

nlohmann::json regions_json(const std::vector<eval::RegionOutcome>& regions) {
  nlohmann::json list = nlohmann::json::array();
  for (const eval::RegionOutcome& r : regions) {
    list.push_back({{"label", r.label},
                    {"pixels", r.pixels},
                    {"outcome", eval::to_string(r.outcome)},
                    {"partners", r.partners}});
  }
  return list;
}

nlohmann::json scores_json(const eval::EvalResult& r, const eval::AngleStats& a) {
  return {{"T", r.settings.tolerance},
          {"gt_regions", r.gt_regions},
          {"ms_regions", r.ms_regions},
          {"ms_regions_outside", r.ms_regions_outside},
          {"correct", r.correct},
          {"over", r.over},
          {"under", r.under},
          {"missed", r.missed},
          {"noise", r.noise},
          {"angle_pairs", a.pairs},
          {"angle_mean_deg", number_or_null(a.mean_deg)},
          {"angle_std_deg", number_or_null(a.std_deg)}};
}

}  // namespace rangeseg::cli
