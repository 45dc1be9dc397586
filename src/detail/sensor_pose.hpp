// The rigid motion from a cloud's frame into its sensor's (a PCD's VIEWPOINT): to_sensor_frame
// applies it to float points, the PCD reader to the stored values, in double.
#pragma once

#include <Eigen/Core>

#include <array>

namespace rangeseg::detail {

struct SensorPose {
  Eigen::Matrix3d to_sensor;  ///< R^T, R the rotation of the pose's quaternion (normalised)
  Eigen::Vector3d origin;     ///< the sensor's position t in the cloud's frame [m]
  /// p' = R^T (p - t)
  Eigen::Vector3d apply(const Eigen::Vector3d& p) const { return to_sensor * (p - origin); }
};

/// `pose` = {tx, ty, tz [m], qw, qx, qy, qz}. Throws std::invalid_argument, starting with
/// `what`, for a non-finite value or a quaternion of norm below 1e-6.
SensorPose sensor_pose(const std::array<double, 7>& pose, const char* what);

}  // namespace rangeseg::detail
