// Stage 3 of Holz & Behnke: bilateral filtering of points and normals over the mesh 1-ring.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"
#include "rangeseg/sensor.hpp"
#include "rangeseg/thread_pool.hpp"

namespace rangeseg {

/// The pixel angle when neither the settings nor the caller give one: 1 / 525 rad, a Kinect
/// (or any PrimeSense camera) at 640 x 480.
inline constexpr float kDefaultPixelAngle = 1.0f / 525.0f;

struct SmoothingSettings;
/// The most filter passes SmoothingSettings::iterations may ask for.
inline constexpr int kMaxSmoothingIterations = 1000;
/// The angle between neighbouring pixel rays the filter uses [rad]: settings.pixel_angle when
/// it is > 0, else 1 / camera_fx when camera_fx [pixel] > 0, else kDefaultPixelAngle.
float pixel_angle_for(const SmoothingSettings& settings, double camera_fx);

/// Settings of the bilateral filter (paper, eqs. 3 and 4). Each pixel i is replaced by the
/// weighted mean over itself (weight 1; including the centre is the usual bilateral filter and
/// keeps every denominator >= 1) and its mesh 1-ring N_i (`Mesh::edges`), with
///
///   w_ij = exp( - ||p_i - p_j||^2 / (2 s_d(z_i)^2)            distance term
///               - ||n_i - n_j||_1 / s_n(z_i)                   normal term (L1 norm, eq. 4)
///               - |I_i - I_j| / (c_I * intensity_scale) )      intensity term
///
/// The distance term is Gaussian in the squared distance (the paper writes exp(-||p_i - p_j||)
/// in unscaled metres, which is ~1 for every ring at Kinect ranges): the squared form needs no
/// square root, and its scale follows depth so that one setting works from 0.5 m to 6 m:
///
///   s_d(z)^2 = distance_scale^2 * ( (pixel_stride * pixel_angle * z)^2 + 2 sigma(z)^2 ),
///   sigma(z) = noise.a + noise.b * (z - noise.z0)^2       [m]
///
/// i.e. `distance_scale` times the expected length of a ring edge on a surface facing the sensor:
/// the neighbour spacing at depth z plus the depth noise of both end points (Kinect model of
/// Nguyen et al. by default). Normals from a 1-ring are only as good as sigma / spacing allows
/// (at 4 m the Kinect noise is 3.4 pixel spacings and 1-ring normals are ~60 degrees off), so the
/// normal scale widens where noise dominates, to keep smoothing there instead of freezing it:
///
///   s_n(z) = normal_scale * max(1, sigma(z) / (pixel_stride * pixel_angle * z)).
///
/// Each edge uses one symmetric pair of scales, the means of both end points' inverse scales,
///   1 / (2 s_d^2)_ij = (1 / (2 s_d(z_i)^2) + 1 / (2 s_d(z_j)^2)) / 2, likewise 1 / s_n,
/// so that w_ij = w_ji and each edge's weight is computed once for both ends.
/// Only mesh edges are used (bit k of pixel i's mask for the edge i -> i + d_k), so depth jumps
/// cut by the mesh stay sharp. The exponential is evaluated with a polynomial approximation
/// (relative error < 5e-5); weights below exp(-30) are treated as 0. Depths z are taken
/// relative to `viewpoint`.
struct SmoothingSettings {
  /// Filter passes [passes], 0 .. kMaxSmoothingIterations; each reads the previous pass's points
  /// and normals, the mesh stays the input's.
  /// 3 passes (the default) halve point and normal errors on planes with Kinect noise from 1 to
  /// 4 m. 0 = the input unchanged.
  int iterations = 3;

  bool use_distance = true;     ///< the spatial term w_d (default on)
  float distance_scale = 1.5f;  ///< k_d: s_d in units of the expected ring edge length [1]
  /// angle between neighbouring pixel rays [rad]; 0 (the default) = 1 / fx of the frame's
  /// camera when the caller knows it (Smoother::set_camera_fx; Pipeline: the intrinsics of a
  /// depth image, the pixel grid of an unorganized cloud, the pinhole camera fitted to an
  /// organized cloud's points), else kDefaultPixelAngle. Set it for a scanner's grid.
  float pixel_angle = 0.0f;
  SensorNoise noise{};  ///< sigma(z) of the sensor (see sensor.hpp)

  bool use_normals = true;    ///< the normal term w_n (default on)
  float normal_scale = 1.0f;  ///< s_n where noise < spacing; ||n_i - n_j||_1 is in 0..2 sqrt(3) [1]

  /// Intensity term, evaluated only where the cloud has `intensity`, else grey from RGB
  /// (0.299 r + 0.587 g + 0.114 b); silently off for clouds with neither.
  bool use_intensity = true;
  float intensity_scale = 0.1f;  ///< s_I: scale of the normalised difference [1]
  /// c_I [intensity units]: brings differences to [0, 1]. 0 = per frame, max - min over valid
  /// points.
  float intensity_range = 0.0f;

  /// true: a point moves only along its viewing ray from `viewpoint` (its depth changes, x/z and
  /// y/z are kept, the grid stays a range image): the weighted mean is projected onto the ray.
  /// false: the point becomes the weighted mean itself.
  bool move_along_ray = true;
  /// false: normals are filtered with the same weights and renormalised, curvature is passed
  /// through. true: after every pass normals and curvature are recomputed from the smoothed
  /// points with compute_normals on the input mesh (slower).
  bool recompute_normals = false;
  std::array<float, 3> viewpoint{0.0f, 0.0f, 0.0f};  ///< sensor origin [m], camera frame
};

/// Throws std::invalid_argument naming the field for a non-positive scale or noise.a, an
/// iteration count, noise.b, pixel_angle or intensity_range below 0, or a non-finite value.
void validate(const SmoothingSettings& settings);

/// Output of the convenience overload of smooth().
struct SmoothedCloud {
  OrganizedCloud cloud;
  NormalMap normals;
};

/// Runs the filter and keeps scratch buffers (second ping-pong buffer, grey image, row
/// accumulators), so that a Smoother reused frame after frame allocates nothing after the first
/// frame (given output objects reused as well). Not thread-safe; use one per thread.
class Smoother {
 public:
  /// Throws std::invalid_argument for invalid settings.
  explicit Smoother(const SmoothingSettings& settings = {});

  /// Filters `cloud` and `normals` over the 1-ring of `mesh` (built from `cloud`) into
  /// `out_cloud` / `out_normals`, reusing their buffers. Optional planes (intensity, rgb, label)
  /// are copied unchanged. Pixels without a ring (invalid, or off the stride lattice) keep their
  /// values; the valid count does not change. A pixel whose normal is NaN keeps its point.
  /// Throws std::invalid_argument for an unorganized cloud, size mismatches, or when an output
  /// object is the corresponding input. iterations == 0 copies the input.
  void run(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
           OrganizedCloud& out_cloud, NormalMap& out_normals);
  /// As above, with every pass split into `pool.threads()` row bands that run concurrently.
  /// The output is bit-identical to the single-threaded call.
  void run(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
           OrganizedCloud& out_cloud, NormalMap& out_normals, ThreadPool& pool);

  const SmoothingSettings& settings() const { return settings_; }

  /// The focal length [pixel] of the camera the next frames come from, for settings'
  /// pixel_angle 0 (then 1 / fx); 0 = unknown (kDefaultPixelAngle). Throws
  /// std::invalid_argument for a negative or non-finite fx.
  void set_camera_fx(double fx);
  /// The pixel angle the next run uses [rad].
  float pixel_angle() const;

 private:
  SmoothingSettings settings_;
  double camera_fx_ = 0;  ///< set_camera_fx
  OrganizedCloud scratch_cloud_;
  NormalMap scratch_normals_;
  FloatPlane grey_;
  OrganizedCloud shifted_;                           ///< points relative to a non-zero viewpoint
  detail::CacheLineVector<float> rows_;              ///< per-row inputs, scales, sums of a pass
  detail::CacheLineVector<std::uint8_t> row_bytes_;  ///< one row of edge bytes
  detail::RowBuffers normal_rows_;                   ///< of the normals recomputed after each pass
  std::size_t rows_layout_ = 0;                      ///< layout rows_ was made for
  // The same per band 1.. of a threaded run (band 0 uses the buffers above).
  std::vector<detail::CacheLineVector<float>> band_rows_;
  std::vector<detail::CacheLineVector<std::uint8_t>> band_row_bytes_;
  std::vector<std::size_t> band_rows_layout_;

  void run_passes(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
                  OrganizedCloud& out_cloud, NormalMap& out_normals, ThreadPool* pool);
};

/// One-shot filter (allocates its scratch buffers per call; keep a Smoother to avoid that).
void smooth(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
            const SmoothingSettings& settings, OrganizedCloud& out_cloud, NormalMap& out_normals);
inline SmoothedCloud smooth(const OrganizedCloud& cloud, const Mesh& mesh, const NormalMap& normals,
                            const SmoothingSettings& settings = {}) {
  SmoothedCloud out;
  smooth(cloud, mesh, normals, settings, out.cloud, out.normals);
  return out;
}

}  // namespace rangeseg
