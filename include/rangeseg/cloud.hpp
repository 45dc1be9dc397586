// Point clouds on a pixel grid.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rangeseg/image.hpp"

namespace rangeseg {

struct SensorNoise;  // sensor.hpp

/// A `width x height` grid of 3D points in metres, camera frame (x right, y down, z forward),
/// stored as separate planes. A pixel without a measurement has NaN in x, y and z.
/// An unorganized cloud is a cloud with height 1; functions that need a grid check
/// `is_organized()` and throw std::invalid_argument otherwise.
///
/// Optional planes are empty when absent: `intensity` (sensor units, any range), `r`, `g`, `b`
/// (0..255) and `label` (integer label per point, e.g. the ground truth of a data set).
struct OrganizedCloud {
  FloatPlane x, y, z;
  FloatPlane intensity;
  BytePlane r, g, b;
  LabelImage label;

  OrganizedCloud() = default;
  /// Allocates x, y, z planes filled with NaN; the optional planes stay empty.
  OrganizedCloud(int width, int height) { resize(width, height); }

  /// Sets the size; x, y, z become NaN, present optional planes are resized and zeroed.
  void resize(int width, int height);
  void add_intensity() { intensity.resize(width(), height(), 0.0f); }
  void add_rgb();
  void add_label() { label.resize(width(), height(), 0); }

  int width() const { return z.width(); }
  int height() const { return z.height(); }
  std::size_t size() const {
    return static_cast<std::size_t>(width()) * static_cast<std::size_t>(height());
  }
  bool empty() const { return size() == 0; }
  bool is_organized() const { return height() > 1; }
  bool has_intensity() const { return !intensity.empty(); }
  bool has_rgb() const { return !r.empty(); }
  bool has_label() const { return !label.empty(); }

  /// A point is valid when x, y and z are all finite.
  bool valid(int u, int v) const {
    return std::isfinite(x(u, v)) && std::isfinite(y(u, v)) && std::isfinite(z(u, v));
  }
  std::size_t count_valid() const;
};

/// Depth range and valid count of a cloud, for `rangeseg info`.
struct CloudStats {
  std::size_t valid = 0;
  float min_z = NAN, max_z = NAN;  ///< metres, over valid points
  /// distance from the origin [m], over valid points: a scan round the sensor (a spinning
  /// lidar's) has points at every z
  float min_range = NAN, max_range = NAN;
};
CloudStats cloud_stats(const OrganizedCloud& cloud);

/// Whether the directions from the origin to the valid points spread over more than a
/// hemisphere (their mean unit vector shorter than 1/2, over at least 100 points): a spinning
/// lidar's or a panoramic scanner's scan, for which a depth camera's noise model, a function of
/// z, is wrong (the `laser` preset's is one of the range). A camera's points lie in a cone (a
/// Kinect's mean unit vector is 0.95 long). The points are taken in the sensor's frame.
bool surrounds_its_sensor(const OrganizedCloud& cloud);

/// What is implausible about the scale of the cloud's coordinates, in words for a user, else
/// empty: coordinates of 8192 m or more that span under a tenth of that (a scan moved into map
/// coordinates, where float points lie a millimetre or more apart), or a median distance of the
/// valid points from the origin beyond 500 m: points far from the origin when they span under a
/// tenth of that distance, else millimetres taken for metres; or below 1 cm. Reads at most ~4096
/// of the points for the median.
std::string cloud_scale_problem(const OrganizedCloud& cloud);

/// What makes the depth noise model `noise` wrong for the cloud, in words for a user, else
/// empty: at the valid points' median distance from the origin (where the sensor is taken to be),
/// 3 sigma (about the segmentation's distance tests) exceeds a tenth of the points' extent (their
/// bounding box's diagonal), so that the tests join surfaces that lie apart in the scene. It
/// happens to points beyond the range of the sensor the model describes, and to points not in
/// their sensor's frame (a map, scans merged in a world frame, a cloud moved away from the
/// origin). Reads at most ~4096 of the points for the median.
std::string noise_scale_problem(const OrganizedCloud& cloud, const SensorNoise& noise);

/// Throws std::invalid_argument naming `what` if the cloud's planes differ in size: x and y must
/// have z's size, and so must intensity and label when present; r, g and b come together (all of
/// z's size, or all empty).
void require_consistent(const OrganizedCloud& cloud, const char* what);

/// Throws std::invalid_argument naming `what` if the cloud is not organized (height < 2) or
/// not consistent (`require_consistent`).
void require_organized(const OrganizedCloud& cloud, const char* what);

/// Every `factor`-th pixel along both axes: pixel (u, v) of the result is pixel
/// (factor * u, factor * v) of `cloud`, with the optional planes that `cloud` has. The result is
/// ceil(width / factor) x ceil(height / factor) pixels; its angular pixel spacing is `factor`
/// times the input's. Defined in src/cloud_ops.cpp. Throws std::invalid_argument if factor < 1 or
/// the cloud is inconsistent.
OrganizedCloud downsample(const OrganizedCloud& cloud, int factor);

/// The valid points of `cloud` as an unorganized cloud (height 1) with the optional planes that
/// `cloud` has, in row-major order: e.g. a range image for the unorganized path. `pixels`, when
/// given, receives for each point the index v * width + u of its pixel in `cloud`. Defined in
/// src/cloud_ops.cpp. Throws std::invalid_argument for an inconsistent cloud.
OrganizedCloud valid_points(const OrganizedCloud& cloud,
                            std::vector<std::size_t>* pixels = nullptr);
/// The same in a shuffled order (std::shuffle with std::mt19937_64(seed): the same order for a
/// seed with one standard library), e.g. to check that nothing depends on the points' order.
OrganizedCloud shuffled_valid_points(const OrganizedCloud& cloud, std::uint64_t seed,
                                     std::vector<std::size_t>* pixels = nullptr);

/// Copies points stored interleaved, row-major, into `cloud` (which becomes width x height points
/// without optional planes; its buffers are reused when the size does not change, so a stream
/// converts without allocating). Each point starts with float x, y, z [m] and the next starts
/// `point_stride` bytes later: 12 for packed xyz, 16 for PCL's `pcl::PointXYZ` (pass
/// `&pcl_cloud.points[0].x`, `sizeof(pcl::PointXYZ)`), 32 for `pcl::PointXYZRGB`.
/// A point with a non-finite coordinate, or at exactly (0, 0, 0) (what RealSense's SDK and many
/// drivers write for a pixel without depth), becomes NaN in x, y and z: no point.
/// height 1 is an unorganized cloud. Defined in src/cloud_ops.cpp. Throws std::invalid_argument
/// for a null pointer, width or height below 1, or a stride below 12 or not a multiple of 4.
void interleaved_to_cloud(const float* xyz, int width, int height, std::size_t point_stride,
                          OrganizedCloud& cloud);
/// The same into a new cloud.
OrganizedCloud interleaved_to_cloud(const float* xyz, int width, int height,
                                    std::size_t point_stride);

/// Moves the points of `cloud` into the frame of a sensor whose pose in the cloud's frame is
/// `pose` = {tx, ty, tz [m], qw, qx, qy, qz} (a PCD's VIEWPOINT, PCL's sensor_origin_ and
/// sensor_orientation_): p' = R^T (p - t), R the rotation of the quaternion (normalised).
/// Invalid points stay as they are. Defined in src/cloud_ops.cpp. Throws std::invalid_argument
/// for a non-finite pose or a quaternion of norm below 1e-6.
void to_sensor_frame(OrganizedCloud& cloud, const std::array<double, 7>& pose);

}  // namespace rangeseg
