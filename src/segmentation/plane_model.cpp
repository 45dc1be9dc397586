// The plane region model (paper, Sec. III-D): running centroids in point and normal space.
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "segmentation/region_growing.hpp"

namespace rangeseg::seg {
namespace {

/// A point joins when its normal is within an angle of the region's normal and its distance to
/// the plane through the region's centroid with that normal is within k sigma(z).
/// The region's normal starts as the mean of its point normals (the paper's running centroid in
/// normal space). Once the region has kPcaMinPoints points it is the least-squares (PCA) normal
/// of the points, oriented like the mean normal: 1-ring normals carry the full sensor noise
/// (and range quantisation) over a one-pixel baseline, while the PCA normal averages over the
/// region's extent, so the model stops following the noise of the first few normals.
/// The plane used by the test is refreshed after every point while the region has fewer than
/// kPcaMinPoints points (mean normal, cheap) and then whenever it has grown by half (PCA), since
/// a large region's plane hardly moves.
class PlaneModel {
 public:
  explicit PlaneModel(const SegmentationSettings& s)
      : cos_max_angle_(static_cast<float>(std::cos(s.max_normal_angle))),
        cos_seed_angle_(static_cast<float>(std::cos(s.max_normal_angle))),
        k_(static_cast<float>(s.max_distance_sigmas)),
        a_(static_cast<float>(s.noise.a)),
        b_(static_cast<float>(s.noise.b)),
        z0_(static_cast<float>(s.noise.z0)),
        max_seed_curvature_(static_cast<float>(std::fmin(s.max_seed_curvature, 3e38))),
        cos_min_angle_(
            static_cast<float>(std::cos(std::min(s.min_normal_angle, s.max_normal_angle)))),
        veto_{.ring_cos = cos_seed_angle_, .clearance = s.seed_clearance} {}

  /// Sets the frame's normal noise constant c, sigma_n(z) = c sigma(z) / z, and the multiple k
  /// of it that bounds the angle test (SegmentationSettings::normal_noise_sigmas); kc2_ =
  /// (k c)^2 so that the test reads 2 (1 - dot) z^2 <= (k c sigma)^2.
  void set_normal_noise(double k, double c) {
    const double kc = k * c;
    adaptive_ = kc > 0;
    kc2_ = static_cast<float>(kc * kc);
    cell_spread_c_ = adaptive_ ? kCellSpreadFactor * c : 0.0;
  }

  void init(const Frame& f, std::int32_t seed) {
    stats_.clear();
    snx_ = sny_ = snz_ = 0.0;
    next_refresh_ = 0;
    add(f, seed);
  }

  bool seed_ok(const Frame& f, std::int32_t seed) const { return seed_passes(f, seed, veto_); }
  SeedVeto seed_veto() const { return veto_; }

  bool accepts(const Frame& f, std::int32_t /*from*/, std::int32_t q) const {
    const float dot = nx_ * f.nx[q] + ny_ * f.ny[q] + nz_ * f.nz[q];
    if (!(dot >= cos_max_angle_)) return false;  // also rejects NaN normals
    const float z = f.z[q];
    const float distance = std::fabs(nx_ * f.x[q] + ny_ * f.y[q] + nz_ * z + d_);
    const float dz = z - z0_;
    const float sigma = a_ + b_ * dz * dz;
    return distance <= k_ * sigma && angle_within_noise(dot, z, sigma);
  }

  void add(const Frame& f, std::int32_t q) {
    stats_.add(f.x[q], f.y[q], f.z[q]);
    snx_ += f.nx[q];
    sny_ += f.ny[q];
    snz_ += f.nz[q];
    if (stats_.count >= next_refresh_) refresh();
  }

  const detail::PlaneStats& stats() const { return stats_; }

  /// Changes whenever the plane that `accepts` tests against changes.
  std::int32_t plane_version() const { return plane_version_; }

  // --- coarse level: whole cells ---

  /// A cell seeds a region when it is a plane by the region test itself: consistent normals
  /// (`cell_normal`: the resultant of its unit normals, |sum n| / count, is at least
  /// cos(max_normal_angle), which every normal within that angle of the mean guarantees, or
  /// the spread the sensor's noise predicts) and points within the distance bound of the plane
  /// through its centroid with its mean normal.
  bool cell_seed_ok(const Cell& c) const {
    if (!(c.curvature <= max_seed_curvature_ * static_cast<float>(c.stats.count))) return false;
    double nx, ny, nz;
    if (!cell_normal(c, nx, ny, nz)) return false;
    const double inv = 1.0 / static_cast<double>(c.stats.count);
    const double d = -(nx * c.stats.sx + ny * c.stats.sy + nz * c.stats.sz) * inv;
    return cell_within(c, nx, ny, nz, d);
  }

  void init_cell(const Cell& c) {
    stats_ = c.stats;
    snx_ = c.snx;
    sny_ = c.sny;
    snz_ = c.snz;
    next_refresh_ = 0;
    refresh();
  }

  /// A neighbouring cell joins as a unit when its mean normal passes the angle test and its
  /// points pass the distance test against the region's plane (see `cell_within`).
  bool accepts_cell(const Cell& c) const {
    double nx, ny, nz;
    if (!cell_normal(c, nx, ny, nz)) return false;
    const double dot = nx * nx_ + ny * ny_ + nz * nz_;
    if (!(dot >= cos_max_angle_)) return false;
    const double z = c.stats.sz / static_cast<double>(c.stats.count), dz = z - z0_;
    if (!angle_within_noise(static_cast<float>(dot), static_cast<float>(z),
                            static_cast<float>(a_ + b_ * dz * dz))) {
      return false;
    }
    return cell_within(c, nx_, ny_, nz_, d_);
  }

  void add_cell(const Cell& c) {
    stats_.merge(c.stats);
    snx_ += c.snx;
    sny_ += c.sny;
    snz_ += c.snz;
    if (stats_.count >= next_refresh_) refresh();
  }

 private:
  static constexpr std::int64_t kPcaMinPoints = 8;
  /// Bound on a cell's normal spread s (see `cell_normal`) in units of the frame's sigma_n(z) at
  /// its depth, for which s = 1 at the median cell by definition. On a plane s is an estimate
  /// from 64 correlated normals; 1.5 keeps most of them (the 90th percentile of all complete
  /// cells is 1.2-1.6 on synthetic Kinect box scenes, whose tails are crease and edge cells,
  /// which the angle and distance tests still reject; 1.25 and 2 score the same there).
  static constexpr double kCellSpreadFactor = 1.5;

  /// The angle between the normals (cosine `dot`) is within k sigma_n(z) or the floor; the
  /// small-angle form 1 - cos(t) = t^2 / 2 avoids a cosine per point.
  bool angle_within_noise(float dot, float z, float sigma) const {
    if (!adaptive_ || dot >= cos_min_angle_) return true;
    return 2.0f * (1.0f - dot) * z * z <= kc2_ * sigma * sigma;
  }

  /// The cell's mean normal, if its normals are consistent: the resultant length |sum n| /
  /// count is at least cos(max_normal_angle), or its spread s = sqrt(1 - |sum n| / count) is
  /// within kCellSpreadFactor sigma_n(z) of the frame. Far from a Kinect the sensor noise spreads
  /// a plane's 1-ring normals wider than max_normal_angle (at 5 m, smoothed once, more than half
  /// are over 25 deg off), while the mean of a cell's 64 normals still points the right way;
  /// without the second test such cells were grown pixel by pixel against that angle test.
  bool cell_normal(const Cell& c, double& nx, double& ny, double& nz) const {
    const double norm = std::sqrt(c.snx * c.snx + c.sny * c.sny + c.snz * c.snz);
    const double count = static_cast<double>(c.stats.count);
    if (!(norm >= cos_max_angle_ * count)) {
      const double z = c.stats.sz / count, dz = z - z0_;
      const double spread = cell_spread_c_ * (a_ + b_ * dz * dz) / z;
      if (!(norm > 0) || !(1.0 - norm / count <= spread * spread)) return false;
    }
    nx = c.snx / norm;
    ny = c.sny / norm;
    nz = c.snz / norm;
    return true;
  }

  /// The distance test for a whole cell from its moments: with mean mu and standard deviation
  /// sd of its points' distances to the plane, mu + 2 sd within k sigma(z) at the cell's
  /// centroid, i.e. all but the two-sided ~5% tail of a Gaussian cell would pass the pixel test.
  bool cell_within(const Cell& c, double nx, double ny, double nz, double d) const {
    const auto& s = c.stats;
    const double inv = 1.0 / static_cast<double>(s.count);
    const double mean = (nx * s.sx + ny * s.sy + nz * s.sz) * inv + d;
    const double rms = s.rms_distance({nx, ny, nz}, d);
    const double sd = std::sqrt(std::max(0.0, rms * rms - mean * mean));
    const double dz = s.sz * inv - z0_;
    const double bound = k_ * (a_ + b_ * dz * dz);
    return std::fabs(mean) + 2.0 * sd <= bound;
  }

  void refresh() {
    const double norm = std::sqrt(snx_ * snx_ + sny_ * sny_ + snz_ * snz_);
    const double inv_count = 1.0 / static_cast<double>(stats_.count);
    double nx = snx_, ny = sny_, nz = snz_;
    if (norm > 0) {
      nx /= norm;
      ny /= norm;
      nz /= norm;
    }
    if (stats_.count >= kPcaMinPoints) pca_normal(inv_count, nx, ny, nz);
    nx_ = static_cast<float>(nx);
    ny_ = static_cast<float>(ny);
    nz_ = static_cast<float>(nz);
    d_ = static_cast<float>(-(nx * stats_.sx + ny * stats_.sy + nz * stats_.sz) * inv_count);
    ++plane_version_;
    // Mean-normal updates are cheap (every point while the region is tiny); eigen-solves run at
    // 8, 12, 18, 27, ... points, so the many tiny regions of noisy areas cost few solves.
    next_refresh_ =
        stats_.count < kPcaMinPoints ? stats_.count + 1 : stats_.count + stats_.count / 2;
  }

  /// Replaces (nx, ny, nz) by the PCA normal, oriented like it, unless the points are
  /// (nearly) collinear.
  void pca_normal(double inv_count, double& nx, double& ny, double& nz) const {
    const auto& s = stats_;
    const double mx = s.sx * inv_count, my = s.sy * inv_count, mz = s.sz * inv_count;
    Eigen::Matrix3d cov;
    cov << s.sxx * inv_count - mx * mx, s.sxy * inv_count - mx * my, s.sxz * inv_count - mx * mz, 0,
        s.syy * inv_count - my * my, s.syz * inv_count - my * mz,  //
        0, 0, s.szz * inv_count - mz * mz;
    cov(1, 0) = cov(0, 1);
    cov(2, 0) = cov(0, 2);
    cov(2, 1) = cov(1, 2);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
    solver.computeDirect(cov);
    const Eigen::Vector3d ev = solver.eigenvalues();
    // A strip of points one pixel wide does not define a plane: keep the mean normal.
    if (!(ev(1) > 4.0 * ev(0)) || !(ev(1) > 0)) return;
    Eigen::Vector3d n = solver.eigenvectors().col(0);
    if (n(0) * nx + n(1) * ny + n(2) * nz < 0) n = -n;
    nx = n(0);
    ny = n(1);
    nz = n(2);
  }

  float cos_max_angle_, cos_seed_angle_, k_, a_, b_, z0_, max_seed_curvature_, cos_min_angle_;
  SeedVeto veto_;
  bool adaptive_ = false;
  float kc2_ = 0;
  double cell_spread_c_ = 0;  ///< kCellSpreadFactor c, 0 without the noise-derived bound
  detail::PlaneStats stats_;
  double snx_ = 0, sny_ = 0, snz_ = 0;
  std::int64_t next_refresh_ = 0;
  float nx_ = 0, ny_ = 0, nz_ = 1, d_ = 0;
  std::int32_t plane_version_ = 0;
};

static_assert(CellGrowingModel<PlaneModel>);

/// The plane model without its cell interface: every pixel is grown individually.
struct PixelPlaneModel {
  PlaneModel& m;
  void init(const Frame& f, std::int32_t seed) { m.init(f, seed); }
  bool seed_ok(const Frame& f, std::int32_t seed) const { return m.seed_ok(f, seed); }
  SeedVeto seed_veto() const { return m.seed_veto(); }
  bool accepts(const Frame& f, std::int32_t p, std::int32_t q) const { return m.accepts(f, p, q); }
  void add(const Frame& f, std::int32_t q) { m.add(f, q); }
  const detail::PlaneStats& stats() const { return m.stats(); }
  std::int32_t plane_version() const { return m.plane_version(); }
};

static_assert(RegionGrowingModel<PixelPlaneModel> && !CellGrowingModel<PixelPlaneModel>);
static_assert(VersionedModel<PlaneModel> && VersionedModel<PixelPlaneModel>);

/// c of the normal noise model sigma_n(z) = c sigma(z) / z: the median over complete cells of
/// s z / sigma(z), where s = sqrt(1 - |mean normal|) is a cell's per-axis normal spread
/// (1 - |mean n| = s^2 for small isotropic deviations). 0 when fewer than 16 cells are complete.
/// The cells are those of `scratch`, or of its growth bands' scratches (`bands` > 1).
double normal_noise_constant(Segmenter::Scratch& scratch, int bands, const SensorNoise& noise) {
  std::vector<double>& c = scratch.cell_normal_noise;
  c.clear();
  for (int b = 0; b < bands; ++b) {
    const Segmenter::Scratch& cells_of = bands > 1 ? *scratch.growth[b] : scratch;
    for (const Cell& cell : cells_of.cells) {
      if (!cell.complete) continue;
      const double n = static_cast<double>(cell.stats.count);
      const double length =
          std::sqrt(cell.snx * cell.snx + cell.sny * cell.sny + cell.snz * cell.snz) / n;
      const double z = cell.stats.sz / n;
      c.push_back(std::sqrt(std::max(0.0, 1.0 - length)) * z / noise.sigma(z));
    }
  }
  if (c.size() < 16) return 0;
  const auto middle = c.begin() + static_cast<std::ptrdiff_t>(c.size() / 2);
  std::nth_element(c.begin(), middle, c.end());
  return *middle;
}

/// Region growing of one frame or growth band (its cells computed).
void grow_plane_regions(const Frame& frame, const SegmentationSettings& settings,
                        Segmenter::Scratch& scratch, PlaneModel& model) {
  if (settings.coarse_cells) {
    grow_regions(frame, model, scratch, &settings, [&] {
      if (settings.reassign_boundary) reassign_before_seeds(frame, settings, scratch);
    });
  } else {
    PixelPlaneModel pixels{model};
    grow_regions(frame, pixels, scratch, &settings);
  }
}

}  // namespace

// With growth bands, each band computes its cells and grows its regions on its own (the bands
// split among the threads); only the normal noise constant, a median over all cells, is
// computed between the two steps, so it is that of the whole frame.
void grow_planes(const Frame& frame, const SegmentationSettings& settings,
                 Segmenter::Scratch& scratch) {
  PlaneModel model(settings);
  const bool cells = settings.coarse_cells || settings.normal_noise_sigmas > 0;
  const int bands = plan_growth_bands(frame, settings.growth_bands, scratch);
  if (bands == 1) {
    if (cells) compute_cells(frame, scratch);
  } else {
    scratch.band_frames.resize(static_cast<std::size_t>(bands));
    for_each_band(scratch, bands, 1, [&](int, int b_begin, int b_end) {
      for (int b = b_begin; b < b_end; ++b) {
        scratch.band_frames[b] = growth_band_frame(frame, scratch, b);
        if (cells) compute_cells(scratch.band_frames[b], *scratch.growth[b]);
      }
    });
  }
  scratch.normal_noise_c = 0;
  if (settings.normal_noise_sigmas > 0) {
    const double c = normal_noise_constant(scratch, bands, settings.noise);
    scratch.normal_noise_c = c;
    model.set_normal_noise(settings.normal_noise_sigmas, c);
  }
  if (bands == 1) {
    grow_plane_regions(frame, settings, scratch, model);
    return;
  }
  for_each_band(scratch, bands, 1, [&](int, int b_begin, int b_end) {
    for (int b = b_begin; b < b_end; ++b) {
      PlaneModel band_model = model;
      grow_plane_regions(scratch.band_frames[b], settings, *scratch.growth[b], band_model);
    }
  });
  join_growth_bands(frame, scratch);
}

}  // namespace rangeseg::seg
