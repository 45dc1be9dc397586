// k-nearest-neighbour rings (the stand-in for the mesh 1-ring of an unorganized cloud).

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "detail/bad_setting.hpp"
#include "rangeseg/unorganized.hpp"
#include "unorganized/internal.hpp"
#include "unorganized/kd_tree.hpp"

namespace rangeseg {
namespace unorganized {

void pack_points(const OrganizedCloud& cloud, std::vector<float>& xyz) {
  const int w = cloud.width(), h = cloud.height();
  xyz.resize(cloud.size() * 3);
  float* out = xyz.data();
  for (int v = 0; v < h; ++v) {
    const float* x = cloud.x.row(v);
    const float* y = cloud.y.row(v);
    const float* z = cloud.z.row(v);
    for (int u = 0; u < w; ++u, out += 3) {
      const bool valid = std::isfinite(x[u]) && std::isfinite(y[u]) && std::isfinite(z[u]);
      out[0] = valid ? x[u] : NAN;
      out[1] = valid ? y[u] : NAN;
      out[2] = valid ? z[u] : NAN;
    }
  }
}

void require_rings_match(const OrganizedCloud& cloud, const PointRings& rings,
                         const NormalMap* normals, const char* what) {
  require_consistent(cloud, what);
  if (rings.size() != cloud.size() || rings.k < 0 ||
      rings.neighbours.size() != rings.size() * static_cast<std::size_t>(rings.k)) {
    std::ostringstream msg;
    msg << what << ": the rings are for " << rings.size() << " points (k = " << rings.k << ", "
        << rings.neighbours.size() << " slots), the cloud has " << cloud.size();
    throw std::invalid_argument(msg.str());
  }
  // The stages index the cloud by the rings without checks: rings filled by the caller are
  // checked here once (count <= k, neighbours in range).
  const auto n = static_cast<std::int64_t>(cloud.size());
  for (std::size_t i = 0; i < rings.size(); ++i) {
    const bool count_ok = rings.count[i] <= rings.k;
    bool in_range = true;
    if (count_ok) {
      for (const std::int32_t j : rings.ring(i)) in_range &= j >= 0 && j < n;
    }
    if (!count_ok || !in_range) {
      std::ostringstream msg;
      msg << what << ": the ring of point " << i << " has "
          << (count_ok ? "a neighbour index outside [0, " + std::to_string(n) + ")"
                       : std::to_string(rings.count[i]) +
                             " neighbours for k = " + std::to_string(rings.k));
      throw std::invalid_argument(msg.str());
    }
  }
  if (normals != nullptr &&
      (normals->width() != cloud.width() || normals->height() != cloud.height() ||
       normals->nx.width() != cloud.width() || normals->ny.width() != cloud.width() ||
       normals->nx.height() != cloud.height() || normals->ny.height() != cloud.height())) {
    std::ostringstream msg;
    msg << what << ": normals of " << normals->width() << " x " << normals->height()
        << " for a cloud of " << cloud.width() << " x " << cloud.height();
    throw std::invalid_argument(msg.str());
  }
}

}  // namespace unorganized

void unorganized::RingTreeDeleter::operator()(RingTree* tree) const { delete tree; }

namespace {

template <class T>
[[noreturn]] void fail(const char* field, T value, const char* condition) {
  detail::throw_bad_setting("RingSettings", field, value, condition);
}

/// The ring test of the mesh (MeshSettings) for the edge from p to q.
struct EdgeTest {
  float max_distance2;  // 0 = none
  float cos_theta2;     // cos(eps_theta)^2; > 1 = off
  float jump2;          // jump_sigmas^2
  SensorNoise noise;
  std::array<float, 3> viewpoint;

  bool operator()(const float* p, const float* q, float distance2) const {
    if (max_distance2 > 0 && distance2 > max_distance2) return false;
    if (cos_theta2 > 1.0f) return true;
    const float rx = p[0] - viewpoint[0], ry = p[1] - viewpoint[1], rz = p[2] - viewpoint[2];
    const float ex = q[0] - p[0], ey = q[1] - p[1], ez = q[2] - p[2];
    const float dot = rx * ex + ry * ey + rz * ez;
    const float ray2 = rx * rx + ry * ry + rz * rz;
    if (dot * dot <= cos_theta2 * ray2 * distance2) return true;
    // Along the ray: a veil, unless the range step is within the noise.
    const float sx = q[0] - viewpoint[0], sy = q[1] - viewpoint[1], sz = q[2] - viewpoint[2];
    const double ri = std::sqrt(static_cast<double>(ray2));
    const double rj = std::sqrt(static_cast<double>(sx * sx + sy * sy + sz * sz));
    const double si = noise.sigma(ri), sj = noise.sigma(rj);
    const double step = ri - rj;
    return step * step <= jump2 * (si * si + sj * sj);
  }
};

/// Most candidates of a balanced ring (4 k for the largest k).
constexpr int kMaxCandidates = 256;
/// Rings of fewer points are not balanced: a few neighbours need not surround a point.
constexpr int kMinBalancedK = 6;

/// The scatter matrix of the offsets of points `idx[0, m)` from `origin` in the search space.
Eigen::Matrix3d scatter(const float* space, const float* origin, const std::uint32_t* idx, int m) {
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  for (int j = 0; j < m; ++j) {
    const float* q = space + 3 * static_cast<std::size_t>(idx[j]);
    const Eigen::Vector3d d(double{q[0]} - origin[0], double{q[1]} - origin[1],
                            double{q[2]} - origin[2]);
    s += d * d.transpose();
  }
  return s;
}

/// Whether the points lie along a line through or beside the origin: the second principal
/// axis of their scatter about it is below 0.1 of the first (a ring on a surface spreads in
/// two directions, ~1 for a grid's 1-ring, 0.3 for the half ring at a border). Without an
/// eigen-solve: for points near a plane (the third axis ~0) the sum of the principal 2x2 minors
/// of the scatter is l1 l2 and its trace l1 + l2, and l2 / l1 < 0.1 is minors < tr^2 0.1 / 1.21;
/// spread in 3D only raises the minors.
bool along_a_line(const float* space, const float* origin, const std::uint32_t* idx, int m) {
  float xx = 0, yy = 0, zz = 0, xy = 0, xz = 0, yz = 0;  // offsets ~1e-3: float suffices
  for (int j = 0; j < m; ++j) {
    const float* q = space + 3 * static_cast<std::size_t>(idx[j]);
    const float dx = q[0] - origin[0], dy = q[1] - origin[1], dz = q[2] - origin[2];
    xx += dx * dx;
    yy += dy * dy;
    zz += dz * dz;
    xy += dx * dy;
    xz += dx * dz;
    yz += dy * dz;
  }
  const double minors = double{xx} * yy - double{xy} * xy + double{xx} * zz - double{xz} * xz +
                        double{yy} * zz - double{yz} * yz;
  const double trace = double{xx} + yy + zz;
  return !(minors >= 0.1 / 1.21 * trace * trace);
}

/// Chooses k of the candidates idx[0, m) (nearest first) in turn per 45-degree sector about
/// the origin in the plane of their two principal axes: the nearest of each sector, then the
/// second nearest of each, and so on. Writes them to idx[0, result), nearest first.
int balanced_ring(const float* space, const float* origin, std::uint32_t* idx, int m, int k) {
  if (m <= k) return m;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter(space, origin, idx, m));
  const Eigen::Vector3d e1 = eig.eigenvectors().col(2), e2 = eig.eigenvectors().col(1);
  std::array<std::uint8_t, kMaxCandidates> sector{};
  for (int j = 0; j < m; ++j) {
    const float* q = space + 3 * static_cast<std::size_t>(idx[j]);
    const Eigen::Vector3d d(double{q[0]} - origin[0], double{q[1]} - origin[1],
                            double{q[2]} - origin[2]);
    const double angle = std::atan2(d.dot(e2), d.dot(e1));  // [-pi, pi]
    sector[static_cast<std::size_t>(j)] = static_cast<std::uint8_t>(
        static_cast<int>(std::floor(angle / (std::numbers::pi / 4) + 8.5)) & 7);
  }
  std::array<int, 8> taken{};
  std::array<bool, kMaxCandidates> chosen{};
  int count = 0;
  for (int round = 0; count < k; ++round) {
    for (int j = 0; j < m && count < k; ++j) {
      const auto js = static_cast<std::size_t>(j);
      if (chosen[js] || taken[sector[js]] != round) continue;
      chosen[js] = true;
      ++taken[sector[js]];
      ++count;
    }
  }
  int out = 0;
  for (int j = 0; j < m; ++j) {
    if (chosen[static_cast<std::size_t>(j)]) idx[out++] = idx[j];
  }
  return out;
}

/// Points closer together than this fraction of the sensor's noise sigma(range), and of the
/// distance to the middle candidate of the ring (by distance, its median), are the same surface
/// point measured again (overlapping scans, tiles stored twice), not neighbours on the surface:
/// the direction between them is noise, and a second copy in a ring would take a place, so that
/// the ring spans less of the surface (a merged room with a third of its points stored again
/// 1e-5 m away: 106 segments, 15 with copies dropped). A real scan's points are a pixel's
/// footprint apart, tens to hundreds of times this bound. (The second bound holds where a noise
/// model is extrapolated far beyond its sensor's range: Kinect's at 150 m is 42 m.)
constexpr double kCoincidentFraction = 0.01;

/// The candidates of one ring, nearest first in the search space: their indices, squared
/// distances from p in space (d2), distances from p in the search space (s), and an upper bound
/// on the search-space distance between two of them per metre between them near each (scale:
/// 1 by distance; by direction, 2 / range, as |a/|a| - b/|b|| <= 2 |a - b| / |a|).
struct Candidates {
  std::array<std::uint32_t, kMaxCandidates> idx;
  std::array<float, kMaxCandidates> d2, s, scale;
};

/// Removes the candidates [0, m) closer to p or to a candidate kept before them than
/// `noise_bound` [m] and kCoincidentFraction of the middle candidate's distance; returns the
/// count left, in the same order.
int drop_coincident(const float* xyz, Candidates& c, int m, float noise_bound) {
  if (m == 0) return 0;
  const float bound2 = std::min(noise_bound * noise_bound,
                                static_cast<float>(kCoincidentFraction * kCoincidentFraction) *
                                    c.d2[static_cast<std::size_t>(m / 2)]);
  const float bound = std::sqrt(bound2);
  int out = 0;
  for (int j = 0; j < m; ++j) {
    const auto uj = static_cast<std::size_t>(j);
    if (c.d2[uj] < bound2) continue;
    const float* q = xyz + 3 * static_cast<std::size_t>(c.idx[uj]);
    // Two coincident candidates are as close in the search space, so only the last few kept
    // need a look (the triangle inequality about p's position there).
    const float reach = bound * c.scale[uj];
    bool close = false;
    for (int i = out - 1; i >= 0 && !close; --i) {
      const auto ui = static_cast<std::size_t>(i);
      if (c.s[uj] - c.s[ui] >= reach) break;
      close =
          unorganized::squared_distance(xyz + 3 * static_cast<std::size_t>(c.idx[ui]), q) < bound2;
    }
    if (close) continue;
    const auto uo = static_cast<std::size_t>(out++);
    c.idx[uo] = c.idx[uj];
    c.s[uo] = c.s[uj];
  }
  return out;
}

}  // namespace

void validate(const RingSettings& s) {
  if (s.k < 2 || s.k > 64) fail("k", s.k, "in [2, 64]");
  if (!std::isfinite(s.max_distance) || s.max_distance < 0) {
    fail("max_distance", s.max_distance, "finite and >= 0 m");
  }
  if (!std::isfinite(s.eps_theta) || s.eps_theta < 0 || s.eps_theta >= 1.5707963f) {
    fail("eps_theta", s.eps_theta, "in [0, pi / 2) rad");
  }
  if (!std::isfinite(s.jump_sigmas) || s.jump_sigmas < 0) {
    fail("jump_sigmas", s.jump_sigmas, "finite and >= 0");
  }
  detail::require_noise(s.noise, "RingSettings");
  for (const float c : s.viewpoint) {
    if (!std::isfinite(c)) fail("viewpoint", c, "finite");
  }
}

namespace {

void build(const OrganizedCloud& cloud, const RingSettings& settings, PointRings& out,
           ThreadPool* pool, RingBuffers::Impl& b) {
  validate(settings);
  require_consistent(cloud, "build_rings");
  if (cloud.size() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max())) {
    throw std::length_error("build_rings: " + std::to_string(cloud.size()) +
                            " points, at most 2^31 - 1 are supported");
  }
  std::vector<float>& xyz = b.xyz;
  unorganized::pack_points(cloud, xyz);
  const std::size_t n = cloud.size();
  // The tree holds the valid points only, packed; `original` maps them back.
  std::vector<float>& valid_xyz = b.valid_xyz;
  std::vector<std::int32_t>& original = b.original;
  valid_xyz.clear();
  original.clear();
  valid_xyz.reserve(xyz.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (std::isnan(xyz[3 * i])) continue;
    valid_xyz.insert(valid_xyz.end(), xyz.begin() + static_cast<std::ptrdiff_t>(3 * i),
                     xyz.begin() + static_cast<std::ptrdiff_t>(3 * i + 3));
    original.push_back(static_cast<std::int32_t>(i));
  }
  const int k = settings.k;
  out.k = k;
  out.by_direction = settings.by_direction;
  out.viewpoint = settings.viewpoint;
  out.neighbours.assign(n * static_cast<std::size_t>(k), -1);
  out.count.assign(n, 0);
  if (original.empty()) return;
  // The search space: the points, or their directions from the viewpoint.
  std::vector<float>& directions = b.directions;
  if (settings.by_direction) {
    directions.resize(valid_xyz.size());
    for (std::size_t c = 0; c < original.size(); ++c) {
      unorganized::direction_from(settings.viewpoint, valid_xyz.data() + 3 * c,
                                  directions.data() + 3 * c);
    }
  }
  if (!b.tree) b.tree.reset(new unorganized::RingTree);
  b.tree->data = unorganized::PackedCloud{
      settings.by_direction ? directions.data() : valid_xyz.data(), original.size()};
  unorganized::Tree& tree = b.tree->tree;
  tree.buildIndex();
  // The points in the tree's leaf order, so that a query's leaves and its neighbours lie close
  // together in memory whatever the input order (a shuffled cloud's). The tree then indexes
  // them directly (vAcc[t] = t): the same nodes, the same distances in the same order, so the
  // same rings.
  std::vector<float>& leaf_xyz = b.leaf_xyz;
  std::vector<float>& leaf_directions = b.leaf_directions;
  std::vector<std::int32_t>& leaf_original = b.leaf_original;
  const std::size_t valid = original.size();
  leaf_xyz.resize(3 * valid);
  leaf_directions.resize(settings.by_direction ? 3 * valid : 0);
  leaf_original.resize(valid);
  for (std::size_t t = 0; t < valid; ++t) {
    const std::size_t c = tree.vAcc[t];
    std::copy_n(valid_xyz.data() + 3 * c, 3, leaf_xyz.data() + 3 * t);
    if (settings.by_direction) {
      std::copy_n(directions.data() + 3 * c, 3, leaf_directions.data() + 3 * t);
    }
    leaf_original[t] = original[c];
    tree.vAcc[t] = static_cast<std::uint32_t>(t);
  }
  const float* const space = settings.by_direction ? leaf_directions.data() : leaf_xyz.data();
  b.tree->data.xyz = space;
  const float cos_theta = std::cos(settings.eps_theta);
  const EdgeTest test{
      .max_distance2 = settings.max_distance * settings.max_distance,
      .cos_theta2 = settings.eps_theta > 0 ? cos_theta * cos_theta : 2.0f,
      .jump2 = settings.jump_sigmas * settings.jump_sigmas,
      .noise = settings.noise,
      .viewpoint = settings.viewpoint,
  };
  const auto query = [&](int /*band*/, int begin, int end) {
    std::array<std::uint32_t, kMaxCandidates + 1> index{};
    std::array<float, kMaxCandidates + 1> distance2{};
    Candidates accepted{};
    for (int t = begin; t < end; ++t) {
      // In the tree's leaf order, so that consecutive queries walk the same nodes (1.8x faster
      // than input order for a shuffled 640x480 frame).
      const auto c = static_cast<std::uint32_t>(t);
      const float* p = leaf_xyz.data() + 3 * static_cast<std::size_t>(c);
      const float* origin = space + 3 * static_cast<std::size_t>(c);
      const float coincident = static_cast<float>(
          kCoincidentFraction * settings.noise.sigma(std::sqrt(double{
                                    unorganized::squared_distance(settings.viewpoint.data(), p)})));
      // The `wanted` nearest that pass the edge test and coincide with no other, nearest
      // first, into `accepted`.
      const auto nearest = [&](int wanted) {
        int asked = wanted;
        for (;;) {
          // asked + 1: the point itself is its own nearest neighbour.
          nanoflann::KNNResultSet<float, std::uint32_t, std::uint32_t> result(
              static_cast<std::uint32_t>(asked + 1));
          result.init(index.data(), distance2.data());
          tree.findNeighbors(result, origin, nanoflann::SearchParams());
          int m = 0;
          for (std::uint32_t j = 0; j < result.size() && m < asked; ++j) {
            if (index[j] == c) continue;
            const float* q = leaf_xyz.data() + 3 * static_cast<std::size_t>(index[j]);
            const float d2 =
                settings.by_direction ? unorganized::squared_distance(p, q) : distance2[j];
            if (!test(p, q, d2)) continue;
            const auto u = static_cast<std::size_t>(m++);
            accepted.idx[u] = index[j];
            accepted.d2[u] = d2;
            accepted.s[u] = std::sqrt(distance2[j]);
            accepted.scale[u] = 1.0f;
            if (settings.by_direction) {
              const float* dir = space + 3 * static_cast<std::size_t>(index[j]);
              const float range = (q[0] - settings.viewpoint[0]) * dir[0] +
                                  (q[1] - settings.viewpoint[1]) * dir[1] +
                                  (q[2] - settings.viewpoint[2]) * dir[2];
              accepted.scale[u] = range > 0 ? 2.0f / range : std::numeric_limits<float>::infinity();
            }
          }
          const int kept = drop_coincident(leaf_xyz.data(), accepted, m, coincident);
          // Coincident candidates dropped: ask again for more in the same proportion, up to
          // twice as many (the tree may have no more). Where many copies of each point lie on
          // top of each other (coordinates rounded to a coarse step) the ring then holds fewer
          // than k: asking for up to kMaxCandidates took 4.4 times as long there.
          const int most = std::min(kMaxCandidates, 2 * wanted);
          if (kept >= wanted || m == kept || result.size() <= static_cast<std::size_t>(asked) ||
              asked >= most) {
            return std::min(kept, wanted);
          }
          asked = std::min(most, (asked * wanted + std::max(kept, 1) - 1) / std::max(kept, 1) + 1);
        }
      };
      int m = nearest(k);
      if (settings.balanced && k >= kMinBalancedK && m >= kMinBalancedK &&
          along_a_line(space, origin, accepted.idx.data(), m)) {
        m = balanced_ring(space, origin, accepted.idx.data(),
                          nearest(std::min(4 * k, kMaxCandidates)), k);
      }
      const auto i = static_cast<std::size_t>(leaf_original[c]);
      std::int32_t* ring = out.neighbours.data() + i * static_cast<std::size_t>(k);
      for (int j = 0; j < m; ++j) {
        ring[j] = leaf_original[accepted.idx[static_cast<std::size_t>(j)]];
      }
      out.count[i] = static_cast<std::uint8_t>(m);
    }
  };
  const int points = static_cast<int>(original.size());
  if (pool != nullptr && pool->threads() > 1) {
    pool->for_each_band(points, 1, query);
  } else {
    query(0, 0, points);
  }
}

}  // namespace

void build_rings(const OrganizedCloud& cloud, const RingSettings& settings, PointRings& out) {
  RingBuffers buffers;
  build(cloud, settings, out, nullptr, buffers.impl());
}

void build_rings(const OrganizedCloud& cloud, const RingSettings& settings, PointRings& out,
                 ThreadPool& pool) {
  RingBuffers buffers;
  build(cloud, settings, out, &pool, buffers.impl());
}

void build_rings(const OrganizedCloud& cloud, const RingSettings& settings, PointRings& out,
                 ThreadPool* pool, RingBuffers& buffers) {
  build(cloud, settings, out, pool, buffers.impl());
}

}  // namespace rangeseg
