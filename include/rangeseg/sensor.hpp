// The sensor's depth noise: one model shared by meshing, smoothing and segmentation.
#pragma once

namespace rangeseg {

/// Axial (depth) noise of the sensor, sigma(z) = a + b (z - z0)^2 [m] at depth z [m]. The
/// default is the structured-light (Kinect / PrimeSense) model of Khoshelham & Elberink (2012);
/// `PipelineSettings` presets set it for other sensors.
struct SensorNoise {
  double a = 0.0012;  ///< [m]
  double b = 0.0019;  ///< [1/m]
  double z0 = 0.4;    ///< [m]
  double sigma(double z) const { return a + b * (z - z0) * (z - z0); }
};

}  // namespace rangeseg
