// Internal: first and second moments of a point set, for least-squares plane fits (PCA).
// The sums are kept in double so that regions of 10^5 points at 5 m still resolve sub-millimetre
// residuals (the covariance is taken relative to the mean, cancellation ~1e-9 relative).
#pragma once

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace rangeseg::detail {

/// A least-squares plane n.x + offset = 0 through `centroid`; `normal` is unit length and faces
/// the origin (offset >= 0). `rms` is the RMS orthogonal residual [m]; `ok` is false for fewer
/// than 3 points or (numerically) collinear points, in which case the other fields are NaN.
struct PlaneFit {
  std::array<double, 3> centroid{NAN, NAN, NAN};
  std::array<double, 3> normal{NAN, NAN, NAN};
  double offset = NAN;
  double rms = NAN;
  /// Standard error of the normal's direction [rad]: sqrt(lambda_0 / (count lambda_1)) with
  /// lambda_0 <= lambda_1 the two smallest covariance eigenvalues (as the slope error of a line
  /// fit).
  double normal_stderr = NAN;
  bool ok = false;

  /// Signed distance of a point to the plane [m].
  double distance(double x, double y, double z) const {
    return normal[0] * x + normal[1] * y + normal[2] * z + offset;
  }
};

/// Running sums of count, x and x x^T over a point set (cf. PEAC / CAPE plane statistics):
/// O(1) add and merge, and a PCA plane fit at any time.
struct PlaneStats {
  std::int64_t count = 0;
  double sx = 0, sy = 0, sz = 0;
  double sxx = 0, sxy = 0, sxz = 0, syy = 0, syz = 0, szz = 0;

  void add(double x, double y, double z) {
    ++count;
    sx += x;
    sy += y;
    sz += z;
    sxx += x * x;
    sxy += x * y;
    sxz += x * z;
    syy += y * y;
    syz += y * z;
    szz += z * z;
  }
  void merge(const PlaneStats& o) {
    count += o.count;
    sx += o.sx;
    sy += o.sy;
    sz += o.sz;
    sxx += o.sxx;
    sxy += o.sxy;
    sxz += o.sxz;
    syy += o.syy;
    syz += o.syz;
    szz += o.szz;
  }
  /// Takes back an earlier add of the same point.
  void remove(double x, double y, double z) {
    --count;
    sx -= x;
    sy -= y;
    sz -= z;
    sxx -= x * x;
    sxy -= x * y;
    sxz -= x * z;
    syy -= y * y;
    syz -= y * z;
    szz -= z * z;
  }
  void clear() { *this = PlaneStats{}; }

  std::array<double, 3> mean() const {
    if (count == 0) return {NAN, NAN, NAN};
    const double inv = 1.0 / static_cast<double>(count);
    return {sx * inv, sy * inv, sz * inv};
  }

  /// RMS of the signed distances n.x + offset over the points (n unit) [m].
  double rms_distance(const std::array<double, 3>& n, double offset) const {
    if (count == 0) return NAN;
    const double inv = 1.0 / static_cast<double>(count);
    const double second = n[0] * n[0] * sxx + n[1] * n[1] * syy + n[2] * n[2] * szz +
                          2.0 * (n[0] * n[1] * sxy + n[0] * n[2] * sxz + n[1] * n[2] * syz);
    const double first = n[0] * sx + n[1] * sy + n[2] * sz;
    return std::sqrt(std::max(0.0, second * inv + 2.0 * offset * first * inv + offset * offset));
  }

  /// Covariance of the points about their mean [m^2] (count > 0).
  Eigen::Matrix3d covariance() const {
    const double inv = 1.0 / static_cast<double>(count);
    const double mx = sx * inv, my = sy * inv, mz = sz * inv;
    Eigen::Matrix3d cov;
    cov(0, 0) = sxx * inv - mx * mx;
    cov(0, 1) = sxy * inv - mx * my;
    cov(0, 2) = sxz * inv - mx * mz;
    cov(1, 1) = syy * inv - my * my;
    cov(1, 2) = syz * inv - my * mz;
    cov(2, 2) = szz * inv - mz * mz;
    cov(1, 0) = cov(0, 1);
    cov(2, 0) = cov(0, 2);
    cov(2, 1) = cov(1, 2);
    return cov;
  }

  /// PCA fit: the normal is the eigenvector of the smallest eigenvalue of the covariance.
  PlaneFit fit() const {
    PlaneFit f;
    if (count < 3) return f;
    const double inv = 1.0 / static_cast<double>(count);
    const double mx = sx * inv, my = sy * inv, mz = sz * inv;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance());
    if (solver.info() != Eigen::Success) return f;
    const Eigen::Vector3d& ev = solver.eigenvalues();  // ascending
    // Collinear (or single-point) sets have two vanishing eigenvalues: no unique plane.
    if (!(ev(1) > 1e-12 * std::max(ev(2), 1e-300))) return f;
    Eigen::Vector3d n = solver.eigenvectors().col(0);
    double d = -(n(0) * mx + n(1) * my + n(2) * mz);
    if (d < 0) {
      n = -n;
      d = -d;
    }
    f.centroid = {mx, my, mz};
    f.normal = {n(0), n(1), n(2)};
    f.offset = d;
    f.rms = std::sqrt(std::max(ev(0), 0.0));
    f.normal_stderr = std::sqrt(std::max(ev(0), 0.0) / (static_cast<double>(count) * ev(1)));
    f.ok = true;
    return f;
  }
};

}  // namespace rangeseg::detail
