#include <cstdint>
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

void convert(const ConvertOptions& o) {
  const std::string ext = io::extension(o.out);
  if ((o.unorganized || o.shuffle) && ext == ".png") {
    throw std::invalid_argument(o.out +
                                ": a depth PNG needs a pixel grid, which --unorganized and "
                                "--shuffle remove (write .pcd or .ply)");
  }
  LoadedInput in = load_input(o.in);
  if (o.shuffle) {
    in.cloud = shuffled_valid_points(in.cloud, *o.shuffle);
  } else if (o.unorganized) {
    in.cloud = valid_points(in.cloud);
  }
  if (ext == ".pcd") {
    io::write_pcd(o.out, in.cloud, {.encoding = parse_encoding(o.encoding)});
  } else if (ext == ".png") {
    require_grid(in.cloud, o.in.path, "a depth PNG", "convert it to .pcd or .ply");
    io::write_depth_png(o.out, cloud_to_depth(in.cloud, o.in.depth_scale).view());
  } else if (ext == ".ply") {
    io::PlyMesh ply;  // points only; `rangeseg mesh` writes faces
    for (int v = 0; v < in.cloud.height(); ++v) {
      for (int u = 0; u < in.cloud.width(); ++u) {
        if (!in.cloud.valid(u, v)) continue;
        ply.xyz.insert(ply.xyz.end(), {in.cloud.x(u, v), in.cloud.y(u, v), in.cloud.z(u, v)});
        if (in.cloud.has_rgb()) {
          ply.rgb.insert(ply.rgb.end(), {in.cloud.r(u, v), in.cloud.g(u, v), in.cloud.b(u, v)});
        }
      }
    }
    io::write_ply(o.out, ply);
  } else {
    throw std::runtime_error(o.out + ": unsupported output type '" + ext +
                             "' (expected .pcd, .png (16-bit depth) or .ply (points))");
  }
  progress("wrote " + o.out);
}

}  // namespace

void add_convert(CLI::App& app) {
  auto o = std::make_shared<ConvertOptions>();
  auto* cmd = app.add_subcommand(
      "convert", "Convert between PCD, depth PNG (+ intrinsics), SegComp .range and PLY points");
  add_input_options(*cmd, o->in);
  cmd->add_option("output", o->out, "Output file: .pcd, .png (16-bit depth) or .ply")->required();
  cmd->add_option("--encoding", o->encoding, "PCD encoding: ascii, binary or binary_compressed")
      ->capture_default_str();
  cmd->add_flag("--unorganized", o->unorganized,
                "Keep only the valid points, as an unorganized cloud (height 1, row-major order)");
  cmd->add_option("--shuffle", o->shuffle,
                  "As --unorganized, in an order shuffled with this seed (an integer)");
  cmd->callback([o] { convert(*o); });
}

}  // namespace rangeseg::cli
