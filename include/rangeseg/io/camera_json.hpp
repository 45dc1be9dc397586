// Camera intrinsics from JSON files.
#pragma once

#include <string>

#include "rangeseg/camera.hpp"

namespace rangeseg::io {

/// Reads pinhole intrinsics from a JSON file in either layout:
///  - Open3D's PinholeCameraIntrinsic (camera_*.json): {"width": W, "height": H,
///    "intrinsic_matrix": [fx, 0, 0, 0, fy, 0, cx, cy, 1]} (the 3x3 matrix in column-major order);
///  - flat: {"fx": .., "fy": .., "cx": .., "cy": .., "width": .., "height": ..} (width and
///    height optional, 0 = not given).
/// Throws std::runtime_error naming the file and the missing or malformed key, and for values
/// that fail rangeseg::validate (fx, fy <= 0, non-finite).
CameraIntrinsics read_camera_json(const std::string& path);

/// The same, on JSON text held in memory; `name` is used in error messages.
CameraIntrinsics parse_camera_json(const std::string& text, const std::string& name);

}  // namespace rangeseg::io
