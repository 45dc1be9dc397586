// Ready-made scenes: the demo, random box scenes and a single plane.
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include "detail/number_text.hpp"
#include "synth/tracer.hpp"

namespace rangeseg::synth {

Scene demo_scene() {
  constexpr double floor_y = 0.8;  // the camera is 0.8 m above the floor, looking horizontally
  Scene scene;
  // A room corner: the back-left corner at (-1.6, 3.6), the back wall turned by 0.35 rad so it
  // recedes to the right (up to ~5.4 m at the image border); walls 4 m high.
  Room room;
  room.yaw = -0.35;
  room.half_extent = {3.0, 2.0, 3.0};
  const detail::Mat3 r = detail::rotation({.yaw = room.yaw});
  const Vec3 corner{-1.6, 0.0, 3.6};
  const Vec3 centre = detail::sub(detail::add(corner, detail::scale(detail::column(r, 0), 3.0)),
                                  detail::scale(detail::column(r, 2), 3.0));
  room.centre = {centre[0], floor_y - room.half_extent[1], centre[2]};
  room.floor = true;
  room.ceiling = false;
  room.left_wall = true;
  room.right_wall = false;
  room.back_wall = true;
  room.front_wall = false;
  scene.room = room;

  // A table-like block 1.4 m x 0.6 m high x 0.7 m, its top 0.2 m below the camera.
  scene.boxes.push_back(
      {.centre = {0.35, floor_y - 0.3, 2.6}, .half_extent = {0.4, 0.3, 0.35}, .name = "table"});
  // Two stacked boxes, the upper one turned.
  scene.boxes.push_back({.centre = {-0.8, floor_y - 0.22, 2.3},
                         .half_extent = {0.22, 0.22, 0.22},
                         .name = "stack_lower"});
  scene.boxes.push_back({.centre = {-0.8, floor_y - 0.44 - 0.14, 2.3},
                         .half_extent = {0.15, 0.14, 0.15},
                         .orientation = {.yaw = 0.4},
                         .name = "stack_upper"});
  // A box turned about the vertical and tipped slightly, to the right behind the table.
  scene.boxes.push_back({.centre = {1.3, floor_y - 0.25, 3.2},
                         .half_extent = {0.3, 0.2, 0.2},
                         .orientation = {.yaw = 0.6, .roll = 0.15},
                         .name = "rotated"});
  scene.cylinders.push_back({.base = {-0.35, floor_y, 3.4},
                             .axis = {0.0, -1.0, 0.0},
                             .radius = 0.15,
                             .height = 0.9,
                             .name = "pillar"});
  scene.spheres.push_back(
      {.centre = {0.3, floor_y - 0.6 - 0.15, 2.6}, .radius = 0.15, .name = "ball"});
  return scene;
}

namespace {

// Uniform draws from std::mt19937_64 computed by hand: identical on every standard library.
class Uniform {
 public:
  explicit Uniform(std::uint64_t seed) : engine_(seed) {}
  double operator()(double lo, double hi) {
    return lo + (hi - lo) * (static_cast<double>(engine_() >> 11) * 0x1.0p-53);
  }
  int integer(int lo, int hi) {  // [lo, hi]
    return lo + static_cast<int>(engine_() % static_cast<std::uint64_t>(hi - lo + 1));
  }

 private:
  std::mt19937_64 engine_;
};

struct Footprint {
  double x, z, radius;
};

}  // namespace

Scene random_scene(std::uint64_t seed, bool with_curved) {
  Uniform random(seed);
  const double floor_y = random(0.7, 1.1);
  const double wall_z = random(4.0, 5.5);
  Scene scene;
  Room room;
  room.half_extent = {10.0, 2.5, wall_z / 2 + 0.5};
  room.centre = {0.0, floor_y - room.half_extent[1], wall_z - room.half_extent[2]};
  room.floor = room.back_wall = true;
  room.ceiling = room.left_wall = room.right_wall = room.front_wall = false;
  scene.room = room;

  std::vector<Footprint> footprints;
  // Places a footprint of the given radius on the floor in view and clear of the others.
  auto place = [&](double radius, double& x, double& z) {
    for (int attempt = 0; attempt < 100; ++attempt) {
      z = random(1.8, wall_z - radius - 0.3);
      x = random(-0.45, 0.45) * z;
      bool clear = true;
      for (const Footprint& f : footprints) {
        clear = clear && std::hypot(f.x - x, f.z - z) > f.radius + radius + 0.05;
      }
      if (clear) {
        footprints.push_back({x, z, radius});
        return true;
      }
    }
    return false;
  };

  const int box_count = random.integer(2, 6);
  for (int i = 0; i < box_count; ++i) {
    const std::string name = "box" + std::to_string(i);
    const bool stack = !scene.boxes.empty() && random(0.0, 1.0) < 0.35;
    const Vec3 half{random(0.1, 0.35), random(0.1, 0.35), random(0.1, 0.35)};
    const double yaw = random(0.0, 1.0) < 0.5 ? 0.0 : random(-0.8, 0.8);
    if (stack) {
      const Box& base = scene.boxes.back();
      const double limit = 0.8 * std::min(base.half_extent[0], base.half_extent[2]);
      const Vec3 top{std::min(half[0], limit), half[1], std::min(half[2], limit)};
      const double base_top = base.centre[1] - base.half_extent[1];
      scene.boxes.push_back({.centre = {base.centre[0], base_top - top[1], base.centre[2]},
                             .half_extent = top,
                             .orientation = {.yaw = yaw},
                             .name = name});
      continue;
    }
    double x = 0, z = 0;
    if (!place(std::hypot(half[0], half[2]), x, z)) continue;
    scene.boxes.push_back({.centre = {x, floor_y - half[1], z},
                           .half_extent = half,
                           .orientation = {.yaw = yaw},
                           .name = name});
  }

  if (with_curved) {
    const int cylinder_count = random.integer(1, 2);
    for (int i = 0; i < cylinder_count; ++i) {
      const double radius = random(0.08, 0.2), height = random(0.2, 0.8);
      double x = 0, z = 0;
      if (!place(radius, x, z)) continue;
      scene.cylinders.push_back({.base = {x, floor_y, z},
                                 .axis = {0.0, -1.0, 0.0},
                                 .radius = radius,
                                 .height = height,
                                 .name = "cylinder" + std::to_string(i)});
    }
    const int sphere_count = random.integer(1, 2);
    for (int i = 0; i < sphere_count; ++i) {
      const double radius = random(0.1, 0.3);
      double x = 0, z = 0;
      if (!place(radius, x, z)) continue;
      scene.spheres.push_back({.centre = {x, floor_y - radius, z},
                               .radius = radius,
                               .name = "sphere" + std::to_string(i)});
    }
  }
  return scene;
}

Scene plane_scene(double distance, double tilt_rad) {
  if (!(distance > 0.0) || !std::isfinite(distance)) {
    throw std::invalid_argument("synth::plane_scene: distance must be positive, got " +
                                rangeseg::detail::number_text(distance));
  }
  if (!(std::abs(tilt_rad) < 1.1)) {
    throw std::invalid_argument(
        "synth::plane_scene: |tilt_rad| must be < 1.1 so the plane fills the view, got " +
        rangeseg::detail::number_text(tilt_rad));
  }
  constexpr double half_size = 100.0;  // m: far larger than the view at any usable distance
  Scene scene;
  scene.rectangles.push_back(
      {.centre = {0.0, 0.0, distance},
       .half_u = {half_size, 0.0, 0.0},
       .half_v = {0.0, half_size * std::cos(tilt_rad), half_size * std::sin(tilt_rad)},
       .name = "plane"});
  return scene;
}

}  // namespace rangeseg::synth
