// Estimating the sensor's depth noise sigma(z) from the residuals of small planar blocks.
#include "rangeseg/sensor.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "detail/number_text.hpp"
#include "rangeseg/cloud.hpp"

namespace rangeseg {
namespace {

/// The smallest sigma reported [m]: noise-free data (and the pipeline needs sigma > 0).
constexpr double kMinSigma = 1e-5;

/// The standard normal quantile: Phi^-1(p), by bisection on Phi (p in (0, 1)).
double normal_quantile(double p) {
  double lo = -10, hi = 10;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

/// The p-quantile of sqrt(chi^2_m / m): what the unbiased RMS residual of a plane fit with m
/// degrees of freedom reads, in units of the noise, at that quantile (Wilson-Hilferty).
double chi_quantile_factor(double p, double m) {
  const double c = 2.0 / (9.0 * m);
  const double t = 1.0 - c + normal_quantile(p) * std::sqrt(c);
  return std::sqrt(std::max(t * t * t, 1e-6));
}

/// Weighted least squares of the bins' sigma on row(z) (N >= 2 coefficients; weights blocks /
/// sigma^2, as each bin's relative error is about 1 / sqrt(blocks)).
template <int N, class Row>
Eigen::Matrix<double, N, 1> weighted_fit(const std::vector<NoiseEstimate::Bin>& bins, Row row) {
  Eigen::Matrix<double, N, N> ata = Eigen::Matrix<double, N, N>::Zero();
  Eigen::Matrix<double, N, 1> atb = Eigen::Matrix<double, N, 1>::Zero();
  for (const auto& b : bins) {
    const double w = b.blocks / (b.sigma * b.sigma);
    const Eigen::Matrix<double, N, 1> r = row(b.z);
    ata += w * r * r.transpose();
    atb += w * b.sigma * r;
  }
  return ata.ldlt().solve(atb);
}

/// The one-coefficient case: the c minimising the weighted squares of sigma - c f(z).
template <class F>
double weighted_scale(const std::vector<NoiseEstimate::Bin>& bins, F f) {
  double num = 0, den = 0;
  for (const auto& b : bins) {
    const double w = b.blocks / (b.sigma * b.sigma), fz = f(b.z);
    num += w * b.sigma * fz;
    den += w * fz * fz;
  }
  return num / den;
}

/// sigma(z) = a + b (z - z0)^2 fitted to the bins: a quadratic in z with its minimum at or before
/// the nearest bin, else a + b z^2 with a, b >= 0, else a constant.
SensorNoise fit_model(const std::vector<NoiseEstimate::Bin>& bins) {
  const double mean = weighted_scale(bins, [](double) { return 1.0; });
  const SensorNoise constant{.a = std::max(mean, kMinSigma), .b = 0, .z0 = 0};
  const double z_min = bins.front().z, z_max = bins.back().z;
  if (bins.size() < 3 || z_max < 1.5 * z_min) return constant;

  const Eigen::Vector3d c =
      weighted_fit<3>(bins, [](double z) { return Eigen::Vector3d(1.0, z, z * z); });
  if (c.allFinite() && c(2) > 0) {
    const double z0 = -c(1) / (2 * c(2));
    const double a = c(0) - c(2) * z0 * z0;
    // A minimum inside the measured range would have the noise fall with depth there.
    if (a > kMinSigma && z0 <= z_min) return {.a = a, .b = c(2), .z0 = z0};
  }
  // a + b z^2 with a, b >= 0: where the free fit's a is negative the constrained one has a = 0
  // (noise growing from almost nothing), where its b is, b = 0 (the constant).
  const Eigen::Vector2d ab =
      weighted_fit<2>(bins, [](double z) { return Eigen::Vector2d(1.0, z * z); });
  if (!ab.allFinite() || !(ab(1) > 0)) return constant;
  if (ab(0) > kMinSigma) return {.a = ab(0), .b = ab(1), .z0 = 0};
  const double b = weighted_scale(bins, [](double z) { return z * z; });
  return std::isfinite(b) && b > 0 ? SensorNoise{.a = kMinSigma, .b = b, .z0 = 0} : constant;
}

}  // namespace

NoiseEstimator::NoiseEstimator(const NoiseEstimateSettings& settings) : settings_(settings) {
  const auto fail = [](const std::string& what) {
    throw std::invalid_argument("NoiseEstimateSettings: " + what);
  };
  if (settings.block < 4 || settings.block > 256) {
    fail("block must be in [4, 256] pixels, got " + std::to_string(settings.block));
  }
  if (!(settings.quantile > 0 && settings.quantile < 1)) {
    fail("quantile must be in (0, 1), got " + rangeseg::detail::number_text(settings.quantile));
  }
  if (!(settings.bin_ratio > 1 && std::isfinite(settings.bin_ratio))) {
    fail("bin_ratio must be finite and > 1, got " +
         rangeseg::detail::number_text(settings.bin_ratio));
  }
  if (!(settings.max_missing >= 0 && settings.max_missing < 0.5)) {
    fail("max_missing must be in [0, 0.5), got " +
         rangeseg::detail::number_text(settings.max_missing));
  }
  if (settings.min_blocks_per_bin < 1) {
    fail("min_blocks_per_bin must be >= 1, got " + std::to_string(settings.min_blocks_per_bin));
  }
}

void NoiseEstimator::add(const OrganizedCloud& cloud) {
  require_organized(cloud, "NoiseEstimator::add");
  const int side = settings_.block;
  const int min_valid = side * side - static_cast<int>(settings_.max_missing * side * side);
  const double centre = 0.5 * (side - 1);
  for (int v0 = 0; v0 + side <= cloud.height(); v0 += side) {
    for (int u0 = 0; u0 + side <= cloud.width(); u0 += side) {
      // Least squares of w = 1/z on the centred pixel offsets (1, du, dv) of the valid pixels.
      Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
      Eigen::Vector3d atw = Eigen::Vector3d::Zero();
      double sww = 0, sz = 0;
      double w0 = NAN;  // the first valid pixel's 1/z: w - w0 keeps the sums well conditioned
      int valid = 0;
      for (int v = v0; v < v0 + side; ++v) {
        const float *x = cloud.x.row(v), *y = cloud.y.row(v), *z = cloud.z.row(v);
        for (int u = u0; u < u0 + side; ++u) {
          if (!(std::isfinite(x[u]) && std::isfinite(y[u]) && z[u] > 0 && std::isfinite(z[u]))) {
            continue;
          }
          const Eigen::Vector3d row(1.0, u - u0 - centre, v - v0 - centre);
          if (valid == 0) w0 = 1.0 / z[u];
          const double w = 1.0 / z[u] - w0;
          ata += row * row.transpose();
          atw += w * row;
          sww += w * w;
          sz += z[u];
          ++valid;
        }
      }
      if (valid < min_valid) continue;
      ++blocks_seen_;
      const Eigen::Vector3d c = ata.ldlt().solve(atw);
      const double rss = sww - c.dot(atw);  // sum of squared residuals of the fit
      const double mean_z = sz / valid;
      // A depth error e changes 1/z by e / z^2.
      const double sigma = std::sqrt(std::max(rss, 0.0) / (valid - 3)) * mean_z * mean_z;
      if (!std::isfinite(sigma) || !(mean_z < std::numeric_limits<float>::max())) continue;
      z_.push_back(static_cast<float>(mean_z));
      sigma_.push_back(
          static_cast<float>(std::min<double>(sigma, std::numeric_limits<float>::max())));
    }
  }
}

NoiseEstimate NoiseEstimator::estimate() const {
  NoiseEstimate out;
  out.blocks_used = z_.size();
  std::vector<std::size_t> order(z_.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(),
            [&](std::size_t i, std::size_t j) { return z_[i] < z_[j]; });
  const int side = settings_.block;
  const double correction =
      chi_quantile_factor(settings_.quantile, static_cast<double>(side) * side - 3.0);
  // (Blocks with missing pixels have a few degrees of freedom fewer: a negligible difference.)
  std::vector<float> values;
  for (std::size_t first = 0; first < order.size();) {
    const double end_z = z_[order[first]] * settings_.bin_ratio;
    std::size_t last = first;
    while (last < order.size() && z_[order[last]] < end_z) ++last;
    const auto count = last - first;
    if (count >= static_cast<std::size_t>(settings_.min_blocks_per_bin)) {
      values.clear();
      for (std::size_t k = first; k < last; ++k) values.push_back(sigma_[order[k]]);
      const auto at = static_cast<std::ptrdiff_t>(settings_.quantile * static_cast<double>(count));
      std::nth_element(values.begin(), values.begin() + at, values.end());
      out.bins.push_back(
          {.z = z_[order[first + count / 2]],
           .sigma = std::max(values[static_cast<std::size_t>(at)] / correction, kMinSigma),
           .blocks = static_cast<int>(count)});
    }
    first = last;
  }
  if (out.bins.empty()) {
    throw std::runtime_error(
        "noise estimate: no depth bin (a factor " +
        rangeseg::detail::number_text(settings_.bin_ratio) + " in depth) has " +
        std::to_string(settings_.min_blocks_per_bin) + " blocks of " + std::to_string(side) + "x" +
        std::to_string(side) + " pixels with at most " +
        rangeseg::detail::number_text(settings_.max_missing) + " of them invalid (" +
        std::to_string(blocks_seen_) + " such blocks in all)");
  }
  out.noise = fit_model(out.bins);
  for (const auto& b : out.bins) {
    const double fitted = out.noise.sigma(b.z);
    out.max_relative_misfit =
        std::max(out.max_relative_misfit, std::fabs(b.sigma - fitted) / fitted);
  }
  return out;
}

NoiseEstimate estimate_noise(const OrganizedCloud& cloud, const NoiseEstimateSettings& settings) {
  NoiseEstimator estimator(settings);
  estimator.add(cloud);
  return estimator.estimate();
}

}  // namespace rangeseg
