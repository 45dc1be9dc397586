#include <memory>
#include <stdexcept>
#include <string>

#include "commands.hpp"
#include "input.hpp"
#include "names.hpp"
#include "output.hpp"
#include "rangeseg/colorize.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"

namespace rangeseg::cli {
namespace {

struct MeshOptions {
  InputOptions in;
  std::string out;
  std::string type = "adaptive";
  std::string normal_png;
  std::string curvature_png;
  std::string preset = "auto";
  std::string config;
  int stride = 1;
};

}  // namespace

void add_mesh(CLI::App& app) {
  auto o = std::make_shared<MeshOptions>();
  auto* cmd = app.add_subcommand(
      "mesh", "Build the approximate mesh with normals; write a PLY coloured by normal");
  add_input_options(*cmd, o->in);
  cmd->add_option("-o,--output", o->out, "Output mesh (.ply)")->required();
  cmd->add_option("--type", o->type, "Mesh type: adaptive, quad, left or right")
      ->capture_default_str();
  cmd->add_option("--stride", o->stride, "Mesh every k-th pixel")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  cmd->add_option("--normal-png", o->normal_png, "Also write the normal map as a PNG");
  cmd->add_option("--curvature-png", o->curvature_png,
                  "Also write the curvature as a false-colour PNG");
  cmd->add_option("--preset", o->preset, kAutoPresetHelp)->capture_default_str();
  cmd->add_option("--config", o->config,
                  "JSON settings overriding the preset (its \"mesh\" and \"noise\" keys apply)");
  cmd->callback([o] {
    // The sensor's noise model sets the mesh's depth-jump gate; --type and --stride override.
    const auto mesh_settings = [o](const std::string& sensor_preset) {
      MeshSettings s =
          settings_from(resolve_preset(o->preset, sensor_preset), "plane", o->config, false).mesh;
      s.type = mesh_type_from_string(o->type);
      s.pixel_stride = o->stride;
      return s;
    };
    require_output_extension(o->out, {".ply"}, "mesh");
    for (const std::string* png : {&o->normal_png, &o->curvature_png}) {
      if (!png->empty()) require_output_extension(*png, {".png"}, "mesh");
    }
    require_distinct_outputs(o->in.path, {o->out, o->normal_png, o->curvature_png}, "mesh");
    mesh_settings("");  // bad options fail before the input is read
    LoadedInput in = load_input(o->in);
    require_grid(in.cloud, o->in.path, "a mesh",
                 "`rangeseg smooth` writes the normals of its points");
    const Mesh mesh = build_mesh(in.cloud, mesh_settings(in.sensor_preset));
    const NormalMap normals = compute_normals(in.cloud, mesh);
    const RgbImage colours =
        colorize_normals(normals.nx.view(), normals.ny.view(), normals.nz.view());
    // A failed command leaves its output paths as they were.
    io::FileGroup group;
    write_mesh_ply(o->out, in.cloud, mesh, &normals, &colours);
    if (!o->normal_png.empty()) io::write_rgb_png(o->normal_png, colours);
    if (!o->curvature_png.empty()) {
      io::write_rgb_png(o->curvature_png, colorize_scalar_auto(normals.curvature.view()));
    }
    group.commit();
    for (const std::string* path : {&o->out, &o->normal_png, &o->curvature_png}) {
      if (!path->empty()) remove_stale_temporaries(*path);
    }
    progress("wrote " + o->out + " (" + std::to_string(count_faces(mesh)) + " faces)");
  });
}

}  // namespace rangeseg::cli
