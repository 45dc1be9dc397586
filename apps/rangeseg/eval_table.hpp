// The score table that `eval`, `eval-segcomp` and `eval-synth` print: one row per image.
#pragma once

#include <cstdio>

#include "rangeseg/eval.hpp"

namespace rangeseg::cli {

inline void print_eval_header() {
  std::printf("%-22s %5s %5s %7s %5s %6s %6s %6s %9s\n", "image", "GT", "MS", "correct", "over",
              "under", "missed", "noise", "angle_deg");
}

inline void print_eval_row(const char* name, const eval::EvalResult& r, const eval::AngleStats& a) {
  std::printf("%-22s %5d %5d %7d %5d %6d %6d %6d %9.2f\n", name, r.gt_regions, r.ms_regions,
              r.correct, r.over, r.under, r.missed, r.noise, a.mean_deg);
}

}  // namespace rangeseg::cli
