// Internal to src/synth: the analytic ray caster and the Kinect-like noise model.
#pragma once

#include <cstdint>
#include <vector>

#include "rangeseg/synth.hpp"

namespace rangeseg::synth::detail {

/// Row-major 3x3 matrix.
using Mat3 = std::array<std::array<double, 3>, 3>;

inline double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline Vec3 add(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
inline Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline Vec3 scale(const Vec3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
/// Throws std::invalid_argument naming `what` for a zero or non-finite vector.
Vec3 normalized(const Vec3& a, const char* what);

/// R = Ry(yaw) * Rx(pitch) * Rz(roll); its columns are the body axes in the camera frame.
Mat3 rotation(const Orientation& orientation);
inline Vec3 column(const Mat3& m, int i) { return {m[0][i], m[1][i], m[2][i]}; }

/// The scene compiled for ray casting: rays start at the camera centre.
class Tracer {
 public:
  /// Validates the shapes (throws std::invalid_argument) and lists the surfaces in label order.
  explicit Tracer(const Scene& scene);

  const std::vector<Surface>& surfaces() const { return surfaces_; }

  /// Nearest intersection of the ray t * dir, t > 0. Returns its label (0: nothing hit) and
  /// sets `t`. With dir.z == 1, t is the depth z.
  int trace(const Vec3& dir, double& t) const;

 private:
  /// Bounding sphere for a cheap rejection test; `usable` is false when it contains the camera.
  struct Bound {
    Vec3 centre;
    double radius_squared;
    double centre_norm_squared;
    bool usable;
    /// True when the ray t * dir (t > 0) certainly misses the sphere.
    bool misses(const Vec3& dir, double dir_norm_squared) const {
      if (!usable) return false;
      const double along = dot(centre, dir);
      return along <= 0.0 ||
             (centre_norm_squared - radius_squared) * dir_norm_squared > along * along;
    }
  };
  static Bound make_bound(const Vec3& centre, double radius);

  struct RectangleShape {
    Vec3 centre, unit_u, unit_v, normal;
    double half_u, half_v, offset;
    int label;
  };
  struct BoxShape {
    Mat3 rotation;        // body -> camera
    Vec3 camera_in_body;  // R^T (0 - centre)
    Vec3 half_extent;
    Bound bound;
    int first_label;  // faces +x, -x, +y, -y, +z, -z
  };
  struct CylinderShape {
    Vec3 base, axis;
    double radius, height;
    Bound bound;
    int first_label;  // side, base cap, top cap
  };
  struct SphereShape {
    Vec3 centre;
    double radius;
    int label;
  };

  void add_rectangle(const Rectangle& rectangle);

  std::vector<Surface> surfaces_;
  std::vector<RectangleShape> rectangles_;
  std::vector<BoxShape> boxes_;
  std::vector<CylinderShape> cylinders_;
  std::vector<SphereShape> spheres_;
};

/// Applies the Kinect-like model in place. `depth` is width x height, row-major, noise-free
/// depth in metres (NaN: nothing hit); dropped pixels become NaN and get label 0.
void apply_kinect_noise(const KinectModel& model, const CameraIntrinsics& camera,
                        std::uint64_t seed, std::vector<double>& depth, LabelImage& labels);

}  // namespace rangeseg::synth::detail
