// The score table that `eval`, `eval-segcomp` and `eval-synth` print: one row per image; and
// their --T option.
#pragma once

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "rangeseg/eval.hpp"

namespace rangeseg::cli {

inline void add_tolerance_option(CLI::App& cmd, double& tolerance) {
  cmd.add_option("--T", tolerance, "Overlap tolerance T of the SegComp protocol, 0.5 < T <= 1")
      ->capture_default_str();
}

/// Throws std::invalid_argument for a --T outside (0.5, 1]; called before any work, which
/// eval::evaluate would otherwise reject only image by image.
inline void require_tolerance(double tolerance) {
  if (!(tolerance > 0.5 && tolerance <= 1.0)) {
    char text[64];
    std::snprintf(text, sizeof text, "--T %g: the overlap tolerance must be in (0.5, 1]",
                  tolerance);
    throw std::invalid_argument(text);
  }
}

/// "12.34", or "-" when there is no pair of planes to measure (NaN).
inline std::string angle_text(double degrees) {
  if (!std::isfinite(degrees)) return "-";
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", degrees);
  return text;
}

/// Pooled angle error "1.23 +- 0.45 deg", or "-".
inline std::string angle_summary(double mean_deg, double std_deg) {
  return std::isfinite(mean_deg) ? angle_text(mean_deg) + " +- " + angle_text(std_deg) + " deg"
                                 : "-";
}

inline void print_eval_header() {
  std::printf("%-22s %5s %5s %7s %5s %6s %6s %6s %9s\n", "image", "GT", "MS", "correct", "over",
              "under", "missed", "noise", "angle_deg");
}

inline void print_eval_row(const char* name, const eval::EvalResult& r, const eval::AngleStats& a) {
  std::printf("%-22s %5d %5d %7d %5d %6d %6d %6d %9s\n", name, r.gt_regions, r.ms_regions,
              r.correct, r.over, r.under, r.missed, r.noise, angle_text(a.mean_deg).c_str());
}

}  // namespace rangeseg::cli
