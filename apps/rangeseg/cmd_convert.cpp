#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "commands.hpp"
#include "input.hpp"
#include "output.hpp"
#include "rangeseg/camera.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/ply.hpp"
#include "rangeseg/io/png.hpp"

namespace rangeseg::cli {
namespace {

namespace fs = std::filesystem;

struct ConvertOptions {
  InputOptions in;
  std::string out;
  std::string encoding = "binary";
  bool unorganized = false;
  std::optional<std::uint64_t> shuffle;
};

io::PcdEncoding parse_encoding(const std::string& name) {
  if (name == "ascii") return io::PcdEncoding::ascii;
  if (name == "binary") return io::PcdEncoding::binary;
  if (name == "binary_compressed") return io::PcdEncoding::binary_compressed;
  throw std::invalid_argument("unknown PCD encoding '" + name +
                              "' (expected ascii, binary or binary_compressed)");
}

/// The smallest of 1, 2 and 5 times a power of ten that is at least `x` > 0.
double round_up_125(double x) {
  const double decade = std::pow(10.0, std::floor(std::log10(x)));
  for (const double m : {1.0, 2.0, 5.0}) {
    if (m * decade >= x * (1 - 1e-12)) return m * decade;
  }
  return 10 * decade;
}

/// A 16-bit depth PNG holds 1..65535 units: a point outside that range would come back as no
/// depth at all, so a convert that loses points is refused with a unit that fits.
void require_depths_kept(const OrganizedCloud& cloud, const DepthImage& depth,
                         const InputOptions& in) {
  std::size_t lost = 0, valid = 0;
  double z_min = INFINITY, z_max = -INFINITY;
  for (int v = 0; v < cloud.height(); ++v) {
    for (int u = 0; u < cloud.width(); ++u) {
      if (!cloud.valid(u, v)) continue;
      ++valid;
      const double z = cloud.z(u, v);
      z_min = std::min(z_min, z);
      z_max = std::max(z_max, z);
      if (depth(u, v) == 0) ++lost;
    }
  }
  if (lost == 0) return;
  const double unit = in.depth_scale;
  char text[512];
  std::snprintf(text, sizeof text,
                "%s: %zu of %zu points would be lost: a 16-bit depth PNG in units of %g m "
                "holds depths of %g to %g m, these points lie at %.4g to %.4g m",
                in.path.c_str(), lost, valid, unit, unit, 65535 * unit, z_min, z_max);
  const double fitting = z_max > 0 ? round_up_125(z_max / 65535.5) : 0;
  std::string advice = "; convert to .pcd or .ply instead";
  if (z_min > 0 && fitting > 0 && z_min >= 0.5 * fitting) {
    char scale[96];
    std::snprintf(scale, sizeof scale, "; give --depth-scale %g (a depth unit of %g mm)", fitting,
                  fitting * 1e3);
    advice = scale + std::string(" or") + advice.substr(1);
  }
  throw std::runtime_error(text + advice);
}

void convert(const ConvertOptions& o) {
  require_output_extension(o.out, {".pcd", ".png", ".ply"}, "convert");
  const std::string ext = io::extension(o.out);
  if ((o.unorganized || o.shuffle) && ext == ".png") {
    throw std::invalid_argument(o.out +
                                ": a depth PNG needs a pixel grid, which --unorganized and "
                                "--shuffle remove (write .pcd or .ply)");
  }
  const std::string json_path = (fs::path(o.out).replace_extension(".json")).string();
  require_distinct_outputs(o.in.path, {o.out, ext == ".png" ? json_path : ""}, "convert");
  if (ext == ".png") require_distinct_outputs(o.in.intrinsics, {json_path}, "convert");
  InputOptions read = o.in;
  // Writing a depth PNG, --depth-scale is the output's unit whatever the input.
  if (ext == ".png" && io::extension(o.in.path) != ".png") read.depth_scale_given = false;
  LoadedInput in = load_input(read);
  if (o.shuffle) {
    in.cloud = shuffled_valid_points(in.cloud, *o.shuffle);
  } else if (o.unorganized) {
    in.cloud = valid_points(in.cloud);
  }
  std::string note;
  if (ext == ".pcd") {
    io::write_pcd(o.out, in.cloud, {.encoding = parse_encoding(o.encoding), .viewpoint = in.pose});
  } else if (ext == ".png") {
    require_grid(in.cloud, o.in.path, "a depth PNG", "convert it to .pcd or .ply");
    // A depth PNG keeps z only: x and y come back from its intrinsics, written beside it.
    CameraIntrinsics camera;
    double off = 0;
    if (!fit_intrinsics(in.cloud, camera, kDefaultFitTolerance, &off)) {
      char how[128] = "its points fit no pinhole camera";
      if (std::isfinite(off)) {
        std::snprintf(how, sizeof how,
                      "its points lie up to %.3g px off the pixels of the best-fitting pinhole "
                      "camera (at most %.2g)",
                      off, kDefaultFitTolerance);
      }
      throw std::runtime_error(o.in.path + ": not a depth camera's image, " + how +
                               ": a depth PNG keeps only z, from which x and y could not be "
                               "computed again; convert it to .pcd or .ply");
    }
    // The depth PNG is of no use without its intrinsics: the pair is written together or not.
    const DepthImage depth = cloud_to_depth(in.cloud, o.in.depth_scale);
    require_depths_kept(in.cloud, depth, o.in);
    io::FileGroup group;
    io::write_depth_png(o.out, depth.view());
    write_json(json_path,
               {{"width", camera.width},
                {"height", camera.height},
                {"intrinsic_matrix", {camera.fx, 0, 0, 0, camera.fy, 0, camera.cx, camera.cy, 1}}});
    group.commit();
    char numbers[160];
    std::snprintf(numbers, sizeof numbers, "fx %.3f, fy %.3f, cx %.3f, cy %.3f px", camera.fx,
                  camera.fy, camera.cx, camera.cy);
    char scale[32];
    std::snprintf(scale, sizeof scale, "%g", o.in.depth_scale);
    note = std::string(" (depth in units of ") + scale + " m) and " + json_path +
           " (its intrinsics: " + numbers + "; read the PNG back with --intrinsics " + json_path +
           ")";
  } else if (ext == ".ply") {
    io::write_ply_cloud(o.out, in.cloud, in.pose);
  } else {
    throw std::runtime_error(o.out + ": unsupported output type '" + ext +
                             "' (expected .pcd, .png (16-bit depth) or .ply (points))");
  }
  remove_stale_temporaries(o.out);
  if (ext == ".png") remove_stale_temporaries(json_path);
  progress("wrote " + o.out + note);
}

}  // namespace

void add_convert(CLI::App& app) {
  auto o = std::make_shared<ConvertOptions>();
  auto* cmd = app.add_subcommand(
      "convert",
      "Convert a cloud (PCD, PLY, depth PNG + intrinsics, SegComp .range, .xyz/.xyzn/.xyzrgb/.pts) "
      "to PCD, PLY points or a depth PNG");
  add_input_options(*cmd, o->in);
  cmd->add_option("output", o->out,
                  "Output file: .pcd, .png (16-bit depth) or .ply (points; an organized cloud "
                  "with its grid, as PCL writes one)")
      ->required();
  cmd->add_option("--encoding", o->encoding, "PCD encoding: ascii, binary or binary_compressed")
      ->capture_default_str();
  cmd->add_flag("--unorganized", o->unorganized,
                "Keep only the valid points, as an unorganized cloud (height 1, row-major order)");
  cmd->add_option("--shuffle", o->shuffle,
                  "As --unorganized, in an order shuffled with this seed (an integer)");
  cmd->callback([o] { convert(*o); });
}

}  // namespace rangeseg::cli
