#include <memory>
#include <stdexcept>
#include <string>

#include "commands.hpp"
#include "names.hpp"
#include "output.hpp"
#include "rangeseg/camera.hpp"
#include "rangeseg/colorize.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/synth.hpp"

namespace rangeseg::cli {
namespace {

struct SynthOptions {
  std::string out_dir;
  std::string scene = "demo";
  std::string noise = "kinect";
  std::uint64_t seed = 1;
};

const char* type_name(synth::SurfaceType t) {
  switch (t) {
    case synth::SurfaceType::plane:
      return "plane";
    case synth::SurfaceType::cylinder:
      return "cylinder";
    case synth::SurfaceType::sphere:
      return "sphere";
  }
  return "unknown";
}

}  // namespace

synth::Scene scene_by_name(const std::string& name, std::uint64_t seed) {
  if (name == "demo") {
    // The library's demo scene (which has a pillar and a ball) with a can lying on the floor,
    // so that the demo shows planes, spheres, standing and lying cylinders.
    synth::Scene scene = synth::demo_scene();
    scene.cylinders.push_back({.base = {0.75, 0.8 - 0.12, 2.1},
                               .axis = {1.0, 0.0, -0.5},
                               .radius = 0.12,
                               .height = 0.45,
                               .name = "can"});
    return scene;
  }
  if (name == "boxes") return synth::random_scene(seed, false);
  if (name == "mixed") return synth::random_scene(seed, true);
  throw std::invalid_argument("unknown scene '" + name + "' (expected demo, boxes or mixed)");
}

synth::Noise noise_by_name(const std::string& name) {
  if (name == "none") return synth::Noise::none;
  if (name == "kinect") return synth::Noise::kinect;
  throw std::invalid_argument("unknown noise model '" + name + "' (expected none or kinect)");
}

nlohmann::json surfaces_json(const synth::Rendering& r) {
  nlohmann::json surfaces = nlohmann::json::array();
  for (std::size_t i = 0; i < r.surfaces.size(); ++i) {
    const synth::Surface& s = r.surfaces[i];
    nlohmann::json j{{"label", i + 1},
                     {"name", s.name},
                     {"type", type_name(s.type)},
                     {"pixels", r.pixel_counts[i]},
                     {"part_of", r.part_of[i]}};
    if (s.type == synth::SurfaceType::plane) {
      j["normal"] = s.normal;
      j["offset"] = s.offset;
    } else {
      j["centre"] = s.centre;
      j["radius"] = s.radius;
      if (s.type == synth::SurfaceType::cylinder) {
        j["axis"] = s.axis;
        j["extent"] = s.extent;
      }
    }
    surfaces.push_back(std::move(j));
  }
  return surfaces;
}

void add_synth(CLI::App& app) {
  auto o = std::make_shared<SynthOptions>();
  auto* cmd = app.add_subcommand(
      "synth",
      "Render a synthetic scene with ground truth (cloud.pcd, depth.png, labels.png, ...)");
  cmd->add_option("-o,--output", o->out_dir, "Output directory")->required();
  cmd->add_option("--scene", o->scene,
                  "demo, boxes (random boxes) or mixed (boxes, cylinders, spheres)")
      ->capture_default_str();
  cmd->add_option("--noise", o->noise, "Sensor noise model: none or kinect")->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the random scene and the noise")
      ->capture_default_str();
  cmd->callback([o] {
    const auto dir = ensure_dir(o->out_dir);
    const synth::Rendering r = synth::render(scene_by_name(o->scene, o->seed),
                                             {.noise = noise_by_name(o->noise), .seed = o->seed});
    io::write_pcd((dir / "cloud.pcd").string(), r.cloud,
                  {.encoding = io::PcdEncoding::binary_compressed});
    io::write_depth_png((dir / "depth.png").string(), cloud_to_depth(r.cloud, 0.001).view());
    io::write_label_png((dir / "labels.png").string(), r.labels);
    io::write_rgb_png((dir / "labels_colour.png").string(), colorize_labels(r.labels, &r.cloud));
    io::write_rgb_png((dir / "depth_colour.png").string(), colorize_depth(r.cloud));
    const CameraIntrinsics cam{};
    write_json((dir / "camera.json").string(),
               {{"width", r.cloud.width()},
                {"height", r.cloud.height()},
                {"intrinsic_matrix", {cam.fx, 0, 0, 0, cam.fy, 0, cam.cx, cam.cy, 1}}});
    write_json((dir / "surfaces.json").string(), {{"surfaces", surfaces_json(r)}});
    progress("wrote " + dir.string() +
             "/{cloud.pcd, depth.png, labels.png, labels_colour.png, "
             "depth_colour.png, camera.json, surfaces.json}");
  });
}

}  // namespace rangeseg::cli
