// Tests of the segmentation's coarse level (8x8 cells) and its seeds: cell statistics, dropouts,
// seed tests and clearance, the label-block neighbour test, cells against pixel-wise growing.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include "detail/plane_stats.hpp"
#include "rangeseg/eval.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/smoothing.hpp"
#include "rangeseg/synth.hpp"
#include "segmentation/internal.hpp"
#include "segmentation_frame_util.hpp"
#include "segmentation_test_util.hpp"

namespace rangeseg {
namespace {

using namespace test;  // the segmentation test helpers

// --- coarse level (cells) ---

TEST(Segmentation, CellStatisticsEqualDirectSums) {
  // A tilted plane at 2-3 m with dropped points: a cell missing 1 or 4 of its 64 vertices is
  // still complete (its sums over the valid ones), one missing 5 is not, nor is one with a
  // missing vertex and a depth step (mesh cut) between valid vertices.
  OrganizedCloud cloud =
      cast(64, 48, [](double a, double b) { return 2.5 / (1.0 + 0.3 * a - 0.2 * b); });
  const auto drop = [&](int u, int v) {
    cloud.x(u, v) = NAN;
    cloud.y(u, v) = NAN;
    cloud.z(u, v) = NAN;
  };
  drop(20, 10);                                                     // cell (2, 1): 1 missing
  for (const int u : {33, 35, 37, 39}) drop(u, 18);                 // cell (4, 2): 4 missing
  for (const int u : {49, 51, 53, 55, 50}) drop(u, 2 + u % 2 * 3);  // cell (6, 0): 5 missing
  drop(41, 34);                                                     // cell (5, 4): 1 missing, and
  for (int v = 32; v < 40; ++v) {                                   // a 30 cm step at u = 44
    for (int u = 44; u < 48; ++u) {
      const float scale = 1.0f + 0.3f / cloud.z(u, v);
      cloud.x(u, v) *= scale;
      cloud.y(u, v) *= scale;
      cloud.z(u, v) *= scale;
    }
  }
  const FrameOf t(std::move(cloud));
  Segmenter::Scratch scratch;
  seg::compute_cells(t.f, scratch);
  ASSERT_EQ(scratch.cell_cols, 8);
  ASSERT_EQ(scratch.cell_rows, 6);
  const auto cell_at = [&](int cu, int cv) { return scratch.cells[cv * 8 + cu]; };
  EXPECT_EQ(cell_at(2, 1).stats.count, 63);
  EXPECT_EQ(cell_at(4, 2).stats.count, 60);
  EXPECT_FALSE(cell_at(6, 0).complete);
  EXPECT_FALSE(cell_at(5, 4).complete);
  int complete = 0;
  for (int cv = 0; cv < 6; ++cv) {
    for (int cu = 0; cu < 8; ++cu) {
      const seg::Cell& cell = cell_at(cu, cv);
      detail::PlaneStats direct;
      double snz = 0;
      for (int v = cv * 8; v < cv * 8 + 8; ++v) {
        for (int u = cu * 8; u < cu * 8 + 8; ++u) {
          if (std::isnan(t.cloud.z(u, v))) continue;
          direct.add(t.cloud.x(u, v), t.cloud.y(u, v), t.cloud.z(u, v));
          snz += t.normals.nz(u, v);
        }
      }
      if (!cell.complete) continue;
      ++complete;
      EXPECT_EQ(cell.stats.count, direct.count) << cu << "," << cv;
      EXPECT_NEAR(cell.stats.sz, direct.sz, 1e-4);
      EXPECT_NEAR(cell.stats.szz, direct.szz, 1e-3);
      EXPECT_NEAR(cell.stats.sxz, direct.sxz, 1e-3);
      EXPECT_NEAR(cell.snz, snz, 1e-3);
      // The fits agree to well below a micrometre of residual.
      const auto a = cell.stats.fit(), b = direct.fit();
      ASSERT_TRUE(a.ok && b.ok);
      EXPECT_GT(std::fabs(a.normal[0] * b.normal[0] + a.normal[1] * b.normal[1] +
                          a.normal[2] * b.normal[2]),
                1 - 1e-6);
      EXPECT_NEAR(a.offset, b.offset, 1e-5);
    }
  }
  EXPECT_EQ(complete, 48 - 2);
}

/// A sensor's scattered dropouts (here 1 pixel in 150) leave cells that miss a vertex or two;
/// they are grown as units, and the missing vertices stay unlabelled.
TEST(Segmentation, ScatteredDropoutsInsideCellsStayUnlabelled) {
  OrganizedCloud cloud =
      cast(160, 120, [](double a, double b) { return 2.5 / (1.0 + 0.3 * a - 0.2 * b); });
  int dropped = 0;
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if ((u * 7919 + v * 104729) % 150 != 0) continue;
      cloud.x(u, v) = NAN;
      cloud.y(u, v) = NAN;
      cloud.z(u, v) = NAN;
      ++dropped;
    }
  }
  ASSERT_GT(dropped, 100);
  const FrameOf t(std::move(cloud));
  Segmenter::Scratch scratch;
  seg::compute_cells(t.f, scratch);
  int gapped = 0;
  for (const seg::Cell& cell : scratch.cells) gapped += cell.complete && cell.stats.count < 64;
  EXPECT_GT(gapped, 50);  // of 300 cells
  const Segmentation seg = segment(t.cloud, t.mesh, t.normals, preset("kinect"));
  ASSERT_EQ(seg.segments.size(), 1u);
  int labelled = 0, with_edges = 0;
  for (int v = 0; v < t.cloud.height(); ++v) {
    for (int u = 0; u < t.cloud.width(); ++u) {
      if (std::isnan(t.cloud.z(u, v))) {
        EXPECT_EQ(seg.labels(u, v), 0) << u << "," << v;
        continue;
      }
      with_edges += t.mesh.edges(u, v) != 0;
      labelled += seg.labels(u, v) == 1;
    }
  }
  EXPECT_EQ(labelled, with_edges);
}

/// A seed needs a mesh 1-ring of unlabelled pixels whose normals agree with its own: a pixel
/// next to a region is one that region rejected, and seeds there start slivers along region
/// boundaries (on the SegComp ABW images: strips 2-7 pixels wide, counted as noise regions).
TEST(Segmentation, SeedsNeedAFreeRingOfAgreeingNormals) {
  FrameOf t(cast(32, 24, [](double a, double b) { return 2.0 / (1.0 + 0.3 * a - 0.2 * b); }));
  const OrganizedCloud& cloud = t.cloud;
  const Mesh& mesh = t.mesh;
  const NormalMap& normals = t.normals;
  Segmentation& out = t.out;
  const seg::Frame& f = t.f;
  const auto at = [&](int u, int v) { return t.at(u, v); };
  const float cos_angle = static_cast<float>(std::cos(25 * kDeg));
  const unsigned ring = f.edges[at(10, 10)];
  ASSERT_GE(std::popcount(ring), 6);  // one diagonal per quad
  EXPECT_TRUE(seg::seed_ring_ok(f, at(10, 10), cos_angle));
  EXPECT_TRUE(seg::seed_ring_ok(f, at(0, 0), cos_angle));  // a corner: three neighbours
  // A labelled mesh neighbour vetoes the seed; a labelled pixel that is none does not.
  for (int k = 0; k < 8; ++k) {
    const int u = 10 + kNeighbourDu[k], v = 10 + kNeighbourDv[k];
    out.labels(u, v) = 3;
    EXPECT_EQ(seg::seed_ring_ok(f, at(10, 10), cos_angle), (ring & (1u << k)) == 0)
        << "labelled neighbour " << k;
    out.labels(u, v) = 0;
  }
  out.labels(12, 10) = 3;
  EXPECT_TRUE(seg::seed_ring_ok(f, at(10, 10), cos_angle));
  out.labels(12, 10) = 0;
  // A neighbour whose normal disagrees, and a pixel without mesh neighbours, are no seeds.
  NormalMap bent = normals;
  bent.nx(11, 10) = 1.0f;
  bent.ny(11, 10) = 0.0f;
  bent.nz(11, 10) = 0.0f;
  const seg::Frame g = seg::make_frame(cloud, mesh, bent, out.labels);
  EXPECT_FALSE(seg::seed_ring_ok(g, at(10, 10), cos_angle));
  Mesh cut = mesh;
  cut.edges(10, 10) = 0;
  const seg::Frame h = seg::make_frame(cloud, cut, normals, out.labels);
  EXPECT_FALSE(seg::seed_ring_ok(h, at(10, 10), cos_angle));
}

// A pixel seed of the plane model also needs a clear (2r + 1)^2 block: no labelled pixel within
// r lattice steps (Chebyshev), clipped at the image border, on the mesh's lattice only.
TEST(Segmentation, SeedsNeedClearanceFromLabelledPixels) {
  FrameOf t(cast(32, 24, [](double, double) { return 2.0; }));
  const OrganizedCloud& cloud = t.cloud;
  Segmentation& out = t.out;
  const seg::Frame& f = t.f;
  const auto at = [&](int u, int v) { return t.at(u, v); };
  for (int r = 0; r <= 4; ++r) EXPECT_TRUE(seg::seed_clear(f, at(10, 10), r));
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      out.labels(u, v) = 7;
      for (const int r : {1, 3}) {
        const bool near = std::abs(u - 10) <= r && std::abs(v - 10) <= r;
        ASSERT_EQ(seg::seed_clear(f, at(10, 10), r), !near) << u << "," << v << " r " << r;
        ASSERT_EQ(seg::seed_passes(f, at(10, 10), {.ring_cos = -1, .clearance = r}), !near);
      }
      EXPECT_TRUE(seg::seed_clear(f, at(10, 10), 0));
      out.labels(u, v) = 0;
    }
  }
  // Corners: the block is clipped, nothing outside the image is read.
  out.labels(3, 3) = 1;
  EXPECT_FALSE(seg::seed_clear(f, at(0, 0), 3));
  EXPECT_TRUE(seg::seed_clear(f, at(0, 0), 2));
  EXPECT_FALSE(seg::seed_clear(f, at(31, 23), 30));
  out.labels(3, 3) = 0;
  // Lattice step 2: only lattice pixels count, and r counts lattice steps.
  seg::Frame g = f;
  g.pixel_stride = 2;
  out.labels(11, 10) = 5;  // off the lattice
  EXPECT_TRUE(seg::seed_clear(g, at(10, 10), 3));
  out.labels(11, 10) = 0;
  out.labels(16, 10) = 5;  // three lattice steps away
  EXPECT_FALSE(seg::seed_clear(g, at(10, 10), 3));
  EXPECT_TRUE(seg::seed_clear(g, at(10, 10), 2));
}

// Along a crease the growth leaves a band of mixed 1-ring normals; with no clearance its
// pixels seed slivers, with the default they do not, and the two faces are found either way.
TEST(Segmentation, SeedClearanceKeepsSliversOutOfCreaseBands) {
  const synth::Rendering r =
      synth::render(synth::random_scene(3),
                    {.noise = synth::Noise::kinect, .seed = 3, .min_surface_pixels = 1000});
  const Mesh mesh = build_mesh(r.cloud);
  OrganizedCloud cloud;
  NormalMap normals;
  smooth(r.cloud, mesh, compute_normals(r.cloud, mesh), {}, cloud, normals);
  SegmentationSettings settings = preset("kinect");
  settings.min_region_size = 1;  // keep every region, so that slivers stay visible
  settings.merge_planes = false;
  settings.reassign_boundary = false;
  const Segmentation with = segment(cloud, mesh, normals, settings);
  settings.seed_clearance = 0;
  const Segmentation without = segment(cloud, mesh, normals, settings);
  const auto small = [](const Segmentation& s) {
    return std::count_if(s.segments.begin(), s.segments.end(),
                         [](const Segment& x) { return x.pixel_count < 50; });
  };
  std::printf("segments below 50 px: %td with clearance, %td without\n", small(with),
              small(without));
  EXPECT_LT(2 * small(with), small(without));
  settings = preset("kinect");
  const eval::EvalResult a =
      eval::evaluate(r.labels, segment(cloud, mesh, normals, settings).labels, {.tolerance = 0.8});
  settings.seed_clearance = 0;
  const eval::EvalResult b =
      eval::evaluate(r.labels, segment(cloud, mesh, normals, settings).labels, {.tolerance = 0.8});
  EXPECT_GE(a.correct, b.correct);
}

#if defined(__SSE2__)
// Boundary re-assignment decides a pixel whose labelled neighbours share one label with one
// plane test (single_neighbour_label, three vector loads); the label must be the one every
// labelled neighbour carries, and the unlabelled neighbours exactly the zero ones, whatever the
// direction mask and the labels outside the 3 x 3 block.
TEST(Segmentation, NeighbourLabelBlockMatchesTheRing) {
  constexpr std::ptrdiff_t stride = 7;
  std::mt19937 rng(5);
  std::array<std::int32_t, 3 * stride> labels{};
  const std::ptrdiff_t q = stride + 2;  // (2, 1): its block spans columns 1-4 of rows 0-2
  int single = 0, mixed = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    // Few distinct labels, so that one shared label is common; 0 = unlabelled.
    for (auto& l : labels) l = static_cast<std::int32_t>(rng() % (trial % 2 == 0 ? 2 : 4));
    const unsigned directions = rng() & 0xFFu;
    unsigned unlabelled = 0;
    std::vector<std::int32_t> seen;
    for (int k = 0; k < 8; ++k) {
      if ((directions >> k & 1u) == 0) continue;
      const std::int32_t l = labels[q + kNeighbourDv[k] * stride + kNeighbourDu[k]];
      if (l == 0) {
        unlabelled |= 1u << k;
      } else if (std::find(seen.begin(), seen.end(), l) == seen.end()) {
        seen.push_back(l);
      }
    }
    const seg::NeighbourLabels got =
        seg::single_neighbour_label(labels.data(), stride, q, directions);
    ASSERT_EQ(got.unlabelled, unlabelled) << "trial " << trial;
    ASSERT_EQ(got.single, seen.size() <= 1) << "trial " << trial;
    if (seen.size() == 1) {
      ASSERT_EQ(got.label, seen[0]) << "trial " << trial;
    }
    if (seen.empty()) {
      ASSERT_EQ(got.label, 0) << "trial " << trial;
    }
    (got.single ? single : mixed) += 1;
  }
  // Both outcomes occur (the test would pass vacuously otherwise).
  EXPECT_GT(single, 1000);
  EXPECT_GT(mixed, 1000);
}
#endif

/// Fraction of the labelled pixels of `a` whose segment's best match in `b` holds them.
double agreement(const LabelImage& a, const LabelImage& b) {
  std::map<std::pair<int, int>, int> overlap;
  std::map<int, int> best;
  int labelled = 0;
  for (int v = 0; v < a.height(); ++v) {
    for (int u = 0; u < a.width(); ++u) {
      if (a(u, v) == 0) continue;
      ++labelled;
      ++overlap[{a(u, v), b(u, v)}];
    }
  }
  for (const auto& [key, count] : overlap) {
    if (key.second != 0) best[key.first] = std::max(best[key.first], count);
  }
  int agree = 0;
  for (const auto& [label, count] : best) agree += count;
  return labelled == 0 ? 1.0 : static_cast<double>(agree) / labelled;
}

/// On the pipeline's (smoothed) input the cells only shortcut the pixel-wise tests: the
/// segmentation must be (nearly) the same. On raw normals, whose noise far away exceeds the
/// angle test, the cells also grow what the pixel tests reject (see FarNoisyWallIsGrownAsCells),
/// but everything the pixel tests find they find too.
TEST(Segmentation, CoarseCellsAgreeWithPixelGrowing) {
  const synth::Rendering r =
      synth::render(synth::random_scene(3),
                    {.noise = synth::Noise::kinect, .seed = 3, .min_surface_pixels = 1000});
  const Mesh mesh = build_mesh(r.cloud, {.eps_theta = 0.05f});
  const NormalMap raw_normals = compute_normals(r.cloud, mesh);
  OrganizedCloud points;
  NormalMap normals;
  smooth(r.cloud, mesh, raw_normals, {}, points, normals);
  SegmentationSettings settings = preset("kinect");
  const Segmentation coarse = segment(points, mesh, normals, settings);
  settings.coarse_cells = false;
  const Segmentation fine = segment(points, mesh, normals, settings);
  expect_consistent(points, coarse, settings);
  const double ab = agreement(coarse.labels, fine.labels),
               ba = agreement(fine.labels, coarse.labels);
  std::printf("coarse %zu segments, pixel-wise %zu; agreement %.3f / %.3f\n",
              coarse.segments.size(), fine.segments.size(), ab, ba);
  EXPECT_GE(ab, 0.95);
  EXPECT_GE(ba, 0.95);
  const eval::EvalResult ec = eval::evaluate(r.labels, coarse.labels, {.tolerance = 0.8});
  const eval::EvalResult ef = eval::evaluate(r.labels, fine.labels, {.tolerance = 0.8});
  EXPECT_GE(ec.correct, ef.correct - 1);

  settings.coarse_cells = true;
  const Segmentation raw_coarse = segment(r.cloud, mesh, raw_normals, settings);
  settings.coarse_cells = false;
  const Segmentation raw_fine = segment(r.cloud, mesh, raw_normals, settings);
  const double raw_ba = agreement(raw_fine.labels, raw_coarse.labels);
  std::printf("raw normals: coarse %zu segments, pixel-wise %zu; pixel-wise found by cells %.3f\n",
              raw_coarse.segments.size(), raw_fine.segments.size(), raw_ba);
  EXPECT_GE(raw_ba, 0.95);
  const eval::EvalResult rc = eval::evaluate(r.labels, raw_coarse.labels, {.tolerance = 0.8});
  const eval::EvalResult rf = eval::evaluate(r.labels, raw_fine.labels, {.tolerance = 0.8});
  EXPECT_GE(rc.correct, rf.correct);
}

// --- analytic scenes ---

}  // namespace
}  // namespace rangeseg
