// Post-processing of the segmentation (refit, merge, re-assignment, compaction, areas): the
// vector paths agree bit for bit across instruction sets, the segment areas equal a direct
// per-face sum over the mesh, and a reused Segmenter gives what a fresh one gives.
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "detail/simd.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/segmentation.hpp"
#include "rangeseg/smoothing.hpp"
#include "rangeseg/synth.hpp"
#include "rangeseg/thread_pool.hpp"
#include "test_util.hpp"

namespace {

using namespace rangeseg;
using rangeseg::detail::simd::Isa;

/// Restores the widest instruction set when a test ends (also on failure).
struct IsaGuard {
  ~IsaGuard() { rangeseg::detail::simd::isa_limit = Isa::avx512; }
};

struct Input {
  OrganizedCloud cloud;
  Mesh mesh;
  NormalMap normals;
};

/// A rendered random scene with Kinect noise, meshed and smoothed as in the pipeline (with the
/// 3 deg occlusion test of the synthetic segmentation tests, see test_segmentation_data.cpp).
Input synthetic_input(std::uint64_t seed, bool curved, int pixel_stride,
                      const CameraIntrinsics& camera = {.width = 640, .height = 480}) {
  const OrganizedCloud raw =
      synth::render(synth::random_scene(seed, curved),
                    {.camera = camera, .noise = synth::Noise::kinect, .seed = seed})
          .cloud;
  Input in;
  in.mesh = build_mesh(raw, {.eps_theta = 0.05f, .pixel_stride = pixel_stride});
  const NormalMap raw_normals = compute_normals(raw, in.mesh);
  smooth(raw, in.mesh, raw_normals, {}, in.cloud, in.normals);
  return in;
}

/// Settings variants that switch each post-processing step on and off.
std::vector<std::pair<std::string, SegmentationSettings>> variants() {
  std::vector<std::pair<std::string, SegmentationSettings>> out;
  for (const RegionModel model : {RegionModel::plane, RegionModel::smooth}) {
    SegmentationSettings s = preset("kinect");
    s.model = model;
    const std::string name = model == RegionModel::plane ? "plane" : "smooth";
    out.emplace_back(name, s);
    SegmentationSettings no_merge = s;
    no_merge.merge_planes = false;
    out.emplace_back(name + " no merge", no_merge);
    SegmentationSettings no_reassign = s;
    no_reassign.reassign_boundary = false;
    out.emplace_back(name + " no reassign", no_reassign);
    SegmentationSettings across = s;
    across.reassign_across_mesh_cuts = true;
    out.emplace_back(name + " across cuts", across);
  }
  return out;
}

bool same_bits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

/// Every label and every Segment field equal bit for bit.
void expect_identical(const Segmentation& a, const Segmentation& b, const std::string& what) {
  ASSERT_EQ(a.labels.width(), b.labels.width()) << what;
  ASSERT_EQ(a.labels.height(), b.labels.height()) << what;
  int differing_pixels = 0;
  for (int v = 0; v < a.labels.height(); ++v) {
    for (int u = 0; u < a.labels.width(); ++u) differing_pixels += a.labels(u, v) != b.labels(u, v);
  }
  EXPECT_EQ(differing_pixels, 0) << what;
  ASSERT_EQ(a.segments.size(), b.segments.size()) << what;
  for (std::size_t j = 0; j < a.segments.size(); ++j) {
    const Segment &sa = a.segments[j], &sb = b.segments[j];
    EXPECT_EQ(sa.label, sb.label) << what;
    EXPECT_EQ(sa.pixel_count, sb.pixel_count) << what << " segment " << j;
    EXPECT_TRUE(same_bits(sa.area_m2, sb.area_m2))
        << what << " segment " << j << ": " << sa.area_m2 << " vs " << sb.area_m2;
    EXPECT_TRUE(same_bits(sa.offset, sb.offset)) << what << " segment " << j;
    EXPECT_TRUE(same_bits(sa.rms_residual, sb.rms_residual)) << what << " segment " << j;
    for (int k = 0; k < 3; ++k) {
      EXPECT_TRUE(same_bits(sa.centroid[k], sb.centroid[k])) << what << " segment " << j;
      EXPECT_TRUE(same_bits(sa.normal[k], sb.normal[k])) << what << " segment " << j;
    }
  }
}

/// The slow way: every mesh face's area (in double) split equally among its corners, summed per
/// label in any order.
std::vector<double> face_areas_per_label(const OrganizedCloud& cloud, const Mesh& mesh,
                                         const LabelImage& labels, int segments) {
  std::vector<double> area(static_cast<std::size_t>(segments) + 1, 0.0);
  const int s = mesh.pixel_stride;
  const auto point = [&](int u, int v) {
    return std::array<double, 3>{cloud.x(u, v), cloud.y(u, v), cloud.z(u, v)};
  };
  const auto face = [&](const std::vector<std::array<int, 2>>& corners) {
    // Twice the area: |diagonal x diagonal| for a quad, |edge x edge| for a triangle.
    const bool quad = corners.size() == 4;
    const auto p0 = point(corners[0][0], corners[0][1]);
    const auto p1 = point(corners[1][0], corners[1][1]);
    const auto p2 = point(corners[2][0], corners[2][1]);
    const auto p3 = quad ? point(corners[3][0], corners[3][1]) : p0;
    std::array<double, 3> d1{}, d2{};
    for (int k = 0; k < 3; ++k) {
      d1[k] = quad ? p2[k] - p0[k] : p1[k] - p0[k];
      d2[k] = quad ? p3[k] - p1[k] : p2[k] - p0[k];
    }
    const double cx = d1[1] * d2[2] - d1[2] * d2[1], cy = d1[2] * d2[0] - d1[0] * d2[2],
                 cz = d1[0] * d2[1] - d1[1] * d2[0];
    const double share =
        0.5 * std::sqrt(cx * cx + cy * cy + cz * cz) / static_cast<double>(corners.size());
    for (const auto& c : corners) area[labels(c[0], c[1])] += share;
  };
  for (int v = 0; v + s < cloud.height(); v += s) {
    for (int u = 0; u + s < cloud.width(); u += s) {
      const std::uint8_t bits = mesh.faces(u, v);
      const std::array<int, 2> a{u, v}, b{u + s, v}, c{u, v + s}, d{u + s, v + s};
      if (bits & face_bits::quad) {
        face({a, c, d, b});
      } else if (bits & face_bits::diag_bc) {
        if (bits & face_bits::tri0) face({a, c, b});
        if (bits & face_bits::tri1) face({b, c, d});
      } else {
        if (bits & face_bits::tri0) face({a, d, b});
        if (bits & face_bits::tri1) face({a, c, d});
      }
    }
  }
  return area;
}

TEST(SegmentationPostprocess, InstructionSetsGiveIdenticalSegmentations) {
  IsaGuard guard;
  for (const int stride : {1, 2}) {
    const Input in = synthetic_input(3, true, stride);
    for (const auto& [name, settings] : variants()) {
      // Every variant at full resolution, the defaults of each model at stride 2 (for speed).
      if (stride == 2 && name.find(' ') != std::string::npos) continue;
      rangeseg::detail::simd::isa_limit = Isa::baseline;
      const Segmentation narrow = segment(in.cloud, in.mesh, in.normals, settings);
      ASSERT_GT(narrow.segments.size(), 2u) << name;
      for (const Isa isa : {Isa::avx2, Isa::avx512}) {
        rangeseg::detail::simd::isa_limit = isa;
        const Segmentation wide = segment(in.cloud, in.mesh, in.normals, settings);
        expect_identical(narrow, wide,
                         name + " stride " + std::to_string(stride) + " isa " +
                             std::to_string(static_cast<int>(isa)));
      }
    }
  }
}

TEST(SegmentationPostprocess, AreasEqualPerFaceSums) {
  for (const int stride : {1, 2}) {
    const Input in = synthetic_input(5, false, stride);
    for (const auto& [name, settings] : variants()) {
      if (name.find("no ") != std::string::npos) continue;  // fewer variants, for speed
      const Segmentation seg = segment(in.cloud, in.mesh, in.normals, settings);
      ASSERT_GT(seg.segments.size(), 2u) << name;
      const std::vector<double> expected = face_areas_per_label(
          in.cloud, in.mesh, seg.labels, static_cast<int>(seg.segments.size()));
      for (const Segment& segment : seg.segments) {
        // Float face areas (relative error ~1e-7 each) against double ones.
        EXPECT_NEAR(segment.area_m2, expected[segment.label], 1e-5 * expected[segment.label])
            << name << " stride " << stride << " segment " << segment.label;
        EXPECT_GT(segment.area_m2, 0.0) << name << " segment " << segment.label;
      }
    }
  }
}

TEST(SegmentationPostprocess, AreasComputedLaterEqualAreasComputedInline) {
  for (const int stride : {1, 2}) {
    const Input in = synthetic_input(6, false, stride);
    SegmentationSettings settings = preset("kinect");
    const Segmentation inline_areas = segment(in.cloud, in.mesh, in.normals, settings);
    settings.compute_area = false;
    Segmenter segmenter;
    Segmentation later;
    segmenter.segment(in.cloud, in.mesh, in.normals, settings, later);
    ASSERT_GT(later.segments.size(), 2u);
    for (const Segment& segment : later.segments) EXPECT_EQ(segment.area_m2, 0.0);
    // Inline areas count the cells of grazing segments closed (Segment::grazing), as the
    // mesh that close_grazing_cells closes has them.
    Mesh closed = in.mesh;
    close_grazing_cells(later, closed);
    segmenter.compute_areas(in.cloud, closed, later);
    expect_identical(inline_areas, later, "stride " + std::to_string(stride));
  }
  // A label that names no segment, or a label image of another size, is rejected.
  const Input in = synthetic_input(6, false, 1);
  Segmenter segmenter;
  Segmentation out;
  segmenter.segment(in.cloud, in.mesh, in.normals, preset("kinect"), out);
  Segmentation bad = out;
  bad.labels(5, 7) = static_cast<std::int32_t>(out.segments.size()) + 1;
  EXPECT_THROW(segmenter.compute_areas(in.cloud, in.mesh, bad), std::invalid_argument);
  bad.labels(5, 7) = -1;
  EXPECT_THROW(segmenter.compute_areas(in.cloud, in.mesh, bad), std::invalid_argument);
  bad = out;
  bad.labels.resize(10, 10, 0);
  EXPECT_THROW(segmenter.compute_areas(in.cloud, in.mesh, bad), std::invalid_argument);
}

TEST(SegmentationPostprocess, ReusedSegmenterMatchesFreshOne) {
  // Frames of different sizes and settings through one Segmenter (its scratch buffers, e.g.
  // the re-assignment queue flags, carry over), each compared with a fresh Segmenter.
  const Input large = synthetic_input(7, false, 1);
  const Input small = synthetic_input(
      8, false, 1,
      {.fx = 262.5, .fy = 262.5, .cx = 159.5, .cy = 119.5, .width = 320, .height = 240});
  Segmenter reused;
  Segmentation out;
  int frame = 0;
  const std::array<const Input*, 4> frames{&large, &small, &large, &small};
  for (const Input* in : frames) {
    for (const auto& [name, settings] : variants()) {
      if (name.find("no ") != std::string::npos) continue;  // fewer variants, for speed
      reused.segment(in->cloud, in->mesh, in->normals, settings, out);
      const Segmentation fresh = segment(in->cloud, in->mesh, in->normals, settings);
      expect_identical(fresh, out, name + " frame " + std::to_string(frame));
    }
    ++frame;
  }
}

TEST(SegmentationPostprocess, ThreadsGiveIdenticalSegmentations) {
  // The frame-wide passes (cells, seed scan, remaps, boundary and adjacency scans) split into
  // row bands: every model and post-processing variant, lattice strides 1 to 3, 2 and 3
  // threads through one Segmenter, against the single-threaded call.
  ThreadPool two(2), three(3);
  Segmenter threaded;
  Segmentation out;
  for (const int stride : {1, 2, 3}) {
    const Input in = synthetic_input(5, true, stride);
    auto settings = variants();
    for (const RegionModel model : {RegionModel::incremental_plane, RegionModel::automatic}) {
      SegmentationSettings s = preset("kinect");
      s.model = model;
      settings.emplace_back(model == RegionModel::automatic ? "auto" : "incremental", s);
    }
    for (const auto& [name, s] : settings) {
      if (stride > 1 && name.find(' ') != std::string::npos) continue;  // for speed
      const Segmentation serial = segment(in.cloud, in.mesh, in.normals, s);
      ASSERT_GT(serial.segments.size(), 2u) << name;
      for (ThreadPool* pool : {&two, &three}) {
        threaded.segment(in.cloud, in.mesh, in.normals, s, out, *pool);
        expect_identical(serial, out,
                         name + " stride " + std::to_string(stride) + " threads " +
                             std::to_string(pool->threads()));
      }
    }
  }
}

TEST(SegmentationPostprocess, RealFrameInstructionSetsAgree) {
  RANGESEG_REQUIRE_DATA("kinect/grabber_frame0.pcd");
  IsaGuard guard;
  const OrganizedCloud cloud = io::read_pcd(data_file.string());
  const Mesh mesh = build_mesh(cloud);
  const NormalMap normals = compute_normals(cloud, mesh);
  for (const auto& [name, settings] : variants()) {
    rangeseg::detail::simd::isa_limit = Isa::baseline;
    const Segmentation narrow = segment(cloud, mesh, normals, settings);
    for (const Isa isa : {Isa::avx2, Isa::avx512}) {
      rangeseg::detail::simd::isa_limit = isa;
      expect_identical(narrow, segment(cloud, mesh, normals, settings),
                       name + " isa " + std::to_string(static_cast<int>(isa)));
    }
  }
}

}  // namespace

namespace {

/// A plane segment of `pixels` points spread over `area` m^2 around `centroid`.
rangeseg::Segment plane_segment(int label, std::array<double, 3> normal,
                                std::array<double, 3> centroid, int pixels, double area,
                                double rms = 0.001) {
  const double length =
      std::sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
  for (double& c : normal) c /= length;
  rangeseg::Segment s;
  s.label = label;
  s.normal = normal;
  s.centroid = centroid;
  s.offset = -(normal[0] * centroid[0] + normal[1] * centroid[1] + normal[2] * centroid[2]);
  s.pixel_count = pixels;
  s.area_m2 = area;
  s.rms_residual = rms;
  s.surface_rms = rms;
  return s;
}

}  // namespace

// Coplanar groups: two pieces of one table on either side of a box are one group, as is a third
// piece through another; a plane 3 cm above the table, a wall and a cylinder are not.
TEST(CoplanarGroups, PiecesOfOnePlaneAreOneGroup) {
  rangeseg::Segmentation seg;
  const std::array<double, 3> up{0.0, -0.8, -0.6};  // a table seen from above, facing the camera
  const auto on_table = [&](double x, double y, double lift) {
    // The point of the table plane (through (0, 0, 1.5)) at x, y, moved `lift` along its normal.
    const double z = 1.5 - (up[1] * y + up[0] * x) / up[2];
    return std::array<double, 3>{x + lift * up[0], y + lift * up[1], z + lift * up[2]};
  };
  seg.segments.push_back(plane_segment(1, up, on_table(-0.3, 0.1, 0.0), 40000, 0.25));
  seg.segments.push_back(plane_segment(2, up, on_table(0.35, 0.05, 0.0), 20000, 0.12));
  seg.segments.push_back(plane_segment(3, up, on_table(0.3, 0.0, 0.03), 5000, 0.02));  // a box top
  seg.segments.push_back(plane_segment(4, {0.0, 0.0, -1.0}, {0.0, -0.3, 2.5}, 3000, 0.2));
  rangeseg::Segment cylinder = plane_segment(5, up, on_table(0.0, 0.2, 0.0), 2500, 0.01);
  cylinder.kind = rangeseg::SurfaceKind::cylinder;
  seg.segments.push_back(cylinder);
  seg.segments.push_back(plane_segment(6, up, on_table(0.1, -0.2, 0.001), 900, 0.005));
  const std::vector<int> groups = rangeseg::coplanar_groups(seg);
  EXPECT_EQ(groups, (std::vector<int>{1, 1, 3, 4, 0, 1}));
  // Tilted by 10 degrees about the x axis, piece 2 is another plane.
  const double t = 10.0 * std::numbers::pi / 180.0;
  const std::array<double, 3> tilted{0.0, up[1] * std::cos(t) - up[2] * std::sin(t),
                                     up[1] * std::sin(t) + up[2] * std::cos(t)};
  seg.segments[1] = plane_segment(2, tilted, seg.segments[1].centroid, 20000, 0.12);
  EXPECT_EQ(rangeseg::coplanar_groups(seg)[1], 2);
  EXPECT_THROW(rangeseg::coplanar_groups(seg, {.merge_angle = -1.0}), std::invalid_argument);
}
