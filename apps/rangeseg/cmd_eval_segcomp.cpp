#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "eval_common.hpp"
#include "eval_table.hpp"
#include "input.hpp"
#include "names.hpp"
#include "output.hpp"
#include "rangeseg/eval.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/perceptron.hpp"
#include "rangeseg/io/rasterfile.hpp"
#include "segment_output.hpp"

namespace rangeseg::cli {
namespace {

namespace fs = std::filesystem;

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
  if (!o.out_dir.empty()) ensure_writable_dir(o.out_dir);
  std::unique_ptr<Pipeline> pipelines[2];
  const std::size_t n_t = o.tolerances.size();
  std::vector<std::vector<eval::EvalResult>> results(n_t);  // per T, per image scored
  std::vector<std::vector<eval::AngleStats>> angles(n_t);
  std::vector<std::string> failures;
  nlohmann::json image_list = nlohmann::json::array();
  if (n_t > 1) std::printf("T = %.2f (the first of --T):\n", o.tolerances.front());
  print_eval_header();
  for (const fs::path& range : images) {
    bool writing = false;  // a result that cannot be written ends the run (a full disk)
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
      const AnglePlanes planes = angle_planes(gt, ms, {});  // once for every T
      for (std::size_t t = 0; t < n_t; ++t) {
        r[t] = eval::evaluate(gt.labels, ms, {.tolerance = o.tolerances[t], .min_gt_label = 10});
        a[t] = angles_for(r[t], gt, planes);
      }
      if (!o.out_dir.empty()) {
        writing = true;
        const std::string stem = range.stem().string();
        const auto dir = ensure_dir(o.out_dir);
        io::FileGroup group;  // an image's .ms-seg, .ms-nor and folder: all of one run
        write_ms_seg((dir / (stem + ".ms-seg")).string(), ms);
        write_ms_nor((dir / (stem + ".ms-nor")).string(), pipeline.segmentation(), gt.sensor);
        write_segmentation_folder((dir / stem).string(), *gt.cloud, pipeline, {.mesh = false});
        group.commit();
        writing = false;
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
      if (writing) throw;
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
  std::vector<eval::EvalSummary> summaries(n_t);
  nlohmann::json summary_list = nlohmann::json::array();
  for (std::size_t t = 0; t < n_t; ++t) {
    summaries[t] = eval::summarize(results[t], angles[t]);
    const eval::EvalSummary& s = summaries[t];
    summary_list.push_back(summary_json(o.tolerances[t], s));
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
      const eval::EvalSummary& s = summaries[t];
      std::printf("%-6.2f %5.1f %7.1f %5.1f %6.1f %6.1f %6.1f %9s\n", o.tolerances[t], s.mean_gt,
                  s.mean_correct, s.mean_over, s.mean_under, s.mean_missed, s.mean_noise,
                  angle_text(s.mean_angle_deg).c_str());
    }
  }
  if (!o.json.empty()) {
    write_json(o.json, {{"folder", o.dir},
                        {"min_gt_label", 10},
                        {"images", image_list},
                        {"averages", summary_list}});
  }
}

}  // namespace

void add_eval_segcomp(CLI::App& app) {
  auto s = std::make_shared<SegcompOptions>();
  auto* seg = app.add_subcommand(
      "eval-segcomp",
      "Segment every SegComp .range image (ABW or Perceptron) that has a .gt-seg beside it in a "
      "folder and score it (paper, Table II)");
  seg->add_option("dir", s->dir,
                  "Folder with SegComp images and ground truth, e.g. abw.test.N.range and "
                  "abw.test.N.gt-seg")
      ->required();
  seg->add_option("-o,--output", s->out_dir,
                  "Also write .ms-seg and .ms-nor files and result folders here");
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
