// The incremental plane region model (Poppinga et al., "Fast plane detection and polygonalization
// in noisy 3D range images", IROS 2008): the region's least-squares plane from running moments,
// with a noise-aware distance test per point and a bound on the region's mean squared error.
#include <Eigen/Eigenvalues>

#include <cmath>
#include <cstdint>

#include "segmentation/region_growing.hpp"

namespace rangeseg::seg {
namespace {

/// Moments of the points weighted by w = 1 / sigma(z)^2, so that the squared residual of any
/// plane n.x + d = 0 in units of each point's sigma^2 is a quadratic form of them.
struct WeightedMoments {
  double sw = 0, sx = 0, sy = 0, sz = 0;
  double sxx = 0, sxy = 0, sxz = 0, syy = 0, syz = 0, szz = 0;

  void add(double w, double x, double y, double z) {
    sw += w;
    sx += w * x;
    sy += w * y;
    sz += w * z;
    sxx += w * x * x;
    sxy += w * x * y;
    sxz += w * x * z;
    syy += w * y * y;
    syz += w * y * z;
    szz += w * z * z;
  }
  /// sum_i w_i (n.x_i + d)^2
  double weighted_sse(double nx, double ny, double nz, double d) const {
    const double second = nx * nx * sxx + ny * ny * syy + nz * nz * szz +
                          2.0 * (nx * ny * sxy + nx * nz * sxz + ny * nz * syz);
    const double first = nx * sx + ny * sy + nz * sz;
    return std::max(0.0, second + 2.0 * d * first + d * d * sw);
  }
};

/// A point joins when (1) its normal is within `max_normal_angle` of the region's normal (as in
/// the plane model; it keeps regions from creeping around creases point by point), (2) its
/// distance to the region's least-squares plane is within k sigma(z), and (3) the region's mean
/// squared residual with the point, in units of sigma(z)^2, stays at most 1. The plane is the
/// mean-normal plane through the centroid for the first kPcaMinPoints points, then the PCA plane
/// of the running moments, refitted whenever the region has grown by an eighth (Poppinga refits
/// at every point; a large region's plane hardly moves, so this gives the same decisions at a
/// fraction of the eigen-solves). The squared-error sum w.r.t. the current plane is updated per
/// point and recomputed exactly from the moments at every refit.
class IncrementalPlaneModel {
 public:
  explicit IncrementalPlaneModel(const SegmentationSettings& s)
      : cos_max_angle_(static_cast<float>(std::cos(s.max_normal_angle))),
        k_(static_cast<float>(s.max_distance_sigmas)),
        a_(static_cast<float>(s.noise.a)),
        b_(static_cast<float>(s.noise.b)),
        z0_(static_cast<float>(s.noise.z0)) {}

  void init(const Frame& f, std::int32_t seed) {
    stats_.clear();
    weighted_ = WeightedMoments{};
    snx_ = sny_ = snz_ = 0.0;
    next_refit_ = 0;
    sse_ = 0;
    add(f, seed);
  }

  bool seed_ok(const Frame& f, std::int32_t seed) const {
    return seed_ring_ok(f, seed, cos_max_angle_);
  }

  bool accepts(const Frame& f, std::int32_t /*from*/, std::int32_t q) const {
    const float dot = nx_ * f.nx[q] + ny_ * f.ny[q] + nz_ * f.nz[q];
    if (!(dot >= cos_max_angle_)) return false;  // also rejects NaN normals
    const float z = f.z[q];
    const float distance = std::fabs(nx_ * f.x[q] + ny_ * f.y[q] + nz_ * z + d_);
    const float dz = z - z0_;
    const float sigma = a_ + b_ * dz * dz;
    if (!(distance <= k_ * sigma)) return false;
    const double normalised = static_cast<double>(distance) / sigma;
    return sse_ + normalised * normalised <= static_cast<double>(stats_.count + 1);
  }

  void add(const Frame& f, std::int32_t q) {
    const double x = f.x[q], y = f.y[q], z = f.z[q];
    stats_.add(x, y, z);
    const double dz = z - z0_;
    const double sigma = a_ + b_ * dz * dz;
    const double w = 1.0 / (sigma * sigma);
    weighted_.add(w, x, y, z);
    const double distance = nx_ * x + ny_ * y + nz_ * z + d_;
    sse_ += w * distance * distance;
    snx_ += f.nx[q];
    sny_ += f.ny[q];
    snz_ += f.nz[q];
    if (stats_.count >= next_refit_) refit();
  }

  const detail::PlaneStats& stats() const { return stats_; }

 private:
  static constexpr std::int64_t kPcaMinPoints = 8;

  void refit() {
    const double inv_count = 1.0 / static_cast<double>(stats_.count);
    double nx = snx_, ny = sny_, nz = snz_;
    const double norm = std::sqrt(nx * nx + ny * ny + nz * nz);
    if (norm > 0) {
      nx /= norm;
      ny /= norm;
      nz /= norm;
    }
    if (stats_.count >= kPcaMinPoints) least_squares_normal(inv_count, nx, ny, nz);
    const double d = -(nx * stats_.sx + ny * stats_.sy + nz * stats_.sz) * inv_count;
    nx_ = static_cast<float>(nx);
    ny_ = static_cast<float>(ny);
    nz_ = static_cast<float>(nz);
    d_ = static_cast<float>(d);
    sse_ = weighted_.weighted_sse(nx, ny, nz, d);
    next_refit_ = stats_.count < kPcaMinPoints ? stats_.count + 1 : stats_.count + stats_.count / 8;
  }

  void least_squares_normal(double inv_count, double& nx, double& ny, double& nz) const {
    const auto& s = stats_;
    const double mx = s.sx * inv_count, my = s.sy * inv_count, mz = s.sz * inv_count;
    Eigen::Matrix3d cov;
    cov(0, 0) = s.sxx * inv_count - mx * mx;
    cov(0, 1) = cov(1, 0) = s.sxy * inv_count - mx * my;
    cov(0, 2) = cov(2, 0) = s.sxz * inv_count - mx * mz;
    cov(1, 1) = s.syy * inv_count - my * my;
    cov(1, 2) = cov(2, 1) = s.syz * inv_count - my * mz;
    cov(2, 2) = s.szz * inv_count - mz * mz;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
    solver.computeDirect(cov);
    const Eigen::Vector3d ev = solver.eigenvalues();
    if (!(ev(1) > 4.0 * ev(0)) || !(ev(1) > 0)) return;  // a strip: keep the mean normal
    Eigen::Vector3d n = solver.eigenvectors().col(0);
    if (n(0) * nx + n(1) * ny + n(2) * nz < 0) n = -n;
    nx = n(0);
    ny = n(1);
    nz = n(2);
  }

  float cos_max_angle_, k_, a_, b_, z0_;
  detail::PlaneStats stats_;
  WeightedMoments weighted_;
  double snx_ = 0, sny_ = 0, snz_ = 0;
  double sse_ = 0;  ///< sum of squared residuals to the current plane, in units of sigma^2
  std::int64_t next_refit_ = 0;
  float nx_ = 0, ny_ = 0, nz_ = 1, d_ = 0;
};

static_assert(RegionGrowingModel<IncrementalPlaneModel>);

}  // namespace

void grow_incremental_planes(const Frame& frame, const SegmentationSettings& settings,
                             Segmenter::Scratch& scratch) {
  IncrementalPlaneModel model(settings);
  grow_regions(frame, model, scratch);
}

}  // namespace rangeseg::seg
