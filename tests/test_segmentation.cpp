// Tests of stage 4 (region-growing segmentation) against analytic scenes, the synthetic
// renderer's ground truth and, when present, the SegComp ABW and OSD data.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "detail/plane_stats.hpp"
#include "detail/simd.hpp"
#include "rangeseg/eval.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/rasterfile.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/smoothing.hpp"
#include "rangeseg/synth.hpp"
#include "rangeseg/thread_pool.hpp"
#include "segmentation/internal.hpp"
#include "test_util.hpp"

namespace rangeseg {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kF = 525.0, kCx = 319.5, kCy = 239.5;

/// Ray-casts a depth function: `depth(a, b)` gives the depth t of the point t (a, b, 1) seen
/// through the pixel with ray slopes a = (u - cx) / f, b = (v - cy) / f (NaN = no point).
OrganizedCloud cast(int width, int height, const std::function<double(double, double)>& depth) {
  OrganizedCloud cloud(width, height);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const double a = (u - kCx) / kF, b = (v - kCy) / kF;
      const double t = depth(a, b);
      if (!std::isfinite(t)) continue;
      cloud.x(u, v) = static_cast<float>(a * t);
      cloud.y(u, v) = static_cast<float>(b * t);
      cloud.z(u, v) = static_cast<float>(t);
    }
  }
  return cloud;
}

struct Pipeline {
  Mesh mesh;
  NormalMap normals;
  Segmentation seg;
};

Pipeline run(const OrganizedCloud& cloud, const SegmentationSettings& settings) {
  Pipeline p;
  p.mesh = build_mesh(cloud);
  p.normals = compute_normals(cloud, p.mesh);
  segment(cloud, p.mesh, p.normals, settings, p.seg);
  return p;
}

double angle_deg(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  const double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  return std::acos(std::clamp(d, -1.0, 1.0)) / kDeg;
}

/// Invariants every segmentation must satisfy.
void expect_consistent(const OrganizedCloud& cloud, const Segmentation& seg,
                       const SegmentationSettings& settings) {
  ASSERT_EQ(seg.labels.width(), cloud.width());
  ASSERT_EQ(seg.labels.height(), cloud.height());
  std::vector<int> counts(seg.segments.size() + 1, 0);
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      const int l = seg.labels(u, v);
      ASSERT_GE(l, 0);
      ASSERT_LE(l, static_cast<int>(seg.segments.size()))
          << "label not compact at " << u << "," << v;
      if (l != 0) {
        ASSERT_TRUE(cloud.valid(u, v)) << "invalid pixel labelled at " << u << "," << v;
      }
      ++counts[l];
    }
  }
  for (std::size_t i = 0; i < seg.segments.size(); ++i) {
    const Segment& s = seg.segments[i];
    EXPECT_EQ(s.label, static_cast<int>(i + 1));
    EXPECT_EQ(s.pixel_count, counts[i + 1]) << "segment " << s.label;
    EXPECT_GE(2 * s.pixel_count, settings.min_region_size);  // below it only when wide (3D)
    if (i > 0) {
      EXPECT_LE(s.pixel_count, seg.segments[i - 1].pixel_count);
    }
    const double norm = std::hypot(s.normal[0], s.normal[1], s.normal[2]);
    EXPECT_NEAR(norm, 1.0, 1e-9);
    EXPECT_GE(s.offset, 0.0);
    const double nc =
        s.normal[0] * s.centroid[0] + s.normal[1] * s.centroid[1] + s.normal[2] * s.centroid[2];
    EXPECT_NEAR(nc + s.offset, 0.0, 1e-9);  // the plane passes through the centroid
    EXPECT_GT(s.area_m2, 0.0);
    EXPECT_GE(s.rms_residual, 0.0);
  }
}

// --- plane statistics ---

TEST(PlaneStats, FitsExactPlaneAndMergeEqualsAddingAll) {
  // Plane 0.3x - 0.2y - z + 2.5 = 0 sampled on a grid.
  std::array<double, 3> n{0.3, -0.2, -1.0};
  const double len = std::hypot(n[0], n[1], n[2]);
  detail::PlaneStats all, first, second;
  for (int i = 0; i < 20; ++i) {
    for (int j = 0; j < 15; ++j) {
      const double x = -1 + 0.1 * i, y = -0.5 + 0.07 * j, z = 0.3 * x - 0.2 * y + 2.5;
      all.add(x, y, z);
      (i < 7 ? first : second).add(x, y, z);
    }
  }
  first.merge(second);
  const auto fa = all.fit(), fm = first.fit();
  ASSERT_TRUE(fa.ok);
  // Facing the camera: the normal has negative z and the offset is positive.
  EXPECT_NEAR(fa.normal[0], n[0] / len, 1e-9);
  EXPECT_NEAR(fa.normal[1], n[1] / len, 1e-9);
  EXPECT_NEAR(fa.normal[2], n[2] / len, 1e-9);
  EXPECT_NEAR(fa.offset, 2.5 / len, 1e-9);
  EXPECT_LT(fa.rms, 1e-7);
  EXPECT_NEAR(fm.offset, fa.offset, 1e-12);
  EXPECT_EQ(first.count, all.count);
  // Collinear points have no plane.
  detail::PlaneStats line;
  for (int i = 0; i < 10; ++i) line.add(i, 2 * i, 3);
  EXPECT_FALSE(line.fit().ok);
}

// --- coarse level (cells) ---

/// A cloud with its mesh, normals, an empty label image and the segmentation's flat view of them.
struct FrameOf {
  explicit FrameOf(OrganizedCloud c)
      : cloud(std::move(c)), mesh(build_mesh(cloud)), normals(compute_normals(cloud, mesh)) {
    out.labels.resize(cloud.width(), cloud.height(), 0);
    f = seg::make_frame(cloud, mesh, normals, out.labels);
  }
  std::int32_t at(int u, int v) const { return static_cast<std::int32_t>(v * f.stride + u); }

  OrganizedCloud cloud;
  Mesh mesh;
  NormalMap normals;
  Segmentation out;
  seg::Frame f;
};

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

TEST(Segmentation, ConvexAndConcaveBoxCornerGiveTwoPlanes) {
  for (const double sign : {1.0, -1.0}) {
    // z = 2 + sign |x|: two planes meeting at 90 degrees along x = 0.
    const OrganizedCloud cloud =
        cast(640, 480, [sign](double a, double) { return 2.0 / (1.0 - sign * std::fabs(a)); });
    const SegmentationSettings settings = preset("kinect");
    const Pipeline p = run(cloud, settings);
    expect_consistent(cloud, p.seg, settings);
    ASSERT_EQ(p.seg.segments.size(), 2u) << "sign " << sign;
    const double r = 1.0 / std::sqrt(2.0);
    // Normals facing the camera: for x > 0 the plane is z = 2 + sign x.
    const std::array<double, 3> right{sign * r, 0.0, -r}, left{-sign * r, 0.0, -r};
    for (const Segment& s : p.seg.segments) {
      const auto& expected = s.centroid[0] > 0 ? right : left;
      EXPECT_LT(angle_deg(s.normal, expected), 0.5) << "sign " << sign;
      EXPECT_LT(s.rms_residual, 1e-4);
      EXPECT_GT(s.pixel_count, 640 * 480 / 2 - 480 * 4);
    }
  }
}

TEST(Segmentation, DepthStepIsSeparated) {
  // A plane at 1 m (left half of the image) in front of a plane at 2 m.
  const OrganizedCloud cloud = cast(640, 480, [](double a, double) { return a < 0 ? 1.0 : 2.0; });
  const SegmentationSettings settings = preset("kinect");
  const Pipeline p = run(cloud, settings);
  expect_consistent(cloud, p.seg, settings);
  ASSERT_EQ(p.seg.segments.size(), 2u);
  const int near_label = p.seg.labels(100, 240), far_label = p.seg.labels(500, 240);
  EXPECT_NE(near_label, 0);
  EXPECT_NE(far_label, 0);
  EXPECT_NE(near_label, far_label);
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const int l = p.seg.labels(u, v);
      if (l != 0) {
        EXPECT_EQ(l, cloud.z(u, v) < 1.5f ? near_label : far_label) << u << "," << v;
      }
    }
  }
  EXPECT_NEAR(p.seg.segments[near_label - 1].offset, 1.0, 1e-4);
  EXPECT_NEAR(p.seg.segments[far_label - 1].offset, 2.0, 1e-4);
}

/// A wall at 2 m with smoothed-Kinect noise (0.3 sigma(z) along the ray) whose mesh is cut along
/// the column u = 320, as a terrace crack cuts a surface seen at grazing incidence: growth cannot
/// cross the cut, so the halves are two regions that touch only across it, and they are one
/// plane at the noise level the frame's segments show: one segment. Control: the right half
/// 16 mm further away (2.6 sigma(2 m) of the sensor model, but 9 times the noise the halves
/// show), also cut: two segments, which merging with the sensor model's sigma(z) would join.
TEST(Segmentation, CoplanarPiecesAcrossAMeshCutMergeButAStepDoesNot) {
  const SegmentationSettings kinect = preset("kinect");
  for (const double step : {0.0, 0.016}) {
    std::mt19937 rng(13);
    std::normal_distribution<double> unit(0.0, 1.0);
    const OrganizedCloud cloud = cast(640, 480, [&](double a, double) {
      const double t = a < (320 - kCx) / kF ? 2.0 : 2.0 + step;
      return t + 0.3 * kinect.noise.sigma(t) * unit(rng);
    });
    Mesh mesh = build_mesh(cloud);
    for (int v = 0; v < 480; ++v) {
      for (int k = 0; k < 8; ++k) {
        if (kNeighbourDu[k] > 0) mesh.edges(319, v) &= static_cast<std::uint8_t>(~(1u << k));
        if (kNeighbourDu[k] < 0) mesh.edges(320, v) &= static_cast<std::uint8_t>(~(1u << k));
      }
    }
    const NormalMap normals = compute_normals(cloud, mesh);
    const Segmentation seg = segment(cloud, mesh, normals, kinect);
    expect_consistent(cloud, seg, kinect);
    const int left = seg.labels(100, 240), right = seg.labels(540, 240);
    ASSERT_NE(left, 0) << step;
    ASSERT_NE(right, 0) << step;
    if (step == 0) {
      EXPECT_EQ(left, right);
      EXPECT_EQ(seg.segments.size(), 1u);
    } else {
      EXPECT_NE(left, right);
    }
  }
}

/// A wall at 1 m seen by a scanner whose calibration bows it: z = 1 + c x^2 with a sagitta of 3 mm
/// over the +-0.6 m of the view (6 sigma of the 0.5 mm noise, Gaussian along the ray). No plane
/// fits the whole wall within 3 sigma, so region growing cuts it into pieces, whose own fits are
/// tilted against each other by ~0.3 deg and leave residuals above sigma; but every piece lies on
/// the plane of their union within the wall's own measured residual, so they are one segment.
/// Without the merge by `lies_on_merged_plane` this gives 2-3 segments.
TEST(Segmentation, BowedWallIsOneSegmentButShallowCreaseIsNot) {
  SegmentationSettings settings = preset("abw");
  settings.noise = {.a = 0.0005, .b = 0.0, .z0 = 0.0};
  const double c = 0.003 / (0.6 * 0.6);  // [1/m]
  for (const std::uint32_t seed : {1u, 2u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.0005);
    const auto noisy = [&](const std::function<double(double, double)>& depth) {
      return cast(640, 480, [&](double a, double b) { return depth(a, b) + noise(rng); });
    };
    // Depth t of the bowed wall along the ray (a, b, 1): t = 1 + c (a t)^2 (fixed point).
    const OrganizedCloud bowed = noisy([c](double a, double) {
      double t = 1.0;
      for (int i = 0; i < 6; ++i) t = 1.0 + c * a * a * t * t;
      return t;
    });
    const Pipeline p = run(bowed, settings);
    expect_consistent(bowed, p.seg, settings);
    ASSERT_EQ(p.seg.segments.size(), 1u) << "seed " << seed;
    EXPECT_GT(p.seg.segments[0].pixel_count, 0.98 * 640 * 480) << "seed " << seed;

    // Control: two planes meeting at 3 deg along x = 0 (the left one fronto-parallel at 1 m)
    // leave the same sagitta-scale residual but as a crease: two segments, split at x = 0.
    const double slope = std::tan(3 * kDeg);
    const OrganizedCloud crease =
        noisy([slope](double a, double) { return a <= 0 ? 1.0 : 1.0 / (1.0 - slope * a); });
    const Pipeline q = run(crease, settings);
    expect_consistent(crease, q.seg, settings);
    ASSERT_EQ(q.seg.segments.size(), 2u) << "seed " << seed;
    const int left = q.seg.labels(100, 240), right = q.seg.labels(540, 240);
    EXPECT_NE(left, 0);
    EXPECT_NE(right, 0);
    EXPECT_NE(left, right);
  }
}

/// Two planes meeting at a 15 deg crease 1.5 m away, with noise along the ray of 0.4 sigma(z) of
/// the Kinect preset (a sensor less noisy than its preset says, or a closer one) and the
/// pipeline's default smoothing. Points near the crease lie within 3 sigma(z) of either plane
/// and the fixed 25 deg normal test passes both, so a region grown on one side creeps a band of
/// pixels over the crease; the normal noise measured in the frame bounds the angle test far
/// tighter and the split follows the crease.
TEST(Segmentation, MeasuredNormalNoiseKeepsRegionsOffShallowCreases) {
  const SegmentationSettings kinect = preset("kinect");
  const double slope = std::tan(15 * kDeg);
  std::mt19937 rng(7);
  std::normal_distribution<double> unit(0.0, 1.0);
  const OrganizedCloud cloud = cast(640, 480, [&](double a, double) {
    const double t = a <= 0 ? 1.5 : 1.5 / (1.0 - slope * a);
    return t + 0.4 * kinect.noise.sigma(t) * unit(rng);
  });
  const Mesh mesh = build_mesh(cloud);
  const NormalMap raw = compute_normals(cloud, mesh);
  OrganizedCloud points;
  NormalMap normals;
  smooth(cloud, mesh, raw, {}, points, normals);
  // Pixels of each segment on the wrong side of the crease (u = cx), 3 columns off it.
  const auto crossing = [&](const SegmentationSettings& settings) {
    const Segmentation seg = segment(points, mesh, normals, settings);
    expect_consistent(points, seg, settings);
    const int left = seg.labels(100, 240), right = seg.labels(540, 240);
    EXPECT_NE(left, 0);
    EXPECT_NE(right, 0);
    EXPECT_NE(left, right);
    int wrong = 0;
    for (int v = 0; v < 480; ++v) {
      for (int u = 0; u < 640; ++u) {
        if (u < 317) wrong += seg.labels(u, v) == right;
        if (u > 322) wrong += seg.labels(u, v) == left;
      }
    }
    return wrong;
  };
  SegmentationSettings fixed = kinect;
  fixed.normal_noise_sigmas = 0;  // the 25 deg test alone
  const int wrong_fixed = crossing(fixed), wrong_measured = crossing(kinect);
  std::printf("pixels across the crease: fixed angle %d, measured normal noise %d\n", wrong_fixed,
              wrong_measured);
  EXPECT_LT(wrong_measured, 480 * 3);  // under 3 columns' worth
  EXPECT_GT(wrong_fixed, 4 * wrong_measured);
}

/// Two box fronts 3 m away meeting at a vertical crease on the optical axis, the left one
/// fronto-parallel, the right one turned by `degrees`; each 0.27 m wide and 0.36 m tall (47 x 63
/// pixels), before a wall at 4 m; Gaussian noise of `sigmas` sigma(z) along the ray.
OrganizedCloud two_fronts(double degrees, double sigmas, const SensorNoise& noise,
                          std::uint32_t seed) {
  const double slope = std::tan(degrees * kDeg);
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  return cast(640, 480, [&](double a, double b) {
    double t = 4.0;
    if (std::fabs(b) <= 0.06 && std::fabs(a) <= 0.09) t = a <= 0 ? 3.0 : 3.0 / (1.0 - slope * a);
    return t + sigmas * noise.sigma(t) * unit(rng);
  });
}

/// Two box fronts 3 m away whose normals differ by 10 or 14 deg, meeting at a crease, with the
/// noise of smoothed Kinect points (0.3 sigma(z) along the ray): each part fits its plane to a
/// few mm, one plane fits their union to about twice that, still below sigma(3 m) = 14 mm. The
/// parts' normals are known to a fraction of a degree, so they are two surfaces (the slack of
/// sigma / 2 in the merge's residual bound is for parts whose normals their fits cannot pin
/// down, e.g. terraces). With the slack for every pair both become one segment.
/// The test is about merging, so the parts are grown pixel by pixel: the raw normals of these
/// points spread like those of a far surface, and the cells, whose normal consistency follows
/// that measured spread, grow over the crease. (On smoothed data with the full Kinect noise at
/// 3 m the two fronts come out as one segment, with or without that test of the cells.)
TEST(Segmentation, CompactPlanesAFewDegreesApartStayApart) {
  SegmentationSettings kinect = preset("kinect");
  kinect.coarse_cells = false;
  for (const double degrees : {10.0, 14.0}) {
    const OrganizedCloud cloud = two_fronts(degrees, 0.3, kinect.noise, 11);
    const Pipeline p = run(cloud, kinect);
    expect_consistent(cloud, p.seg, kinect);
    const int left = p.seg.labels(296, 240), right = p.seg.labels(343, 240);
    EXPECT_NE(left, 0) << degrees;
    EXPECT_NE(right, 0) << degrees;
    EXPECT_NE(left, right) << degrees;
  }
}

/// The same two fronts 14 and 20 deg apart with the full Kinect noise (sigma(3 m) = 14 mm along
/// the ray) after the default smoothing: near the crease the points of both lie within the
/// growth test's bounds, and the region grown from one front creeps over the other. One plane
/// then fits their union to several times the residual of the frame's other segment (the wall
/// behind), and two planes fit the parts each to the wall's level: the split separates them at
/// the crease. Without the split (`split_residual_factor` = 0) they stay one segment for at
/// least one of the angles. (At 10 deg the union's residual relative to sigma(z) is less than
/// the default 2.5 times the wall's; with split_residual_factor 2 that crease is split too.)
TEST(Segmentation, RegionThatCreptOverACreaseIsSplit) {
  const SegmentationSettings kinect = preset("kinect");
  SegmentationSettings no_split = kinect;
  no_split.split_residual_factor = 0;
  int joined_without_split = 0;
  for (const double degrees : {14.0, 20.0}) {
    const OrganizedCloud cloud = two_fronts(degrees, 1.0, kinect.noise, 5);
    const Mesh mesh = build_mesh(cloud);
    const NormalMap raw = compute_normals(cloud, mesh);
    OrganizedCloud points;
    NormalMap normals;
    smooth(cloud, mesh, raw, {}, points, normals);
    const Segmentation seg = segment(points, mesh, normals, kinect);
    expect_consistent(points, seg, kinect);
    const int left = seg.labels(296, 240), right = seg.labels(343, 240);
    ASSERT_NE(left, 0) << degrees;
    ASSERT_NE(right, 0) << degrees;
    EXPECT_NE(left, right) << degrees;
    if (left != right) {
      const double c = std::cos(degrees * kDeg), s = std::sin(degrees * kDeg);
      EXPECT_LT(angle_deg(seg.segments[left - 1].normal, {0.0, 0.0, -1.0}), 2.0) << degrees;
      EXPECT_LT(angle_deg(seg.segments[right - 1].normal, {s, 0.0, -c}), 2.0) << degrees;
    }
    const Segmentation joined = segment(points, mesh, normals, no_split);
    joined_without_split += joined.labels(296, 240) == joined.labels(343, 240) ? 1 : 0;
  }
  EXPECT_GE(joined_without_split, 1);
}

/// A bowed wall (that of BowedWallIsOneSegmentButShallowCreaseIsNot: sagitta ~3 mm over the
/// view, noise 0.5 mm, like a scanner's calibration bend) with a flat plate 0.7 m in front of
/// it, so that the split compares the wall's residual with another segment's: the plate fits to
/// the noise, the wall to about twice that, below split_residual_factor (2.5) times the plate's,
/// so it stays one segment. A bend of the whole view is not a crease.
TEST(Segmentation, BowedWallIsNotSplit) {
  SegmentationSettings settings = preset("abw");
  settings.noise = {.a = 0.0005, .b = 0.0, .z0 = 0.0};
  const double c = 0.003 / (0.6 * 0.6);  // [1/m]
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.0005);
  const OrganizedCloud cloud = cast(640, 480, [&](double a, double b) {
    if (std::fabs(a) < 0.15 && std::fabs(b) < 0.15) return 0.7 + noise(rng);  // the plate
    double t = 1.0;
    for (int i = 0; i < 6; ++i) t = 1.0 + c * a * a * t * t;
    return t + noise(rng);
  });
  const Pipeline p = run(cloud, settings);
  expect_consistent(cloud, p.seg, settings);
  ASSERT_EQ(p.seg.segments.size(), 2u);
  const double wall_rms = p.seg.segments[0].rms_residual,
               plate_rms = p.seg.segments[1].rms_residual;
  std::printf("wall rms %.2f mm, plate rms %.2f mm\n", wall_rms * 1e3, plate_rms * 1e3);
  EXPECT_GT(wall_rms, 1.5 * plate_rms);
  EXPECT_GT(p.seg.segments[0].pixel_count, 0.95 * (640 * 480 - 150 * 150));
}

/// A wall 5 m away, smoothed once: 56 % of its 1-ring normals are more than 25 deg off (sigma(5 m)
/// = 4 cm and 8 cm disparity steps over a 1 cm pixel footprint), so the resultant of a cell's 64
/// normals is often shorter than cos(25 deg) although their mean points the right way. Where the
/// frame's measured normal noise predicts such a spread, a cell is still one plane: the wall is
/// grown cell by cell, 96 % of its points in one segment. With the fixed 25 deg resultant test
/// its cells were grown pixel by pixel against the per-pixel angle test: 86 %, the rest
/// unlabelled specks.
TEST(Segmentation, FarNoisyWallIsGrownAsCells) {
  const SegmentationSettings kinect = preset("kinect");
  synth::Scene scene;
  scene.rectangles.push_back({.centre = {0.0, 0.0, 5.0},
                              .half_u = {4.0, 0.0, 0.0},
                              .half_v = {0.0, 3.0, 0.0},
                              .name = "wall"});
  for (const std::uint64_t seed : {1u, 2u}) {
    const synth::Rendering r = synth::render(scene, {.noise = synth::Noise::kinect, .seed = seed});
    const Mesh mesh = build_mesh(r.cloud);
    const NormalMap raw = compute_normals(r.cloud, mesh);
    OrganizedCloud points;
    NormalMap normals;
    smooth(r.cloud, mesh, raw, {.iterations = 1}, points, normals);
    const Segmentation seg = segment(points, mesh, normals, kinect);
    expect_consistent(points, seg, kinect);
    std::int64_t valid = 0;
    for (int v = 0; v < points.height(); ++v) {
      for (int u = 0; u < points.width(); ++u) valid += points.valid(u, v) ? 1 : 0;
    }
    ASSERT_FALSE(seg.segments.empty()) << "seed " << seed;
    std::printf("seed %llu: %zu segments, largest %d of %lld valid pixels\n",
                static_cast<unsigned long long>(seed), seg.segments.size(),
                seg.segments[0].pixel_count, static_cast<long long>(valid));
    EXPECT_GE(static_cast<double>(seg.segments[0].pixel_count), 0.93 * static_cast<double>(valid))
        << "seed " << seed;
    EXPECT_LE(seg.segments.size(), 2u) << "seed " << seed;
    EXPECT_LT(angle_deg(seg.segments[0].normal, {0.0, 0.0, -1.0}), 0.5) << "seed " << seed;
  }
}

/// A point on a plane that the mesh's depth-jump gate left without edges (as on a surface seen at
/// grazing incidence) joins the plane's segment when re-assignment may cross mesh cuts, and stays
/// unlabelled otherwise (it has no mesh neighbour).
TEST(Segmentation, ReassignmentAcrossMeshCutsReachesIsolatedPoints) {
  const OrganizedCloud cloud = cast(160, 120, [](double a, double) { return 1.0 + 0.2 * a; });
  Mesh mesh = build_mesh(cloud);
  const NormalMap normals = compute_normals(cloud, mesh);
  const int u0 = 80, v0 = 60;
  for (int k = 0; k < 8; ++k) {  // cut every edge of (u0, v0), both directions
    mesh.edges(u0 + kNeighbourDu[k], v0 + kNeighbourDv[k]) &=
        static_cast<std::uint8_t>(~(1u << ((k + 4) % 8)));
  }
  mesh.edges(u0, v0) = 0;
  for (const bool across : {false, true}) {
    SegmentationSettings settings = preset("abw");
    settings.reassign_across_mesh_cuts = across;
    const Segmentation seg = segment(cloud, mesh, normals, settings);
    expect_consistent(cloud, seg, settings);
    ASSERT_EQ(seg.segments.size(), 1u);
    EXPECT_EQ(seg.labels(u0, v0), across ? 1 : 0) << "across " << across;
    EXPECT_EQ(seg.segments[0].pixel_count, 160 * 120 - (across ? 0 : 1));
  }
}

/// A face too small to keep (6 columns, below min_region_size here) meets a large plane at a
/// right-angle crease 1.5 m away. Its points next to the crease lie within 3 sigma(z) of the
/// large plane, so re-assignment by distance alone gives them to it; their normals are 90 deg
/// off, and with the normal test (default 60 deg) only the crease pixels, whose 1-ring normals
/// mix both faces, may join.
TEST(Segmentation, ReassignmentLeavesPointsOfAnotherFace) {
  const double a_end = 6.0 / kF;  // the strip: columns 320..325, then no data
  // Left: the plane x + z = 1.5; right: z - x = 1.5 (normals (1, 0, 1) and (-1, 0, 1) / sqrt 2).
  const OrganizedCloud cloud = cast(640, 480, [&](double a, double) {
    if (a <= 0) return 1.5 / (1.0 + a);
    return a < a_end ? 1.5 / (1.0 - a) : std::numeric_limits<double>::quiet_NaN();
  });
  const Mesh mesh = build_mesh(cloud);
  const NormalMap normals = compute_normals(cloud, mesh);
  SegmentationSettings settings = preset("kinect");
  settings.min_region_size = 6 * 480 + 1;  // the strip's own segment is dissolved
  const auto joined = [&](double max_angle) {
    settings.reassign_max_normal_angle = max_angle;
    const Segmentation seg = segment(cloud, mesh, normals, settings);
    expect_consistent(cloud, seg, settings);
    const int left = seg.labels(100, 240);
    EXPECT_NE(left, 0);
    int count = 0;  // strip pixels off the crease in the large plane's segment
    for (int v = 0; v < 480; ++v) {
      for (int u = 321; u < 640; ++u) count += left != 0 && seg.labels(u, v) == left;
    }
    return count;
  };
  const int by_distance = joined(kPi);
  const int with_normals = joined(preset("kinect").reassign_max_normal_angle);
  std::printf("strip pixels joining the large plane: distance only %d, with the normal test %d\n",
              by_distance, with_normals);
  EXPECT_GE(by_distance, 480);  // at least a column
  EXPECT_EQ(with_normals, 0);
}

TEST(Segmentation, HolesAreNeverLabelledAndAreaIsCorrect) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  // A fronto-parallel plane at 1.5 m with 5% random holes and a rectangular hole.
  OrganizedCloud cloud = cast(640, 480, [](double, double) { return 1.5; });
  const OrganizedCloud full = cloud;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      if (uniform(rng) < 0.05 || (u > 200 && u < 260 && v > 100 && v < 300)) {
        cloud.x(u, v) = cloud.y(u, v) = cloud.z(u, v) = NAN;
      }
    }
  }
  const SegmentationSettings settings = preset("kinect");
  const Pipeline p = run(cloud, settings);
  expect_consistent(cloud, p.seg, settings);
  ASSERT_EQ(p.seg.segments.size(), 1u);
  // The area is that of the mesh faces: at most the full view's area (z/f per pixel squared).
  const double pixel_area = (1.5 / kF) * (1.5 / kF);
  const double full_area = 639.0 * 479.0 * pixel_area;
  EXPECT_LT(p.seg.segments[0].area_m2, full_area);
  EXPECT_GT(p.seg.segments[0].area_m2, 0.7 * full_area);
  const Pipeline q = run(full, settings);
  ASSERT_EQ(q.seg.segments.size(), 1u);
  EXPECT_NEAR(q.seg.segments[0].area_m2, full_area, 1e-6 * full_area);
}

/// Segment areas against a slow double sum over the explicit face list (each face split evenly
/// among its corners' labels), on a scene with a crease, a step, holes and both triangle
/// diagonals (and as a quad mesh), and identical on every instruction set of the vectorised face
/// areas.
TEST(Segmentation, AreasMatchTheFaceListOnEveryInstructionSet) {
  using rangeseg::detail::simd::Isa;
  OrganizedCloud cloud = cast(203, 151, [](double a, double b) {
    // (a in [-0.61, -0.22], b in [-0.46, -0.17] on this image)
    return (a > -0.4 ? 1.2 + 2.0 * (a + 0.4) : 1.2) + (b > -0.3 ? 0.4 : 0.0) + 0.3 * a * a;
  });
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if ((u * 7 + v * 3) % 61 == 0) cloud.x(u, v) = cloud.y(u, v) = cloud.z(u, v) = NAN;
    }
  }
  for (const MeshType type : {MeshType::adaptive, MeshType::quad}) {
    SCOPED_TRACE(type == MeshType::quad ? "quad mesh" : "adaptive mesh");
    const Mesh mesh = build_mesh(cloud, {.type = type});
    const NormalMap normals = compute_normals(cloud, mesh);
    rangeseg::TriangleList faces;
    rangeseg::extract_faces(mesh, false, faces);
    const auto corners = static_cast<std::size_t>(faces.vertices_per_face);
    ASSERT_EQ(corners, type == MeshType::quad ? 4u : 3u);

    rangeseg::detail::simd::isa_limit = Isa::baseline;
    Segmentation baseline;
    segment(cloud, mesh, normals, preset("kinect"), baseline);
    ASSERT_GE(baseline.segments.size(), 2u);
    std::vector<double> reference(baseline.segments.size() + 1, 0.0);
    const int w = cloud.width();
    for (std::size_t f = 0; f < faces.indices.size(); f += corners) {
      std::array<std::array<double, 3>, 4> p{};
      std::array<int, 4> label{};
      for (std::size_t k = 0; k < corners; ++k) {
        const int i = faces.indices[f + k], u = i % w, v = i / w;
        p[k] = {cloud.x(u, v), cloud.y(u, v), cloud.z(u, v)};
        label[k] = baseline.labels(u, v);
      }
      // Half the cross product of the diagonals (a triangle's: of two edges from one corner).
      const auto& q = corners == 4 ? p[3] : p[0];
      const std::array<double, 3> e{p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
      const std::array<double, 3> g{p[1][0] - q[0], p[1][1] - q[1], p[1][2] - q[2]};
      const double cx = e[1] * g[2] - e[2] * g[1], cy = e[2] * g[0] - e[0] * g[2],
                   cz = e[0] * g[1] - e[1] * g[0];
      const double area = 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
      for (std::size_t k = 0; k < corners; ++k) {
        reference[static_cast<std::size_t>(label[k])] += area / static_cast<double>(corners);
      }
    }
    for (const rangeseg::Segment& seg : baseline.segments) {
      EXPECT_NEAR(seg.area_m2, reference[static_cast<std::size_t>(seg.label)],
                  1e-5 * reference[static_cast<std::size_t>(seg.label)])
          << "segment " << seg.label;
    }
    for (Isa isa : {Isa::avx2, Isa::avx512}) {
      rangeseg::detail::simd::isa_limit = isa;
      Segmentation wide;
      segment(cloud, mesh, normals, preset("kinect"), wide);
      ASSERT_EQ(wide.segments.size(), baseline.segments.size());
      for (std::size_t j = 0; j < wide.segments.size(); ++j) {
        EXPECT_EQ(wide.segments[j].area_m2, baseline.segments[j].area_m2) << "isa " << int(isa);
      }
    }
  }
  rangeseg::detail::simd::isa_limit = Isa::avx512;
}

/// min_region_size counts pixels, which undercounts a face seen obliquely: a face of 154 pixels
/// (7 columns, 22 rows) inclined by 75 deg to the view, 1 m away, is 27 x 22 pixel footprints in
/// 3D, wider than sqrt(2 * 200) = 20 in both directions, so it is kept; a frontal patch of 144
/// pixels (12 x 12 footprints) beside it is not.
TEST(Segmentation, ObliqueSmallFaceIsKeptButAFrontalPatchIsNot) {
  const double slope = std::tan(75 * kDeg);
  const double a_face = (303.0 - kCx) / kF;  // the face's centre column
  const OrganizedCloud cloud = cast(640, 480, [&](double a, double b) {
    const double u = a * kF + kCx, v = b * kF + kCy;
    if (u >= 300 && u < 307 && v >= 229 && v < 251) {
      return (1.0 - slope * a_face) / (1.0 - slope * a);  // z = 1 + slope (x - x_face)
    }
    if (u >= 400 && u < 412 && v >= 234 && v < 246) return 1.0;
    return 2.0;
  });
  const SegmentationSettings settings = preset("kinect");
  ASSERT_EQ(settings.min_region_size, 200);
  const Pipeline p = run(cloud, settings);
  expect_consistent(cloud, p.seg, settings);
  ASSERT_EQ(p.seg.segments.size(), 2u);
  const int face = p.seg.labels(303, 240);
  ASSERT_NE(face, 0);
  EXPECT_GT(p.seg.segments[face - 1].pixel_count, 140);
  EXPECT_LT(p.seg.segments[face - 1].pixel_count, 200);
  const std::array<double, 3> normal{std::sin(75 * kDeg), 0.0, -std::cos(75 * kDeg)};
  EXPECT_LT(angle_deg(p.seg.segments[face - 1].normal, normal), 1.0);
  EXPECT_EQ(p.seg.labels(405, 240), 0);
}

/// A table top 0.3 m below the sensor, 2-3 m away (seen at 6-8.5 deg), with its front face and
/// a wall at 4 m, Kinect noise along the ray and one smoothing pass, as the pipeline runs. The
/// top's rows lie 4-7 cm apart in depth against 1-1.5 cm of noise, so its 1-ring normals are off
/// by tens of degrees and growth leaves it in unlabelled fragments; the grazing-plane search
/// fits it whole. The top is 1 m wide and 0.6 m deep (0.6 m^2).
struct GrazingTop {
  double coverage = 0;             ///< share of the top's valid pixels in its best segment
  std::array<double, 3> normal{};  ///< that segment's normal
  double area = 0;                 ///< its area_m2 [m^2]
  double open_area = 0;            ///< its area over the mesh's own faces (compute_areas) [m^2]
  bool grazing = false;
  /// Summed |difference| of every segment's area_m2 and its area over the mesh that
  /// close_grazing_cells closed [m^2].
  double closed_mismatch = 0;
};

GrazingTop grazing_top(const SegmentationSettings& settings) {
  constexpr double kTop = 0.2, kFront = 2.4, kBack = 3.0, kHalfWidth = 0.5;
  std::mt19937 rng(29);
  std::normal_distribution<double> unit(0.0, 1.0);
  const SegmentationSettings kinect = preset("kinect");
  LabelImage truth(640, 480);
  const OrganizedCloud raw = cast(640, 480, [&](double a, double b) {
    double t = 4.0;  // wall
    int label = 0;
    if (b > 0 && std::abs(a) * kTop / b <= kHalfWidth) {
      const double on_top = kTop / b;  // depth where the ray meets the plane y = kTop
      if (on_top >= kFront && on_top <= kBack) {
        t = on_top;
        label = 1;
      } else if (on_top < kFront && b * kFront <= 0.8 && std::abs(a) * kFront <= kHalfWidth) {
        t = kFront;  // the front face, down to 0.8 m below the sensor
      }
    }
    const int u = static_cast<int>(std::lround(a * kF + kCx));
    const int v = static_cast<int>(std::lround(b * kF + kCy));
    truth(u, v) = label;
    return t + kinect.noise.sigma(t) * unit(rng);
  });
  const Mesh mesh = build_mesh(raw);
  OrganizedCloud points;
  NormalMap normals;
  smooth(raw, mesh, compute_normals(raw, mesh), {.iterations = 1}, points, normals);
  Segmentation seg = segment(points, mesh, normals, settings);
  expect_consistent(points, seg, settings);
  std::map<int, int> hits;
  int top_pixels = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      if (truth(u, v) != 1) continue;
      ++top_pixels;
      if (seg.labels(u, v) != 0) ++hits[seg.labels(u, v)];
    }
  }
  EXPECT_GT(top_pixels, 1500);
  std::pair<int, int> best{0, 0};
  for (const auto& [label, count] : hits) {
    if (count > best.second) best = {label, count};
  }
  GrazingTop out;
  if (best.first == 0) return out;
  const Segment& top = seg.segments[static_cast<std::size_t>(best.first - 1)];
  out.coverage = static_cast<double>(best.second) / top_pixels;
  out.normal = top.normal;
  out.area = top.area_m2;
  out.grazing = top.grazing;
  Segmentation areas = seg;
  Segmenter segmenter;
  segmenter.compute_areas(points, mesh, areas);
  out.open_area = areas.segments[static_cast<std::size_t>(best.first - 1)].area_m2;
  Mesh closed = mesh;
  close_grazing_cells(seg, closed);
  // The closed mesh stays a mesh: every edge is known at both ends.
  for (int v = 1; v + 1 < 480; ++v) {
    for (int u = 1; u + 1 < 640; ++u) {
      for (int k = 0; k < 8; ++k) {
        const int back =
            (closed.edges(u + kNeighbourDu[k], v + kNeighbourDv[k]) >> ((k + 4) % 8)) & 1;
        EXPECT_EQ((closed.edges(u, v) >> k) & 1, back) << u << "," << v << " direction " << k;
      }
    }
  }
  segmenter.compute_areas(points, closed, areas);
  for (std::size_t j = 0; j < seg.segments.size(); ++j) {
    out.closed_mismatch += std::abs(seg.segments[j].area_m2 - areas.segments[j].area_m2);
  }
  return out;
}

TEST(Segmentation, TableTopSeenAtGrazingIncidenceIsOneSegment) {
  const SegmentationSettings kinect = preset("kinect");
  const GrazingTop top = grazing_top(kinect);
  EXPECT_GT(top.coverage, 0.9);
  EXPECT_LT(angle_deg(top.normal, {0.0, -1.0, 0.0}), 1.0);
  // The mesh has few faces there; the area counts the top's cells closed, as the mesh that
  // close_grazing_cells closes does.
  EXPECT_TRUE(top.grazing);
  EXPECT_LT(top.open_area, 0.2 * 0.6);
  EXPECT_NEAR(top.area, 0.6, 0.2 * 0.6);  // less a rim of half a pixel: 9 rows deep
  EXPECT_LT(top.closed_mismatch, 1e-9);
  SegmentationSettings off = kinect;
  off.grazing_min_angle = 0;  // without the search, growth leaves the top in fragments
  EXPECT_LT(grazing_top(off).coverage, 0.5);
}

/// A box 2-2.6 m away, noise-free, with the sensor's noise model set to 0.5 mm: its top (0.3 m
/// below the sensor, 6.6-8.5 deg to the rays) and its side (0.35 m to the left, 7.7-10 deg) lose
/// their mesh faces, as the angle test cuts edges that steep and the noise no longer explains the
/// depth steps. Both are left to the grazing-plane search as one unlabelled component, joined at
/// the box's edge, whose least-squares plane is neither. The search starts from the best sampled
/// plane, takes the top or the side, and searches the rest again: both become segments.
TEST(Segmentation, GrazingTopAndSideOfOneComponentAreTwoSegments) {
  constexpr double kTop = 0.3, kSide = -0.35, kFar = -0.9, kBottom = 0.8;
  constexpr double kFront = 2.0, kBack = 2.6;
  LabelImage truth(640, 480);  // 1 top, 2 side
  const OrganizedCloud cloud = cast(640, 480, [&](double a, double b) {
    double t = 4.0;  // wall
    int label = 0;
    const auto hit = [&](double depth, int surface) {
      if (depth < t) t = depth, label = surface;
    };
    if (a * kFront >= kFar && a * kFront <= kSide && b * kFront >= kTop && b * kFront <= kBottom) {
      hit(kFront, 0);
    }
    if (b > 0) {
      const double on_top = kTop / b;
      if (on_top >= kFront && on_top <= kBack && a * on_top >= kFar && a * on_top <= kSide) {
        hit(on_top, 1);
      }
    }
    if (a < 0) {
      const double on_side = kSide / a;
      if (on_side >= kFront && on_side <= kBack && b * on_side >= kTop && b * on_side <= kBottom) {
        hit(on_side, 2);
      }
    }
    truth(static_cast<int>(std::lround(a * kF + kCx)),
          static_cast<int>(std::lround(b * kF + kCy))) = label;
    return t;
  });
  const SensorNoise exact{.a = 0.0005, .b = 0.0, .z0 = 0.0};
  SegmentationSettings settings = preset("kinect");
  settings.noise = exact;
  Pipeline p;
  p.mesh = build_mesh(cloud, {.noise = exact});
  p.normals = compute_normals(cloud, p.mesh);
  segment(cloud, p.mesh, p.normals, settings, p.seg);
  expect_consistent(cloud, p.seg, settings);
  const std::array<std::array<double, 3>, 2> normals{{{0.0, -1.0, 0.0}, {1.0, 0.0, 0.0}}};
  for (int surface = 1; surface <= 2; ++surface) {
    std::map<int, int> hits;
    int pixels = 0;
    for (int v = 0; v < 480; ++v) {
      for (int u = 0; u < 640; ++u) {
        if (truth(u, v) != surface) continue;
        ++pixels;
        ++hits[p.seg.labels(u, v)];
      }
    }
    ASSERT_GT(pixels, 1500) << "surface " << surface;
    const auto best = std::max_element(
        hits.begin(), hits.end(), [](const auto& x, const auto& y) { return x.second < y.second; });
    ASSERT_NE(best->first, 0) << "surface " << surface << " left unlabelled";
    EXPECT_GT(best->second, 0.9 * pixels) << "surface " << surface;
    const Segment& segment = p.seg.segments[static_cast<std::size_t>(best->first - 1)];
    EXPECT_TRUE(segment.grazing) << "surface " << surface;
    const std::array<double, 3> n = normals[static_cast<std::size_t>(surface - 1)];
    const std::array<double, 3> flipped{-n[0], -n[1], -n[2]};
    EXPECT_LT(std::min(angle_deg(segment.normal, n), angle_deg(segment.normal, flipped)), 0.5)
        << "surface " << surface;
  }
}

/// Mixed pixels along a depth step (a laser scanner's veil): 10 columns between a plate at 1.5 m
/// and a wall at 3 m whose depths step evenly from one to the other. They lie on one plane, but
/// it runs within 1.5 deg of the viewing rays (0.15 m per column against a 3 mm footprint), as a
/// surface through the sensor would: no segment. With a lower grazing_min_angle they become one.
TEST(Segmentation, VeilAlongADepthStepIsNoGrazingPlane) {
  const OrganizedCloud cloud = cast(640, 480, [&](double a, double) {
    const double u = a * kF + kCx;
    if (u < 300) return 1.5;
    if (u >= 310) return 3.0;
    return 1.5 + 1.5 * (u - 299.5) / 11.0;
  });
  SegmentationSettings settings = preset("kinect");
  const Pipeline p = run(cloud, settings);
  expect_consistent(cloud, p.seg, settings);
  EXPECT_EQ(p.seg.segments.size(), 2u);
  for (int v = 0; v < 480; v += 7) {
    for (int u = 301; u < 309; ++u) EXPECT_EQ(p.seg.labels(u, v), 0) << u << "," << v;
  }
  settings.grazing_min_angle = 0.2 * kDeg;
  const Pipeline q = run(cloud, settings);
  EXPECT_EQ(q.seg.segments.size(), 3u);
  EXPECT_NE(q.seg.labels(305, 240), 0);
}

TEST(Segmentation, MinRegionSizeRemovesSmallSegments) {
  // An 8x8 pixel patch at 1 m in front of a plane at 2 m.
  const auto depth = [](double a, double b) {
    const double u = a * kF + kCx, v = b * kF + kCy;
    return (u >= 300 && u < 308 && v >= 200 && v < 208) ? 1.0 : 2.0;
  };
  const OrganizedCloud cloud = cast(640, 480, depth);
  SegmentationSettings settings = preset("kinect");
  settings.min_region_size = 100;
  const Pipeline p = run(cloud, settings);
  expect_consistent(cloud, p.seg, settings);
  ASSERT_EQ(p.seg.segments.size(), 1u);
  for (int v = 200; v < 208; ++v) {
    for (int u = 300; u < 308; ++u) EXPECT_EQ(p.seg.labels(u, v), 0);
  }
  settings.min_region_size = 20;
  const Pipeline q = run(cloud, settings);
  expect_consistent(cloud, q.seg, settings);
  ASSERT_EQ(q.seg.segments.size(), 2u);
  EXPECT_EQ(q.seg.segments[1].pixel_count, 64);
}

TEST(Segmentation, SmoothModelSeparatesSphereFromPlane) {
  // A sphere of radius 0.4 m centred 2 m away in front of a plane at 3 m.
  const double cz = 2.0, radius = 0.4;
  const auto depth = [&](double a, double b) {
    const double dd = a * a + b * b + 1.0;  // |ray|^2 for ray (a, b, 1)
    const double bq = -2.0 * cz, cq = cz * cz - radius * radius;
    const double disc = bq * bq - 4.0 * dd * cq;
    if (disc >= 0) return (-bq - std::sqrt(disc)) / (2.0 * dd);
    return 3.0;
  };
  const OrganizedCloud cloud = cast(640, 480, depth);
  SegmentationSettings settings = preset("kinect");
  settings.model = RegionModel::smooth;
  const Pipeline p = run(cloud, settings);
  expect_consistent(cloud, p.seg, settings);
  ASSERT_EQ(p.seg.segments.size(), 2u);
  const int sphere = p.seg.labels(320, 240), plane = p.seg.labels(20, 20);
  EXPECT_NE(sphere, 0);
  EXPECT_NE(plane, 0);
  EXPECT_NE(sphere, plane);
  EXPECT_EQ(p.seg.segments[sphere - 1].model, SegmentModel::smooth);
  // Most of the sphere's pixels are in one segment (rim pixels at grazing angles may not be).
  int sphere_pixels = 0, in_segment = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      if (cloud.z(u, v) < 2.9f) {
        ++sphere_pixels;
        in_segment += p.seg.labels(u, v) == sphere;
      }
    }
  }
  EXPECT_GT(in_segment, 0.95 * sphere_pixels);
  EXPECT_GT(p.seg.segments[sphere - 1].rms_residual, 0.01);  // not a plane
}

TEST(Segmentation, SegmenterReuseGivesIdenticalResults) {
  const OrganizedCloud cloud =
      cast(320, 240, [](double a, double) { return 2.0 / (1.0 - std::fabs(a)); });
  const Mesh mesh = build_mesh(cloud);
  const NormalMap normals = compute_normals(cloud, mesh);
  Segmenter segmenter;
  Segmentation first, out;
  segmenter.segment(cloud, mesh, normals, preset("kinect"), first);
  segmenter.segment(cloud, mesh, normals, preset("kinect"), out);
  const auto* data = out.labels.row(0);
  segmenter.segment(cloud, mesh, normals, preset("kinect"), out);
  EXPECT_EQ(out.labels.row(0), data);  // the label buffer is reused
  ASSERT_EQ(out.segments.size(), first.segments.size());
  for (int v = 0; v < 240; ++v) {
    for (int u = 0; u < 320; ++u) ASSERT_EQ(out.labels(u, v), first.labels(u, v));
  }
}

/// Growth bands cut every region that crosses a seam; merging over the whole frame joins the
/// pieces again. A noisy floor-like plane crossing all three seams of 4 bands is one segment as
/// large as without bands, and a crease across the seams still splits the frame where it runs
/// (noise of half the Kinect preset's sigma(z) along the ray, no smoothing).
TEST(Segmentation, GrowthBandSeamsAreJoinedButCreasesAreNot) {
  SegmentationSettings settings = preset("kinect");
  std::mt19937 rng(7);
  std::normal_distribution<double> unit(0.0, 1.0);
  const auto noisy = [&](const std::function<double(double, double)>& depth) {
    return cast(640, 480, [&](double a, double b) {
      const double t = depth(a, b);
      return t + 0.5 * settings.noise.sigma(t) * unit(rng);
    });
  };
  // A plane tilted 40 deg about the x axis, 1.5 m away at the image centre.
  const double tilt = std::tan(40 * kDeg);
  const OrganizedCloud floor = noisy([tilt](double, double b) { return 1.5 / (1.0 - tilt * b); });
  const Pipeline whole = run(floor, settings);
  settings.growth_bands = 4;
  const Pipeline banded = run(floor, settings);
  expect_consistent(floor, banded.seg, settings);
  ASSERT_EQ(whole.seg.segments.size(), 1u);
  ASSERT_EQ(banded.seg.segments.size(), 1u);
  EXPECT_GT(banded.seg.segments[0].pixel_count, 0.95 * 640 * 480);
  EXPECT_NEAR(banded.seg.segments[0].pixel_count, whole.seg.segments[0].pixel_count,
              0.002 * 640 * 480);
  EXPECT_LT(angle_deg(banded.seg.segments[0].normal, whole.seg.segments[0].normal), 0.05);

  // Two planes at 1.2 m meeting at a 30 deg crease along the column u = 320.
  const double slope = std::tan(30 * kDeg);
  const OrganizedCloud crease =
      noisy([slope](double a, double) { return a <= 0 ? 1.2 : 1.2 / (1.0 - slope * a); });
  const Pipeline q = run(crease, settings);
  expect_consistent(crease, q.seg, settings);
  ASSERT_EQ(q.seg.segments.size(), 2u);
  for (const int v : {20, 130, 240, 350, 460}) {
    EXPECT_EQ(q.seg.labels(100, v), q.seg.labels(100, 20)) << v;
    EXPECT_EQ(q.seg.labels(540, v), q.seg.labels(540, 20)) << v;
  }
  EXPECT_NE(q.seg.labels(100, 20), q.seg.labels(540, 20));
  EXPECT_NE(q.seg.labels(100, 20), 0);
  EXPECT_NE(q.seg.labels(540, 20), 0);
}

/// A band is at least 4 cell rows tall: more bands than that allows give the largest count
/// that fits (7 at 240 rows = 30 cell rows; 3 at 241 rows with mesh stride 2 = 15 cell rows of
/// lattice rows, the last band taking the partial cell row; 1 at 48 rows), and the results with
/// a thread pool equal those without (bands are split among the threads, never the other way
/// round).
TEST(Segmentation, GrowthBandsAreClampedAndIndependentOfThreads) {
  const auto boxes = [](double a, double b) {
    return a < -0.1 ? 1.2 : (b > 0.05 ? 1.0 / (0.8 + 0.4 * b) : 1.6 - 0.5 * a);
  };
  struct Case {
    int height, stride, bands;
  };
  for (const Case c : {Case{240, 1, 7}, Case{241, 2, 3}, Case{48, 1, 1}}) {
    const OrganizedCloud cloud = cast(320, c.height, boxes);
    const Mesh mesh = build_mesh(cloud, {.pixel_stride = c.stride});
    const NormalMap normals = compute_normals(cloud, mesh);
    SegmentationSettings settings = preset("kinect");
    settings.growth_bands = c.bands;
    const Segmentation expected = segment(cloud, mesh, normals, settings);
    expect_consistent(cloud, expected, settings);
    ASSERT_GE(expected.segments.size(), 2u) << c.height;
    settings.growth_bands = 64;
    for (const int threads : {1, 2, 3}) {
      Segmenter segmenter;
      ThreadPool pool(threads);
      Segmentation out;
      segmenter.segment(cloud, mesh, normals, settings, out, pool);
      ASSERT_EQ(out.segments.size(), expected.segments.size()) << c.height << " " << threads;
      for (int v = 0; v < c.height; ++v) {
        for (int u = 0; u < 320; ++u) {
          ASSERT_EQ(out.labels(u, v), expected.labels(u, v))
              << u << "," << v << " " << c.height << " " << threads;
        }
      }
    }
  }
}

/// Growth bands on frames of many shapes (thin, tiny, odd heights, mesh strides 1-3, holes):
/// never a crash, and the same segmentation with and without threads.
TEST(Segmentation, GrowthBandsOnAnyFrameShape) {
  std::mt19937 rng(5);
  for (const int height : {2, 31, 32, 33, 63, 97, 130}) {
    for (const int width : {2, 3, 40}) {
      for (const int stride : {1, 2, 3}) {
        std::uniform_real_distribution<double> hole(0.0, 1.0);
        const OrganizedCloud cloud = cast(width, height, [&](double a, double b) {
          return hole(rng) < 0.05 ? NAN : (b > 0.0 ? 1.0 + 0.3 * a : 1.5);
        });
        const Mesh mesh = build_mesh(cloud, {.pixel_stride = stride});
        const NormalMap normals = compute_normals(cloud, mesh);
        SegmentationSettings settings = preset("kinect");
        settings.min_region_size = 4;
        settings.growth_bands = 64;
        const Segmentation one = segment(cloud, mesh, normals, settings);
        expect_consistent(cloud, one, settings);
        ThreadPool pool(2);
        Segmenter segmenter;
        Segmentation two;
        segmenter.segment(cloud, mesh, normals, settings, two, pool);
        ASSERT_EQ(two.segments.size(), one.segments.size()) << width << "x" << height;
        for (int v = 0; v < height; ++v) {
          for (int u = 0; u < width; ++u) ASSERT_EQ(two.labels(u, v), one.labels(u, v));
        }
      }
    }
  }
}

TEST(Segmentation, MeshStrideLabelsOnlyLatticeVertices) {
  // Left half (u < 160) at 1 m, right half at 2 m.
  const OrganizedCloud cloud =
      cast(320, 240, [](double a, double) { return a * kF + kCx < 160 ? 1.0 : 2.0; });
  const Mesh mesh = build_mesh(cloud, {.pixel_stride = 2});
  const NormalMap normals = compute_normals(cloud, mesh);
  const SegmentationSettings settings = preset("kinect");
  const Segmentation seg = segment(cloud, mesh, normals, settings);
  expect_consistent(cloud, seg, settings);
  EXPECT_EQ(seg.segments.size(), 2u);
  for (int v = 0; v < 240; ++v) {
    for (int u = 0; u < 320; ++u) {
      if (u % 2 != 0 || v % 2 != 0) {
        EXPECT_EQ(seg.labels(u, v), 0);
      }
    }
  }
}

TEST(Segmentation, PresetsAndValidation) {
  EXPECT_NO_THROW(preset("kinect"));
  EXPECT_NEAR(preset("abw").noise.sigma(1.0), 0.0005, 1e-12);
  EXPECT_NEAR(preset("kinect").noise.sigma(2.4), 0.0012 + 0.0019 * 4.0, 1e-12);
  EXPECT_TRUE(preset("abw").reassign_across_mesh_cuts);
  EXPECT_FALSE(preset("kinect").reassign_across_mesh_cuts);
  EXPECT_GE(preset("laser").noise.sigma(10.0), 0.01);
  EXPECT_NEAR(preset("ideal").noise.sigma(5.0), 0.0005, 1e-12);
  EXPECT_FALSE(pipeline_preset("ideal").smooth);
  EXPECT_TRUE(pipeline_preset("kinect").smooth);
  try {
    preset("lidar");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("lidar"), std::string::npos);
    EXPECT_NE(what.find("kinect"), std::string::npos);
    EXPECT_NE(what.find("abw"), std::string::npos);
    EXPECT_NE(what.find("laser"), std::string::npos);
    EXPECT_NE(what.find("ideal"), std::string::npos);
  }
  const OrganizedCloud cloud = cast(64, 48, [](double, double) { return 1.0; });
  const Mesh mesh = build_mesh(cloud);
  const NormalMap normals = compute_normals(cloud, mesh);
  const OrganizedCloud other = cast(32, 48, [](double, double) { return 1.0; });
  Segmentation out;
  EXPECT_THROW(segment(other, mesh, normals, {}, out), std::invalid_argument);
  EXPECT_THROW(segment(cloud, mesh, normals, {.max_distance_sigmas = 0}, out),
               std::invalid_argument);
  EXPECT_THROW(segment(cloud, mesh, normals, {.min_region_size = 0}, out), std::invalid_argument);
  EXPECT_THROW(segment(cloud, mesh, normals, {.normal_noise_sigmas = -1}, out),
               std::invalid_argument);
  EXPECT_THROW(segment(cloud, mesh, normals, {.min_normal_angle = 4}, out), std::invalid_argument);
  EXPECT_THROW(segment(cloud, mesh, normals, {.reassign_max_normal_angle = -0.1}, out),
               std::invalid_argument);
  EXPECT_THROW(segment(cloud, mesh, normals, {.seed_clearance = -1}, out), std::invalid_argument);
  EXPECT_THROW(segment(cloud, mesh, normals, {.growth_bands = 0}, out), std::invalid_argument);
  EXPECT_THROW(segment(cloud, mesh, normals, {.growth_bands = 65}, out), std::invalid_argument);
  EXPECT_THROW(segment(cloud, mesh, normals, {.split_residual_factor = -1}, out),
               std::invalid_argument);
  EXPECT_THROW(segment(cloud, mesh, normals, {.split_residual_factor = NAN}, out),
               std::invalid_argument);
  EXPECT_THROW(segment(cloud, mesh, normals, {.grazing_min_angle = -0.1}, out),
               std::invalid_argument);
  EXPECT_THROW(
      segment(cloud, mesh, normals, {.grazing_min_angle = 0.3, .grazing_max_angle = 0.2}, out),
      std::invalid_argument);
  EXPECT_THROW(segment(cloud, mesh, normals, {.grazing_max_angle = NAN}, out),
               std::invalid_argument);
  EXPECT_THROW(segment(OrganizedCloud(64, 1), mesh, normals, {}, out), std::invalid_argument);
  // close_grazing_cells: sizes must match and labels must name segments.
  segment(cloud, mesh, normals, {}, out);
  ASSERT_EQ(out.segments.size(), 1u);
  out.segments[0].grazing = true;
  Mesh small = build_mesh(other);
  EXPECT_THROW(close_grazing_cells(out, small), std::invalid_argument);
  Mesh closed = mesh;
  out.labels(5, 5) = 7;
  EXPECT_THROW(close_grazing_cells(out, closed), std::invalid_argument);
}

// --- synthetic Kinect scenes with ground truth ---

TEST(Segmentation, SyntheticKinectScenesDetectPlanes) {
  const SegmentationSettings settings = preset("kinect");
  int gt_total = 0, correct_total = 0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    // Planar regions of reasonable size: at least 1000 pixels (smaller ones get label 0).
    const synth::Rendering r =
        synth::render(synth::random_scene(seed),
                      {.noise = synth::Noise::kinect, .seed = seed, .min_surface_pixels = 1000});
    // Beyond ~3 m the disparity quantisation step (z^2 / (b f s) ~ 5 cm at 4 m) makes edges
    // between neighbouring terraces nearly parallel to the viewing ray; the default 12.5 deg
    // occlusion test would cut the mesh there, so a 3 deg one is used.
    const Mesh mesh = build_mesh(r.cloud, {.eps_theta = 0.05f});
    const NormalMap normals = compute_normals(r.cloud, mesh);
    OrganizedCloud smoothed;
    NormalMap smoothed_normals;
    smooth(r.cloud, mesh, normals, {}, smoothed, smoothed_normals);
    const Segmentation seg = segment(smoothed, mesh, smoothed_normals, settings);
    expect_consistent(smoothed, seg, settings);
    const eval::EvalResult e = eval::evaluate(r.labels, seg.labels, {.tolerance = 0.8});
    std::printf("random_scene(%llu): GT %d, correct %d, over %d, under %d, missed %d, noise %d\n",
                static_cast<unsigned long long>(seed), e.gt_regions, e.correct, e.over, e.under,
                e.missed, e.noise);
    gt_total += e.gt_regions;
    correct_total += e.correct;
  }
  std::printf("synthetic Kinect: %d of %d GT planes correct (%.1f%%)\n", correct_total, gt_total,
              100.0 * correct_total / gt_total);
  // Target 90%; reached 86% here (25 of 29, 2026-12-01).
  EXPECT_GE(correct_total, 0.7 * gt_total);
}

// --- SegComp ABW ---

TEST(Segmentation, SegCompAbw) {
  RANGESEG_REQUIRE_DATA("segcomp_abw/abw.test.0.range");
  const auto dir = data_file.parent_path();
  // The same settings as `rangeseg eval-segcomp` (pipeline_preset("abw"): no smoothing).
  const PipelineSettings pipeline = pipeline_preset("abw");
  ASSERT_FALSE(pipeline.smooth);
  const SegmentationSettings& settings = pipeline.segmentation;
  std::vector<eval::EvalResult> results;
  for (int i = 0; i < 10; ++i) {
    const std::string stem = (dir / ("abw.test." + std::to_string(i))).string();
    const OrganizedCloud cloud = io::read_abw_range(stem + ".range");
    const LabelImage gt = io::read_segcomp_gt(stem + ".gt-seg");
    const Mesh mesh = build_mesh(cloud, pipeline.mesh);
    const NormalMap normals = compute_normals(cloud, mesh, pipeline.normals);
    const Segmentation seg = segment(cloud, mesh, normals, settings);
    expect_consistent(cloud, seg, settings);
    const eval::EvalResult e =
        eval::evaluate(gt, seg.labels, {.tolerance = 0.8, .min_gt_label = 10});
    std::printf("abw.test.%d: GT %2d correct %2d over %d under %d missed %2d noise %2d\n", i,
                e.gt_regions, e.correct, e.over, e.under, e.missed, e.noise);
    results.push_back(e);
  }
  const eval::EvalSummary sum = eval::summarize(results);
  std::printf(
      "ABW mean: GT %.2f correct %.2f (%.1f%%) over %.2f under %.2f missed %.2f noise %.2f\n",
      sum.mean_gt, sum.mean_correct, 100.0 * sum.mean_correct / sum.mean_gt, sum.mean_over,
      sum.mean_under, sum.mean_missed, sum.mean_noise);
  // Target 85%, over + under <= 0.5, noise <= 2; reached 88.0% (over 0.1, under 0, noise 1.5)
  // since pieces of one plane merge when each lies on their union's plane within the plane's
  // measured residual, re-assignment also reaches points the mesh cut off (84.9%, over 0.6,
  // noise 3.2 before) and seeds may not touch a region (87.5%, over 0.2, noise 1.9 before).
  // Thresholds leave a little slack for cross-CPU rounding.
  EXPECT_GE(sum.mean_correct / sum.mean_gt, 0.87);
  EXPECT_LE(sum.mean_over + sum.mean_under, 0.3);
  EXPECT_LE(sum.mean_noise, 1.7);
}

// --- real Kinect frame with a labelled table ---

TEST(Segmentation, OsdTableIsOneSegment) {
  RANGESEG_REQUIRE_DATA("osd/test0.pcd");
  const OrganizedCloud cloud = io::read_pcd(data_file.string());
  ASSERT_TRUE(cloud.has_label());
  const Mesh mesh = build_mesh(cloud);
  const NormalMap normals = compute_normals(cloud, mesh);
  const SegmentationSettings settings = preset("kinect");
  const Segmentation seg = segment(cloud, mesh, normals, settings);
  expect_consistent(cloud, seg, settings);
  std::map<int, int> overlap;
  int table = 0;
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      const int gt = cloud.label(u, v);
      if (gt < 1 || gt > 9 || !cloud.valid(u, v)) continue;
      ++table;
      ++overlap[seg.labels(u, v)];
    }
  }
  ASSERT_GT(table, 0);
  int best = 0, best_label = 0;
  for (const auto& [label, count] : overlap) {
    if (label != 0 && count > best) {
      best = count;
      best_label = label;
    }
  }
  std::printf("OSD test0: table %d pixels, %.1f%% in segment %d\n", table, 100.0 * best / table,
              best_label);
  EXPECT_GE(best, 0.9 * table);
}

}  // namespace
}  // namespace rangeseg
