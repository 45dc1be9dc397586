// Camera intrinsics from the files robotics tools write: Open3D's JSON and ROS's camera_info
// YAML.
#pragma once

#include <string>
#include <vector>

#include "rangeseg/camera.hpp"

namespace rangeseg::io {

/// What a camera file states: the pinhole intrinsics, and the lens distortion when it gives one.
/// rangeseg takes a depth image as a pinhole camera's (rectified); the distortion is reported so
/// that a caller can warn that it is not applied.
struct CameraFile {
  /// The camera of the depth images: a ROS file's projection matrix P (the rectified image's
  /// camera, which ROS's depth_image_proc uses) when it gives a non-zero one, else its K.
  CameraIntrinsics intrinsics;
  /// K as stated (the unrectified image's camera); equal to `intrinsics` unless P was used.
  CameraIntrinsics camera_matrix;
  std::string distortion_model;    ///< e.g. "plumb_bob"; empty when the file names none
  std::vector<double> distortion;  ///< coefficients as stated (ROS's D), empty when none

  /// True when any distortion coefficient is not zero.
  bool distorted() const;
  /// True when `intrinsics` come from P and differ from K (fx, fy, cx or cy).
  bool projection_differs() const;
};

/// Reads a camera file: `.yaml` / `.yml` as ROS camera_info YAML (parse_camera_yaml), any other
/// name as camera JSON (parse_camera_json in camera_json.hpp, which states no distortion).
/// Throws std::runtime_error naming the file and the problem.
CameraFile read_camera_file(const std::string& path);

/// Parses ROS camera_info YAML, in any of the layouts ROS tools write:
///  - a calibration file of camera_calibration (`ost.yaml`): image_width, image_height,
///    camera_matrix {rows: 3, cols: 3, data: [9]}, distortion_model, distortion_coefficients
///    {data: [...]}, projection_matrix {rows: 3, cols: 4, data: [12]};
///  - a sensor_msgs/CameraInfo message as `ros2 topic echo --once` (k, d, p, width, height,
///    distortion_model) or ROS 1's `rostopic echo -n 1` (K, D, P) prints it; the first YAML
///    document is read (echo ends it with `---`);
///  - flat: fx, fy, cx, cy, optional width and height.
/// K is the row-major 3x3 matrix [fx, 0, cx, 0, fy, cy, 0, 0, 1], P the row-major 3x4 matrix
/// [fx', 0, cx', Tx, 0, fy', cy', Ty, 0, 0, 1, 0] (Tx, Ty: a stereo pair's baseline, not used);
/// a non-zero P gives the intrinsics, as depth images are taken as rectified. Binning or a region
/// of interest (ROS's binning_x/y > 1, a non-zero roi) describe a smaller image than K's and are
/// refused, as are a skewed or all-zero K (an uncalibrated camera), a P of another form and values
/// that fail rangeseg::validate. Throws std::runtime_error naming `name`, the key and the value
/// (and the line for invalid YAML).
CameraFile parse_camera_yaml(const std::string& text, const std::string& name);

}  // namespace rangeseg::io
