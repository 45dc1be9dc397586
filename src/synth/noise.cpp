// Kinect-like structured-light noise: axial Gaussian noise, disparity quantisation, dropouts.
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

#include "detail/number_text.hpp"
#include "synth/tracer.hpp"

namespace rangeseg::synth {

KinectModel constant_noise(double sigma) {
  if (!(sigma > 0 && std::isfinite(sigma))) {
    throw std::invalid_argument("synth: constant noise needs a finite sigma > 0, got " +
                                rangeseg::detail::number_text(sigma));
  }
  return {.sigma_base = sigma,
          .sigma_quadratic = 0,
          .subpixel = 1e6,
          .min_range = 0.1,
          .max_range = 20,
          .edge_dropout = 0,
          .random_dropout = 0};
}

double kinect_sigma(const KinectModel& model, double z) {
  const double dz = z - model.sigma_offset;
  return model.sigma_base + model.sigma_quadratic * dz * dz;
}

namespace detail {
namespace {

// Own uniform / Gaussian draws on top of std::mt19937_64 (whose output is fixed by the
// standard), so the noise is identical across standard library implementations.
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double gaussian() {  // Box-Muller; the second value of each pair is discarded for simplicity
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  std::mt19937_64 engine_;
};

void validate(const KinectModel& m) {
  auto check = [](double value, bool ok, const char* name) {
    if (!ok || !std::isfinite(value)) {
      throw std::invalid_argument(std::string("synth: KinectModel::") + name +
                                  " out of range: " + rangeseg::detail::number_text(value));
    }
  };
  check(m.sigma_base, m.sigma_base >= 0, "sigma_base");
  check(m.sigma_quadratic, m.sigma_quadratic >= 0, "sigma_quadratic");
  check(m.sigma_offset, true, "sigma_offset");
  check(m.baseline, m.baseline > 0, "baseline");
  check(m.subpixel, m.subpixel > 0, "subpixel");
  check(m.quantisation_fx, m.quantisation_fx >= 0, "quantisation_fx");
  check(m.min_range, m.min_range >= 0, "min_range");
  check(m.max_range, m.max_range > m.min_range, "max_range");
  check(m.edge_relative_jump, m.edge_relative_jump >= 0, "edge_relative_jump");
  check(m.edge_sigmas, m.edge_sigmas >= 0, "edge_sigmas");
  check(m.edge_dropout, m.edge_dropout >= 0 && m.edge_dropout <= 1, "edge_dropout");
  check(m.random_dropout, m.random_dropout >= 0 && m.random_dropout <= 1, "random_dropout");
}

}  // namespace

void apply_kinect_noise(const KinectModel& model, const CameraIntrinsics& camera,
                        std::uint64_t seed, std::vector<double>& depth, LabelImage& labels) {
  validate(model);
  const int width = labels.width(), height = labels.height();
  if (depth.size() != static_cast<std::size_t>(width) * height) {
    throw std::invalid_argument("synth: depth buffer size " + std::to_string(depth.size()) +
                                " does not match the label image " + std::to_string(width) + "x" +
                                std::to_string(height));
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Disparity [pixel] = sensor_bf / z, in the pixels of the sensor's own disparity image, which
  // the quantisation divides.
  const double sensor_bf =
      model.baseline * (model.quantisation_fx > 0 ? model.quantisation_fx : camera.fx);

  // Depth edges are found on the noise-free image, before anything is dropped.
  std::vector<std::uint8_t> edge(depth.size(), 0);
  auto is_jump = [&](double z, double neighbour) {
    if (std::isnan(neighbour)) return true;  // silhouette against nothing
    const double threshold =
        std::max(model.edge_relative_jump * z, model.edge_sigmas * kinect_sigma(model, z));
    return std::abs(z - neighbour) > threshold;
  };
  for (int v = 0; v < height; ++v) {
    const double* row = depth.data() + static_cast<std::size_t>(v) * width;
    std::uint8_t* edge_row = edge.data() + static_cast<std::size_t>(v) * width;
    for (int u = 0; u < width; ++u) {
      const double z = row[u];
      if (std::isnan(z)) continue;
      edge_row[u] =
          (u > 0 && is_jump(z, row[u - 1])) || (u + 1 < width && is_jump(z, row[u + 1])) ||
          (v > 0 && is_jump(z, row[u - width])) || (v + 1 < height && is_jump(z, row[u + width]));
    }
  }

  // Every pixel consumes the same number of draws, so a change in one pixel's outcome does not
  // shift the noise of all later pixels.
  Random random(seed);
  for (int v = 0; v < height; ++v) {
    double* row = depth.data() + static_cast<std::size_t>(v) * width;
    const std::uint8_t* edge_row = edge.data() + static_cast<std::size_t>(v) * width;
    std::int32_t* label_row = labels.row(v);
    for (int u = 0; u < width; ++u) {
      const double edge_draw = random.uniform();
      const double dropout_draw = random.uniform();
      const double gaussian = random.gaussian();
      double& z = row[u];
      if (std::isnan(z)) continue;
      bool drop =
          (edge_row[u] && edge_draw < model.edge_dropout) || dropout_draw < model.random_dropout;
      if (!drop) {
        // Quantisation adds variance step^2 / 12; the Gaussian part supplies the rest.
        const double step = z * z / (model.subpixel * sensor_bf);
        const double sigma = kinect_sigma(model, z);
        const double gaussian_variance = std::max(0.0, sigma * sigma - step * step / 12.0);
        const double noisy = z + std::sqrt(gaussian_variance) * gaussian;
        const double disparity = std::round(model.subpixel * sensor_bf / noisy) / model.subpixel;
        if (noisy > 0.0 && disparity > 0.0) {
          z = sensor_bf / disparity;
          drop = z < model.min_range || z > model.max_range;
        } else {
          drop = true;
        }
      }
      if (drop) {
        z = nan;
        label_row[u] = 0;
      }
    }
  }
}

}  // namespace detail
}  // namespace rangeseg::synth
