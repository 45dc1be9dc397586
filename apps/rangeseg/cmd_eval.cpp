#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "eval_table.hpp"
#include "input.hpp"
#include "names.hpp"
#include "output.hpp"
#include "rangeseg/eval.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/perceptron.hpp"
#include "rangeseg/io/ply.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/io/rasterfile.hpp"
#include "segment_output.hpp"

namespace rangeseg::cli {
namespace {

namespace fs = std::filesystem;

struct GroundTruth {
  LabelImage labels;
  int min_label = 1;
  std::optional<OrganizedCloud> cloud;  ///< for plane fits, when the format brings points
  io::SegcompSensor sensor = io::SegcompSensor::abw;  ///< of a SegComp .range beside a .gt-seg
  std::string range_error;  ///< why the .range beside a .gt-seg could not be read
};

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
  if (ext == ".png") return io::read_label_png(path);
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

/// The labels of the curved surfaces (any type but "plane") in a `synth` surfaces.json.
std::vector<int> curved_labels(const std::string& path) {
  const std::vector<std::uint8_t> bytes = io::read_file(path, 64 << 20);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(bytes.begin(), bytes.end());
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": not valid JSON: " + e.what());
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

using PlaneTable = std::vector<std::optional<eval::PlaneParams>>;

/// The planes a segmenter reported in the .ms-nor beside a .ms-seg (`ms_path`), as Hoover's tools
/// score them: a line "label nx ny nz" per region, the unit normal in the SegComp axes of
/// `sensor` (write_ms_nor's), each plane through its region's centroid in `cloud`. nullopt when
/// there is no such file. Throws std::runtime_error naming the file and line for a line that is
/// not a label 1-255 and a finite, non-zero normal.
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

/// Hoover's angle measure over the planes: ground-truth regions listed in `curved` have no plane
/// (their least-squares plane depends on which of their points a region holds). The machine's
/// planes are `reported` ones when given, else fitted to its regions' points.
eval::AngleStats angles_for(const eval::EvalResult& r, const GroundTruth& gt, const LabelImage& ms,
                            const std::vector<int>& curved, const PlaneTable* reported = nullptr) {
  if (!gt.cloud) return {};
  std::vector<std::optional<eval::PlaneParams>> gt_planes =
      eval::fit_planes(*gt.cloud, gt.labels, gt.min_label, eval::kGroundTruthTrimSigmas);
  for (const int label : curved) {
    if (static_cast<std::size_t>(label) < gt_planes.size()) {
      gt_planes[static_cast<std::size_t>(label)].reset();
    }
  }
  return eval::angle_error(r, gt.labels, gt_planes,
                           reported != nullptr ? *reported : eval::fit_planes(*gt.cloud, ms, 1));
}

struct EvalOptions {
  std::string gt, pred;
  double tolerance = 0.8;
  std::string cloud;     ///< points for the angle error when the ground truth brings none
  std::string surfaces;  ///< synth's surfaces.json: curved regions left out of the angle error
  std::string json;
  int min_gt_label = -1;  ///< -1: by format (10 for .gt-seg, else 1)
  bool regions = false;
};

/// "3 (over: 7 9)" style partner list.
std::string partner_list(const std::vector<int>& partners) {
  std::string text;
  for (const int p : partners) {
    if (!text.empty()) text += ' ';
    text += std::to_string(p);
  }
  return text.empty() ? "-" : text;
}

void print_regions(const char* side, const std::vector<eval::RegionOutcome>& regions) {
  std::printf("%s regions:\n%8s %9s %-8s %s\n", side, "label", "pixels", "outcome", "partners");
  for (const eval::RegionOutcome& r : regions) {
    std::printf("%8d %9lld %-8s %s\n", r.label, static_cast<long long>(r.pixels),
                eval::to_string(r.outcome), partner_list(r.partners).c_str());
  }
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

/// A number, or null for NaN (no pair of planes to measure).
nlohmann::json number_or_null(double x) {
  return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
}

/// The counts and the angle error of one scored pair at one T.
nlohmann::json scores_json(const eval::EvalResult& r, const eval::AngleStats& a) {
  return {{"T", r.settings.tolerance},
          {"gt_regions", r.gt_regions},
          {"ms_regions", r.ms_regions},
          {"correct", r.correct},
          {"over", r.over},
          {"under", r.under},
          {"missed", r.missed},
          {"noise", r.noise},
          {"angle_pairs", a.pairs},
          {"angle_mean_deg", number_or_null(a.mean_deg)},
          {"angle_std_deg", number_or_null(a.std_deg)}};
}

nlohmann::json result_json(const EvalOptions& o, const eval::EvalResult& r,
                           const eval::AngleStats& a) {
  nlohmann::json j = {{"ground_truth", o.gt}, {"segmentation", o.pred}};
  j.update(scores_json(r, a));
  j["min_gt_label"] = r.settings.min_gt_label;
  j["gt"] = regions_json(r.gt);
  j["ms"] = regions_json(r.ms);
  return j;
}

struct SegcompOptions {
  std::string dir;
  std::string out_dir;
  std::string preset = "auto";  ///< auto: abw or perceptron, by each image's scanner
  std::string model = "plane";
  std::string config;
  std::vector<double> tolerances{0.8};  ///< the first is the per-image table's
  std::string json;
  bool no_smooth = false;
};

/// SegComp .ms-seg: 8-bit rasterfile, 0 = unlabelled. Throws std::runtime_error naming the file
/// for a label above 255, which the format cannot store.
void write_ms_seg(const std::string& path, const LabelImage& labels) {
  BytePlane raw(labels.width(), labels.height(), 0);
  for (int v = 0; v < labels.height(); ++v) {
    for (int u = 0; u < labels.width(); ++u) {
      const int l = labels(u, v);
      if (l > 255) {
        throw std::runtime_error(path + ": segment " + std::to_string(l) +
                                 " does not fit SegComp's 8-bit .ms-seg (labels 1-255)");
      }
      raw(u, v) = static_cast<std::uint8_t>(l > 0 ? l : 0);
    }
  }
  io::write_rasterfile(path, raw.view());
}

/// SegComp .ms-nor: one line per region, "label nx ny nz", the unit normal in the scanner frame
/// of the SegComp tools: for ABW X right, Y up, Z towards the sensor (our camera-frame normal
/// with y and z negated); for Perceptron X left, Y up, Z away from the sensor (x and y negated).
void write_ms_nor(const std::string& path, const Segmentation& seg, io::SegcompSensor sensor) {
  const bool abw = sensor == io::SegcompSensor::abw;
  std::string text;
  char line[128];
  for (const Segment& s : seg.segments) {
    if (s.label > 255) break;
    std::snprintf(line, sizeof line, "%d %.6f %.6f %.6f\n", s.label,
                  abw ? s.normal[0] : -s.normal[0], -s.normal[1], abw ? -s.normal[2] : s.normal[2]);
    text += line;
  }
  io::write_file_atomic(path, text);
}

/// The SegComp images of a folder: every .range file with a .gt-seg beside it, ordered by name
/// with the image numbers compared as numbers (abw.test.2 before abw.test.10).
std::vector<fs::path> segcomp_images(const std::string& dir) {
  std::vector<fs::path> images;
  std::vector<std::string> without_truth;
  std::error_code error;
  fs::directory_iterator entries(dir, error);
  if (error) throw std::runtime_error(dir + ": cannot open the folder: " + error.message());
  for (const auto& e : entries) {
    if (e.path().extension() != ".range") continue;
    fs::path gt = e.path();
    gt.replace_extension(".gt-seg");
    if (fs::exists(gt)) {
      images.push_back(e.path());
    } else {
      without_truth.push_back(e.path().filename().string());
    }
  }
  if (images.empty()) {
    throw std::runtime_error(dir + ": no .range file with a .gt-seg beside it" +
                             (without_truth.empty()
                                  ? std::string()
                                  : " (" + without_truth.front() + " has no ground truth)"));
  }
  std::sort(images.begin(), images.end(), natural_less);  // abw.test.2 before abw.test.10
  return images;
}

/// The averages over images at one T, and the pooled angle error; also a JSON object.
nlohmann::json summary_json(double tolerance, const eval::EvalSummary& s) {
  return {{"T", tolerance},
          {"images", s.images},
          {"mean_gt_regions", number_or_null(s.mean_gt)},
          {"mean_correct", number_or_null(s.mean_correct)},
          {"mean_over", number_or_null(s.mean_over)},
          {"mean_under", number_or_null(s.mean_under)},
          {"mean_missed", number_or_null(s.mean_missed)},
          {"mean_noise", number_or_null(s.mean_noise)},
          {"angle_pairs", s.angle_pairs},
          {"angle_mean_deg", number_or_null(s.mean_angle_deg)},
          {"angle_std_deg", number_or_null(s.std_angle_deg)}};
}

void run_segcomp(const SegcompOptions& o) {
  if (o.tolerances.empty()) throw std::invalid_argument("--T: give at least one tolerance");
  for (const double t : o.tolerances) require_tolerance(t);
  const std::vector<fs::path> images = segcomp_images(o.dir);
  // One pipeline per scanner: --preset, or (auto) the scanner's own preset.
  const auto pipeline_for = [&](io::SegcompSensor sensor) {
    const bool abw = sensor == io::SegcompSensor::abw;
    const std::string preset = o.preset != "auto" ? o.preset : abw ? "abw" : "perceptron";
    return std::make_unique<Pipeline>(settings_from(preset, o.model, o.config, o.no_smooth));
  };
  // Bad options stop here, before any image; a bad image is reported and skipped below.
  for (const io::SegcompSensor sensor : {io::SegcompSensor::abw, io::SegcompSensor::perceptron}) {
    pipeline_for(sensor);
  }
  std::unique_ptr<Pipeline> pipelines[2];
  const std::size_t n_t = o.tolerances.size();
  std::vector<std::vector<eval::EvalResult>> results(n_t);  // per T, per image scored
  std::vector<std::vector<eval::AngleStats>> angles(n_t);
  std::vector<std::string> failures;
  nlohmann::json image_list = nlohmann::json::array();
  if (n_t > 1) std::printf("T = %.2f (the first of --T):\n", o.tolerances.front());
  print_eval_header();
  for (const fs::path& range : images) {
    try {
      fs::path gt_path = range;
      gt_path.replace_extension(".gt-seg");
      GroundTruth gt = load_ground_truth(gt_path.string());
      if (!gt.cloud) gt.cloud = io::read_segcomp_range(range.string(), &gt.sensor);
      auto& slot = pipelines[static_cast<int>(gt.sensor)];
      if (!slot) slot = pipeline_for(gt.sensor);
      Pipeline& pipeline = *slot;
      pipeline.process(*gt.cloud);
      const LabelImage& ms = pipeline.segmentation().labels;
      std::vector<eval::EvalResult> r(n_t);
      std::vector<eval::AngleStats> a(n_t);
      for (std::size_t t = 0; t < n_t; ++t) {
        r[t] = eval::evaluate(gt.labels, ms, {.tolerance = o.tolerances[t], .min_gt_label = 10});
        a[t] = angles_for(r[t], gt, ms, {});
      }
      if (!o.out_dir.empty()) {
        const std::string stem = range.stem().string();
        const auto dir = ensure_dir(o.out_dir);
        write_ms_seg((dir / (stem + ".ms-seg")).string(), ms);
        write_ms_nor((dir / (stem + ".ms-nor")).string(), pipeline.segmentation(), gt.sensor);
        write_segmentation_folder((dir / stem).string(), *gt.cloud, pipeline, {.mesh = false});
      }
      print_eval_row(range.filename().string().c_str(), r.front(), a.front());
      nlohmann::json per_t = nlohmann::json::array();
      for (std::size_t t = 0; t < n_t; ++t) {
        results[t].push_back(r[t]);
        angles[t].push_back(a[t]);
        nlohmann::json item = scores_json(r[t], a[t]);
        item["gt"] = regions_json(r[t].gt);
        item["ms"] = regions_json(r[t].ms);
        per_t.push_back(std::move(item));
      }
      image_list.push_back({{"image", range.filename().string()}, {"results", per_t}});
    } catch (const std::exception& e) {
      std::printf("%-22s skipped: %s\n", range.filename().string().c_str(), e.what());
      failures.push_back(e.what());
      image_list.push_back({{"image", range.filename().string()}, {"error", e.what()}});
    }
  }
  if (results.front().empty()) {
    throw std::runtime_error(o.dir + ": none of the " + std::to_string(images.size()) +
                             " images could be scored; the first failure: " + failures.front());
  }
  if (!failures.empty()) {
    std::printf("%zu of %zu images skipped (above); the averages are over the other %zu\n",
                failures.size(), images.size(), results.front().size());
  }
  nlohmann::json summaries = nlohmann::json::array();
  for (std::size_t t = 0; t < n_t; ++t) {
    const eval::EvalSummary s = eval::summarize(results[t], angles[t]);
    summaries.push_back(summary_json(o.tolerances[t], s));
    if (t == 0) {
      std::printf("%-22s %5.1f %5s %7.1f %5.1f %6.1f %6.1f %6.1f %9s\n", "average", s.mean_gt, "",
                  s.mean_correct, s.mean_over, s.mean_under, s.mean_missed, s.mean_noise,
                  angle_text(s.mean_angle_deg).c_str());
      std::printf(
          "correctly detected: %.1f%% of ground-truth regions (T = %.2f), angle error %s (pooled "
          "over the %d pairs of adjacent correctly detected planes)\n",
          100.0 * s.mean_correct / s.mean_gt, o.tolerances[t],
          angle_summary(s.mean_angle_deg, s.std_angle_deg).c_str(), s.angle_pairs);
    }
  }
  if (n_t > 1) {
    // Hoover et al. plot these averages over T (their figures 7-11).
    std::printf("\naverages per image over T:\n%-6s %5s %7s %5s %6s %6s %6s %9s\n", "T", "GT",
                "correct", "over", "under", "missed", "noise", "angle_deg");
    for (std::size_t t = 0; t < n_t; ++t) {
      const eval::EvalSummary s = eval::summarize(results[t], angles[t]);
      std::printf("%-6.2f %5.1f %7.1f %5.1f %6.1f %6.1f %6.1f %9s\n", o.tolerances[t], s.mean_gt,
                  s.mean_correct, s.mean_over, s.mean_under, s.mean_missed, s.mean_noise,
                  angle_text(s.mean_angle_deg).c_str());
    }
  }
  if (!o.json.empty()) {
    write_json(
        o.json,
        {{"folder", o.dir}, {"min_gt_label", 10}, {"images", image_list}, {"averages", summaries}});
  }
}

}  // namespace

void add_eval(CLI::App& app) {
  auto o = std::make_shared<EvalOptions>();
  auto* cmd =
      app.add_subcommand("eval", "Score a segmentation against ground truth (SegComp protocol)");
  cmd->add_option("ground_truth", o->gt,
                  "SegComp .gt-seg, 16-bit label .png, or .pcd or .ply with a label field")
      ->required();
  cmd->add_option("segmentation", o->pred,
                  "16-bit label .png (e.g. labels.png), SegComp .ms-seg, or .pcd or .ply with a "
                  "label field (segment's cloud.pcd of an unorganized cloud)")
      ->required();
  add_tolerance_option(*cmd, o->tolerance);
  cmd->add_option("--cloud", o->cloud,
                  "Points of the scene (any input the other commands take) for the angle error, "
                  "when the ground truth "
                  "brings none (e.g. a label PNG from `synth`)");
  cmd->add_option("--surfaces", o->surfaces,
                  "surfaces.json of `synth`: the angle error leaves out the spheres and cylinders "
                  "(as eval-synth does), whose fitted planes depend on which points a region "
                  "holds");
  cmd->add_option("--min-gt-label", o->min_gt_label,
                  "Ground-truth labels below this are no region (not scored): default 10 for a "
                  ".gt-seg (SegComp reserves 0-9), 1 for the other formats (0 = unlabelled)")
      ->check(CLI::Range(0, std::numeric_limits<int>::max()));
  cmd->add_flag("--regions", o->regions,
                "Also list every region with its size, outcome and partner regions");
  cmd->add_option("--json", o->json, "Write the scores and per-region outcomes to this JSON file");
  cmd->callback([o] {
    require_tolerance(o->tolerance);
    GroundTruth gt = load_ground_truth(o->gt);
    if (o->min_gt_label >= 0) gt.min_label = o->min_gt_label;
    if (!gt.range_error.empty() && o->cloud.empty()) {
      std::fprintf(stderr, "warning: no angle error: %s\n", gt.range_error.c_str());
    }
    const std::vector<int> curved =
        o->surfaces.empty() ? std::vector<int>{} : curved_labels(o->surfaces);
    if (!o->cloud.empty()) {
      InputOptions cloud_options;
      cloud_options.path = o->cloud;
      OrganizedCloud cloud = load_input(cloud_options).cloud;
      if (cloud.width() != gt.labels.width() || cloud.height() != gt.labels.height()) {
        throw std::runtime_error(o->cloud + ": the cloud is " + std::to_string(cloud.width()) +
                                 "x" + std::to_string(cloud.height()) + ", the ground truth " +
                                 std::to_string(gt.labels.width()) + "x" +
                                 std::to_string(gt.labels.height()));
      }
      gt.cloud = std::move(cloud);
    }
    const LabelImage ms = load_machine(o->pred);
    if (ms.width() != gt.labels.width() || ms.height() != gt.labels.height()) {
      throw std::runtime_error(o->pred + ": the segmentation is " + std::to_string(ms.width()) +
                               "x" + std::to_string(ms.height()) + ", the ground truth (" + o->gt +
                               ") " + std::to_string(gt.labels.width()) + "x" +
                               std::to_string(gt.labels.height()));
    }
    const std::optional<PlaneTable> reported =
        gt.cloud ? reported_planes(o->pred, ms, *gt.cloud, gt.sensor) : std::nullopt;
    // The library's checks (label ranges, ...) name no file: say which pair was scored.
    eval::EvalResult r;
    eval::AngleStats a;
    try {
      r = eval::evaluate(gt.labels, ms, {.tolerance = o->tolerance, .min_gt_label = gt.min_label});
      a = angles_for(r, gt, ms, curved, reported ? &*reported : nullptr);
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(o->gt + " against " + o->pred + ": " + e.what());
    }
    std::printf("T = %.2f; ground-truth labels >= %d are regions%s\n", r.settings.tolerance,
                r.settings.min_gt_label,
                reported ? "; the machine's planes: its .ms-nor's normals" : "");
    print_eval_header();
    print_eval_row(fs::path(o->gt).filename().string().c_str(), r, a);
    if (o->regions) {
      print_regions("ground-truth", r.gt);
      print_regions("machine", r.ms);
    }
    if (!o->json.empty()) {
      nlohmann::json j = result_json(*o, r, a);
      j["machine_planes"] = reported ? "ms-nor" : "fitted";
      write_json(o->json, j);
    }
  });

  auto s = std::make_shared<SegcompOptions>();
  auto* seg = app.add_subcommand(
      "eval-segcomp",
      "Segment every SegComp .range image (ABW or Perceptron) that has a .gt-seg beside it in a "
      "folder and score it (paper, Table II)");
  seg->add_option("dir", s->dir,
                  "Folder with SegComp images and ground truth, e.g. abw.test.N.range and "
                  "abw.test.N.gt-seg")
      ->required();
  seg->add_option("-o,--output", s->out_dir, "Also write .ms-seg files and result folders here");
  add_settings_options(*seg, s->model, s->preset, s->config, s->no_smooth, /*auto_preset=*/true);
  seg->add_option("--T", s->tolerances,
                  "Overlap tolerance T of the SegComp protocol, 0.5 < T <= 1; a list (e.g. "
                  "0.51,0.6,0.7,0.8,0.9,0.95) also prints the averages at each T, as Hoover et "
                  "al. plot them; the per-image table is the first T's")
      ->delimiter(',')
      ->capture_default_str();
  seg->add_option("--json", s->json,
                  "Write every image's scores and region outcomes at each T, and the averages, "
                  "to this JSON file");
  seg->callback([s] { run_segcomp(*s); });
}

}  // namespace rangeseg::cli
