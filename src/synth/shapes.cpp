// Analytic ray intersection with rectangles, oriented boxes, finite cylinders and spheres.
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "detail/number_text.hpp"
#include "synth/tracer.hpp"

namespace rangeseg::synth {

namespace detail {
namespace {

// Hits nearer than this are ignored so that a surface through the camera centre is not "seen".
constexpr double kMinT = 1e-9;

std::string to_string(const Vec3& v) {
  return "(" + rangeseg::detail::number_text(v[0]) + ", " + rangeseg::detail::number_text(v[1]) +
         ", " + rangeseg::detail::number_text(v[2]) + ")";
}

bool finite(const Vec3& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

void require_positive(double value, const std::string& what) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument("synth: " + what + " must be positive and finite, got " +
                                rangeseg::detail::number_text(value));
  }
}

void require_finite(const Vec3& v, const std::string& what) {
  if (!finite(v)) throw std::invalid_argument("synth: " + what + " is not finite: " + to_string(v));
}

Surface plane_surface(const Vec3& normal, const Vec3& point, std::string name) {
  Surface s;
  s.type = SurfaceType::plane;
  s.normal = normal;
  s.offset = -dot(normal, point);
  s.name = std::move(name);
  return s;
}

// Real roots of a t^2 + b t + c = 0 in ascending order (count 0 or 2).
void quadratic_roots(double a, double b, double c, double roots[2], int& count) {
  count = 0;
  const double disc = b * b - 4.0 * a * c;
  if (disc < 0.0 || a <= 0.0) return;
  // Stable form: avoid cancellation between -b and sqrt(disc).
  const double q = -0.5 * (b + std::copysign(std::sqrt(disc), b));
  double t0 = q / a;
  double t1 = q != 0.0 ? c / q : t0;
  if (t0 > t1) std::swap(t0, t1);
  roots[count++] = t0;
  roots[count++] = t1;
}

}  // namespace

Vec3 normalized(const Vec3& a, const char* what) {
  const double n = std::sqrt(dot(a, a));
  if (!(n > 0.0) || !std::isfinite(n)) {
    throw std::invalid_argument(std::string("synth: ") + what +
                                " must be a non-zero finite vector, got " + to_string(a));
  }
  return scale(a, 1.0 / n);
}

Mat3 rotation(const Orientation& o) {
  const double cy = std::cos(o.yaw), sy = std::sin(o.yaw);
  const double cp = std::cos(o.pitch), sp = std::sin(o.pitch);
  const double cr = std::cos(o.roll), sr = std::sin(o.roll);
  const Mat3 ry{{{cy, 0, sy}, {0, 1, 0}, {-sy, 0, cy}}};
  const Mat3 rx{{{1, 0, 0}, {0, cp, -sp}, {0, sp, cp}}};
  const Mat3 rz{{{cr, -sr, 0}, {sr, cr, 0}, {0, 0, 1}}};
  auto mul = [](const Mat3& a, const Mat3& b) {
    Mat3 m{};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        for (int k = 0; k < 3; ++k) m[i][j] += a[i][k] * b[k][j];
      }
    }
    return m;
  };
  return mul(ry, mul(rx, rz));
}

Tracer::Tracer(const Scene& scene) {
  if (scene.room) {
    const Room& room = *scene.room;
    require_finite(room.centre, "room centre");
    for (int i = 0; i < 3; ++i) require_positive(room.half_extent[i], "room half extent");
    if (!std::isfinite(room.yaw)) {
      throw std::invalid_argument("synth: room yaw is not finite: " +
                                  rangeseg::detail::number_text(room.yaw));
    }
    const Mat3 r = rotation({.yaw = room.yaw});
    const Vec3 ex = scale(column(r, 0), room.half_extent[0]);
    const Vec3 ey = scale(column(r, 1), room.half_extent[1]);
    const Vec3 ez = scale(column(r, 2), room.half_extent[2]);
    const Vec3& c = room.centre;
    // u x v points into the room (see Room in synth.hpp).
    if (room.floor) add_rectangle({add(c, ey), ex, ez, "floor"});
    if (room.ceiling) add_rectangle({sub(c, ey), ez, ex, "ceiling"});
    if (room.left_wall) add_rectangle({sub(c, ex), ey, ez, "left_wall"});
    if (room.right_wall) add_rectangle({add(c, ex), ez, ey, "right_wall"});
    if (room.back_wall) add_rectangle({add(c, ez), ey, ex, "back_wall"});
    if (room.front_wall) add_rectangle({sub(c, ez), ex, ey, "front_wall"});
  }
  for (const Rectangle& rectangle : scene.rectangles) add_rectangle(rectangle);

  static const char* const kFaceNames[6] = {"+x", "-x", "+y", "-y", "+z", "-z"};
  for (const Box& box : scene.boxes) {
    require_finite(box.centre, "box '" + box.name + "' centre");
    for (int i = 0; i < 3; ++i) {
      require_positive(box.half_extent[i], "box '" + box.name + "' half extent");
    }
    BoxShape shape;
    shape.rotation = rotation(box.orientation);
    shape.half_extent = box.half_extent;
    for (int i = 0; i < 3; ++i) {
      shape.camera_in_body[i] = -dot(column(shape.rotation, i), box.centre);
    }
    if (!finite(shape.camera_in_body)) {
      throw std::invalid_argument("synth: box '" + box.name + "' orientation is not finite");
    }
    shape.bound = make_bound(box.centre, std::sqrt(dot(box.half_extent, box.half_extent)));
    shape.first_label = static_cast<int>(surfaces_.size()) + 1;
    for (int face = 0; face < 6; ++face) {
      const int axis = face / 2;
      const double sign = face % 2 == 0 ? 1.0 : -1.0;
      const Vec3 normal = scale(column(shape.rotation, axis), sign);
      const Vec3 point = add(box.centre, scale(normal, box.half_extent[axis]));
      surfaces_.push_back(plane_surface(normal, point, box.name + "/" + kFaceNames[face]));
    }
    boxes_.push_back(shape);
  }

  for (const Cylinder& cylinder : scene.cylinders) {
    const std::string what = "cylinder '" + cylinder.name + "'";
    require_finite(cylinder.base, what + " base");
    require_positive(cylinder.radius, what + " radius");
    require_positive(cylinder.height, what + " height");
    const Vec3 axis = normalized(cylinder.axis, "cylinder axis");
    const double half_height = 0.5 * cylinder.height;
    CylinderShape shape{
        cylinder.base,
        axis,
        cylinder.radius,
        cylinder.height,
        make_bound(add(cylinder.base, scale(axis, half_height)),
                   std::sqrt(cylinder.radius * cylinder.radius + half_height * half_height)),
        static_cast<int>(surfaces_.size()) + 1};
    Surface side;
    side.type = SurfaceType::cylinder;
    side.centre = cylinder.base;
    side.axis = axis;
    side.radius = cylinder.radius;
    side.extent = cylinder.height;
    side.name = cylinder.name + "/side";
    surfaces_.push_back(side);
    surfaces_.push_back(plane_surface(scale(axis, -1.0), cylinder.base, cylinder.name + "/base"));
    surfaces_.push_back(plane_surface(axis, add(cylinder.base, scale(axis, cylinder.height)),
                                      cylinder.name + "/top"));
    cylinders_.push_back(shape);
  }

  for (const Sphere& sphere : scene.spheres) {
    require_finite(sphere.centre, "sphere '" + sphere.name + "' centre");
    require_positive(sphere.radius, "sphere '" + sphere.name + "' radius");
    Surface s;
    s.type = SurfaceType::sphere;
    s.centre = sphere.centre;
    s.radius = sphere.radius;
    s.name = sphere.name;
    spheres_.push_back({sphere.centre, sphere.radius, static_cast<int>(surfaces_.size()) + 1});
    surfaces_.push_back(std::move(s));
  }
}

Tracer::Bound Tracer::make_bound(const Vec3& centre, double radius) {
  const double margin = 1.0 + 1e-9;  // never reject a ray that grazes the shape
  Bound bound{centre, radius * radius * margin, dot(centre, centre), false};
  bound.usable = bound.centre_norm_squared > bound.radius_squared;
  return bound;
}

void Tracer::add_rectangle(const Rectangle& rectangle) {
  const std::string what = "rectangle '" + rectangle.name + "'";
  require_finite(rectangle.centre, what + " centre");
  const double half_u = std::sqrt(dot(rectangle.half_u, rectangle.half_u));
  const double half_v = std::sqrt(dot(rectangle.half_v, rectangle.half_v));
  require_positive(half_u, what + " |half_u|");
  require_positive(half_v, what + " |half_v|");
  const Vec3 unit_u = scale(rectangle.half_u, 1.0 / half_u);
  const Vec3 unit_v = scale(rectangle.half_v, 1.0 / half_v);
  if (std::abs(dot(unit_u, unit_v)) > 1e-9) {
    throw std::invalid_argument("synth: " + what + " half_u " + to_string(rectangle.half_u) +
                                " and half_v " + to_string(rectangle.half_v) +
                                " are not orthogonal");
  }
  Vec3 normal = normalized(cross(unit_u, unit_v), "rectangle normal");
  if (dot(normal, rectangle.centre) > 0.0) normal = scale(normal, -1.0);  // face the camera
  Surface surface = plane_surface(normal, rectangle.centre, rectangle.name);
  rectangles_.push_back({rectangle.centre, unit_u, unit_v, normal, half_u, half_v, surface.offset,
                         static_cast<int>(surfaces_.size()) + 1});
  surfaces_.push_back(std::move(surface));
}

int Tracer::trace(const Vec3& dir, double& t_out) const {
  double best = std::numeric_limits<double>::infinity();
  int label = 0;
  const double dir_norm_squared = dot(dir, dir);

  for (const RectangleShape& r : rectangles_) {
    const double denom = dot(r.normal, dir);
    if (denom == 0.0) continue;
    const double t = -r.offset / denom;
    if (!(t > kMinT && t < best)) continue;
    const Vec3 q = sub(scale(dir, t), r.centre);
    if (std::abs(dot(q, r.unit_u)) <= r.half_u && std::abs(dot(q, r.unit_v)) <= r.half_v) {
      best = t;
      label = r.label;
    }
  }

  for (const BoxShape& b : boxes_) {
    if (b.bound.misses(dir, dir_norm_squared)) continue;
    // Slab test in the body frame; the entering face is the one whose slab is entered last.
    double t_near = -std::numeric_limits<double>::infinity();
    double t_far = std::numeric_limits<double>::infinity();
    int face = -1;
    bool miss = false;
    for (int i = 0; i < 3 && !miss; ++i) {
      const double o = b.camera_in_body[i];
      const double d = dot(column(b.rotation, i), dir);
      const double h = b.half_extent[i];
      if (d == 0.0) {
        miss = std::abs(o) > h;
        continue;
      }
      const double t_minus = (-h - o) / d, t_plus = (h - o) / d;
      const bool enters_minus = d > 0.0;
      const double t_enter = enters_minus ? t_minus : t_plus;
      const double t_exit = enters_minus ? t_plus : t_minus;
      if (t_enter > t_near) {
        t_near = t_enter;
        face = 2 * i + (enters_minus ? 1 : 0);
      }
      t_far = std::min(t_far, t_exit);
    }
    if (miss || face < 0 || t_near > t_far || !(t_near > kMinT) || t_near >= best) continue;
    best = t_near;
    label = b.first_label + face;
  }

  for (const CylinderShape& c : cylinders_) {
    if (c.bound.misses(dir, dir_norm_squared)) continue;
    const Vec3 w = scale(c.base, -1.0);  // ray origin relative to the base centre
    const double wa = dot(w, c.axis), da = dot(dir, c.axis);
    const Vec3 wp = sub(w, scale(c.axis, wa)), dp = sub(dir, scale(c.axis, da));
    double roots[2];
    int count = 0;
    quadratic_roots(dot(dp, dp), 2.0 * dot(wp, dp), dot(wp, wp) - c.radius * c.radius, roots,
                    count);
    for (int k = 0; k < count; ++k) {
      const double t = roots[k];
      if (!(t > kMinT && t < best)) continue;
      const double s = wa + t * da;
      if (s >= 0.0 && s <= c.height) {
        best = t;
        label = c.first_label;
        break;  // roots are sorted
      }
    }
    if (da != 0.0) {
      for (int cap = 0; cap < 2; ++cap) {
        const double t = ((cap == 0 ? 0.0 : c.height) - wa) / da;
        if (!(t > kMinT && t < best)) continue;
        const Vec3 q = add(w, scale(dir, t));
        const Vec3 radial = sub(q, scale(c.axis, dot(q, c.axis)));
        if (dot(radial, radial) <= c.radius * c.radius) {
          best = t;
          label = c.first_label + 1 + cap;
        }
      }
    }
  }

  for (const SphereShape& s : spheres_) {
    double roots[2];
    int count = 0;
    quadratic_roots(dot(dir, dir), -2.0 * dot(dir, s.centre),
                    dot(s.centre, s.centre) - s.radius * s.radius, roots, count);
    for (int k = 0; k < count; ++k) {
      if (roots[k] > kMinT && roots[k] < best) {
        best = roots[k];
        label = s.label;
        break;
      }
    }
  }

  t_out = best;
  return label;
}

}  // namespace detail

double signed_distance(const Surface& surface, const Vec3& p) {
  using namespace detail;
  switch (surface.type) {
    case SurfaceType::plane:
      return dot(surface.normal, p) + surface.offset;
    case SurfaceType::sphere:
      return std::sqrt(dot(sub(p, surface.centre), sub(p, surface.centre))) - surface.radius;
    case SurfaceType::cylinder: {
      const Vec3 q = sub(p, surface.centre);
      const Vec3 radial = sub(q, scale(surface.axis, dot(q, surface.axis)));
      return std::sqrt(dot(radial, radial)) - surface.radius;
    }
  }
  return std::numeric_limits<double>::quiet_NaN();
}

Vec3 surface_normal(const Surface& surface, const Vec3& p) {
  using namespace detail;
  switch (surface.type) {
    case SurfaceType::plane:
      return surface.normal;
    case SurfaceType::sphere:
      return normalized(sub(p, surface.centre), "point minus sphere centre");
    case SurfaceType::cylinder: {
      const Vec3 q = sub(p, surface.centre);
      return normalized(sub(q, scale(surface.axis, dot(q, surface.axis))),
                        "point offset from cylinder axis");
    }
  }
  return {};
}

}  // namespace rangeseg::synth
