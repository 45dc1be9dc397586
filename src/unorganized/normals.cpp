// Stage 2 over k-nearest-neighbour rings: area-weighted fan normals and curvature.
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <vector>

#include "rangeseg/unorganized.hpp"
#include "unorganized/internal.hpp"

namespace rangeseg {
namespace {

/// A monotone stand-in for atan2(y, x) in [0, 4) (the "diamond angle"): orders directions by
/// angle without a transcendental call.
inline float pseudo_angle(float x, float y) {
  const float s = std::fabs(x) + std::fabs(y);
  if (!(s > 0)) return 0.0f;
  const float t = y / s;
  if (x >= 0) return y >= 0 ? t : 4.0f + t;
  return 2.0f - t;
}

/// The least-squares normal of p and its ring (double moments about p), or false when they do
/// not span a plane.
bool pca_normal(const float* xyz, const float* p, std::span<const std::int32_t> ring,
                Eigen::Vector3d& normal) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (const std::int32_t j : ring) {
    const float* q = xyz + 3 * static_cast<std::size_t>(j);
    const Eigen::Vector3d d(double{q[0]} - p[0], double{q[1]} - p[1], double{q[2]} - p[2]);
    sum += d;
    second += d * d.transpose();
  }
  const double count = static_cast<double>(ring.size()) + 1.0;  // p itself is at d = 0
  const Eigen::Vector3d mean = sum / count;
  const Eigen::Matrix3d covariance = second / count - mean * mean.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(covariance);
  const Eigen::Vector3d& ev = solver.eigenvalues();
  // Collinear points span no plane; in float their coordinates are only known to ~1.2e-7 |p|,
  // so a spread across the line below a few of those steps is rounding, not a second axis.
  const double rounding =
      8.0 * std::numeric_limits<float>::epsilon() *
      std::sqrt(double{p[0]} * p[0] + double{p[1]} * p[1] + double{p[2]} * p[2]);
  if (!(ev(1) > std::max(1e-6 * ev(2), rounding * rounding))) return false;
  normal = solver.eigenvectors().col(0);
  return normal.allFinite();
}

/// lambda_1 lambda_2, the product of the two larger eigenvalues of a symmetric positive
/// semi-definite 3x3 matrix, without an eigen-solve (which spends its time in atan2 and sincos):
/// the smallest eigenvalue lambda_0 is the smallest root of the characteristic polynomial
/// p(l) = l^3 - c1 l^2 + c2 l - c3, which is increasing and concave on [0, lambda_0], so
/// Newton's steps from 0 approach it from below; then lambda_1 lambda_2 = c2 - lambda_0 (c1 -
/// lambda_0).
double larger_eigenvalue_product(const Eigen::Matrix3d& a) {
  const double c1 = a.trace();
  const double c2 = a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0) + a(0, 0) * a(2, 2) - a(0, 2) * a(2, 0) +
                    a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1);
  const double c3 = a.determinant();
  double l = 0;
  // Quadratic convergence for a plane's ring (lambda_0 far below lambda_1); linear where
  // lambda_0 and lambda_1 are close, hence the cap.
  for (int step = 0; step < 100; ++step) {
    const double p = ((l - c1) * l + c2) * l - c3;
    const double slope = (3.0 * l - 2.0 * c1) * l + c2;
    if (!(p < 0) || !(slope > 0)) break;
    const double next = l - p / slope;
    if (!(next > l)) break;
    l = next;
  }
  return std::max(0.0, c2 - l * (c1 - l));
}

struct RingNormal {
  std::array<float, 3> n{NAN, NAN, NAN};
  float curvature = NAN;
};

/// The unit vector from p to the viewpoint, or false at the viewpoint.
bool towards(const std::array<float, 3>& viewpoint, const float* p, Eigen::Vector3d& axis) {
  axis = Eigen::Vector3d(double{viewpoint[0]} - p[0], double{viewpoint[1]} - p[1],
                         double{viewpoint[2]} - p[2]);
  const double length = axis.norm();
  if (!(length > 0)) return false;
  axis /= length;
  return true;
}

/// A fan whose summed face normals are shorter than this times the ring's summed squared edge
/// lengths spans no plane: its ring lies along a line (a grid ring of 12 gives 0.43; the PCA test
/// below asks for a spread across the line of 1e-3 of the spread along it).
constexpr double kMinFanRatio = 1e-3;

/// The fan normal of point i over its ring (see compute_normals), facing `viewpoint`.
RingNormal ring_normal(const float* xyz, std::size_t i, std::span<const std::int32_t> ring,
                       const PointRings& rings, const std::array<float, 3>& viewpoint) {
  RingNormal out;
  const std::size_t m = ring.size();
  if (m < 2) return out;
  const float* p = xyz + 3 * i;
  // n0: the axis, pointing to the sensor for rings by direction (so that the fan runs
  // counter-clockwise as seen from it), of either sign for PCA.
  Eigen::Vector3d n0;
  if (rings.by_direction ? !towards(rings.viewpoint, p, n0) : !pca_normal(xyz, p, ring, n0)) {
    return out;
  }
  // A right-handed basis (a, b, n0) of the tangent plane; the fan runs counter-clockwise.
  const Eigen::Vector3d a = n0.unitOrthogonal();
  const Eigen::Vector3d b = n0.cross(a);
  std::array<Eigen::Vector3d, 64> d;
  std::array<float, 64> key{};
  std::array<std::uint8_t, 64> order{};
  double squared_lengths = 0;
  for (std::size_t j = 0; j < m; ++j) {
    const float* q = xyz + 3 * static_cast<std::size_t>(ring[j]);
    d[j] = Eigen::Vector3d(double{q[0]} - p[0], double{q[1]} - p[1], double{q[2]} - p[2]);
    key[j] = pseudo_angle(static_cast<float>(d[j].dot(a)), static_cast<float>(d[j].dot(b)));
    order[j] = static_cast<std::uint8_t>(j);
    squared_lengths += d[j].squaredNorm();
  }
  std::sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(m),
            [&](std::uint8_t l, std::uint8_t r) { return key[l] < key[r]; });
  // Consecutive neighbours more than 120 deg apart about n0 bound no triangle (a border).
  const double cos_max_gap = std::cos(2.0 * std::numbers::pi / 3.0);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  // (With two neighbours both pairs are tried; only one runs counter-clockwise.)
  for (std::size_t j = 0; j < m; ++j) {
    const Eigen::Vector3d& u = d[order[j]];
    const Eigen::Vector3d& w = d[order[(j + 1) % m]];
    const Eigen::Vector3d face = u.cross(w);  // twice the triangle's area
    const double along = face.dot(n0);
    const double cosine = u.dot(w);
    const double lengths = std::sqrt(u.squaredNorm() * w.squaredNorm());
    if (along <= 0 || cosine < cos_max_gap * lengths) continue;
    sum += face;
  }
  const double norm = sum.norm();
  if (!(norm > 0) || (rings.by_direction && !(norm > kMinFanRatio * squared_lengths))) return out;
  Eigen::Vector3d n = sum / norm;
  const Eigen::Vector3d ray(double{p[0]} - viewpoint[0], double{p[1]} - viewpoint[1],
                            double{p[2]} - viewpoint[2]);
  if (n.dot(ray) > 0) n = -n;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (std::size_t j = 0; j < m; ++j) centroid += d[j];
  centroid /= static_cast<double>(m);
  const double r2 = squared_lengths / static_cast<double>(m);
  out.n = {static_cast<float>(n(0)), static_cast<float>(n(1)), static_cast<float>(n(2))};
  out.curvature = r2 > 0 ? static_cast<float>(2.0 * std::fabs(centroid.dot(n)) / r2) : NAN;
  return out;
}

}  // namespace

namespace {

void normals_over_rings(const OrganizedCloud& cloud, const PointRings& rings,
                        const NormalSettings& settings, NormalMap& out, ThreadPool* pool,
                        std::vector<float>& xyz) {
  unorganized::require_rings_match(cloud, rings, nullptr, "compute_normals");
  const int w = cloud.width(), h = cloud.height();
  out.nx.resize(w, h, NAN);
  out.ny.resize(w, h, NAN);
  out.nz.resize(w, h, NAN);
  out.curvature.resize(w, h, NAN);
  unorganized::pack_points(cloud, xyz);
  unorganized::for_points(rings.size(), pool, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      if (rings.count[i] == 0) continue;
      const RingNormal r = ring_normal(xyz.data(), i, rings.ring(i), rings, settings.viewpoint);
      unorganized::at(out.nx, i) = r.n[0];
      unorganized::at(out.ny, i) = r.n[1];
      unorganized::at(out.nz, i) = r.n[2];
      unorganized::at(out.curvature, i) = r.curvature;
    }
  });
}

}  // namespace

void compute_normals(const OrganizedCloud& cloud, const PointRings& rings,
                     const NormalSettings& settings, NormalMap& out) {
  std::vector<float> xyz;
  normals_over_rings(cloud, rings, settings, out, nullptr, xyz);
}

void compute_normals(const OrganizedCloud& cloud, const PointRings& rings,
                     const NormalSettings& settings, NormalMap& out, ThreadPool& pool) {
  std::vector<float> xyz;
  normals_over_rings(cloud, rings, settings, out, &pool, xyz);
}

void compute_normals(const OrganizedCloud& cloud, const PointRings& rings,
                     const NormalSettings& settings, NormalMap& out, ThreadPool* pool,
                     RingBuffers& buffers) {
  normals_over_rings(cloud, rings, settings, out, pool, buffers.impl().xyz);
}

double point_area(const OrganizedCloud& cloud, const PointRings& rings, std::size_t i) {
  if (i >= rings.size() || rings.count[i] == 0) return 0.0;
  const double px = unorganized::at(cloud.x, i), py = unorganized::at(cloud.y, i),
               pz = unorganized::at(cloud.z, i);
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (const std::int32_t j : rings.ring(i)) {
    const auto q = static_cast<std::size_t>(j);
    const Eigen::Vector3d d(unorganized::at(cloud.x, q) - px, unorganized::at(cloud.y, q) - py,
                            unorganized::at(cloud.z, q) - pz);
    second += d * d.transpose();
  }
  const double m = rings.count[i];
  return 4.0 * std::numbers::pi * std::sqrt(larger_eigenvalue_product(second / m)) / (m + 1.0);
}

}  // namespace rangeseg
