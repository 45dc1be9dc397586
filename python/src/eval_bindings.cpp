// rangeseg.evaluate: the SegComp protocol of Hoover et al.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "arrays.hpp"
#include "bindings.hpp"
#include "rangeseg/eval.hpp"

namespace rangeseg::python {
namespace {

using namespace pybind11::literals;

py::dict evaluate(const py::object& ground_truth, const py::object& segmentation, double tolerance,
                  int min_gt_label, const py::object& points) {
  const LabelImage gt = labels_from_array(ground_truth, "ground_truth");
  const LabelImage ms = labels_from_array(segmentation, "segmentation");
  if (ms.width() != gt.width() || ms.height() != gt.height()) {
    throw std::invalid_argument("segmentation has the shape (" + std::to_string(ms.height()) +
                                ", " + std::to_string(ms.width()) + ") but ground_truth (" +
                                std::to_string(gt.height()) + ", " + std::to_string(gt.width()) +
                                ")");
  }
  // Depth in millimetres given as labels is scored, with a warning (eval::depth_likeness).
  for (const auto& [labels, name] : {std::pair{&gt, "ground_truth"}, {&ms, "segmentation"}}) {
    const eval::DepthLikeness d = eval::depth_likeness(*labels);
    if (!d.likely) continue;
    const std::string message = std::string(name) + ": " + eval::describe(d);
    if (PyErr_WarnEx(PyExc_UserWarning, message.c_str(), 1) != 0) throw py::error_already_set();
  }
  const eval::EvalSettings settings{.tolerance = tolerance, .min_gt_label = min_gt_label};
  const eval::EvalResult r = eval::evaluate(gt, ms, settings);
  py::dict out("tolerance"_a = tolerance, "gt_regions"_a = r.gt_regions,
               "ms_regions"_a = r.ms_regions, "ms_regions_outside"_a = r.ms_regions_outside,
               "correct"_a = r.correct, "over"_a = r.over, "under"_a = r.under,
               "missed"_a = r.missed, "noise"_a = r.noise, "correct_pairs"_a = r.correct_pairs);
  if (!points.is_none()) {
    const py::array p = numeric_array(points, "points");
    if (p.ndim() != 3 || p.shape(0) != gt.height() || p.shape(1) != gt.width() || p.shape(2) != 3) {
      throw std::invalid_argument("points must have the shape (" + std::to_string(gt.height()) +
                                  ", " + std::to_string(gt.width()) +
                                  ", 3) of the label images, got " + shape_text(p));
    }
    // A label image of one row is an unorganized cloud to cloud_from_arrays: (W, 3).
    const OrganizedCloud cloud =
        cloud_from_arrays(gt.height() >= 2 ? py::object(p) : p.attr("reshape")(-1, 3), py::none(),
                          py::none(), py::none());
    const eval::AngleStats a = eval::angle_error(
        r, gt, eval::fit_planes(cloud, gt, min_gt_label, eval::kGroundTruthTrimSigmas),
        eval::fit_planes(cloud, ms, 1));
    out["angle_pairs"] = a.pairs;
    out["angle_error_deg"] = a.mean_deg;
    out["angle_error_std_deg"] = a.std_deg;
  }
  return out;
}

}  // namespace

void bind_eval(py::module_& m) {
  m.def("evaluate", &evaluate, "ground_truth"_a, "segmentation"_a, "tolerance"_a = 0.8,
        "min_gt_label"_a = 1, "points"_a = py::none(),
        R"(Scores a segmentation against ground truth by the SegComp protocol (Hoover et al.
1996): two integer label images of one size. Ground-truth labels below min_gt_label are
no region (10 for SegComp .gt-seg images); segmentation labels <= 0 are unlabelled.
Returns a dict: gt_regions, ms_regions (ms_regions_outside: those lying only on
ground truth that is no region, counted nowhere else), correct, over, under, missed, noise (counts at
the overlap tolerance T = tolerance, 0.5 < T <= 1) and correct_pairs [(gt, ms)]; with
the points (H, W, 3) also Hoover's angle error of adjacent correctly detected planes
(angle_error_deg, its std, angle_pairs; NaN when there is no such pair), the ground truth's
planes fitted robustly (points more than 3 robust sigmas off left out), the segmentation's
plainly. A label image that looks like a depth image (no label below 100, and labels
that change between a fifth or more of neighbouring pixels) gives a UserWarning.)");
}

}  // namespace rangeseg::python
