// Sphere and cylinder fits: closed-form initial estimates from the normals (and an algebraic
// circle fit), refined by Levenberg-Marquardt on the geometric point-to-surface distances.
#include "rangeseg/primitives.hpp"

#include "detail/primitive_fit.hpp"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace rangeseg {
namespace {

using Eigen::Vector3d;

Vector3d vec(const Point3& p) { return {p[0], p[1], p[2]}; }
Point3 arr(const Vector3d& v) { return {v(0), v(1), v(2)}; }

bool finite(const Vector3d& v) {
  return std::isfinite(v(0)) && std::isfinite(v(1)) && std::isfinite(v(2));
}

void require_same_length(const char* what, std::size_t points, std::size_t normals) {
  if (points != normals) {
    throw std::invalid_argument(std::string(what) + ": " + std::to_string(points) + " points but " +
                                std::to_string(normals) + " normals");
  }
}

Vector3d centroid_of(std::span<const Point3> points) {
  Vector3d c = Vector3d::Zero();
  for (const Point3& p : points) c += vec(p);
  return c / static_cast<double>(points.size());
}

/// Two unit vectors completing `a` (unit) to an orthonormal basis.
void complete_basis(const Vector3d& a, Vector3d& e1, Vector3d& e2) {
  const Vector3d helper = std::fabs(a(0)) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY();
  e1 = a.cross(helper).normalized();
  e2 = a.cross(e1);
}

/// Levenberg-Marquardt over N parameters. `evaluate(params, JtJ*, Jtr*)` returns the sum of
/// squared residuals at params (and accumulates the normal equations when the pointers are
/// non-null); `update(params, delta)` returns the parameters moved by delta.
template <int N, class Params, class Evaluate, class Update>
double levenberg_marquardt(Params& params, int max_iterations, Evaluate&& evaluate,
                           Update&& update) {
  using Mat = Eigen::Matrix<double, N, N>;
  using Vec = Eigen::Matrix<double, N, 1>;
  Mat jtj;
  Vec jtr;
  double cost = evaluate(params, &jtj, &jtr);
  double lambda = 1e-3;
  for (int it = 0; it < max_iterations && std::isfinite(cost); ++it) {
    bool improved = false;
    for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
      Mat damped = jtj;
      for (int k = 0; k < N; ++k) damped(k, k) += lambda * std::max(jtj(k, k), 1e-12);
      const Vec delta = damped.ldlt().solve(-jtr);
      if (!delta.allFinite()) break;
      Params trial = update(params, delta);
      const double trial_cost = evaluate(trial, nullptr, nullptr);
      if (trial_cost < cost) {
        const double gain = cost - trial_cost;
        params = trial;
        lambda = std::max(lambda * 0.1, 1e-9);
        improved = true;
        if (gain <= 1e-12 * cost) return trial_cost;
        cost = evaluate(params, &jtj, &jtr);
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  return cost;
}

using Matrix3XMap = Eigen::Map<Eigen::Matrix3Xd>;

/// The points a fit currently runs over: all, or the inliers of a refit (3 x cols).
struct Points {
  const double* data = nullptr;
  Eigen::Index cols = 0;
  Eigen::Map<const Eigen::Matrix3Xd> map() const { return {data, 3, cols}; }
};

/// Resizes `storage` for 3 x n doubles and maps it.
Matrix3XMap map_3xn(std::vector<double>& storage, Eigen::Index n) {
  storage.resize(3 * static_cast<std::size_t>(n));
  return {storage.data(), 3, n};
}

/// 10 times the robust standard deviation (1.4826 times the median absolute value) of the
/// residuals of the least-squares fit: the bound beyond which a point is dropped from the refits.
template <class Residual>
double outlier_bound(Eigen::Index n, Residual&& residual, std::vector<double>& abs_r) {
  abs_r.resize(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) abs_r[static_cast<std::size_t>(i)] = std::fabs(residual(i));
  const auto middle = abs_r.begin() + n / 2;
  std::nth_element(abs_r.begin(), middle, abs_r.end());
  return 10.0 * 1.4826 * *middle;
}

/// PrimitiveFitSettings::outlier_refits: the fit is redone (`refit()`, on the points `active`
/// then points to) on the points within outlier_bound of it, with that bound fixed (a fit pulled
/// by outliers leaves some of them inside at first; a surface's own systematic deviations, such
/// as a smoothed cylinder's flattened silhouettes, stay in, where a re-estimated bound would peel
/// them off round by round), until they no longer change. `active` ends at `all` again. Returns
/// whether the fit was redone.
template <class Residual, class Refit>
bool refit_inliers(int max_refits, const Matrix3XMap& all, detail::PrimitiveFitBuffers& b,
                   Points& active, Residual&& residual, Refit&& refit) {
  if (max_refits <= 0) return false;
  const Eigen::Index n = all.cols();
  const double bound = outlier_bound(n, residual, b.abs_residuals);
  std::vector<char>& keep = b.keep;
  std::vector<char>& kept = b.kept;
  keep.assign(static_cast<std::size_t>(n), 1);
  kept.assign(static_cast<std::size_t>(n), 1);
  bool refitted = false;
  for (int round = 0; round < max_refits; ++round) {
    Eigen::Index count = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      keep[static_cast<std::size_t>(i)] = std::fabs(residual(i)) <= bound;
      count += keep[static_cast<std::size_t>(i)];
    }
    if (keep == kept || count == 0) break;
    b.inliers.resize(3 * static_cast<std::size_t>(count));
    Matrix3XMap inliers(b.inliers.data(), 3, count);
    for (Eigen::Index i = 0, k = 0; i < n; ++i) {
      if (keep[static_cast<std::size_t>(i)] != 0) inliers.col(k++) = all.col(i);
    }
    active = {b.inliers.data(), count};
    const bool ok = refit();
    active = {all.data(), n};
    if (!ok) break;
    kept = keep;
    refitted = true;
  }
  return refitted;
}

struct SphereParams {
  Vector3d centre = Vector3d::Zero();
  double radius = 0;
};

struct CylinderParams {
  Vector3d point = Vector3d::Zero();  ///< on the axis
  Vector3d axis = Vector3d::UnitY();  ///< unit
  double radius = 0;
};

/// Closest point to the lines x_i + t m_i (m_i unit) in the least-squares sense; false when the
/// lines are (nearly) parallel.
template <int D, class Matrix>
bool closest_to_lines(const Matrix& x, const Matrix& m, Eigen::Matrix<double, D, 1>& out) {
  using Mat = Eigen::Matrix<double, D, D>;
  Mat a = Mat::Zero();
  Eigen::Matrix<double, D, 1> b = Eigen::Matrix<double, D, 1>::Zero();
  int used = 0;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    const auto n = m.col(i);
    if (!n.allFinite() || n.squaredNorm() < 0.25) continue;
    const Mat p = Mat::Identity() - n * n.transpose() / n.squaredNorm();
    a += p;
    b += p * x.col(i);
    ++used;
  }
  if (used < D) return false;
  Eigen::SelfAdjointEigenSolver<Mat> solver(a / used);
  // Normals spanning less than ~3 degrees do not locate a centre.
  if (!(solver.eigenvalues()(0) > 2e-3)) return false;
  out = a.ldlt().solve(b);
  return out.allFinite();
}

}  // namespace

SphereFit detail::fit_sphere(std::span<const Point3> points, std::span<const Point3> normals,
                             const PrimitiveFitSettings& settings, PrimitiveFitBuffers& buffers) {
  require_same_length("fit_sphere", points.size(), normals.size());
  SphereFit fit;
  const auto n = static_cast<Eigen::Index>(points.size());
  if (n < 4) return fit;
  const Vector3d origin = centroid_of(points);
  Matrix3XMap x = map_3xn(buffers.points, n), m = map_3xn(buffers.normals, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    x.col(i) = vec(points[static_cast<std::size_t>(i)]) - origin;
    m.col(i) = vec(normals[static_cast<std::size_t>(i)]);
  }
  SphereParams params{};
  if (!closest_to_lines<3>(x, m, params.centre)) {
    // Algebraic fit |x|^2 + D.x + E = 0 (Kasa): linear in (D, E).
    Eigen::Matrix4d a = Eigen::Matrix4d::Zero();
    Eigen::Vector4d b = Eigen::Vector4d::Zero();
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Vector4d row(x(0, i), x(1, i), x(2, i), 1.0);
      a += row * row.transpose();
      b -= row * x.col(i).squaredNorm();
    }
    const Eigen::Vector4d s = a.ldlt().solve(b);
    if (!s.allFinite()) return fit;
    params.centre = -0.5 * s.head<3>();
  }
  double sum = 0;
  for (Eigen::Index i = 0; i < n; ++i) sum += (x.col(i) - params.centre).norm();
  params.radius = sum / static_cast<double>(n);

  Points active{x.data(), n};  // the points the fit runs over
  const auto residual = [&](const SphereParams& p, Eigen::Index i) {
    return (x.col(i) - p.centre).norm() - p.radius;
  };
  const auto evaluate = [&](const SphereParams& p, Eigen::Matrix4d* jtj, Eigen::Vector4d* jtr) {
    double cost = 0;
    if (jtj) {
      jtj->setZero();
      jtr->setZero();
    }
    const auto pts = active.map();
    for (Eigen::Index i = 0; i < pts.cols(); ++i) {
      const Vector3d w = pts.col(i) - p.centre;
      const double dist = w.norm();
      const double r = dist - p.radius;
      cost += r * r;
      if (jtj && dist > 0) {
        Eigen::Vector4d j;
        j << -w / dist, -1.0;
        *jtj += j * j.transpose();
        *jtr += j * r;
      }
    }
    return cost;
  };
  const auto update = [](const SphereParams& p, const Eigen::Vector4d& d) {
    return SphereParams{p.centre + d.head<3>(), p.radius + d(3)};
  };
  double cost = levenberg_marquardt<4>(params, settings.max_iterations, evaluate, update);
  if (std::isfinite(cost) &&
      refit_inliers(
          settings.outlier_refits, x, buffers, active,
          [&](Eigen::Index i) { return residual(params, i); },
          [&] {
            SphereParams refit = params;
            const double c =
                levenberg_marquardt<4>(refit, settings.max_iterations, evaluate, update);
            if (!std::isfinite(c) || !finite(refit.centre) || !(refit.radius > 0)) return false;
            params = refit;
            return true;
          })) {
    cost = evaluate(params, nullptr, nullptr);  // the RMS over all points
  }
  if (!std::isfinite(cost) || !finite(params.centre) || !(params.radius > 0)) return fit;
  fit.centre = arr(params.centre + origin);
  fit.radius = params.radius;
  fit.rms = std::sqrt(cost / static_cast<double>(n));
  fit.ok = true;
  return fit;
}

CylinderFit detail::fit_cylinder(std::span<const Point3> points, std::span<const Point3> normals,
                                 const PrimitiveFitSettings& settings,
                                 PrimitiveFitBuffers& buffers) {
  require_same_length("fit_cylinder", points.size(), normals.size());
  CylinderFit fit;
  const auto n = static_cast<Eigen::Index>(points.size());
  if (n < 5) return fit;
  const Vector3d origin = centroid_of(points);
  Matrix3XMap x = map_3xn(buffers.points, n);
  Eigen::Matrix3d normal_scatter = Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    x.col(i) = vec(points[static_cast<std::size_t>(i)]) - origin;
    const Vector3d nv = vec(normals[static_cast<std::size_t>(i)]);
    if (finite(nv)) normal_scatter += nv * nv.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> normal_solver(normal_scatter);
  const Vector3d& ev = normal_solver.eigenvalues();

  Points active{x.data(), n};  // the points the fit runs over
  const auto residual = [&](const CylinderParams& p, Eigen::Index i) {
    const Vector3d w = x.col(i) - p.point;
    return (w - w.dot(p.axis) * p.axis).norm() - p.radius;
  };
  const auto evaluate = [&](const CylinderParams& p, Eigen::Matrix<double, 5, 5>* jtj,
                            Eigen::Matrix<double, 5, 1>* jtr) {
    Vector3d e1, e2;
    complete_basis(p.axis, e1, e2);
    double cost = 0;
    if (jtj) {
      jtj->setZero();
      jtr->setZero();
    }
    const auto pts = active.map();
    for (Eigen::Index i = 0; i < pts.cols(); ++i) {
      const Vector3d w = pts.col(i) - p.point;
      const double along = w.dot(p.axis);
      const Vector3d q = w - along * p.axis;
      const double rho = q.norm();
      const double r = rho - p.radius;
      cost += r * r;
      if (jtj && rho > 0) {
        const Vector3d g = q / rho;
        Eigen::Matrix<double, 5, 1> j;
        // d rho / d(axis tilt along e1, e2), d rho / d(point shift along e1, e2), d / d radius.
        j << -along * g.dot(e1), -along * g.dot(e2), -g.dot(e1), -g.dot(e2), -1.0;
        *jtj += j * j.transpose();
        *jtr += j * r;
      }
    }
    return cost;
  };
  const auto update = [](const CylinderParams& p, const Eigen::Matrix<double, 5, 1>& d) {
    Vector3d e1, e2;
    complete_basis(p.axis, e1, e2);
    CylinderParams out;
    out.axis = (p.axis + d(0) * e1 + d(1) * e2).normalized();
    out.point = p.point + d(2) * e1 + d(3) * e2;
    out.point -= out.point.dot(out.axis) * out.axis;  // closest to the centroid (origin)
    out.radius = p.radius + d(4);
    return out;
  };

  // Candidate axes: the direction most perpendicular to the normals, and, when the normals span
  // only a narrow arc (a thin strip of a cylinder, or a nearly flat patch), also the second one.
  int candidates = 1;
  if (!(ev(1) > 0.05 * ev(2))) candidates = 2;
  double best_cost = INFINITY;
  CylinderParams best{};
  for (int c = 0; c < candidates; ++c) {
    CylinderParams p;
    p.axis = normal_solver.eigenvectors().col(c);
    if (!finite(p.axis)) continue;
    Vector3d e1, e2;
    complete_basis(p.axis, e1, e2);
    // Algebraic circle fit of the projected points (Kasa): u^2 + v^2 + D u + E v + F = 0.
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    Vector3d b = Vector3d::Zero();
    for (Eigen::Index i = 0; i < n; ++i) {
      const double u = x.col(i).dot(e1), v = x.col(i).dot(e2);
      const Vector3d row(u, v, 1.0);
      a += row * row.transpose();
      b -= row * (u * u + v * v);
    }
    const Vector3d s = a.ldlt().solve(b);
    if (!s.allFinite()) continue;
    const double cu = -0.5 * s(0), cv = -0.5 * s(1);
    const double r2 = cu * cu + cv * cv - s(2);
    if (!(r2 > 0)) continue;
    p.point = cu * e1 + cv * e2;
    p.radius = std::sqrt(r2);
    const double cost = levenberg_marquardt<5>(p, settings.max_iterations, evaluate, update);
    if (cost < best_cost && finite(p.axis) && finite(p.point) && p.radius > 0) {
      best_cost = cost;
      best = p;
    }
  }
  if (!std::isfinite(best_cost)) return fit;
  const bool refitted = refit_inliers(
      settings.outlier_refits, x, buffers, active,
      [&](Eigen::Index i) { return residual(best, i); },
      [&] {
        CylinderParams refit = best;
        const double c = levenberg_marquardt<5>(refit, settings.max_iterations, evaluate, update);
        if (!std::isfinite(c) || !finite(refit.axis) || !finite(refit.point) ||
            !(refit.radius > 0)) {
          return false;
        }
        best = refit;
        return true;
      });
  if (refitted) best_cost = evaluate(best, nullptr, nullptr);  // the RMS over all points
  // Sign convention: the axis points up in the camera frame (y down), ties towards +x / +z.
  Vector3d axis = best.axis;
  if (axis(1) > 0 || (axis(1) == 0 && (axis(0) < 0 || (axis(0) == 0 && axis(2) < 0)))) {
    axis = -axis;
  }
  double lo = INFINITY, hi = -INFINITY;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double t = (x.col(i) - best.point).dot(axis);
    lo = std::min(lo, t);
    hi = std::max(hi, t);
  }
  fit.axis = arr(axis);
  fit.axis_point = arr(best.point + lo * axis + origin);
  fit.radius = best.radius;
  fit.extent = hi - lo;
  fit.rms = std::sqrt(best_cost / static_cast<double>(n));
  fit.ok = true;
  return fit;
}

SphereFit fit_sphere(std::span<const Point3> points, std::span<const Point3> normals,
                     const PrimitiveFitSettings& settings) {
  detail::PrimitiveFitBuffers buffers;
  return detail::fit_sphere(points, normals, settings, buffers);
}

CylinderFit fit_cylinder(std::span<const Point3> points, std::span<const Point3> normals,
                         const PrimitiveFitSettings& settings) {
  detail::PrimitiveFitBuffers buffers;
  return detail::fit_cylinder(points, normals, settings, buffers);
}

}  // namespace rangeseg
