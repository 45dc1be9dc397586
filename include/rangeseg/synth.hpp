// Synthetic range images with ground truth: an analytic ray caster for planes, boxes, cylinders
// and spheres, an optional Kinect-like noise model, and a few ready-made scenes.
//
// Everything is in the camera frame (x right, y down, z forward, metres; angles in radians).
// The camera sits at the origin and looks along +z; pixel (u, v) sees the ray
// t * ((u - cx) / fx, (v - cy) / fy, 1), t = depth z.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "rangeseg/camera.hpp"
#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"

namespace rangeseg::synth {

using Vec3 = std::array<double, 3>;  ///< (x, y, z) in metres, camera frame

enum class SurfaceType { plane, cylinder, sphere };

/// Analytic description of one ground-truth surface (one label). Fields not used by `type` are 0.
struct Surface {
  SurfaceType type = SurfaceType::plane;
  /// plane: unit normal n and offset d with n.x + d = 0 [m]. n points to the side the face is
  /// seen from (outwards for solids, into the room for room walls), i.e. towards the camera
  /// whenever the face is visible.
  Vec3 normal{};
  double offset = 0;  ///< plane: d of n.x + d = 0 [m]
  /// sphere: centre; cylinder: centre of the base cap (a point on the axis) [m].
  Vec3 centre{};
  /// cylinder: unit axis direction, from the base cap towards the top cap.
  Vec3 axis{};
  double radius = 0;  ///< sphere / cylinder radius [m]
  double extent = 0;  ///< cylinder: length along the axis from `centre` [m]
  std::string name;   ///< e.g. "floor", "table/-y", "can/side", "ball"
};

/// Signed distance of p from the (unbounded) surface [m]: plane n.p + d, sphere |p - c| - r,
/// cylinder radial distance from the infinite axis - r. Positive on the side the normal points to.
double signed_distance(const Surface& surface, const Vec3& p);

/// Unit surface normal at (or near) p, oriented like `Surface::normal` for planes and outwards
/// for spheres and cylinder sides.
Vec3 surface_normal(const Surface& surface, const Vec3& p);

/// Body-to-camera rotation R = Ry(yaw) * Rx(pitch) * Rz(roll) [radians]; a body-frame vector b
/// maps to R b in the camera frame. yaw turns about the camera's vertical (y, down) axis.
struct Orientation {
  double yaw = 0;
  double pitch = 0;
  double roll = 0;
};

/// Oriented solid box. Its six faces are labelled in the order +x, -x, +y, -y, +z, -z (body
/// axes; with y down, "-y" is the top face of an unrotated box).
struct Box {
  Vec3 centre{};
  Vec3 half_extent{0.5, 0.5, 0.5};  ///< half side lengths along the body axes [m], > 0
  Orientation orientation{};
  std::string name = "box";
};

/// Finite solid cylinder from `base` to base + height * axis. Labels: side, base cap, top cap.
struct Cylinder {
  Vec3 base{};                ///< centre of the base cap [m]
  Vec3 axis{0.0, -1.0, 0.0};  ///< direction base -> top (normalised by render); default: up
  double radius = 0.1;        ///< [m], > 0
  double height = 0.5;        ///< [m], > 0
  std::string name = "cylinder";
};

struct Sphere {
  Vec3 centre{};
  double radius = 0.1;  ///< [m], > 0
  std::string name = "sphere";
};

/// Bounded planar rectangle (double-sided): the points centre + a * half_u + b * half_v,
/// |a|, |b| <= 1. `half_u` and `half_v` must be orthogonal and non-zero; the labelled normal is
/// normalize(half_u x half_v) [m].
struct Rectangle {
  Vec3 centre{};
  Vec3 half_u{1.0, 0.0, 0.0};
  Vec3 half_v{0.0, 1.0, 0.0};
  std::string name = "rectangle";
};

/// A box seen from the inside, rotated by `yaw` about the vertical axis. Each enabled face is a
/// rectangle whose normal points into the room. Labels in the order floor (body +y), ceiling
/// (-y), left wall (-x), right wall (+x), back wall (+z), front wall (-z), enabled ones only.
struct Room {
  Vec3 centre{0.0, -0.45, 2.0};
  Vec3 half_extent{3.0, 1.25, 3.0};  ///< [m]
  double yaw = 0;                    ///< [rad]
  bool floor = true, ceiling = false;
  bool left_wall = true, right_wall = true, back_wall = true, front_wall = false;
};

/// Surfaces are labelled in this order: room faces, rectangles, boxes (6 each), cylinders
/// (3 each), spheres (1 each); label l describes Rendering::surfaces[l - 1] (see
/// RenderSettings::split_disconnected for the labels after these).
struct Scene {
  std::optional<Room> room;
  std::vector<Rectangle> rectangles;
  std::vector<Box> boxes;
  std::vector<Cylinder> cylinders;
  std::vector<Sphere> spheres;
};

enum class Noise { none, kinect };

/// Kinect-like structured-light sensor model (Khoshelham & Elberink 2012, Nguyen et al. 2012).
struct KinectModel {
  double sigma_base = 0.0012;       ///< sigma(z) = base + quadratic (z - offset)^2 [m]
  double sigma_quadratic = 0.0019;  ///< [1/m]
  double sigma_offset = 0.4;        ///< [m]
  double baseline = 0.075;          ///< projector-camera baseline b [m]; disparity = b fx / z
  double subpixel = 8.0;            ///< disparity quantisation steps per pixel [1/pixel]
  /// Focal length of the sensor's own disparity image, whose pixels the quantisation divides
  /// [pixel]: a Kinect streaming 320x240 still matches its pattern at 640x480 (f = 525 px), so
  /// its depth steps do not grow when the stream is smaller. 0 = the rendering camera's fx.
  double quantisation_fx = 525.0;
  double min_range = 0.4;            ///< no measurement nearer than this [m]
  double max_range = 6.0;            ///< no measurement beyond this [m]
  double edge_relative_jump = 0.05;  ///< depth jump to a 4-neighbour counted as an edge, / z
  double edge_sigmas = 4.0;          ///< ... or this many sigma(z) if larger [dimensionless]
  double edge_dropout = 0.5;         ///< probability that a pixel at a depth edge is dropped
  double random_dropout = 0.005;     ///< probability that any pixel is dropped
};

/// Axial noise standard deviation of the model at depth z [m].
double kinect_sigma(const KinectModel& model, double z);

/// A laser's noise in the terms of the Kinect model: Gaussian along the ray with one `sigma` [m]
/// at every range (0.1-20 m), no disparity quantisation and no dropouts (`rangeseg synth --noise
/// constant:SIGMA`). Throws std::invalid_argument unless sigma is finite and > 0.
KinectModel constant_noise(double sigma);

struct RenderSettings {
  CameraIntrinsics camera{.width = 640, .height = 480};  ///< width, height must be > 0
  Noise noise = Noise::none;
  KinectModel kinect{};    ///< used when noise == Noise::kinect
  std::uint64_t seed = 1;  ///< noise and dropouts are a deterministic function of the seed
  /// Pixels of surfaces with fewer visible pixels than this keep their points but get label 0
  /// [pixels].
  int min_surface_pixels = 0;
  /// Each 8-connected part of a surface in the noise-free image is its own ground-truth region:
  /// the largest part keeps the surface's label, the others get new labels after the scene's
  /// surfaces (Rendering::surfaces holds a copy of the description, named "<name>#2", ...). A
  /// segment is a connected image region (region growing, SegComp's hand-made ground truth), so a
  /// floor seen on both sides of a box is two regions. false: one label per surface.
  bool split_disconnected = true;
};

struct Rendering {
  OrganizedCloud cloud;  ///< points, NaN where nothing was hit or measured; cloud.label = labels
  LabelImage labels;     ///< ground-truth surface label per pixel, 0 = none
  /// every surface of the scene, then the extra parts (RenderSettings::split_disconnected);
  /// surfaces[l - 1] describes label l
  std::vector<Surface> surfaces;
  std::vector<std::int64_t> pixel_counts;  ///< labelled pixels per surface, same indexing
  /// per label, same indexing: the label of the scene surface it is a part of (itself for the
  /// scene's surfaces), to count one region per surface instead
  std::vector<std::int32_t> part_of;
};

/// Ray-casts `scene` (nearest surface wins) and applies the noise model.
/// With Noise::kinect, per pixel and in this order: depth edges in the noise-free image are
/// dropped with probability edge_dropout, any pixel with random_dropout; the depth along the
/// viewing ray gets Gaussian noise and is quantised in disparity, b fx / (round(s b fx / z) / s).
/// The Gaussian part has variance sigma(z)^2 - q^2 / 12 (q = quantisation step at z), so the
/// total axial noise has standard deviation ~sigma(z). Depths outside [min_range, max_range]
/// are dropped. Dropped pixels have NaN points and label 0; points stay on their pixel ray.
/// Throws std::invalid_argument for a bad camera or degenerate shapes.
Rendering render(const Scene& scene, const RenderSettings& settings = {});

/// The built-in demo: a room corner (floor and two walls) with a table-like box, two stacked
/// boxes, a rotated box, a standing cylinder and a sphere lying on the table, 1.7 - 4.5 m away,
/// all in the default 640x480 view.
Scene demo_scene();

/// Random boxes (2 - 6, some rotated about the vertical, some stacked) on a floor in front of a
/// back wall; with_curved adds 1 - 2 cylinders and 1 - 2 spheres. Deterministic from the seed.
Scene random_scene(std::uint64_t seed, bool with_curved = false);

/// A single plane filling the whole default view: at depth `distance` [m] on the optical axis,
/// tilted by `tilt_rad` about the camera x axis (0 = fronto-parallel). Throws
/// std::invalid_argument unless distance > 0 and |tilt_rad| < 1.1 (both finite).
Scene plane_scene(double distance, double tilt_rad = 0.0);

}  // namespace rangeseg::synth
