// Segmentation evaluation by the SegComp protocol of Hoover et al., "An experimental comparison
// of range image segmentation algorithms", IEEE PAMI 18(7), 1996.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"

namespace rangeseg::eval {

struct EvalSettings {
  /// Overlap tolerance T of Hoover et al., 0.5 < T <= 1 (dimensionless). The paper's tables
  /// sweep T from 0.51 to 0.95; 0.8 is the value most often quoted.
  double tolerance = 0.8;
  /// Ground-truth labels below this are "no region" (shadow, no data, unlabelled boundary):
  /// 10 for SegComp .gt-seg files (0..9 reserved), 1 for label PNGs where 0 means unlabelled.
  /// Must be >= 0.
  int min_gt_label = 1;
};

/// How a region was classified. A region takes part in at most one classification.
enum class Outcome { correct, over, under, missed, noise };
const char* to_string(Outcome outcome);

/// The classification of one ground-truth (GT) or machine-segmentation (MS) region.
struct RegionOutcome {
  int label = 0;
  std::int64_t pixels = 0;  ///< region size P [pixels], counted only where GT has a region
  Outcome outcome = Outcome::missed;
  /// Labels of the regions on the other side of the classification, ascending:
  /// correct: the one partner; over (GT region): the machine pieces; over (MS region): the GT
  /// region it is a piece of; under (MS region): the merged GT regions; under (GT region): the
  /// merging machine region; missed / noise: empty.
  std::vector<int> partners;
};

struct EvalResult {
  int width = 0, height = 0;  ///< image size the result was computed on [pixels]
  EvalSettings settings;
  int gt_regions = 0;  ///< GT regions with at least one pixel
  /// MS regions with at least one pixel on a GT region. MS regions lying entirely on excluded
  /// pixels are not counted anywhere except in `ms_regions_outside`.
  int ms_regions = 0;
  int ms_regions_outside = 0;
  int correct = 0;  ///< correct detections (pairs)
  int over = 0;     ///< over-segmentation instances = GT regions split into >= 2 MS regions
  int under = 0;    ///< under-segmentation instances = MS regions merging >= 2 GT regions
  int missed = 0;   ///< GT regions in no classification
  int noise = 0;    ///< MS regions in no classification
  std::vector<std::pair<int, int>> correct_pairs;  ///< (GT label, MS label), ascending GT label
  std::vector<RegionOutcome> gt;                   ///< one per GT region, ascending label
  std::vector<RegionOutcome> ms;                   ///< one per counted MS region, ascending label

  /// The entry for a label, or nullptr if there is no such region.
  const RegionOutcome* find_gt(int label) const;
  const RegionOutcome* find_ms(int label) const;
};

/// Classifies every region of `machine` against `ground_truth` (same size) at tolerance T.
///
/// Pixel counts: pixels whose GT label is < `min_gt_label` are excluded from every count, so the
/// size P_m of a machine region is its pixel count over GT-region pixels only, and its pixels on
/// excluded GT pixels are ignored (as in SegComp, where the machine result on shadow / no-data
/// pixels is not judged). Machine labels <= 0 are "unlabelled": such pixels belong to no machine
/// region but still count in the size P_n of their GT region. With O_mn the overlap:
///  - correct detection of R_n by R_m: O_mn >= T P_m and O_mn >= T P_n;
///  - over-segmentation of R_n into R_m1..R_mx (x >= 2): O_min >= T P_mi each, sum >= T P_n;
///  - under-segmentation of R_n1..R_nx (x >= 2) by R_m: O_mni >= T P_ni each, sum >= T P_m;
///  - missed: a GT region in none of these; noise: a MS region in none of these.
/// Because T > 0.5 each region lies mostly inside at most one region of the other segmentation,
/// so the region sets above are unique (all candidates are used). The only conflict possible is
/// that a correct pair also satisfies the over- or under-segmentation test together with small
/// extra regions; correct detection takes precedence and the extra regions are noise / missed.
/// Comparisons O >= T P are made with a relative slack of 1e-12 so that a decimal T such as 0.8
/// acts as the exact fraction (O = 8, P = 10 is accepted).
///
/// Throws std::invalid_argument if the sizes differ (both sizes in the message), T is outside
/// (0.5, 1] or min_gt_label < 0. Memory and time are O(pixels + distinct label pairs); labels may
/// be any int32 values (no dense label x label table).
EvalResult evaluate(const LabelImage& ground_truth, const LabelImage& machine,
                    const EvalSettings& settings = {});

/// How much a label image looks like a depth image (a 16-bit depth PNG in millimetres given as
/// labels by mistake).
struct DepthLikeness {
  /// At least 16 distinct labels, none below 100 (no depth sensor measures nearer than 100 mm;
  /// a segmentation numbers its regions from 1, SegComp's from 10), and labels that differ
  /// between at least a fifth of the pairs of labelled 4-neighbours: depth is smooth, not
  /// piecewise constant (a Kinect's millimetres change between a third of them, at its
  /// disparity terraces; a segmentation's labels at its borders only, a few percent).
  bool likely = false;
  std::size_t distinct = 0;   ///< distinct labels in 1..65535
  int lowest = 0;             ///< the smallest of them (0 when there is none)
  double changing_share = 0;  ///< of the pairs of labelled 4-neighbours, those that differ
};

/// Labels <= 0 are unlabelled; labels above 65535 are left out. O(pixels).
DepthLikeness depth_likeness(const LabelImage& labels);
/// The evidence, for a warning: "its N labels, none below L, differ between P% of neighbouring
/// pixels (a segmentation's between a few percent): is it a depth image?".
std::string describe(const DepthLikeness& likeness);

/// A plane n . p + offset = 0, p in metres; `normal` need not be unit length (it is normalised).
struct PlaneParams {
  std::array<double, 3> normal{0.0, 0.0, 1.0};
  double offset = 0.0;  ///< [m] for a unit normal
};

/// Least-squares plane (PCA in double over the valid points) of every label >= `min_label`,
/// indexed by label (size = max label + 1; empty if there is none). The normal is unit length and
/// oriented towards the sensor origin (offset >= 0). nullopt for labels with fewer than 3 valid
/// points or whose points are (numerically) collinear.
///
/// With `trim_sigmas` > 0 the fit is robust to mislabelled points, as hand-drawn ground truth
/// has (SegComp's ABW image 0 labels one pixel of another surface, 190 mm off, with a thin
/// strip's label, and tilts its least-squares plane by 68 degrees): points farther from their
/// label's plane than trim_sigmas x 1.4826 x the median distance (a robust sigma; at least 0.1
/// mm) are left out and the plane refitted, until the points kept no longer change (at most 5
/// refits). Fit ground truth so (kGroundTruthTrimSigmas); a segmentation's own planes are what
/// it reports, fitted plainly.
///
/// Throws std::invalid_argument if the sizes differ, min_label < 0, trim_sigmas < 0 or not
/// finite, or a label exceeds 2^24 - 1.
std::vector<std::optional<PlaneParams>> fit_planes(const OrganizedCloud& cloud,
                                                   const LabelImage& labels, int min_label,
                                                   double trim_sigmas = 0.0);

/// The trim of ground-truth plane fits in `eval`, `eval-segcomp`, `eval-synth` and Python's
/// `evaluate` (dimensionless, robust sigmas).
inline constexpr double kGroundTruthTrimSigmas = 3.0;

struct AngleSettings {
  /// GT regions are adjacent when a 4-neighbour pair of their pixels touches, or is separated by
  /// at most this many consecutive excluded pixels (GT label < min_gt_label) in a row or column:
  /// SegComp ground truth has 1-2 pixel wide unlabelled boundaries between surfaces [pixels].
  int max_gap = 3;
};

/// Angle-difference statistics [degrees]; mean and std are NaN when `pairs` == 0.
struct AngleStats {
  int pairs = 0;    ///< adjacent pairs of correctly detected regions that entered the statistics
  int skipped = 0;  ///< such pairs skipped because one of the four planes was missing
  double mean_deg = NAN;
  double std_deg = NAN;  ///< population standard deviation
};

/// Hoover's angle measure: for every pair (a, b) of correctly detected GT regions that are
/// adjacent in `ground_truth`, with machine partners (a', b'), the difference
/// |angle(a, b) - angle(a', b')| between the angle of the two GT planes and that of the two
/// machine planes. Before the angle between two normals (0..180 degrees) is taken, each normal is
/// oriented towards the sensor origin (offset >= 0), the visible side of a surface, which fixes
/// the sign ambiguity of fitted and user-supplied planes alike. Planes are looked up by label
/// (index = label); a label outside the vector or nullopt skips the pair. Throws
/// std::invalid_argument if `ground_truth` does not have the size of `result`, a used plane has a
/// zero or non-finite normal, or max_gap < 0.
AngleStats angle_error(const EvalResult& result, const LabelImage& ground_truth,
                       const std::vector<std::optional<PlaneParams>>& gt_planes_by_label,
                       const std::vector<std::optional<PlaneParams>>& ms_planes_by_label,
                       const AngleSettings& settings = {});

/// Means over images, as in the tables of Hoover et al.
struct EvalSummary {
  int images = 0;
  double mean_gt = NAN, mean_correct = NAN, mean_over = NAN, mean_under = NAN, mean_missed = NAN,
         mean_noise = NAN;
  /// Angle difference pooled over all pairs of all images [degrees]; NaN if there are none.
  double mean_angle_deg = NAN;
  double std_angle_deg = NAN;  ///< pooled population standard deviation [degrees]
  int angle_pairs = 0;
};

/// `angles` is either empty or has one entry per result. Throws std::invalid_argument otherwise.
EvalSummary summarize(const std::vector<EvalResult>& results,
                      const std::vector<AngleStats>& angles = {});

}  // namespace rangeseg::eval
