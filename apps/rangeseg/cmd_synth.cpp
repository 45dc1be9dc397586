#include <cmath>
#include <exception>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "commands.hpp"
#include "names.hpp"
#include "output.hpp"
#include "rangeseg/camera.hpp"
#include "rangeseg/colorize.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/synth.hpp"

namespace rangeseg::cli {
namespace {

struct SynthOptions {
  std::string out_dir;
  std::string scene = "demo";
  std::string noise = "kinect";
  std::string camera = "kinect";
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

namespace {

/// "kinect:WxH": the Kinect's horizontal field of view (57 deg) on W x H square pixels, as a
/// driver streams it at another resolution (320x240: fx 262.5).
CameraIntrinsics kinect_at(const std::string& camera) {
  constexpr int kMaxSide = 8192;
  const std::string size = camera.substr(camera.find(':') + 1);
  int w = 0, h = 0;
  char x = 0, rest = 0;
  std::istringstream parse(size);
  if (!(parse >> w >> x >> h) || x != 'x' || parse >> rest || w < 16 || h < 16 || w > kMaxSide ||
      h > kMaxSide) {
    throw std::invalid_argument("--camera " + camera +
                                ": kinect:WIDTHxHEIGHT needs two whole numbers of pixels in 16.." +
                                std::to_string(kMaxSide) + ", e.g. kinect:320x240");
  }
  const double f = CameraIntrinsics{}.fx * w / 640.0;
  return {.fx = f, .fy = f, .cx = 0.5 * (w - 1), .cy = 0.5 * (h - 1), .width = w, .height = h};
}

}  // namespace

synth::RenderSettings sensor_by_name(const std::string& noise, const std::string& camera) {
  synth::RenderSettings s;
  if (camera == "perceptron") {
    // SegComp's Perceptron laser as a pinhole: 512 x 512 pixels over 51.65 x 36.73 deg.
    constexpr double kDegree = 3.14159265358979323846 / 180.0;
    s.camera = {.fx = 256.0 / std::tan(0.5 * 51.65 * kDegree),
                .fy = 256.0 / std::tan(0.5 * 36.73 * kDegree),
                .cx = 255.5,
                .cy = 255.5,
                .width = 512,
                .height = 512};
  } else if (camera.rfind("kinect:", 0) == 0) {
    s.camera = kinect_at(camera);
  } else if (camera != "kinect") {
    throw std::invalid_argument("unknown camera '" + camera +
                                "' (expected kinect, kinect:WIDTHxHEIGHT or perceptron)");
  }
  if (noise == "none") return s;
  s.noise = synth::Noise::kinect;
  if (noise == "kinect") return s;
  const std::string prefix = "constant:";
  if (noise.compare(0, prefix.size(), prefix) == 0) {
    // A laser's noise: Gaussian along the ray with one sigma at every range, no quantisation in
    // disparity and no dropouts (the Kinect model with those terms off).
    std::size_t used = 0;
    double sigma = -1;
    try {
      sigma = std::stod(noise.substr(prefix.size()), &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != noise.size() - prefix.size() || !(sigma > 0 && sigma <= 1)) {
      throw std::invalid_argument("--noise " + noise +
                                  ": constant:SIGMA needs a sigma in metres in (0, 1]");
    }
    s.kinect = synth::constant_noise(sigma);
    return s;
  }
  throw std::invalid_argument("unknown noise model '" + noise +
                              "' (expected none, kinect or constant:SIGMA)");
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
    } else if (s.type == synth::SurfaceType::cylinder) {
      // Named as in segments.json: the axis starts at the base point and runs `extent` along it.
      j["axis_point"] = s.centre;
      j["axis"] = s.axis;
      j["radius"] = s.radius;
      j["extent"] = s.extent;
    } else {
      j["centre"] = s.centre;
      j["radius"] = s.radius;
    }
    surfaces.push_back(std::move(j));
  }
  return surfaces;
}

void add_sensor_options(CLI::App& cmd, std::string& noise, std::string& camera) {
  cmd.add_option("--noise", noise,
                 "Sensor noise model: none, kinect (structured light, sigma growing with depth, "
                 "dropouts) or constant:SIGMA (a laser: SIGMA metres along the ray at any range)")
      ->capture_default_str();
  cmd.add_option("--camera", camera,
                 "kinect (640x480, f = 525 px), kinect:WIDTHxHEIGHT (its 57 deg field of view "
                 "at another resolution, e.g. kinect:320x240 with f = 262.5 px; the kinect "
                 "noise keeps the depth steps of the sensor's 525 px disparity image) or "
                 "perceptron (512x512 over 51.65 x 36.73 deg, SegComp's Perceptron laser)")
      ->capture_default_str();
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
  add_sensor_options(*cmd, o->noise, o->camera);
  cmd->add_option("--seed", o->seed, "Seed of the random scene and the noise")
      ->capture_default_str();
  cmd->callback([o] {
    synth::RenderSettings settings = sensor_by_name(o->noise, o->camera);
    settings.seed = o->seed;
    const synth::Scene scene = scene_by_name(o->scene, o->seed);
    const auto dir = ensure_dir(o->out_dir);
    const synth::Rendering r = synth::render(scene, settings);
    io::FileGroup group;  // a scene and its ground truth are replaced together, or not at all
    io::write_pcd((dir / "cloud.pcd").string(), r.cloud,
                  {.encoding = io::PcdEncoding::binary_compressed});
    io::write_depth_png((dir / "depth.png").string(), cloud_to_depth(r.cloud, 0.001).view());
    io::write_label_png((dir / "labels.png").string(), r.labels);
    io::write_rgb_png((dir / "labels_colour.png").string(), colorize_labels(r.labels, &r.cloud));
    io::write_rgb_png((dir / "depth_colour.png").string(), colorize_depth(r.cloud));
    const CameraIntrinsics& cam = settings.camera;
    write_json((dir / "camera.json").string(),
               {{"width", r.cloud.width()},
                {"height", r.cloud.height()},
                {"intrinsic_matrix", {cam.fx, 0, 0, 0, cam.fy, 0, cam.cx, cam.cy, 1}}});
    write_json((dir / "surfaces.json").string(), {{"surfaces", surfaces_json(r)}});
    group.commit();
    progress("wrote " + dir.string() +
             "/{cloud.pcd, depth.png, labels.png, labels_colour.png, "
             "depth_colour.png, camera.json, surfaces.json}");
  });
}

}  // namespace rangeseg::cli
