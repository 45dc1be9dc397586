// Stage 1: mesh construction, face extraction.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <iostream>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "rangeseg/mesh.hpp"
#include "rangeseg/synth.hpp"
#include "test_util.hpp"

#if __has_include("rangeseg/io/pcd.hpp")
#include "rangeseg/io/pcd.hpp"
#define RANGESEG_HAVE_PCD 1
#endif

namespace {

using rangeseg::Mesh;
using rangeseg::MeshSettings;
using rangeseg::MeshType;
using rangeseg::OrganizedCloud;
namespace face_bits = rangeseg::face_bits;

constexpr double kF = 525.0;
const MeshType kAllTypes[] = {MeshType::quad, MeshType::left_cut, MeshType::right_cut,
                              MeshType::adaptive};

// Pinhole ray-cast: depth(u, v) returns z (NaN or <= 0 for no hit).
OrganizedCloud render(int w, int h, const std::function<double(double, double)>& depth_of_ray) {
  OrganizedCloud c(w, h);
  const double cx = (w - 1) / 2.0, cy = (h - 1) / 2.0;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const double dx = (u - cx) / kF, dy = (v - cy) / kF;
      const double z = depth_of_ray(dx, dy);
      if (!(z > 0)) continue;
      c.x(u, v) = static_cast<float>(dx * z);
      c.y(u, v) = static_cast<float>(dy * z);
      c.z(u, v) = static_cast<float>(z);
    }
  }
  return c;
}

// Plane n . p = dist (n towards +z seen from the camera means dist > 0).
OrganizedCloud plane(int w, int h, double nx, double ny, double nz, double dist) {
  return render(w, h, [=](double dx, double dy) { return dist / (nx * dx + ny * dy + nz); });
}

TEST(Mesh, FullGridFaceCountsPerType) {
  const int w = 37, h = 23;
  const OrganizedCloud cloud = plane(w, h, 0.2, -0.1, 1.0, 1.5);
  for (MeshType type : kAllTypes) {
    for (int s : {1, 2, 3, 5}) {
      const Mesh mesh = rangeseg::build_mesh(cloud, {.type = type, .pixel_stride = s});
      const std::size_t cells = static_cast<std::size_t>((w - 1) / s) * ((h - 1) / s);
      const std::size_t expected = type == MeshType::quad ? cells : 2 * cells;
      EXPECT_EQ(rangeseg::count_faces(mesh), expected) << "type " << int(type) << " stride " << s;
      // Only lattice pixels carry bits.
      for (int v = 0; v < h; ++v) {
        for (int u = 0; u < w; ++u) {
          if (u % s != 0 || v % s != 0) {
            ASSERT_EQ(mesh.faces(u, v), 0);
            ASSERT_EQ(mesh.edges(u, v), 0);
          }
        }
      }
      rangeseg::TriangleList list;
      rangeseg::extract_faces(mesh, false, list);
      EXPECT_EQ(list.indices.size(), expected * list.vertices_per_face);
      EXPECT_EQ(list.vertices_per_face, type == MeshType::quad ? 4 : 3);
    }
  }
}

TEST(Mesh, DiagonalChoice) {
  // A plane seen at a slant: the a-d and b-c diagonals differ in length; adaptive picks the
  // shorter.
  const OrganizedCloud cloud = plane(20, 20, 0.7, 0.7, 1.0, 1.0);
  const Mesh left = rangeseg::build_mesh(cloud, {.type = MeshType::left_cut});
  const Mesh right = rangeseg::build_mesh(cloud, {.type = MeshType::right_cut});
  const Mesh adaptive = rangeseg::build_mesh(cloud, {.type = MeshType::adaptive});
  for (int v = 0; v < 19; ++v) {
    for (int u = 0; u < 19; ++u) {
      ASSERT_EQ(left.faces(u, v), face_bits::tri0 | face_bits::tri1 | face_bits::diag_bc);
      ASSERT_EQ(right.faces(u, v), face_bits::tri0 | face_bits::tri1);
      auto p = [&](int du, int dv) {
        return std::array<double, 3>{cloud.x(u + du, v + dv), cloud.y(u + du, v + dv),
                                     cloud.z(u + du, v + dv)};
      };
      auto d2 = [](std::array<double, 3> a, std::array<double, 3> b) {
        return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
               (a[2] - b[2]) * (a[2] - b[2]);
      };
      const bool bc_shorter = d2(p(1, 0), p(0, 1)) < d2(p(0, 0), p(1, 1));
      ASSERT_EQ((adaptive.faces(u, v) & face_bits::diag_bc) != 0, bc_shorter);
    }
  }
}

// The length bound eps_d(r) of an edge is that of its farther end, and its linear term grows with
// the pixel stride: a (0, 0, 1) and b (0.01, 0, 1.4), 0.4001 m apart, with eps_d = 0.3 r per
// pixel of stride (eps_theta 0 and jump_sigmas 0 leave the length test alone): eps_d(b) = 0.42 m
// admits the edge, eps_d(a) = 0.30 m would not; at stride 2, 0.15 r per pixel is the same bound.
// (Edges are those of faces: c = (0, 0.01, 1) below a makes the triangle a b c.)
TEST(Mesh, AnEdgeIsBoundByItsFartherEndsLengthLimit) {
  for (const int stride : {1, 2}) {
    OrganizedCloud cloud(stride + 1, stride + 1);
    cloud.x(0, 0) = 0.0F;
    cloud.y(0, 0) = 0.0F;
    cloud.z(0, 0) = 1.0F;
    cloud.x(stride, 0) = 0.01F;
    cloud.y(stride, 0) = 0.0F;
    cloud.z(stride, 0) = 1.4F;
    cloud.x(0, stride) = 0.0F;  // c, below a: the triangle a b c carries the edge
    cloud.y(0, stride) = 0.01F;
    cloud.z(0, stride) = 1.0F;
    for (const float per_pixel :
         {0.3F / static_cast<float>(stride), 0.28F / static_cast<float>(stride)}) {
      const Mesh mesh = rangeseg::build_mesh(cloud, {.eps_theta = 0.0F,
                                                     .max_edge_a = 0.0F,
                                                     .max_edge_b = per_pixel,
                                                     .max_edge_c = 0.0F,
                                                     .pixel_stride = stride,
                                                     .jump_sigmas = 0.0F});
      // 0.28 r: eps_d(b) = 0.392 m, shorter than the edge.
      const bool expected = per_pixel * static_cast<float>(stride) > 0.29F;
      EXPECT_EQ((mesh.edges(0, 0) & 1) != 0, expected) << "stride " << stride << ", " << per_pixel;
    }
  }
}

TEST(Mesh, DepthJumpIsCut) {
  // Box face at 1 m in front of a wall at 2 m.
  const int w = 80, h = 60;
  OrganizedCloud cloud = render(w, h, [](double dx, double dy) {
    return (std::abs(dx) < 0.03 && std::abs(dy) < 0.02) ? 1.0 : 2.0;
  });
  for (MeshType type : kAllTypes) {
    const Mesh mesh = rangeseg::build_mesh(cloud, {.type = type});
    rangeseg::TriangleList list;
    rangeseg::extract_faces(mesh, false, list);
    std::size_t near_faces = 0;
    for (std::size_t f = 0; f < list.indices.size(); f += list.vertices_per_face) {
      int n_near = 0;
      for (int k = 0; k < list.vertices_per_face; ++k) {
        const int i = list.indices[f + k];
        n_near += cloud.z(i % w, i / w) < 1.5f;
      }
      ASSERT_TRUE(n_near == 0 || n_near == list.vertices_per_face) << "face straddles the jump";
      near_faces += n_near > 0;
    }
    EXPECT_GT(near_faces, 0u);
    // Edge masks never cross the jump either.
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        for (int k = 0; k < 8; ++k) {
          if (mesh.edges(u, v) >> k & 1) {
            ASSERT_EQ(cloud.z(u, v) < 1.5f,
                      cloud.z(u + rangeseg::kNeighbourDu[k], v + rangeseg::kNeighbourDv[k]) < 1.5f);
          }
        }
      }
    }
  }
}

// Noisy plane with holes: the per-cell result must match a slow double-precision re-derivation
// of the rules in the header (except for edges within float rounding of a threshold).
TEST(Mesh, MatchesSlowReference) {
  const int w = 64, h = 48;
  OrganizedCloud cloud = plane(w, h, 0.3, 0.2, 1.0, 2.0);
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.0f, 0.01f);
  std::uniform_real_distribution<float> uni(0.0f, 1.0f);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const float k = 1.0f + noise(rng) / cloud.z(u, v);
      cloud.x(u, v) *= k, cloud.y(u, v) *= k, cloud.z(u, v) *= k;
      if (uni(rng) < 0.05f) cloud.x(u, v) = cloud.y(u, v) = cloud.z(u, v) = NAN;
    }
  }
  for (MeshType type : kAllTypes) {
    for (int s : {1, 2}) {
      for (float jump_sigmas : {3.0f, 0.0f}) {  // with and without the noise gate
        const MeshSettings settings{.type = type,
                                    .viewpoint = {0.01f, -0.02f, 0.0f},
                                    .pixel_stride = s,
                                    .jump_sigmas = jump_sigmas};
        const Mesh mesh = rangeseg::build_mesh(cloud, settings);
        int mismatches = 0, cells = 0, ambiguous = 0, partial = 0;
        for (int v = 0; v + s < h; v += s) {
          for (int u = 0; u + s < w; u += s) {
            std::array<std::array<double, 3>, 4> p;
            std::array<bool, 4> ok;
            const int pu[4] = {u, u + s, u, u + s}, pv[4] = {v, v, v + s, v + s};
            for (int i = 0; i < 4; ++i) {
              p[i] = {cloud.x(pu[i], pv[i]), cloud.y(pu[i], pv[i]), cloud.z(pu[i], pv[i])};
              ok[i] = cloud.valid(pu[i], pv[i]);
            }
            bool near_threshold = false;
            auto edge = [&](int i, int j) {
              if (!ok[i] || !ok[j]) return false;
              double e[3], r[3], len2 = 0, r2 = 0, dot = 0, q2 = 0;
              for (int k = 0; k < 3; ++k) {
                e[k] = p[j][k] - p[i][k];
                r[k] = p[i][k] - settings.viewpoint[k];
                const double q = p[j][k] - settings.viewpoint[k];
                len2 += e[k] * e[k], r2 += r[k] * r[k], dot += e[k] * r[k], q2 += q * q;
              }
              const double range = std::sqrt(std::max(r2, q2));
              const double eps = settings.max_edge_a + settings.max_edge_b * s * range +
                                 settings.max_edge_c * range * range;
              const double c = std::cos(double(settings.eps_theta));
              const double m1 = eps * eps - len2, m2 = c * c * len2 * r2 - dot * dot;
              // Noise gate: a range step within jump_sigmas sigmas of the difference skips the
              // angle test.
              const auto& nm = settings.noise;
              const double ri = std::sqrt(r2), rj = std::sqrt(q2);
              const double var = double(settings.jump_sigmas) * settings.jump_sigmas *
                                 (nm.sigma(ri) * nm.sigma(ri) + nm.sigma(rj) * nm.sigma(rj));
              const double m3 = var - (ri - rj) * (ri - rj);
              if (std::abs(m1) < 1e-5 * eps * eps || std::abs(m2) < 1e-5 * len2 * r2 ||
                  std::abs(m3) < 1e-6 * (std::max(ri, rj) * std::abs(ri - rj) + var)) {
                near_threshold = true;
              }
              return m1 >= 0 && (m2 >= 0 || m3 >= 0);
            };
            const bool ab = edge(0, 1), ac = edge(0, 2), bd = edge(1, 3), cd = edge(2, 3),
                       ad = edge(0, 3), bc = edge(1, 2);
            std::uint8_t expected = 0;
            if (type == MeshType::quad) {
              expected = (ab && ac && bd && cd) ? face_bits::quad : 0;
            } else {
              const int fad = (ad && bd && ab ? 1 : 0) | (ac && cd && ad ? 2 : 0);
              const int fbc = (ac && bc && ab ? 1 : 0) | (bc && cd && bd ? 2 : 0);
              const int nad = std::popcount(unsigned(fad)), nbc = std::popcount(unsigned(fbc));
              double lad = 0, lbc = 0;
              for (int k = 0; k < 3; ++k) {
                lad += (p[3][k] - p[0][k]) * (p[3][k] - p[0][k]);
                lbc += (p[2][k] - p[1][k]) * (p[2][k] - p[1][k]);
              }
              if (nad != nbc && std::abs(lad - lbc) < 1e-5 * lad) near_threshold = true;
              bool use_bc = type == MeshType::left_cut ||
                            (type == MeshType::adaptive && (nad != nbc ? nbc > nad : lbc < lad));
              if (type == MeshType::adaptive && nad == nbc && std::abs(lad - lbc) < 1e-5 * lad) {
                near_threshold = true;
              }
              const int fx = use_bc ? fbc : fad;
              expected = fx == 0 ? 0 : std::uint8_t(fx | (use_bc ? face_bits::diag_bc : 0));
            }
            ++cells;
            if (near_threshold) {
              ++ambiguous;
              continue;
            }
            mismatches += mesh.faces(u, v) != expected;
            partial += expected != 0 && std::popcount(unsigned(expected & 3)) == 1;
          }
        }
        EXPECT_EQ(mismatches, 0) << "type " << int(type) << " stride " << s << " jump_sigmas "
                                 << jump_sigmas;
        EXPECT_LT(ambiguous, cells / 100);
        if (type != MeshType::quad) {
          EXPECT_GT(partial, cells / 50);  // the rules are exercised
        }
      }
    }
  }
}

TEST(Mesh, HolesSymmetryAndCompaction) {
  const int w = 50, h = 40;
  OrganizedCloud cloud = plane(w, h, -0.2, 0.3, 1.0, 1.2);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> uni(0.0f, 1.0f);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      if (uni(rng) < 0.1f) cloud.x(u, v) = cloud.y(u, v) = cloud.z(u, v) = NAN;
    }
  }
  for (MeshType type : kAllTypes) {
    for (int s : {1, 2}) {
      const Mesh mesh = rangeseg::build_mesh(cloud, {.type = type, .pixel_stride = s});
      // Symmetric edges, none touching an invalid vertex.
      for (int v = 0; v < h; ++v) {
        for (int u = 0; u < w; ++u) {
          for (int k = 0; k < 8; ++k) {
            if (!(mesh.edges(u, v) >> k & 1)) continue;
            ASSERT_TRUE(cloud.valid(u, v));
            const int qu = u + s * rangeseg::kNeighbourDu[k],
                      qv = v + s * rangeseg::kNeighbourDv[k];
            ASSERT_TRUE(qu >= 0 && qu < w && qv >= 0 && qv < h);
            ASSERT_TRUE(mesh.edges(qu, qv) >> ((k + 4) % 8) & 1) << u << "," << v << " k " << k;
          }
        }
      }
      rangeseg::TriangleList full, compact;
      rangeseg::extract_faces(mesh, false, full);
      rangeseg::extract_faces(mesh, true, compact);
      ASSERT_EQ(full.indices.size(), compact.indices.size());
      EXPECT_TRUE(full.vertex_pixel.empty());
      std::set<int> used;
      for (int i : full.indices) {
        ASSERT_TRUE(cloud.valid(i % w, i / w));
        used.insert(i);
      }
      // Compaction keeps exactly the used vertices, in pixel order, and the same faces.
      ASSERT_EQ(compact.vertex_pixel.size(), used.size());
      EXPECT_TRUE(std::equal(used.begin(), used.end(), compact.vertex_pixel.begin()));
      for (std::size_t i = 0; i < full.indices.size(); ++i) {
        ASSERT_EQ(compact.vertex_pixel.at(compact.indices[i]), full.indices[i]);
      }
      // Every face edge is in the edge masks and vice versa.
      std::set<std::pair<int, int>> face_edges;
      const int n = full.vertices_per_face;
      for (std::size_t f = 0; f < full.indices.size(); f += n) {
        for (int k = 0; k < n; ++k) {
          face_edges.insert({full.indices[f + k], full.indices[f + (k + 1) % n]}),
              face_edges.insert({full.indices[f + (k + 1) % n], full.indices[f + k]});
        }
      }
      std::size_t mask_edges = 0;
      for (int v = 0; v < h; ++v) {
        for (int u = 0; u < w; ++u) {
          for (int k = 0; k < 8; ++k) {
            if (mesh.edges(u, v) >> k & 1) {
              ++mask_edges;
              const int q =
                  (v + s * rangeseg::kNeighbourDv[k]) * w + u + s * rangeseg::kNeighbourDu[k];
              ASSERT_TRUE(face_edges.count({v * w + u, q}));
            }
          }
        }
      }
      EXPECT_EQ(mask_edges, face_edges.size());
    }
  }
}

TEST(Mesh, WindingFacesTheSensor) {
  const int w = 40, h = 30;
  const OrganizedCloud cloud = render(w, h, [](double dx, double dy) {
    // A wavy surface: normals vary but always face the camera.
    return 1.5 + 0.05 * std::sin(40 * dx) * std::cos(30 * dy);
  });
  for (MeshType type : kAllTypes) {
    const Mesh mesh = rangeseg::build_mesh(cloud, {.type = type});
    rangeseg::TriangleList list;
    rangeseg::extract_faces(mesh, false, list);
    ASSERT_GT(list.indices.size(), 0u);
    const int n = list.vertices_per_face;
    for (std::size_t f = 0; f < list.indices.size(); f += n) {
      auto p = [&](int k) {
        const int i = list.indices[f + k];
        return std::array<double, 3>{cloud.x(i % w, i / w), cloud.y(i % w, i / w),
                                     cloud.z(i % w, i / w)};
      };
      // Newell's normal (works for the quad too) against the direction to the sensor.
      double nrm[3] = {0, 0, 0};
      for (int k = 0; k < n; ++k) {
        const auto a = p(k), b = p((k + 1) % n);
        nrm[0] += (a[1] - b[1]) * (a[2] + b[2]);
        nrm[1] += (a[2] - b[2]) * (a[0] + b[0]);
        nrm[2] += (a[0] - b[0]) * (a[1] + b[1]);
      }
      const auto c = p(0);
      ASSERT_GT(-(nrm[0] * c[0] + nrm[1] * c[1] + nrm[2] * c[2]), 0.0) << "face " << f / n;
    }
  }
}

TEST(Mesh, ReusesBuffersAndValidates) {
  const OrganizedCloud cloud = plane(64, 48, 0.0, 0.0, 1.0, 2.0);
  Mesh mesh;
  rangeseg::build_mesh(cloud, {}, mesh);
  const std::uint8_t* faces = mesh.faces.row(0);
  const std::uint8_t* edges = mesh.edges.row(0);
  rangeseg::build_mesh(cloud, {.type = MeshType::quad}, mesh);
  EXPECT_EQ(mesh.faces.row(0), faces);
  EXPECT_EQ(mesh.edges.row(0), edges);
  EXPECT_EQ(rangeseg::count_faces(mesh), 63u * 47u);

  EXPECT_THROW(rangeseg::build_mesh(OrganizedCloud(10, 1)), std::invalid_argument);
  EXPECT_THROW(rangeseg::build_mesh(cloud, {.eps_theta = -0.1f}), std::invalid_argument);
  EXPECT_THROW(rangeseg::build_mesh(cloud, {.max_edge_c = NAN}), std::invalid_argument);
  EXPECT_THROW(rangeseg::build_mesh(cloud, {.pixel_stride = 0}), std::invalid_argument);
  EXPECT_THROW(rangeseg::build_mesh(cloud, {.viewpoint = {0, INFINITY, 0}}), std::invalid_argument);
  EXPECT_THROW(rangeseg::build_mesh(cloud, {.type = static_cast<MeshType>(9)}),
               std::invalid_argument);
  // Every field is named with its value; the noise model is the other stages' (sigma > 0).
  const auto message = [&](const MeshSettings& settings) {
    try {
      rangeseg::validate(settings);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  EXPECT_EQ(message({.max_edge_b = -1.0f}),
            "MeshSettings::max_edge_b = -1 must be finite and >= 0");
  EXPECT_EQ(message({.viewpoint = {0, INFINITY, 0}}),
            "MeshSettings::viewpoint[1] = inf must be finite [m]");
  EXPECT_EQ(message({.noise = {.a = -1.0}}), "MeshSettings::noise.a = -1 must be finite and > 0");
  EXPECT_EQ(message({.noise = {.a = 0.0, .b = 0.0}}),
            "MeshSettings::noise.a = 0 must be finite and > 0");
  EXPECT_EQ(message({.noise = {.b = -1.0}}), "MeshSettings::noise.b = -1 must be finite and >= 0");
  EXPECT_EQ(message({.pixel_stride = 0}), "MeshSettings::pixel_stride = 0 must be >= 1");
  // A value just past the bound keeps its digits (an ostream's 6 would print 1.5708), and a
  // float prints as the float it is.
  EXPECT_EQ(message({.eps_theta = 1.5708001f}),
            "MeshSettings::eps_theta = 1.5708001 must be in [0, pi/2] rad");
  EXPECT_EQ(message({}), "no exception");
}

// Kinect noise (Gaussian + disparity quantisation) on a fronto-parallel plane: the noise gate
// keeps nearly every ring complete at all depths. Without it (jump_sigmas = 0) a large part of
// the edges at 4 m are taken for occlusions.
TEST(Mesh, KinectNoisePlaneStaysConnected) {
  namespace synth = rangeseg::synth;
  for (double z : {1.0, 2.0, 4.0}) {
    const synth::Rendering r =
        synth::render(synth::plane_scene(z), {.noise = synth::Noise::kinect, .seed = 11});
    const OrganizedCloud& c = r.cloud;
    for (float jump_sigmas : {3.0f, 0.0f}) {
      const Mesh mesh = rangeseg::build_mesh(c, {.jump_sigmas = jump_sigmas});
      std::size_t valid = 0, complete = 0, possible = 0, kept = 0;
      for (int v = 1; v + 1 < c.height(); ++v) {
        for (int u = 1; u + 1 < c.width(); ++u) {
          if (!c.valid(u, v)) continue;
          int p = 0, k = 0;
          for (int d = 0; d < 8; d += 2) {  // the 4-neighbours are in every triangle ring
            if (!c.valid(u + rangeseg::kNeighbourDu[d], v + rangeseg::kNeighbourDv[d])) continue;
            ++p;
            k += mesh.edges(u, v) >> d & 1;
          }
          ++valid;
          complete += k == p;
          possible += p;
          kept += k;
        }
      }
      const double complete_fraction = double(complete) / double(valid);
      const double kept_fraction = double(kept) / double(possible);
      std::cout << "plane " << z << " m, jump_sigmas " << jump_sigmas << ": complete rings "
                << complete_fraction << ", edges kept " << kept_fraction << "\n";
      if (jump_sigmas > 0) {
        EXPECT_GE(complete_fraction, 0.98) << z << " m";
        EXPECT_GE(kept_fraction, 0.995) << z << " m";
      } else if (z >= 4.0) {
        EXPECT_LT(kept_fraction, 0.9);  // the test can tell the gate from no gate
      }
    }
  }
}

// A box 1 m in front of a wall, with Kinect noise: no face bridges the depth jump.
TEST(Mesh, KinectNoiseDepthJumpIsCut) {
  namespace synth = rangeseg::synth;
  for (double wall : {2.0, 3.0}) {
    synth::Scene scene;
    scene.rectangles.push_back(
        {.centre = {0.0, 0.0, wall}, .half_u = {4.0, 0.0, 0.0}, .half_v = {0.0, 4.0, 0.0}});
    scene.boxes.push_back({.centre = {0.0, 0.0, wall - 1.0}, .half_extent = {0.3, 0.3, 0.3}});
    const synth::Rendering r = synth::render(scene, {.noise = synth::Noise::kinect, .seed = 5});
    const OrganizedCloud& c = r.cloud;
    for (MeshType type : kAllTypes) {
      const Mesh mesh = rangeseg::build_mesh(c, {.type = type});
      rangeseg::TriangleList list;
      rangeseg::extract_faces(mesh, false, list);
      std::size_t near_faces = 0, bridging = 0;
      const float split = static_cast<float>(wall - 0.5);
      for (std::size_t f = 0; f < list.indices.size(); f += list.vertices_per_face) {
        int n_near = 0;
        for (int k = 0; k < list.vertices_per_face; ++k) {
          const int i = list.indices[f + k];
          n_near += c.z(i % c.width(), i / c.width()) < split;
        }
        bridging += n_near != 0 && n_near != list.vertices_per_face;
        near_faces += n_near == list.vertices_per_face;
      }
      EXPECT_EQ(bridging, 0u) << "wall " << wall << " type " << int(type);
      EXPECT_GT(near_faces, 1000u);
    }
  }
}

#ifdef RANGESEG_HAVE_PCD
TEST(Mesh, RealKinectFrameIsWellConnected) {
  RANGESEG_REQUIRE_DATA("kinect/grabber_frame0.pcd");
  const OrganizedCloud cloud = rangeseg::io::read_pcd(data_file.string());
  for (MeshType type : kAllTypes) {
    const Mesh mesh = rangeseg::build_mesh(cloud, {.type = type});
    std::size_t valid = 0, used = 0;
    for (int v = 0; v < cloud.height(); ++v) {
      for (int u = 0; u < cloud.width(); ++u) {
        valid += cloud.valid(u, v);
        used += mesh.edges(u, v) != 0;
      }
    }
    const double fraction = double(used) / double(valid);
    RecordProperty("used_fraction_type" + std::to_string(int(type)), std::to_string(fraction));
    std::cout << "grabber_frame0 type " << int(type) << ": " << rangeseg::count_faces(mesh)
              << " faces, " << used << " / " << valid << " valid points used (" << fraction
              << ")\n";
    EXPECT_GT(fraction, 0.95);
  }
}
#endif

}  // namespace

// Regression: compaction wrote one vertex past the end when the last lattice pixel was unused
// (heap corruption on real frames whose bottom-right corner has no measurement).
TEST(Mesh, CompactionWithUnusedLastPixel) {
  OrganizedCloud cloud(6, 5);
  for (int v = 0; v < 5; ++v) {
    for (int u = 0; u < 6; ++u) {
      cloud.x(u, v) = (u - 2.5f) * 0.002f;
      cloud.y(u, v) = (v - 2.0f) * 0.002f;
      cloud.z(u, v) = 1.0f;
    }
  }
  cloud.z(5, 4) = NAN;  // the last pixel
  const Mesh mesh = rangeseg::build_mesh(cloud, {});
  rangeseg::TriangleList list;
  rangeseg::extract_faces(mesh, true, list);
  ASSERT_EQ(list.vertex_pixel.size(), 29u);
  EXPECT_EQ(list.vertex_pixel.back(), 4 * 6 + 4);
  for (const std::int32_t i : list.indices) EXPECT_LT(i, 29);
}

// Row bands (detail/row_bands.hpp) and the instruction-set paths (detail/simd.hpp).
#include "detail/row_bands.hpp"
#include "detail/simd.hpp"

namespace {

// A tilted plane with noise, holes and a depth step, of odd size: rows end inside a vector, and
// band boundaries fall between lattice rows.
OrganizedCloud rough_cloud(int w, int h, unsigned seed) {
  OrganizedCloud cloud = plane(w, h, 0.3, -0.2, 1.0, 1.5);
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 0.004f);
  std::uniform_real_distribution<float> uni(0.0f, 1.0f);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const float k = (u > w / 2 ? 1.3f : 1.0f) + noise(rng);
      cloud.x(u, v) *= k, cloud.y(u, v) *= k, cloud.z(u, v) *= k;
      if (uni(rng) < 0.08f) cloud.x(u, v) = cloud.y(u, v) = cloud.z(u, v) = NAN;
    }
  }
  return cloud;
}

::testing::AssertionResult same_bytes(const rangeseg::BytePlane& a, const rangeseg::BytePlane& b) {
  if (a.width() != b.width() || a.height() != b.height()) {
    return ::testing::AssertionFailure() << "sizes differ";
  }
  for (int v = 0; v < a.height(); ++v) {
    for (int u = 0; u < a.width(); ++u) {
      if (a(u, v) != b(u, v)) {
        return ::testing::AssertionFailure()
               << "pixel (" << u << ", " << v << "): " << int(a(u, v)) << " vs " << int(b(u, v));
      }
    }
  }
  return ::testing::AssertionSuccess();
}

// Bands [k h / bands, (k + 1) h / bands), computed last band first into a mesh whose planes
// start out as garbage (at stride 1 prepare_mesh keeps planes of the right size as they are).
Mesh mesh_in_bands(const OrganizedCloud& cloud, const MeshSettings& settings, int bands) {
  Mesh mesh;
  mesh.faces.resize(cloud.width(), cloud.height(), 0xA5);
  mesh.edges.resize(cloud.width(), cloud.height(), 0x5A);
  rangeseg::detail::prepare_mesh(cloud, settings, mesh);
  rangeseg::detail::RowBuffers rows;  // one for all bands, as one thread reuses them
  for (int k = bands - 1; k >= 0; --k) {
    rangeseg::detail::build_mesh_rows(cloud, settings, mesh, k * cloud.height() / bands,
                                      (k + 1) * cloud.height() / bands, rows);
  }
  return mesh;
}

}  // namespace

TEST(Mesh, RowBandsAreBitIdentical) {
  const OrganizedCloud cloud = rough_cloud(45, 31, 11);
  for (MeshType type : kAllTypes) {
    for (int s : {1, 2, 3}) {
      const MeshSettings settings{.type = type, .pixel_stride = s};
      const Mesh whole = rangeseg::build_mesh(cloud, settings);
      ASSERT_GT(rangeseg::count_faces(whole), 0u);
      for (int bands : {1, 2, 3}) {
        const Mesh banded = mesh_in_bands(cloud, settings, bands);
        EXPECT_TRUE(same_bytes(banded.faces, whole.faces))
            << "type " << int(type) << " stride " << s << " bands " << bands;
        EXPECT_TRUE(same_bytes(banded.edges, whole.edges))
            << "type " << int(type) << " stride " << s << " bands " << bands;
      }
    }
  }
  // Empty and out-of-range bands write nothing.
  Mesh mesh = rangeseg::build_mesh(cloud, {});
  const Mesh before = mesh;
  rangeseg::detail::RowBuffers rows;
  rangeseg::detail::build_mesh_rows(cloud, {}, mesh, 10, 10, rows);
  rangeseg::detail::build_mesh_rows(cloud, {}, mesh, -5, 0, rows);
  rangeseg::detail::build_mesh_rows(cloud, {}, mesh, cloud.height(), cloud.height() + 4, rows);
  EXPECT_TRUE(same_bytes(mesh.edges, before.edges));
}

// The kernels run on 4 lanes (SSE2), 8 (AVX2) or 16 (AVX-512), whichever the CPU has up to the
// limit: the same IEEE operations in the same order, so the meshes are identical.
TEST(Mesh, InstructionSetsAgree) {
  using rangeseg::detail::simd::Isa;
  for (const auto& [w, h] : {std::pair{45, 31}, std::pair{8, 2}, std::pair{1, 3}}) {
    const OrganizedCloud cloud = rough_cloud(w, h, 5);
    for (MeshType type : kAllTypes) {
      for (int s : {1, 2}) {
        const MeshSettings settings{
            .type = type, .viewpoint = {0.02f, 0.0f, -0.01f}, .pixel_stride = s};
        rangeseg::detail::simd::isa_limit = Isa::baseline;
        const Mesh baseline = rangeseg::build_mesh(cloud, settings);
        for (Isa isa : {Isa::avx2, Isa::avx512}) {
          rangeseg::detail::simd::isa_limit = isa;
          const Mesh wide = rangeseg::build_mesh(cloud, settings);
          EXPECT_TRUE(same_bytes(baseline.faces, wide.faces))
              << w << "x" << h << " type " << int(type) << " stride " << s << " isa " << int(isa);
          EXPECT_TRUE(same_bytes(baseline.edges, wide.edges))
              << w << "x" << h << " type " << int(type) << " stride " << s << " isa " << int(isa);
        }
      }
    }
  }
}

#ifdef RANGESEG_HAVE_PCD
TEST(Mesh, RealFrameRowBandsAndInstructionSets) {
  using rangeseg::detail::simd::Isa;
  RANGESEG_REQUIRE_DATA("kinect/grabber_frame0.pcd");
  const OrganizedCloud cloud = rangeseg::io::read_pcd(data_file.string());
  const Mesh whole = rangeseg::build_mesh(cloud, {});
  const Mesh banded = mesh_in_bands(cloud, {}, 3);
  EXPECT_TRUE(same_bytes(banded.faces, whole.faces));
  EXPECT_TRUE(same_bytes(banded.edges, whole.edges));
  for (Isa isa : {Isa::baseline, Isa::avx2}) {
    rangeseg::detail::simd::isa_limit = isa;
    const Mesh narrow = rangeseg::build_mesh(cloud, {});
    EXPECT_TRUE(same_bytes(narrow.faces, whole.faces)) << "isa " << int(isa);
    EXPECT_TRUE(same_bytes(narrow.edges, whole.edges)) << "isa " << int(isa);
  }
  rangeseg::detail::simd::isa_limit = Isa::avx512;
}
#endif

TEST(Mesh, NonFinitePointsHaveNoEdges) {
  // A point with an infinite coordinate is no point (OrganizedCloud::valid), like a NaN one: with
  // an infinite range, eps_d and the noise gate are infinite too, and every edge would pass.
  // Coordinates so large that the squared range overflows are treated alike.
  using rangeseg::detail::simd::Isa;
  const int w = 50, h = 40;
  OrganizedCloud cloud = plane(w, h, -0.2, 0.3, 1.0, 1.2);
  const float inf = std::numeric_limits<float>::infinity();
  std::set<std::pair<int, int>> bad;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const int kind = (u * 7 + v * 13) % 23;
      if (kind > 4) continue;
      bad.insert({u, v});
      if (kind == 0) cloud.z(u, v) = inf;
      if (kind == 1) cloud.z(u, v) = -inf;
      if (kind == 2) cloud.x(u, v) = inf;
      if (kind == 3) cloud.y(u, v) = -inf;
      if (kind == 4) cloud.z(u, v) = 3e19f;
    }
  }
  for (Isa isa : {Isa::baseline, Isa::avx2, Isa::avx512}) {
    rangeseg::detail::simd::isa_limit = isa;
    for (MeshType type : kAllTypes) {
      for (int s : {1, 2}) {
        const Mesh mesh = rangeseg::build_mesh(cloud, {.type = type, .pixel_stride = s});
        int edges = 0, to_bad = 0;
        for (int v = 0; v < h; v += s) {
          for (int u = 0; u < w; u += s) {
            for (int k = 0; k < 8; ++k) {
              if (!(mesh.edges(u, v) >> k & 1)) continue;
              ++edges;
              to_bad += bad.count({u, v}) + bad.count({u + s * rangeseg::kNeighbourDu[k],
                                                       v + s * rangeseg::kNeighbourDv[k]});
            }
          }
        }
        EXPECT_GT(edges, 0);
        EXPECT_EQ(to_bad, 0) << "type " << int(type) << " stride " << s << " isa " << int(isa);
      }
    }
  }
  rangeseg::detail::simd::isa_limit = Isa::avx512;
}
