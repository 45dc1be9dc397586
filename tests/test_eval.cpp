// SegComp evaluation (Hoover et al. 1996) on hand-made label images with known outcomes.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <random>
#include <set>
#include <stdexcept>
#include <string>

#include "rangeseg/eval.hpp"

namespace {

using rangeseg::LabelImage;
using rangeseg::OrganizedCloud;
using namespace rangeseg::eval;

/// Sets the pixels x0 <= x < x1, y0 <= y < y1 to `label`.
void fill_rect(LabelImage& image, int x0, int y0, int x1, int y1, int label) {
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) image(x, y) = label;
  }
}

/// 20x20 image of four 10x10 quadrants labelled base, base+1, base+2, base+3.
LabelImage quadrants(int base) {
  LabelImage image(20, 20, 0);
  fill_rect(image, 0, 0, 10, 10, base);
  fill_rect(image, 10, 0, 20, 10, base + 1);
  fill_rect(image, 0, 10, 10, 20, base + 2);
  fill_rect(image, 10, 10, 20, 20, base + 3);
  return image;
}

void expect_counts(const EvalResult& r, int correct, int over, int under, int missed, int noise) {
  EXPECT_EQ(r.correct, correct);
  EXPECT_EQ(r.over, over);
  EXPECT_EQ(r.under, under);
  EXPECT_EQ(r.missed, missed);
  EXPECT_EQ(r.noise, noise);
  EXPECT_EQ(static_cast<int>(r.correct_pairs.size()), correct);
}

Outcome gt_outcome(const EvalResult& r, int label) {
  const RegionOutcome* region = r.find_gt(label);
  EXPECT_NE(region, nullptr) << "no GT region " << label;
  return region ? region->outcome : Outcome::missed;
}
Outcome ms_outcome(const EvalResult& r, int label) {
  const RegionOutcome* region = r.find_ms(label);
  EXPECT_NE(region, nullptr) << "no MS region " << label;
  return region ? region->outcome : Outcome::noise;
}

TEST(Eval, PerfectMatchIsAllCorrect) {
  const EvalResult r = evaluate(quadrants(1), quadrants(11));
  EXPECT_EQ(r.gt_regions, 4);
  EXPECT_EQ(r.ms_regions, 4);
  expect_counts(r, 4, 0, 0, 0, 0);
  const std::vector<std::pair<int, int>> expected{{1, 11}, {2, 12}, {3, 13}, {4, 14}};
  EXPECT_EQ(r.correct_pairs, expected);
  ASSERT_EQ(r.gt.size(), 4u);
  EXPECT_EQ(r.gt[0].pixels, 100);
  EXPECT_EQ(r.gt[0].partners, std::vector<int>{11});
  EXPECT_EQ(ms_outcome(r, 14), Outcome::correct);
}

TEST(Eval, SplitRegionIsOneOverSegmentation) {
  LabelImage gt(20, 20, 0), ms(20, 20, 0);
  fill_rect(gt, 0, 0, 10, 20, 1);
  fill_rect(gt, 10, 0, 20, 20, 2);
  fill_rect(ms, 0, 0, 10, 10, 5);
  fill_rect(ms, 0, 10, 10, 20, 6);
  fill_rect(ms, 10, 0, 20, 20, 7);
  const EvalResult r = evaluate(gt, ms);
  expect_counts(r, 1, 1, 0, 0, 0);
  EXPECT_EQ(gt_outcome(r, 1), Outcome::over);
  EXPECT_EQ(r.find_gt(1)->partners, (std::vector<int>{5, 6}));
  EXPECT_EQ(ms_outcome(r, 5), Outcome::over);
  EXPECT_EQ(ms_outcome(r, 6), Outcome::over);
  EXPECT_EQ(r.find_ms(6)->partners, std::vector<int>{1});
  EXPECT_EQ(gt_outcome(r, 2), Outcome::correct);
}

TEST(Eval, OverSegmentationNeedsTheSumToCoverTheRegion) {
  // Two pieces, each inside GT 1, together only 60 % of it; the rest is unlabelled.
  LabelImage gt(20, 20, 1), ms(20, 20, 0);
  fill_rect(ms, 0, 0, 20, 6, 5);
  fill_rect(ms, 0, 6, 20, 12, 6);
  const EvalResult r = evaluate(gt, ms);
  expect_counts(r, 0, 0, 0, 1, 2);
  // At T = 0.6 the same pieces are an over-segmentation (240 >= 0.6 * 400).
  const EvalResult r6 = evaluate(gt, ms, {.tolerance = 0.6});
  expect_counts(r6, 0, 1, 0, 0, 0);
}

TEST(Eval, MergedRegionsAreOneUnderSegmentation) {
  LabelImage gt(20, 20, 0), ms(20, 20, 0);
  fill_rect(gt, 0, 0, 10, 10, 1);
  fill_rect(gt, 0, 10, 10, 20, 2);
  fill_rect(gt, 10, 0, 20, 20, 3);
  fill_rect(ms, 0, 0, 10, 20, 5);
  fill_rect(ms, 10, 0, 20, 20, 6);
  const EvalResult r = evaluate(gt, ms);
  expect_counts(r, 1, 0, 1, 0, 0);
  EXPECT_EQ(ms_outcome(r, 5), Outcome::under);
  EXPECT_EQ(r.find_ms(5)->partners, (std::vector<int>{1, 2}));
  EXPECT_EQ(gt_outcome(r, 1), Outcome::under);
  EXPECT_EQ(gt_outcome(r, 2), Outcome::under);
  EXPECT_EQ(r.find_gt(2)->partners, std::vector<int>{5});
  EXPECT_EQ(r.correct_pairs, (std::vector<std::pair<int, int>>{{3, 6}}));
}

TEST(Eval, HalfCoverageIsMissedPlusNoise) {
  // MS 5 lies inside GT 1 but covers only half of it; the other half is unlabelled.
  LabelImage gt(20, 20, 1), ms(20, 20, 0);
  fill_rect(ms, 0, 0, 10, 20, 5);
  const EvalResult r = evaluate(gt, ms);
  EXPECT_EQ(r.gt_regions, 1);
  EXPECT_EQ(r.ms_regions, 1);
  expect_counts(r, 0, 0, 0, 1, 1);
  EXPECT_EQ(gt_outcome(r, 1), Outcome::missed);
  EXPECT_EQ(ms_outcome(r, 5), Outcome::noise);
  EXPECT_TRUE(r.find_gt(1)->partners.empty());
}

TEST(Eval, StraddlingRegionIsNoiseAndBothGtRegionsMissed) {
  LabelImage gt(20, 20, 0), ms(20, 20, 0);
  fill_rect(gt, 0, 0, 10, 20, 1);
  fill_rect(gt, 10, 0, 20, 20, 2);
  fill_rect(ms, 5, 0, 15, 20, 5);
  expect_counts(evaluate(gt, ms), 0, 0, 0, 2, 1);
}

TEST(Eval, TinySpuriousRegionIsNoise) {
  LabelImage ms = quadrants(11);
  fill_rect(ms, 3, 3, 5, 5, 99);  // 4 pixels inside quadrant 1
  const EvalResult r = evaluate(quadrants(1), ms);
  EXPECT_EQ(r.ms_regions, 5);
  expect_counts(r, 4, 0, 0, 0, 1);
  EXPECT_EQ(ms_outcome(r, 99), Outcome::noise);
  EXPECT_EQ(r.find_ms(11)->pixels, 96);
}

TEST(Eval, CorrectDetectionTakesPrecedenceOverUnderSegmentation) {
  // MS 5 covers everything: it correctly detects GT 1 (396 of 400 pixels) and also contains
  // the tiny GT 2 completely. GT 2 is missed, not part of an under-segmentation.
  LabelImage gt(20, 20, 1), ms(20, 20, 5);
  fill_rect(gt, 8, 8, 10, 10, 2);
  const EvalResult r = evaluate(gt, ms);
  expect_counts(r, 1, 0, 0, 1, 0);
  EXPECT_EQ(gt_outcome(r, 2), Outcome::missed);
}

TEST(Eval, OverlapExactlyAtToleranceCounts) {
  // 10x2: GT 1 is row 0, GT 2 is row 1. MS 5 covers the first k pixels of row 0, MS 6 the rest
  // of row 0 plus row 1. GT 1 is correctly detected iff k >= 10 T.
  for (int k : {6, 7, 8, 9, 10}) {
    LabelImage gt(10, 2, 1), ms(10, 2, 6);
    fill_rect(gt, 0, 1, 10, 2, 2);
    fill_rect(ms, 0, 0, k, 1, 5);
    const double T = k / 10.0;  // 0.6, 0.7, 0.8, 0.9, 1.0: overlap exactly T * P
    if (k < 10) {
      const EvalResult at = evaluate(gt, ms, {.tolerance = T});
      EXPECT_EQ(gt_outcome(at, 1), Outcome::correct) << "T = " << T;
      // Just above: GT 1 is missed, MS 5 is noise.
      const EvalResult above = evaluate(gt, ms, {.tolerance = T + 1e-6});
      EXPECT_EQ(gt_outcome(above, 1), Outcome::missed) << "T = " << T;
      EXPECT_EQ(ms_outcome(above, 5), Outcome::noise) << "T = " << T;
    } else {
      // k = 10: MS 5 is GT 1 exactly and MS 6 is GT 2 exactly, correct even at T = 1.
      expect_counts(evaluate(gt, ms, {.tolerance = 1.0}), 2, 0, 0, 0, 0);
    }
  }
  // 0.56 * 25 evaluates to 14.000000000000002 in double; the exact fraction is 14.
  LabelImage gt25(5, 5, 1), ms25(5, 5, 0);
  for (int i = 0; i < 14; ++i) ms25(i % 5, i / 5) = 5;
  expect_counts(evaluate(gt25, ms25, {.tolerance = 0.56}), 1, 0, 0, 0, 0);
  expect_counts(evaluate(gt25, ms25, {.tolerance = 0.57}), 0, 0, 0, 1, 1);
  // T = 0.8, k = 8: MS 6 has 12 pixels with 10 on GT 2 (10 >= 9.6): both correct.
  LabelImage gt(10, 2, 1), ms(10, 2, 6);
  fill_rect(gt, 0, 1, 10, 2, 2);
  fill_rect(ms, 0, 0, 8, 1, 5);
  expect_counts(evaluate(gt, ms, {.tolerance = 0.8}), 2, 0, 0, 0, 0);
  // T = 0.85: MS 6 no longer lies inside GT 2 (10 < 0.85 * 12 = 10.2) and MS 5 covers too little
  // of GT 1 (8 < 8.5): both GT regions missed, both MS regions noise.
  expect_counts(evaluate(gt, ms, {.tolerance = 0.85}), 0, 0, 0, 2, 2);
}

TEST(Eval, ExcludedGroundTruthPixelsDoNotCount) {
  // Columns 10..14 have GT label 0 (no data). MS 5 spans columns 0..14: 200 pixels on GT 1 and
  // 100 excluded ones. Counted over all pixels it would be 300 with 200 / 300 < 0.8 overlap.
  LabelImage gt(20, 20, 0), ms(20, 20, 0);
  fill_rect(gt, 0, 0, 10, 20, 1);
  fill_rect(gt, 15, 0, 20, 20, 2);
  fill_rect(ms, 0, 0, 15, 20, 5);
  fill_rect(ms, 15, 0, 20, 20, 6);
  const EvalResult r = evaluate(gt, ms);
  expect_counts(r, 2, 0, 0, 0, 0);
  EXPECT_EQ(r.find_ms(5)->pixels, 200);
  EXPECT_EQ(r.ms_regions_outside, 0);

  // SegComp-style: labels below 10 are "no region"; a machine region lying only there is
  // neither counted nor noise.
  LabelImage gt10(20, 20, 1), ms10(20, 20, 0);
  fill_rect(gt10, 0, 0, 10, 20, 10);
  fill_rect(gt10, 12, 0, 20, 20, 11);
  fill_rect(gt10, 10, 0, 12, 20, 2);  // boundary pixels
  fill_rect(ms10, 0, 0, 10, 20, 3);
  fill_rect(ms10, 10, 0, 12, 20, 4);  // only on excluded pixels
  fill_rect(ms10, 12, 0, 20, 20, 5);
  const EvalResult r10 = evaluate(gt10, ms10, {.min_gt_label = 10});
  EXPECT_EQ(r10.gt_regions, 2);
  EXPECT_EQ(r10.ms_regions, 2);
  EXPECT_EQ(r10.ms_regions_outside, 1);
  EXPECT_EQ(r10.find_ms(4), nullptr);
  expect_counts(r10, 2, 0, 0, 0, 0);
  // With min_gt_label = 1 the boundary label 2 is a region of its own, found by MS 4.
  const EvalResult r1 = evaluate(gt10, ms10, {.min_gt_label = 1});
  EXPECT_EQ(r1.gt_regions, 3);
  expect_counts(r1, 3, 0, 0, 0, 0);
}

TEST(Eval, UnlabelledAndNegativeMachinePixelsBelongToNoRegion) {
  // Labels <= 0 in the machine image are "unlabelled" but still count in the GT region size.
  LabelImage gt(20, 20, 1), ms(20, 20, 7);
  fill_rect(ms, 0, 0, 20, 3, 0);
  fill_rect(ms, 0, 3, 20, 5, -4);
  const EvalResult r = evaluate(gt, ms);  // O = 300 of P_n = 400: missed at T = 0.8
  EXPECT_EQ(r.ms_regions, 1);
  expect_counts(r, 0, 0, 0, 1, 1);
  expect_counts(evaluate(gt, ms, {.tolerance = 0.75}), 1, 0, 0, 0, 0);
}

TEST(Eval, LargeLabelValuesWork) {
  LabelImage gt = quadrants(65532), ms = quadrants(2000000000);
  const EvalResult r = evaluate(gt, ms);
  expect_counts(r, 4, 0, 0, 0, 0);
  EXPECT_EQ(r.correct_pairs.back(), (std::pair<int, int>{65535, 2000000003}));
}

TEST(Eval, InvalidInputsThrow) {
  const LabelImage a(20, 20, 1), b(20, 21, 1);
  try {
    evaluate(a, b);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("20x20"), std::string::npos) << message;
    EXPECT_NE(message.find("20x21"), std::string::npos) << message;
  }
  EXPECT_THROW(evaluate(a, a, {.tolerance = 0.5}), std::invalid_argument);
  EXPECT_THROW(evaluate(a, a, {.tolerance = 1.01}), std::invalid_argument);
  EXPECT_THROW(evaluate(a, a, {.tolerance = NAN}), std::invalid_argument);
  EXPECT_THROW(evaluate(a, a, {.min_gt_label = -1}), std::invalid_argument);
  EXPECT_NO_THROW(evaluate(a, a, {.tolerance = 1.0}));
  EXPECT_NO_THROW(evaluate(a, a, {.tolerance = 0.51}));
  const EvalResult empty = evaluate(LabelImage{}, LabelImage{});
  EXPECT_EQ(empty.gt_regions, 0);
  expect_counts(empty, 0, 0, 0, 0, 0);
}

// Independent slow reference: dense overlap matrix over compacted labels, the definitions
// applied literally, same precedence (correct, then over, then under).
struct Counts {
  int correct = 0, over = 0, under = 0, missed = 0, noise = 0;
};
Counts reference_counts(const LabelImage& gt, const LabelImage& ms, double T) {
  std::map<int, int> gi, mi;
  for (int y = 0; y < gt.height(); ++y) {
    for (int x = 0; x < gt.width(); ++x) {
      if (gt(x, y) < 1) continue;
      gi.emplace(gt(x, y), 0);
      if (ms(x, y) > 0) mi.emplace(ms(x, y), 0);
    }
  }
  int k = 0;
  for (auto& [label, index] : gi) index = k++;
  k = 0;
  for (auto& [label, index] : mi) index = k++;
  const int N = static_cast<int>(gi.size()), M = static_cast<int>(mi.size());
  std::vector<std::vector<long>> O(M, std::vector<long>(N, 0));
  std::vector<long> Pn(N, 0), Pm(M, 0);
  for (int y = 0; y < gt.height(); ++y) {
    for (int x = 0; x < gt.width(); ++x) {
      if (gt(x, y) < 1) continue;
      const int n = gi[gt(x, y)];
      ++Pn[n];
      if (ms(x, y) > 0) {
        const int m = mi[ms(x, y)];
        ++Pm[m];
        ++O[m][n];
      }
    }
  }
  const auto ge = [T](long o, long p) { return o >= T * p - 1e-9; };
  std::vector<int> gt_state(N, 0), ms_state(M, 0);  // 0 open, 1 classified
  Counts c;
  for (int n = 0; n < N; ++n) {
    for (int m = 0; m < M; ++m) {
      if (ge(O[m][n], Pm[m]) && ge(O[m][n], Pn[n])) {
        ++c.correct;
        gt_state[n] = ms_state[m] = 1;
      }
    }
  }
  for (int n = 0; n < N; ++n) {
    if (gt_state[n]) continue;
    std::vector<int> set;
    long sum = 0;
    for (int m = 0; m < M; ++m) {
      if (!ms_state[m] && O[m][n] > 0 && ge(O[m][n], Pm[m])) {
        set.push_back(m);
        sum += O[m][n];
      }
    }
    if (set.size() >= 2 && ge(sum, Pn[n])) {
      ++c.over;
      gt_state[n] = 1;
      for (int m : set) ms_state[m] = 1;
    }
  }
  for (int m = 0; m < M; ++m) {
    if (ms_state[m]) continue;
    std::vector<int> set;
    long sum = 0;
    for (int n = 0; n < N; ++n) {
      if (!gt_state[n] && O[m][n] > 0 && ge(O[m][n], Pn[n])) {
        set.push_back(n);
        sum += O[m][n];
      }
    }
    if (set.size() >= 2 && ge(sum, Pm[m])) {
      ++c.under;
      ms_state[m] = 1;
      for (int n : set) gt_state[n] = 1;
    }
  }
  for (int s : gt_state) c.missed += s == 0;
  for (int s : ms_state) c.noise += s == 0;
  return c;
}

TEST(Eval, MatchesSlowReferenceOnRandomBlockImages) {
  std::mt19937 rng(12345);
  int total_over = 0, total_under = 0, total_correct = 0, total_missed = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const int w = 48, h = 40;
    LabelImage gt(w, h, 0), ms(w, h, 0);
    // GT: random rectangles over a background region; some pixels excluded (label 0).
    std::uniform_int_distribution<int> coord_x(0, w - 1), coord_y(0, h - 1);
    fill_rect(gt, 0, 0, w, h, 1);
    for (int r = 0; r < 8; ++r) {
      const int x0 = coord_x(rng), y0 = coord_y(rng);
      fill_rect(gt, x0, y0, std::min(w, x0 + 4 + static_cast<int>(rng() % 16)),
                std::min(h, y0 + 4 + static_cast<int>(rng() % 12)), 2 + r);
    }
    // MS: the GT relabelled, with regions randomly split, merged, shifted and blotched.
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        int label = 100 + gt(x, y);
        if (gt(x, y) % 3 == 0 && x > w / 2) label += 50;    // split
        if (gt(x, y) % 4 == 1) label = 100 + gt(x, y) + 1;  // merge with the next label
        ms(x, y) = label;
      }
    }
    for (int b = 0; b < 6; ++b) {
      const int x0 = coord_x(rng), y0 = coord_y(rng);
      fill_rect(ms, x0, y0, std::min(w, x0 + 1 + static_cast<int>(rng() % 8)),
                std::min(h, y0 + 1 + static_cast<int>(rng() % 8)),
                static_cast<int>(rng() % 3 == 0 ? 0 : 500 + b));
    }
    for (int e = 0; e < 40; ++e) gt(coord_x(rng), coord_y(rng)) = 0;
    for (double T : {0.51, 0.7, 0.8, 0.95}) {
      const EvalResult r = evaluate(gt, ms, {.tolerance = T});
      const Counts c = reference_counts(gt, ms, T);
      ASSERT_EQ(r.correct, c.correct) << "trial " << trial << " T " << T;
      ASSERT_EQ(r.over, c.over) << "trial " << trial << " T " << T;
      ASSERT_EQ(r.under, c.under) << "trial " << trial << " T " << T;
      ASSERT_EQ(r.missed, c.missed) << "trial " << trial << " T " << T;
      ASSERT_EQ(r.noise, c.noise) << "trial " << trial << " T " << T;
      // Every GT region is in exactly one class; MS likewise.
      int gt_in_classes = r.missed, ms_in_classes = r.noise + r.under;
      for (const RegionOutcome& g : r.gt) {
        if (g.outcome == Outcome::correct || g.outcome == Outcome::over ||
            g.outcome == Outcome::under) {
          ++gt_in_classes;
        }
      }
      for (const RegionOutcome& m : r.ms) {
        if (m.outcome == Outcome::correct || m.outcome == Outcome::over) ++ms_in_classes;
      }
      EXPECT_EQ(gt_in_classes, r.gt_regions);
      EXPECT_EQ(ms_in_classes, r.ms_regions);
      total_over += r.over;
      total_under += r.under;
      total_correct += r.correct;
      total_missed += r.missed;
    }
  }
  // The generator must exercise every class, or the comparison proves little.
  EXPECT_GT(total_over, 0);
  EXPECT_GT(total_under, 0);
  EXPECT_GT(total_correct, 0);
  EXPECT_GT(total_missed, 0);
}

// ---------------------------------------------------------------------------------------------
// Angle differences.

double deg(double d) { return d * std::numbers::pi / 180.0; }

/// GT with three vertical strips 1 | 2 | 3 separated by `gap` columns of label 0; MS identical
/// with labels +10.
void strips(int gap, LabelImage& gt, LabelImage& ms) {
  const int w = 30 + 2 * gap;
  gt = LabelImage(w, 10, 0);
  ms = LabelImage(w, 10, 0);
  for (int s = 0; s < 3; ++s) {
    const int x0 = s * (10 + gap);
    fill_rect(gt, x0, 0, x0 + 10, 10, 1 + s);
    fill_rect(ms, x0, 0, x0 + 10, 10, 11 + s);
  }
}

TEST(EvalAngle, PerpendicularPlanesAgainst88DegreesIsTwoDegrees) {
  LabelImage gt, ms;
  strips(2, gt, ms);
  const EvalResult r = evaluate(gt, ms);
  ASSERT_EQ(r.correct, 3);
  std::vector<std::optional<PlaneParams>> gt_planes(3), ms_planes(13);
  // GT 1: z = 2, GT 2: x = 1, both facing the origin: 90 degrees.
  gt_planes[1] = PlaneParams{{0, 0, -1}, 2.0};
  gt_planes[2] = PlaneParams{{-1, 0, 0}, 1.0};
  ms_planes[11] = PlaneParams{{0, 0, -1}, 2.0};
  // The machine plane of GT 2 is tilted by 2 degrees (88 degrees to MS 11) and given with the
  // opposite sign convention, which must not matter.
  const double t = deg(2.0);
  ms_planes[12] = PlaneParams{{std::cos(t), 0, std::sin(t)}, -1.0};
  const AngleStats a = angle_error(r, gt, gt_planes, ms_planes);
  EXPECT_EQ(a.pairs, 1);    // (1,2); (2,3) lacks GT 3's plane
  EXPECT_EQ(a.skipped, 1);  // (2,3)
  EXPECT_NEAR(a.mean_deg, 2.0, 1e-9);
  EXPECT_NEAR(a.std_deg, 0.0, 1e-9);
}

TEST(EvalAngle, MeanAndStdOverSeveralPairs) {
  LabelImage gt, ms;
  strips(1, gt, ms);
  const EvalResult r = evaluate(gt, ms);
  std::vector<std::optional<PlaneParams>> gt_planes(4), ms_planes(14);
  // GT: normals at 0, 90 and 180-ish; build all in the x-z plane, facing the origin.
  const auto plane_at = [](double angle_deg) {
    const double a = deg(angle_deg);
    return PlaneParams{{std::sin(a), 0, -std::cos(a)}, 1.0};
  };
  gt_planes[1] = plane_at(0);
  gt_planes[2] = plane_at(60);
  gt_planes[3] = plane_at(100);
  ms_planes[11] = plane_at(0);
  ms_planes[12] = plane_at(62);   // (1,2): 60 vs 62 -> 2
  ms_planes[13] = plane_at(106);  // (2,3): 40 vs 44 -> 4
  const AngleStats a = angle_error(r, gt, gt_planes, ms_planes);
  EXPECT_EQ(a.pairs, 2);
  EXPECT_NEAR(a.mean_deg, 3.0, 1e-9);
  EXPECT_NEAR(a.std_deg, 1.0, 1e-9);
}

TEST(EvalAngle, AdjacencyAcrossGapsUpToMaxGap) {
  std::vector<std::optional<PlaneParams>> gt_planes(4), ms_planes(14);
  for (int l = 1; l <= 3; ++l) gt_planes[l] = ms_planes[l + 10] = PlaneParams{{0, 0, -1}, 1.0 * l};
  for (int gap : {0, 1, 3, 4}) {
    LabelImage gt, ms;
    strips(gap, gt, ms);
    const EvalResult r = evaluate(gt, ms);
    const AngleStats a = angle_error(r, gt, gt_planes, ms_planes);
    EXPECT_EQ(a.pairs, gap <= 3 ? 2 : 0) << "gap " << gap;
    if (gap <= 3) {
      EXPECT_NEAR(a.mean_deg, 0.0, 1e-9);
    } else {
      EXPECT_TRUE(std::isnan(a.mean_deg));
    }
    EXPECT_EQ(angle_error(r, gt, gt_planes, ms_planes, {.max_gap = 4}).pairs, 2) << "gap " << gap;
    if (gap > 0) {
      EXPECT_EQ(angle_error(r, gt, gt_planes, ms_planes, {.max_gap = gap - 1}).pairs, 0)
          << "gap " << gap;
    }
  }
}

TEST(EvalAngle, VerticalAdjacencyAndOnlyCorrectRegions) {
  // Rows: GT 1 on top, GT 2 below; MS splits GT 2 (over-segmented), so no correct pair.
  LabelImage gt(10, 20, 0), ms(10, 20, 0);
  fill_rect(gt, 0, 0, 10, 10, 1);
  fill_rect(gt, 0, 10, 10, 20, 2);
  fill_rect(ms, 0, 0, 10, 10, 11);
  fill_rect(ms, 0, 10, 10, 20, 12);
  std::vector<std::optional<PlaneParams>> planes(13, PlaneParams{{0, 0, -1}, 1.0});
  EXPECT_EQ(angle_error(evaluate(gt, ms), gt, planes, planes).pairs, 1);
  fill_rect(ms, 5, 10, 10, 20, 9);
  EXPECT_EQ(angle_error(evaluate(gt, ms), gt, planes, planes).pairs, 0);
}

TEST(EvalAngle, InvalidInputsThrow) {
  LabelImage gt, ms;
  strips(0, gt, ms);
  const EvalResult r = evaluate(gt, ms);
  std::vector<std::optional<PlaneParams>> planes(14, PlaneParams{{0, 0, -1}, 1.0});
  EXPECT_THROW(angle_error(r, LabelImage(5, 5, 1), planes, planes), std::invalid_argument);
  EXPECT_THROW(angle_error(r, gt, planes, planes, {.max_gap = -1}), std::invalid_argument);
  auto bad = planes;
  bad[2] = PlaneParams{{0, 0, 0}, 1.0};
  EXPECT_THROW(angle_error(r, gt, bad, planes), std::invalid_argument);
}

/// Cloud on a 20x20 pixel grid: x = (u - 10) cm, y = (v - 10) cm, z from the region's plane.
OrganizedCloud analytic_cloud(LabelImage& labels) {
  OrganizedCloud cloud(20, 20);
  labels = LabelImage(20, 20, 0);
  for (int v = 0; v < 20; ++v) {
    for (int u = 0; u < 20; ++u) {
      const double x = (u - 10) * 0.01, y = (v - 10) * 0.01;
      double z = 0;
      int label = 0;
      if (u < 10) {
        label = 1;
        z = 2.0 + 0.5 * x - 0.2 * y;  // 0.5 x - 0.2 y - z + 2 = 0
      } else if (u < 19) {
        label = 2;
        z = 3.0;
      } else {
        label = 3;  // one column: collinear points
        z = 2.5;
      }
      cloud.x(u, v) = static_cast<float>(x);
      cloud.y(u, v) = static_cast<float>(y);
      cloud.z(u, v) = static_cast<float>(z);
      labels(u, v) = label;
    }
  }
  labels(0, 0) = 0;  // excluded: moved off the plane, must not disturb the fit
  cloud.z(0, 0) = 100.0f;
  cloud.z(1, 0) = NAN;  // invalid point in region 1
  labels(5, 5) = 5;     // a single point: too few for a plane
  cloud.z(5, 5) = 2.0f + 0.5f * cloud.x(5, 5) - 0.2f * cloud.y(5, 5);
  return cloud;
}

TEST(EvalPlanes, FitPlanesRecoversAnalyticPlanes) {
  LabelImage labels;
  const OrganizedCloud cloud = analytic_cloud(labels);
  const auto planes = fit_planes(cloud, labels, 1);
  ASSERT_EQ(planes.size(), 6u);
  EXPECT_FALSE(planes[0].has_value());  // below min_label
  ASSERT_TRUE(planes[1].has_value());
  const double norm = std::sqrt(0.25 + 0.04 + 1.0);
  const std::array<double, 3> n1{0.5 / norm, -0.2 / norm, -1.0 / norm};
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(planes[1]->normal[i], n1[i], 1e-5) << i;
  EXPECT_NEAR(planes[1]->offset, 2.0 / norm, 1e-5);
  ASSERT_TRUE(planes[2].has_value());
  EXPECT_NEAR(planes[2]->normal[2], -1.0, 1e-9);
  EXPECT_NEAR(planes[2]->offset, 3.0, 1e-6);
  EXPECT_FALSE(planes[3].has_value());  // collinear
  EXPECT_FALSE(planes[4].has_value());  // absent
  EXPECT_FALSE(planes[5].has_value());  // one point

  // Fitted GT planes against themselves give zero angle error; the GT angle between 1 and 2 is
  // acos(n1 . (0,0,-1)) and a machine plane rotated about the y axis changes it by exactly that.
  const EvalResult r = evaluate(labels, labels);
  const AngleStats same = angle_error(r, labels, planes, planes);
  EXPECT_EQ(same.pairs, 1);    // (1,2); 3 has no plane, 5 is inside 1 and not adjacent to 2
  EXPECT_EQ(same.skipped, 2);  // (2,3) and (1,5)
  EXPECT_NEAR(same.mean_deg, 0.0, 1e-6);
  auto ms_planes = planes;
  ms_planes[2] = PlaneParams{{std::sin(deg(3.0)), 0, -std::cos(deg(3.0))}, 3.0};
  const double gt_angle = std::acos(n1[2] * -1.0) * 180.0 / std::numbers::pi;
  const double ms_angle = std::acos(n1[0] * std::sin(deg(3.0)) + n1[2] * -std::cos(deg(3.0))) *
                          180.0 / std::numbers::pi;
  EXPECT_NEAR(angle_error(r, labels, planes, ms_planes).mean_deg, std::abs(gt_angle - ms_angle),
              1e-6);
}

// Hand-drawn ground truth labels a stray pixel of another surface: a strip 3 pixels wide on
// z = 2 m with noise, and one pixel 30 rows away, 0.19 m behind it. Its least-squares plane
// tilts by tens of degrees; the robust fit leaves the pixel out and recovers the strip's plane,
// and equals the plain fit on clean data to well within the noise.
TEST(EvalPlanes, RobustFitLeavesOutAMislabelledPixel) {
  OrganizedCloud cloud(40, 40);
  LabelImage labels(40, 40, 0);
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.0f, 0.001f);
  for (int v = 0; v < 40; ++v) {
    for (int u = 0; u < 40; ++u) {
      cloud.x(u, v) = (u - 20) * 0.01f;
      cloud.y(u, v) = (v - 20) * 0.01f;
      cloud.z(u, v) = 2.0f + noise(rng);
      if (v >= 2 && v < 5) labels(u, v) = 1;
    }
  }
  LabelImage clean = labels;
  labels(10, 35) = 1;
  cloud.z(10, 35) = 2.19f;
  const auto angle_to_z = [](const std::optional<PlaneParams>& p) {
    return std::acos(std::fabs(p->normal[2])) * 180.0 / std::numbers::pi;
  };
  const auto plain = fit_planes(cloud, labels, 1);
  const auto robust = fit_planes(cloud, labels, 1, kGroundTruthTrimSigmas);
  ASSERT_TRUE(plain[1].has_value());
  ASSERT_TRUE(robust[1].has_value());
  EXPECT_GT(angle_to_z(plain[1]), 10.0);
  EXPECT_LT(angle_to_z(robust[1]), 0.5);
  EXPECT_NEAR(robust[1]->offset, 2.0, 0.002);

  const auto clean_plain = fit_planes(cloud, clean, 1);
  const auto clean_robust = fit_planes(cloud, clean, 1, kGroundTruthTrimSigmas);
  EXPECT_LT(angle_to_z(clean_plain[1]), 0.5);
  EXPECT_NEAR(clean_robust[1]->offset, clean_plain[1]->offset, 1e-3);
  EXPECT_THROW(fit_planes(cloud, labels, 1, -1.0), std::invalid_argument);
  EXPECT_THROW(fit_planes(cloud, labels, 1, NAN), std::invalid_argument);
}

TEST(EvalPlanes, FitPlanesValidatesInputs) {
  LabelImage labels;
  const OrganizedCloud cloud = analytic_cloud(labels);
  EXPECT_THROW(fit_planes(cloud, LabelImage(20, 19, 1), 1), std::invalid_argument);
  EXPECT_THROW(fit_planes(cloud, labels, -1), std::invalid_argument);
  EXPECT_TRUE(fit_planes(cloud, LabelImage(20, 20, 0), 1).empty());
}

TEST(EvalSummary, MeansAndPooledAngles) {
  EvalResult a, b;
  a.gt_regions = 10;
  a.correct = 8;
  a.over = 1;
  a.missed = 1;
  a.noise = 3;
  b.gt_regions = 20;
  b.correct = 14;
  b.under = 2;
  b.missed = 2;
  b.noise = 0;
  AngleStats sa{.pairs = 1, .skipped = 0, .mean_deg = 2.0, .std_deg = 0.0};
  AngleStats sb{.pairs = 3, .skipped = 0, .mean_deg = 4.0, .std_deg = 1.0};
  const EvalSummary s = summarize({a, b}, {sa, sb});
  EXPECT_EQ(s.images, 2);
  EXPECT_DOUBLE_EQ(s.mean_gt, 15.0);
  EXPECT_DOUBLE_EQ(s.mean_correct, 11.0);
  EXPECT_DOUBLE_EQ(s.mean_over, 0.5);
  EXPECT_DOUBLE_EQ(s.mean_under, 1.0);
  EXPECT_DOUBLE_EQ(s.mean_missed, 1.5);
  EXPECT_DOUBLE_EQ(s.mean_noise, 1.5);
  EXPECT_EQ(s.angle_pairs, 4);
  EXPECT_NEAR(s.mean_angle_deg, 3.5, 1e-12);            // (1*2 + 3*4) / 4
  EXPECT_NEAR(s.std_angle_deg, std::sqrt(1.5), 1e-12);  // (4 + 3*17)/4 - 3.5^2
  EXPECT_THROW(summarize({a, b}, {sa}), std::invalid_argument);
  const EvalSummary no_angles = summarize({a});
  EXPECT_TRUE(std::isnan(no_angles.mean_angle_deg));
  EXPECT_EQ(summarize({}).images, 0);
}

TEST(Eval, OutcomeNames) {
  EXPECT_STREQ(to_string(Outcome::correct), "correct");
  EXPECT_STREQ(to_string(Outcome::noise), "noise");
}

}  // namespace

namespace {

// A tilted plane's depth in millimetres, z = base + slope (u + v) quantised to whole mm.
LabelImage depth_mm(int base, double slope) {
  LabelImage depth(64, 48, 0);
  for (int v = 0; v < 48; ++v) {
    for (int u = 0; u < 64; ++u) depth(u, v) = base + static_cast<int>(slope * (u + v));
  }
  return depth;
}

}  // namespace

TEST(Eval, DepthImagesGivenAsLabelsAreTold) {
  // A plane from 1 m, 3 mm deeper per pixel: every neighbour differs.
  const DepthLikeness far = depth_likeness(depth_mm(1000, 3.0));
  EXPECT_TRUE(far.likely);
  EXPECT_EQ(far.lowest, 1000);
  EXPECT_GT(far.changing_share, 0.9);
  EXPECT_TRUE(depth_likeness(depth_mm(238, 0.5)).likely) << "238 mm: near, at half a mm a pixel";
  // A frontal wall: one depth, one "label".
  EXPECT_FALSE(depth_likeness(depth_mm(1000, 0.0)).likely);

  // A segmentation: 8 x 6 blocks of 8 x 8 pixels, numbered from 1, then from 1001.
  LabelImage blocks(64, 48, 0);
  for (int v = 0; v < 48; ++v) {
    for (int u = 0; u < 64; ++u) blocks(u, v) = 1 + u / 8 + 8 * (v / 8);
  }
  const DepthLikeness segmentation = depth_likeness(blocks);
  EXPECT_FALSE(segmentation.likely);
  EXPECT_EQ(segmentation.distinct, 48u);
  EXPECT_NEAR(segmentation.changing_share, (7.0 * 48 + 5.0 * 64) / (63.0 * 48 + 47.0 * 64), 1e-12);
  for (int v = 0; v < 48; ++v) {
    for (int u = 0; u < 64; ++u) blocks(u, v) += 1000;
  }
  EXPECT_FALSE(depth_likeness(blocks).likely) << "piecewise constant, whatever the numbers";
  EXPECT_FALSE(depth_likeness(LabelImage(64, 48, 0)).likely);
}

// An under-segmentation needs the ground-truth regions it holds to make up T of the machine
// region's own size, not of theirs: A and B (100 px each) lie wholly in m, which also holds 150
// of C's 400 px, so they fill 200 / 350 = 57 % of m, below T = 0.8: no under-segmentation, and
// m and the rest of C (250 px) are noise; A, B and C are missed.
TEST(Eval, UnderSegmentationCountsTheMachineRegionsOwnSize) {
  LabelImage gt(20, 30, 0), ms(20, 30, 0);
  fill_rect(gt, 0, 0, 10, 10, 1);    // A
  fill_rect(gt, 10, 0, 20, 10, 2);   // B
  fill_rect(gt, 0, 10, 20, 30, 3);   // C
  fill_rect(ms, 0, 0, 20, 17, 11);   // A, B and 140 px of C
  fill_rect(ms, 0, 17, 10, 18, 11);  // 10 px more of C
  fill_rect(ms, 10, 17, 20, 18, 12);
  fill_rect(ms, 0, 18, 20, 30, 12);  // the other 250 px of C
  const EvalResult r = evaluate(gt, ms, {.tolerance = 0.8});
  expect_counts(r, 0, 0, 0, 3, 2);
  // With m holding only 12 px of C (200 / 212 >= 0.8), it is one.
  fill_rect(ms, 0, 10, 20, 18, 12);
  fill_rect(ms, 0, 10, 12, 11, 11);
  const EvalResult under = evaluate(gt, ms, {.tolerance = 0.8});
  EXPECT_EQ(under.under, 1);
  EXPECT_EQ(gt_outcome(under, 1), Outcome::under);
  EXPECT_EQ(gt_outcome(under, 2), Outcome::under);
}
