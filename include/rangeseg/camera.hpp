// Pinhole camera intrinsics and conversion between depth images and organized clouds.
#pragma once

#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"

namespace rangeseg {

/// Pinhole intrinsics in pixels: pixel (u, v) with depth z (metres) is the point
/// x = (u - cx) z / fx, y = (v - cy) z / fy. Defaults: fx, fy, cx, cy of a Kinect / PrimeSense
/// at 640x480; the image size not given.
struct CameraIntrinsics {
  double fx = 525.0;  ///< focal length along x [pixel]
  double fy = 525.0;  ///< focal length along y [pixel]
  double cx = 319.5;  ///< principal point x [pixel]
  double cy = 239.5;  ///< principal point y [pixel]
  int width = 0;      ///< image width [pixel], 0 = not given (else depth images must have it)
  int height = 0;     ///< image height [pixel], 0 = not given (else depth images must have it)
};

/// Throws std::invalid_argument unless fx, fy > 0 and all values are finite.
void validate(const CameraIntrinsics& camera);

/// Converts a depth image (raw units, 0 = no measurement) to an organized cloud.
/// `depth_scale` is metres per raw unit (0.001 for millimetres). Invalid pixels become NaN.
/// Throws std::invalid_argument for invalid intrinsics (`validate`), a width or height the
/// camera states that is not the image's, a depth_scale not > 0, or an invalid view.
OrganizedCloud depth_to_cloud(View<const std::uint16_t> depth, const CameraIntrinsics& camera,
                              double depth_scale = 0.001);

/// The same into `cloud`, whose x, y, z planes are reused when they already have the depth
/// image's size (nothing is allocated then: a camera loop converts every frame into one cloud);
/// its optional planes (intensity, rgb, label) are removed. Throws like depth_to_cloud.
void depth_to_cloud(View<const std::uint16_t> depth, const CameraIntrinsics& camera,
                    double depth_scale, OrganizedCloud& cloud);

/// A depth image in metres (e.g. a ROS 32FC1 image) to a cloud, reusing `cloud` as above; NaN,
/// infinite and non-positive depths are no measurement. Throws std::invalid_argument for invalid
/// intrinsics, a camera width / height other than the image's, or a view with no data, fewer
/// than 1 column or 2 rows.
void depth_to_cloud(View<const float> depth, const CameraIntrinsics& camera, OrganizedCloud& cloud);

/// Rows [row_begin, row_end) of the conversions above into `cloud`, which must already have the
/// depth image's size (checked); for converting row bands on several threads. Throws
/// std::invalid_argument for invalid intrinsics, depth_scale or rows.
void depth_to_cloud_rows(View<const std::uint16_t> depth, const CameraIntrinsics& camera,
                         double depth_scale, OrganizedCloud& cloud, int row_begin, int row_end);
void depth_to_cloud_rows(View<const float> depth, const CameraIntrinsics& camera,
                         OrganizedCloud& cloud, int row_begin, int row_end);

/// How far [pixel] a point may lie off its pixel under a fitted pinhole camera before the fit is
/// refused: points computed from a depth image in float lie within ~2e-4 pixel of their pixel
/// (PCL's stereo frame table_scene_mug_stereo_textured within 0.02), a laser scanner's grid or an
/// uncorrected lens far beyond it.
inline constexpr double kDefaultFitTolerance = 0.05;

/// The pinhole intrinsics of an organized cloud computed from a depth image: the least-squares
/// fx, cx of x / z = (u - cx) / fx over its valid points with z > 0, and fy, cy alike, with width
/// and height the cloud's. Returns false when there are fewer than two distinct columns or rows
/// with such points, or when a point lies more than `tolerance` pixels off its pixel under the
/// fitted camera (a laser scanner's grid, a cloud transformed out of the camera's frame, a
/// stereo camera's sub-pixel points). `max_error`, when given, receives that largest deviation
/// [pixel] (infinity when nothing was fitted).
bool fit_intrinsics(const OrganizedCloud& cloud, CameraIntrinsics& camera,
                    double tolerance = kDefaultFitTolerance, double* max_error = nullptr);

/// Converts the z plane of an organized cloud back to raw depth units (rounded; 0 where the
/// point is invalid, z <= 0, or z / depth_scale does not fit in 16 bits). Throws
/// std::invalid_argument for depth_scale <= 0 or non-finite, or an inconsistent cloud.
DepthImage cloud_to_depth(const OrganizedCloud& cloud, double depth_scale = 0.001);

}  // namespace rangeseg
