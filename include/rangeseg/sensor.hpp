// The sensor's depth noise: one model shared by meshing, smoothing and segmentation, and its
// estimate from the data for a sensor that no preset describes.
#pragma once

#include <cstddef>
#include <vector>

namespace rangeseg {

struct OrganizedCloud;

/// Axial (depth) noise of the sensor, sigma(z) = a + b (z - z0)^2 [m] at depth z [m]. The
/// default is the structured-light (Kinect / PrimeSense) model of Nguyen et al. (2012);
/// `PipelineSettings` presets set it for other sensors.
struct SensorNoise {
  double a = 0.0012;  ///< [m]
  double b = 0.0019;  ///< [1/m]
  double z0 = 0.4;    ///< [m]
  double sigma(double z) const { return a + b * (z - z0) * (z - z0); }
};

/// Settings of `NoiseEstimator`.
struct NoiseEstimateSettings {
  /// Side of the square pixel blocks that are fitted with a plane each [pixels] (4..256). A
  /// block's residual is the noise over its extent: random noise, and also the low-frequency
  /// distortion of a real sensor (a Kinect's 8x8 blocks read ~25 % less than its 16x16 ones at
  /// 1-3 m, which is what a plane segment sees; synthetic noise reads the same at both).
  int block = 16;
  /// Blocks with a larger fraction of invalid pixels (sensor dropouts) are not used
  /// (dimensionless, in [0, 0.5)).
  double max_missing = 0.1;
  /// Per depth bin, sigma is this quantile of the blocks' values (dimensionless, in (0, 1)):
  /// blocks over a crease, a depth step or a curved surface fit worse than the noise alone, so
  /// the planar ones are the lower part of the distribution. The quantile is corrected for the
  /// spread that the noise alone gives a block's residual.
  double quantile = 0.25;
  /// Depth bins grow geometrically, each spanning this factor in depth (dimensionless, > 1).
  double bin_ratio = 1.15;
  /// Bins with fewer usable blocks are not used for the fit (>= 1) [blocks], default 12.
  int min_blocks_per_bin = 12;
};

/// The result of `NoiseEstimator::estimate`: the fitted model and what it was fitted to.
struct NoiseEstimate {
  struct Bin {
    double z = 0;      ///< median depth of the bin's blocks [m]
    double sigma = 0;  ///< measured axial noise there [m], at least 1e-5 (noise-free data)
    int blocks = 0;    ///< blocks used
  };
  /// sigma(z) fitted to the bins (weighted least squares; b = 0 when the bins span less than a
  /// factor 1.5 in depth, or when noise does not grow with depth). Valid over the bins' depth
  /// range; outside it, an extrapolation.
  SensorNoise noise;
  std::vector<Bin> bins;        ///< the bins used, by depth
  std::size_t blocks_used = 0;  ///< blocks with enough valid pixels, over all frames added
  /// Largest |measured - fitted| / fitted over the bins (dimensionless): how well the model's
  /// form describes the sensor.
  double max_relative_misfit = 0;
};

/// Estimates a sensor's axial depth noise sigma(z) from organized clouds of ordinary scenes, for
/// a sensor that no preset describes (a RealSense or other stereo camera, a time-of-flight
/// camera) from raw (unsmoothed) frames: in every `block x block` pixel block whose points are
/// (nearly) all valid, the inverse depth 1 / z is fitted with a plane over the pixel offsets (a
/// plane's inverse depth is linear in the pixel coordinates of a pinhole camera, at any
/// orientation); the RMS residual, unbiased for the fit's three parameters and converted to depth
/// (times z^2), is one measurement of sigma at the block's depth. Planar surfaces at several depths
/// (floor, walls, a table) are what it needs. Frames can be pooled: `add` each,
/// then `estimate`. The result's `noise` goes into `set_noise(PipelineSettings&, ...)`
/// (pipeline.hpp), or into the `noise` section of the CLI's `--config` (`rangeseg noise`).
class NoiseEstimator {
 public:
  /// Throws std::invalid_argument for settings out of their documented ranges.
  explicit NoiseEstimator(const NoiseEstimateSettings& settings = {});
  /// Adds the blocks of one frame. Throws std::invalid_argument unless `cloud` is organized.
  void add(const OrganizedCloud& cloud);
  /// Throws std::runtime_error, with the counts, when no depth bin has `min_blocks_per_bin`
  /// blocks (too few valid pixels in the frames added).
  NoiseEstimate estimate() const;

 private:
  NoiseEstimateSettings settings_;
  std::vector<float> z_, sigma_;  ///< per block: mean depth [m] and measured sigma [m]
  std::size_t blocks_seen_ = 0;   ///< blocks with enough valid pixels (max_missing)
};

/// One frame's estimate: NoiseEstimator(settings), add(cloud), estimate().
NoiseEstimate estimate_noise(const OrganizedCloud& cloud,
                             const NoiseEstimateSettings& settings = {});

}  // namespace rangeseg
