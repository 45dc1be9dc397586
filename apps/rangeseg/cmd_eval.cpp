#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "eval_common.hpp"
#include "eval_table.hpp"
#include "input.hpp"
#include "output.hpp"
#include "rangeseg/eval.hpp"

namespace rangeseg::cli {
namespace {

namespace fs = std::filesystem;

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

nlohmann::json result_json(const EvalOptions& o, const eval::EvalResult& r,
                           const eval::AngleStats& a) {
  nlohmann::json j = {{"ground_truth", o.gt}, {"segmentation", o.pred}};
  j.update(scores_json(r, a));
  j["min_gt_label"] = r.settings.min_gt_label;
  j["gt"] = regions_json(r.gt);
  j["ms"] = regions_json(r.ms);
  return j;
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
      a = angles_for(r, gt, angle_planes(gt, ms, curved, reported ? &*reported : nullptr));
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
}

}  // namespace rangeseg::cli
