// What `eval` and `eval-segcomp` share: reading ground truth and segmentations in every format
// they take, the machine planes a .ms-nor reports, Hoover's angle measure over them, and the
// JSON of the scores.
#pragma once

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/eval.hpp"
#include "rangeseg/image.hpp"
#include "rangeseg/io/perceptron.hpp"

namespace rangeseg::cli {

struct GroundTruth {
  LabelImage labels;
  int min_label = 1;
  std::optional<OrganizedCloud> cloud;  ///< for plane fits, when the format brings points
  io::SegcompSensor sensor = io::SegcompSensor::abw;  ///< of a SegComp .range beside a .gt-seg
  std::string range_error;  ///< why the .range beside a .gt-seg could not be read
};

/// A SegComp .gt-seg (labels from 10; the .range beside it gives the points), a 16-bit label
/// PNG, or a PCD or PLY with a label field. Throws std::runtime_error naming the file.
GroundTruth load_ground_truth(const std::string& path);

/// A segmentation: a 16-bit label PNG, a SegComp .ms-seg, or a PCD or PLY with a label field.
/// Throws std::runtime_error naming the file.
LabelImage load_machine(const std::string& path);

/// The labels of the curved surfaces (any type but "plane") in a `synth` surfaces.json.
std::vector<int> curved_labels(const std::string& path);

using PlaneTable = std::vector<std::optional<eval::PlaneParams>>;

/// The planes a segmenter reported in the .ms-nor beside a .ms-seg (`ms_path`), as Hoover's tools
/// score them: a line "label nx ny nz" per region, the unit normal in the SegComp axes of
/// `sensor` (write_ms_nor's), each plane through its region's centroid in `cloud`. nullopt when
/// there is no such file. Throws std::runtime_error naming the file and line for a line that is
/// not a label 1-255 and a finite, non-zero normal.
std::optional<PlaneTable> reported_planes(const std::string& ms_path, const LabelImage& ms,
                                          const OrganizedCloud& cloud, io::SegcompSensor sensor);

/// The planes Hoover's angle measure compares, by label, which do not depend on T: the ground
/// truth's fitted robustly, where regions listed in `curved` have none (their least-squares plane
/// depends on which of their points a region holds); the machine's `reported` ones when given,
/// else fitted to its regions' points. Empty when the ground truth brings no points.
struct AnglePlanes {
  PlaneTable gt, ms;
};
AnglePlanes angle_planes(const GroundTruth& gt, const LabelImage& ms,
                         const std::vector<int>& curved, const PlaneTable* reported = nullptr);

/// Hoover's angle measure of one scoring over `planes` (no pairs without the ground truth's
/// points).
eval::AngleStats angles_for(const eval::EvalResult& r, const GroundTruth& gt,
                            const AnglePlanes& planes);

/// A number, or null for NaN (no pair of planes to measure).
nlohmann::json number_or_null(double x);
/// Every region of one side with its size, outcome and partners.
nlohmann::json regions_json(const std::vector<eval::RegionOutcome>& regions);
/// The counts and the angle error of one scored pair at one T.
nlohmann::json scores_json(const eval::EvalResult& r, const eval::AngleStats& a);

}  // namespace rangeseg::cli
