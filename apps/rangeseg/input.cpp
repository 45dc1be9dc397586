#include "input.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>

#include "output.hpp"
#include "rangeseg/camera.hpp"
#include "rangeseg/io/camera_file.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/perceptron.hpp"
#include "rangeseg/io/ply.hpp"
#include "rangeseg/io/png.hpp"
#include "rangeseg/io/rasterfile.hpp"
#include "rangeseg/io/xyz.hpp"
#include "rangeseg/pixel_grid.hpp"

namespace rangeseg::cli {

void add_input_options(CLI::App& cmd, InputOptions& o, bool positional) {
  if (positional) {
    cmd.add_option(
           "input", o.path,
           "Input file: .pcd, .ply, 16-bit depth .png, SegComp .range, .xyz/.xyzn/.xyzrgb/.pts")
        ->required();
  }
  CLI::Option* intrinsics =
      cmd.add_option("--intrinsics", o.intrinsics,
                     "Camera intrinsics for depth PNGs: JSON (Open3D camera_*.json layout, or "
                     "{fx, fy, cx, cy}) or ROS camera_info YAML (.yaml: a calibration file or a "
                     "CameraInfo message; its projection matrix P, the rectified image's camera, "
                     "when it gives one, else K); its width and height, when given, must be the "
                     "PNG's");
  CLI::Option* fx = cmd.add_option("--fx", o.fx,
                                   "Focal length x [pixel] for depth PNGs (default --fy when "
                                   "given, else 525, a Kinect's)")
                        ->each([&o](const std::string&) { o.fx_given = true; });
  CLI::Option* fy = cmd.add_option("--fy", o.fy,
                                   "Focal length y [pixel] for depth PNGs (default --fx when "
                                   "given, else 525)")
                        ->each([&o](const std::string&) { o.fy_given = true; });
  CLI::Option* cx =
      cmd.add_option("--cx", o.cx, "Principal point x [pixel] for depth PNGs (default (width-1)/2)")
          ->each([&o](const std::string&) { o.cx_given = true; });
  CLI::Option* cy =
      cmd.add_option("--cy", o.cy,
                     "Principal point y [pixel] for depth PNGs (default (height-1)/2)")
          ->each([&o](const std::string&) { o.cy_given = true; });
  // The JSON sets all four, so a number given beside it would be dropped without a word.
  intrinsics->excludes(fx)->excludes(fy)->excludes(cx)->excludes(cy);
  cmd.add_flag("--apply-viewpoint", o.apply_viewpoint,
               "Move a PCD's points into the frame of the sensor its VIEWPOINT names (a PLY's: "
               "its PCL camera element; a cloud saved in another frame); by default points are "
               "taken as stored, in the sensor's frame (PCL's OpenNI grabber writes VIEWPOINT 0 "
               "0 0 0 1 0 0 for such points)");
  cmd.add_option("--depth-scale", o.depth_scale,
                 "Metres per depth PNG unit (0.001 = millimetres, as a RealSense D400 "
                 "writes by default; D405: 0.0001; TUM sequences: 0.0002)")
      ->capture_default_str()
      ->check(CLI::Validator(
          [](const std::string& text) {
            double value = 0;
            const bool number = CLI::detail::lexical_cast(text, value);
            return number && std::isfinite(value) && value > 0
                       ? std::string()
                       : "must be a finite number > 0 [m per unit], got " + text;
          },
          "SCALE", "finite, > 0"))
      ->each([&o](const std::string&) { o.depth_scale_given = true; });
}

namespace {

// Once per file, not per frame of a batch (whose frames may load on several threads).
void warn_distortion(const std::string& path, const io::CameraFile& file) {
  static std::mutex mutex;
  static std::set<std::string> warned;
  const std::lock_guard lock(mutex);
  if (!warned.insert(path).second) return;
  std::string coefficients;
  for (const double d : file.distortion) {
    char text[32];
    std::snprintf(text, sizeof text, "%s%g", coefficients.empty() ? "" : ", ", d);
    coefficients += text;
  }
  note(
      "warning: %s: its lens distortion (%s [%s]) is not applied: the depth "
      "images are taken as a pinhole camera's (rectified)",
      path.c_str(),
      file.distortion_model.empty() ? "no model named" : file.distortion_model.c_str(),
      coefficients.c_str());
}

void note_projection(const std::string& path, const io::CameraFile& file) {
  static std::mutex mutex;
  static std::set<std::string> noted;
  const std::lock_guard lock(mutex);
  if (!noted.insert(path).second) return;
  const CameraIntrinsics& p = file.intrinsics;
  const CameraIntrinsics& k = file.camera_matrix;
  note(
      "%s: the projection matrix P (fx %.2f, fy %.2f, cx %.2f, cy %.2f) is "
      "the camera of the depth images, as for ROS's depth_image_proc: they are taken "
      "as rectified; K (fx %.2f, fy %.2f, cx %.2f, cy %.2f) is the raw image's",
      path.c_str(), p.fx, p.fy, p.cx, p.cy, k.fx, k.fy, k.cx, k.cy);
}

bool camera_options_given(const InputOptions& o) {
  return !o.intrinsics.empty() || o.fx_given || o.fy_given || o.cx_given || o.cy_given;
}

}  // namespace

std::pair<double, double> focal_lengths(const InputOptions& o) {
  // Square pixels unless both are given: one focal length alone is the camera's.
  return {o.fx_given || !o.fy_given ? o.fx : o.fy, o.fy_given || !o.fx_given ? o.fy : o.fx};
}

std::string camera_source(const InputOptions& o) {
  if (!o.intrinsics.empty()) return o.intrinsics;
  if (camera_options_given(o)) return "--fx / --fy / --cx / --cy";
  return o.tum_sequence ? "TUM RGB-D's" : "the default, a Kinect's";
}

CameraIntrinsics intrinsics_for(const InputOptions& o, int width, int height) {
  if (!o.intrinsics.empty()) {
    const io::CameraFile file = io::read_camera_file(o.intrinsics);
    if (file.distorted()) warn_distortion(o.intrinsics, file);
    if (file.projection_differs()) note_projection(o.intrinsics, file);
    return file.intrinsics;
  }
  const auto [fx, fy] = focal_lengths(o);
  CameraIntrinsics cam{.fx = fx,
                       .fy = fy,
                       .cx = o.cx_given ? o.cx : (width - 1) / 2.0,
                       .cy = o.cy_given ? o.cy : (height - 1) / 2.0,
                       .width = width,
                       .height = height};
  validate(cam);
  return cam;
}

namespace {

// The sensor pose a PCD's VIEWPOINT or a PLY's camera element gives: kept in `in`, and with
// --apply-viewpoint the points are moved into that sensor's frame.
void take_viewpoint(LoadedInput& in, const std::array<double, 7>& p, const InputOptions& o,
                    const char* what, bool moved_by_reader = false) {
  if (p == std::array<double, 7>{0, 0, 0, 1, 0, 0, 0}) return;
  char pose[160];
  std::snprintf(pose, sizeof pose, "%g %g %g %g %g %g %g", p[0], p[1], p[2], p[3], p[4], p[5],
                p[6]);
  in.viewpoint = pose;
  in.pose = p;
  if (!o.apply_viewpoint) return;
  try {
    if (!moved_by_reader) to_sensor_frame(in.cloud, p);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(o.path + ": " + what + " " + pose + ": " + e.what());
  }
  in.pose = {0, 0, 0, 1, 0, 0, 0};
  note(
      "%s: %s %s: its points are moved into that sensor's frame, in which "
      "the results are given",
      o.path.c_str(), what, pose);
}

}  // namespace

namespace {

// Once per process: a batch's frames share their options and may load on several threads.
// `message` runs only for the one that prints.
template <class Message>
void warn_once(std::once_flag& flag, const Message& message) {
  std::call_once(flag, [&] { note("%s", message().c_str()); });
}

/// The median of `values` (reordered), NaN for none.
double median_of(std::vector<float>& values) {
  if (values.empty()) return std::nan("");
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

/// Points stored as floats in a map's frame keep the steps floats have there when the VIEWPOINT
/// moves them into the sensor's frame: the cloud then looks fine but is not (checked on the
/// VIEWPOINT's translation, near which the stored points lie).
void check_stored_precision(const std::string& path, const std::array<double, 7>& viewpoint) {
  constexpr double kFarCoordinate = 8192;  // floats there lie 1 mm apart (as cloud_scale_problem)
  const double largest =
      std::max({std::abs(viewpoint[0]), std::abs(viewpoint[1]), std::abs(viewpoint[2])});
  if (largest < kFarCoordinate) return;
  const double step =
      static_cast<double>(std::nextafter(static_cast<float>(largest), INFINITY)) - largest;
  static std::once_flag flag;
  warn_once(flag, [&] {
    char text[320];
    std::snprintf(text, sizeof text,
                  ": x y z are stored as float near the VIEWPOINT's coordinates (up to %.6g m), "
                  "where floats lie %.3g m apart: moved into the sensor's frame, the points keep "
                  "those steps (store them as doubles, or subtract the offset before saving)",
                  largest, step);
    return "warning: " + path + text;
  });
}

/// Every depth reading must become a point: a depth scale or focal length beyond float's range
/// (e.g. --depth-scale 1e300 or 1e-300) would otherwise leave an empty cloud with no reason.
void require_finite_points(const std::string& path, const DepthImage& depth,
                           const OrganizedCloud& cloud, const CameraIntrinsics& cam,
                           double depth_scale) {
  std::size_t readings = 0;
  for (int v = 0; v < depth.height(); ++v) {
    for (int u = 0; u < depth.width(); ++u) readings += depth(u, v) != 0 ? 1 : 0;
  }
  const std::size_t points = cloud.count_valid();
  if (points == readings) return;
  char text[320];
  std::snprintf(text, sizeof text,
                ": %zu of %zu depth readings give no finite point in single precision (depth "
                "scale %g m/unit, fx %g px, fy %g px): check --depth-scale and the camera",
                readings - points, readings, depth_scale, cam.fx, cam.fy);
  throw std::runtime_error(path + text);
}

/// A camera file (JSON or ROS YAML) in the folder of `image` that reads as one and states no
/// other image size, the one named like the image first; "" when there is none. Looks at a
/// bounded number of entries, so a huge folder costs little.
std::string camera_file_beside(const std::string& image, int width, int height) {
  const std::filesystem::path path(image);
  const std::filesystem::path folder = path.parent_path().empty() ? "." : path.parent_path();
  const auto fits = [&](const std::filesystem::path& file) {
    const std::string ext = io::extension(file.string());
    std::error_code ec;
    if ((ext != ".json" && ext != ".yaml" && ext != ".yml") ||
        !std::filesystem::is_regular_file(file, ec) ||
        std::filesystem::file_size(file, ec) > (1u << 20) || ec) {
      return false;
    }
    try {
      const CameraIntrinsics c = io::read_camera_file(file.string()).intrinsics;
      return (c.width == 0 || c.width == width) && (c.height == 0 || c.height == height);
    } catch (const std::exception&) {
      return false;  // a settings file or anything else that is no camera
    }
  };
  for (const char* ext : {".json", ".yaml", ".yml"}) {
    std::filesystem::path same = path;
    if (fits(same.replace_extension(ext))) return same.string();
  }
  std::error_code ec;
  int looked = 0;
  for (const auto& e : std::filesystem::directory_iterator(folder, ec)) {
    if (++looked > 1000) break;
    if (fits(e.path())) return e.path().string();
  }
  return "";
}

// A depth image's camera and scale, when nothing named them or they are implausible.
void check_depth_image(const InputOptions& o, const OrganizedCloud& cloud, bool eight_bit) {
  if (!o.tum_sequence && !o.depth_scale_given) {
    // An image of a TUM sequence's depth/ folder, given alone or as that folder: its depth.txt
    // would have given TUM's scale (5000 per metre, not millimetres) and camera.
    const std::filesystem::path sequence =
        std::filesystem::path(o.path).parent_path().parent_path();
    std::error_code ec;
    if (std::filesystem::is_regular_file(
            (sequence.empty() ? std::filesystem::path(".") : sequence) / "depth.txt", ec)) {
      static std::once_flag flag;
      warn_once(flag, [&] {
        const std::string folder = sequence.empty() ? "." : sequence.string();
        return "warning: " + o.path + " is a frame of the TUM RGB-D sequence " + folder +
               " (its depth.txt), read in millimetres: give " + folder +
               " for TUM's 5000 units per metre and camera, or --depth-scale 0.0002";
      });
    }
  }
  if (!camera_options_given(o) && !o.tum_sequence) {
    static std::once_flag flag;
    warn_once(flag, [&] {
      const std::string camera = camera_file_beside(o.path, cloud.width(), cloud.height());
      const std::string beside =
          camera.empty() ? ""
                         : " (" + camera + " beside it is a camera file for this image's size: " +
                               "pass it with --intrinsics)";
      return "note: " + o.path +
             ": no camera given (--intrinsics, --fx/--fy): depth PNGs are taken as a Kinect's, "
             "fx = fy = 525 px, the principal point at the centre" +
             beside;
    });
  }
  if (eight_bit) {
    static std::once_flag flag;
    warn_once(flag, [&] {
      return "warning: " + o.path +
             ": an 8-bit PNG, read as depth in units of --depth-scale (0..255); a depth camera "
             "writes 16-bit PNGs: is it a picture or a mask?";
    });
  }
  // The median depth of the valid pixels, against ten times the range of depth cameras
  // (0.2-20 m) either way.
  std::vector<float> z;
  const int step = std::max(1, cloud.height() / 64);
  for (int v = 0; v < cloud.height(); v += step) {
    const float* row = cloud.z.row(v);
    for (int u = 0; u < cloud.width(); u += step) {
      if (std::isfinite(row[u]) && row[u] > 0) z.push_back(row[u]);
    }
  }
  const double median = median_of(z);
  if (std::isnan(median) || (median > 0.02 && median < 200)) return;
  static std::once_flag flag;
  warn_once(flag, [&] {
    char text[96];
    std::snprintf(text, sizeof text, "the median depth is %.4g m with --depth-scale %g m/unit",
                  median, o.depth_scale);
    return "warning: " + o.path + ": " + text +
           ": is the scale right? (0.001 for millimetres, as a RealSense D400's default; 0.0001 "
           "for a D405's 0.1 mm units, 0.0002 for TUM)";
  });
}

// Points in millimetres, or far from the origin (a georeferenced scan's UTM coordinates, which
// float cuts to steps of up to 0.5 m): named once, as the results would be wrong without error.
void check_cloud_scale(const std::string& path, const OrganizedCloud& cloud) {
  const std::string problem = cloud_scale_problem(cloud);
  if (problem.empty()) return;
  static std::once_flag flag;
  warn_once(flag, [&] { return "warning: " + path + ": " + problem; });
}

}  // namespace

void check_noise_scale(const std::string& path, const OrganizedCloud& cloud,
                       const SensorNoise& noise) {
  static std::once_flag checked;
  std::call_once(checked, [&] {
    if (!cloud_scale_problem(cloud).empty()) return;  // named already, and the likelier cause
    const std::string problem = noise_scale_problem(cloud, noise);
    if (problem.empty()) return;
    static std::once_flag flag;
    warn_once(flag, [&] {
      return "warning: " + path + ": " + problem +
             " (--apply-viewpoint applies a PCD's VIEWPOINT; a constant noise: --config "
             "'{\"noise\": {\"a\": 0.01, \"b\": 0}}')";
    });
  });
}

void note_auto_preset(const std::string& preset_option, const LoadedInput& in,
                      const std::string& path) {
  // A grid without points tells nothing (the no-segments warning says what is wrong with it).
  if (preset_option != "auto" || !in.sensor_preset.empty() || !in.cloud.is_organized() ||
      in.camera_fx > 0 || in.cloud.count_valid() == 0) {
    return;
  }
  static std::once_flag checked;
  std::call_once(checked, [&] {
    CameraIntrinsics camera;
    if (fit_intrinsics(in.cloud, camera)) return;
    note(
        "note: %s: no pinhole camera explains this grid (a scanner's, or "
        "points moved out of the camera's frame); --preset auto takes it for a depth "
        "camera's (kinect). For a laser scanner give --preset laser: its range noise at "
        "short range is above a depth camera's, and the kinect preset leaves much of "
        "such a scan unlabelled.",
        path.c_str());
  });
}

LoadedInput load_input(const InputOptions& o) {
  LoadedInput in;
  if (io::extension(o.path) != ".png" && (camera_options_given(o) || o.depth_scale_given)) {
    static std::once_flag flag;
    warn_once(flag, [&] {
      return "warning: " + o.path +
             ": --intrinsics, --fx, --fy, --cx, --cy and --depth-scale apply to depth PNGs "
             "only: this file's points are used as they are";
    });
  }
  const std::string ext = io::extension(o.path);
  if (ext == ".pcd") {
    io::PcdInfo info;
    // The reader applies the VIEWPOINT to the stored values: doubles keep map coordinates.
    in.cloud = io::read_pcd(o.path, &info, {.to_sensor_frame = o.apply_viewpoint});
    static const char* const names[] = {"ascii", "binary", "binary_compressed"};
    in.format = std::string("PCD ") + names[static_cast<int>(info.encoding)];
    in.fields = info.fields_summary;
    if (in.cloud.has_label()) in.ground_truth = in.cloud.label;
    if (info.moved_from_sensor()) {
      take_viewpoint(in, info.viewpoint, o, "VIEWPOINT", true);
      if (o.apply_viewpoint && !info.xyz_double) check_stored_precision(o.path, info.viewpoint);
    }
  } else if (ext == ".png") {
    bool eight_bit = false;
    const DepthImage depth = io::read_depth_png(o.path, &eight_bit);
    const CameraIntrinsics cam = intrinsics_for(o, depth.width(), depth.height());
    try {
      in.cloud = depth_to_cloud(depth.view(), cam, o.depth_scale);
      in.camera_fx = cam.fx;
      in.camera = cam;
      in.camera_source = camera_source(o);
    } catch (const std::invalid_argument& e) {
      // e.g. intrinsics of another image size (depth_to_cloud checks them)
      throw std::runtime_error(o.path + (o.intrinsics.empty() ? "" : " with " + o.intrinsics) +
                               ": " + e.what());
    }
    require_finite_points(o.path, depth, in.cloud, cam, o.depth_scale);
    check_depth_image(o, in.cloud, eight_bit);
    in.format = eight_bit ? "8-bit depth PNG" : "16-bit depth PNG";
    char scale[48];
    std::snprintf(scale, sizeof scale, "depth (scale %g m/unit)", o.depth_scale);
    in.fields = scale;
  } else if (ext == ".ply") {
    io::PlyCloudInfo info;
    in.cloud = io::read_ply_cloud(o.path, &info);
    in.format = "PLY " + info.format;
    if (!info.grid.empty()) {
      in.format += " (organized by its " +
                   std::string(info.grid == "range_grid" ? "range_grid element"
                               : info.grid == "rows"     ? "obj_info num_cols / num_rows"
                                                         : "camera element's viewport") +
                   ")";
    }
    in.fields = info.fields_summary;
    if (in.cloud.has_label()) in.ground_truth = in.cloud.label;
    if (info.viewpoint_ignored) {
      if (o.apply_viewpoint) {
        throw std::runtime_error(o.path +
                                 ": --apply-viewpoint: the camera element's axes are no "
                                 "rotation, so its sensor pose cannot be applied");
      }
      note(
          "%s: the camera element's axes are no rotation: its sensor pose is "
          "ignored",
          o.path.c_str());
    }
    take_viewpoint(in, info.viewpoint, o, "camera element's sensor pose");
  } else if (io::is_text_cloud_extension(ext)) {
    in.cloud = io::read_text_cloud(o.path);
    in.format = "text point cloud (" + ext + ")";
    in.fields = std::string("x y z") + (in.cloud.has_intensity() ? " intensity" : "") +
                (in.cloud.has_rgb() ? " r g b" : "");
  } else if (ext == ".range") {
    io::SegcompSensor sensor{};
    in.cloud = io::read_segcomp_range(o.path, &sensor);
    const bool abw = sensor == io::SegcompSensor::abw;
    in.format = abw ? "SegComp ABW rasterfile" : "SegComp Perceptron range image";
    in.fields = abw ? "range (8 bit)" : "range (12 bit)";
    in.sensor_preset = abw ? "abw" : "perceptron";
    std::filesystem::path gt = o.path;
    gt.replace_extension(".gt-seg");
    if (std::filesystem::exists(gt)) {
      in.ground_truth = io::read_segcomp_gt(gt.string());
      in.ground_truth_min_label = 10;
    }
  } else {
    throw std::runtime_error(o.path + ": unsupported file type '" + ext +
                             "' (expected .pcd, .ply, .png, .range, .xyz, .xyzn, .xyzrgb or .pts)");
  }
  if (in.cloud.empty()) throw std::runtime_error(o.path + ": the cloud has no points");
  if (ext != ".png" && ext != ".range") check_cloud_scale(o.path, in.cloud);
  if (in.cloud.height() == 1 && in.sensor_preset.empty() && surrounds_its_sensor(in.cloud)) {
    in.sensor_preset = "laser";
  }
  return in;
}

void require_output_extension(const std::string& path, const std::vector<std::string>& extensions,
                              const std::string& command) {
  const std::string ext = io::extension(path);
  if (std::find(extensions.begin(), extensions.end(), ext) != extensions.end()) return;
  std::string expected;
  for (const std::string& e : extensions) expected += (expected.empty() ? "" : " or ") + e;
  throw std::invalid_argument(path + ": " + command + " cannot write " +
                              (ext.empty() ? "a file without extension" : "'" + ext + "' files") +
                              " (expected " + expected + ")");
}

void require_distinct_outputs(const std::string& input, const std::vector<std::string>& outputs,
                              const std::string& command) {
  const auto same = [](const std::string& a, const std::string& b) {
    std::error_code error;
    if (std::filesystem::equivalent(a, b, error)) return true;
    const auto normal = [](const std::string& p) {
      std::error_code e;
      return std::filesystem::weakly_canonical(std::filesystem::absolute(p, e), e);
    };
    return normal(a) == normal(b);
  };
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    if (outputs[i].empty()) continue;
    if (!input.empty() && same(outputs[i], input)) {
      throw std::invalid_argument(outputs[i] + ": the output is the input file: " + command +
                                  " would write its result over it (give another output file)");
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (!outputs[j].empty() && same(outputs[i], outputs[j])) {
        throw std::invalid_argument(outputs[i] + ": given for two of " + command +
                                    "'s outputs, which would write one over the other");
      }
    }
  }
}

void require_grid(OrganizedCloud& cloud, const std::string& path, const std::string& what,
                  const std::string& instead) {
  if (cloud.is_organized()) return;
  if (io::extension(path) == ".png") {
    // A one-row depth image: height 1 reads as an unorganized cloud (PCL's convention).
    throw std::runtime_error(path + ": a depth image of one row (" + std::to_string(cloud.width()) +
                             " x 1 pixels), which reads as an " + "unorganized cloud: " + what +
                             " needs two rows or more; " + instead);
  }
  PixelGrid grid;
  if (!find_pixel_grid(cloud, grid)) {
    throw std::runtime_error(path + ": an unorganized cloud (" + std::to_string(cloud.size()) +
                             " points, height 1) whose points do not lie on a camera's pixel "
                             "grid: " +
                             what + " needs the pixel grid of an organized cloud; " + instead);
  }
  OrganizedCloud on_grid;
  scatter_to_grid(cloud, grid, on_grid);
  cloud = std::move(on_grid);
  note(
      "%s: unorganized, its points on a %d x %d pixel grid (fx %.2f, fy %.2f, "
      "cx %.2f, cy %.2f px), which %s uses",
      path.c_str(), grid.width, grid.height, grid.fx, grid.fy, grid.cx, grid.cy, what.c_str());
}

namespace {

namespace fs = std::filesystem;

/// TUM RGB-D depth PNGs: 5000 units per metre.
constexpr double kTumDepthScale = 1.0 / 5000.0;

bool is_tum_list(const fs::path& p) { return p.filename() == "depth.txt"; }

bool is_frame_file(const fs::path& p) {
  const std::string ext = io::extension(p.string());
  // Hidden files (".name", macOS "._name" resource forks) are no frames.
  if (p.filename().string().starts_with('.')) return false;
  return ext == ".pcd" || ext == ".ply" || ext == ".png" || ext == ".range" ||
         io::is_text_cloud_extension(ext);
}

/// Frames of a TUM sequence from its depth.txt: "timestamp path" per line, '#' comments. A
/// malformed line becomes a frame that fails with the reason, so the batch goes on.
void add_tum_frames(const fs::path& list, std::vector<FrameSource>& frames) {
  const auto fail = [&](const std::string& why) {
    frames.push_back({.path = list.string(),
                      .name = list.parent_path().filename().string(),
                      .error = list.string() + ": " + why});
  };
  std::ifstream in(list);
  if (!in) return fail("cannot open the TUM depth list");
  const fs::path folder = list.parent_path();
  std::string line;
  int line_number = 0;
  const std::size_t first = frames.size();
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    // A byte order mark, as some Windows editors write at the start of a text file.
    if (line_number == 1 && line.starts_with("\xEF\xBB\xBF")) line.erase(0, 3);
    const std::size_t start = line.find_first_not_of(" \t");
    if (start == std::string::npos || line[start] == '#') continue;
    std::istringstream fields(line);
    std::string timestamp, file;
    fields >> timestamp >> file;
    if (file.empty()) {
      frames.push_back({.path = list.string(),
                        .name = "line" + std::to_string(line_number),
                        .error = list.string() + ":" + std::to_string(line_number) +
                                 ": expected 'timestamp path', got '" + line + "'"});
      continue;
    }
    frames.push_back(
        {.path = (folder / file).string(), .name = timestamp, .error = {}, .tum = true});
  }
  if (frames.size() == first) fail("lists no depth images");
}

void add_directory_frames(const fs::path& dir, std::vector<FrameSource>& frames) {
  std::vector<fs::path> files;
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
    // A dangling link of a frame's name is a frame that fails, not one left out unseen.
    std::error_code error;
    const bool dangling = e.is_symlink(error) && !e.exists(error);
    if ((dangling || e.is_regular_file()) && is_frame_file(e.path())) files.push_back(e.path());
  }
  if (files.empty()) {
    // Reported with the other failures: one empty folder among the inputs stops nothing.
    frames.push_back(
        {.path = dir.string(),
         .name = dir.filename().empty() ? dir.parent_path().filename().string()
                                        : dir.filename().string(),
         .error = dir.string() +
                  ": no .pcd, .ply, .png, .range, .xyz, .xyzn, .xyzrgb or .pts files in the "
                  "directory"});
    return;
  }
  std::sort(files.begin(), files.end(), natural_less);
  for (const fs::path& f : files) {
    std::error_code error;
    std::string why;
    if (!fs::exists(f, error)) {
      why = f.string() + ": a symbolic link to '" + fs::read_symlink(f, error).string() +
            "', which does not exist";
    }
    frames.push_back({.path = f.string(), .name = f.stem().string(), .error = why});
  }
}

}  // namespace

bool natural_less(const fs::path& a, const fs::path& b) {
  const std::string x = a.filename().string(), y = b.filename().string();
  const auto digit = [](char c) { return c >= '0' && c <= '9'; };
  std::size_t i = 0, j = 0;
  while (i < x.size() && j < y.size()) {
    if (digit(x[i]) && digit(y[j])) {
      // Numbers by value: without leading zeros, the longer is larger, else by their digits.
      std::size_t ei = i, ej = j;
      while (ei < x.size() && digit(x[ei])) ++ei;
      while (ej < y.size() && digit(y[ej])) ++ej;
      std::size_t si = i, sj = j;
      while (si + 1 < ei && x[si] == '0') ++si;
      while (sj + 1 < ej && y[sj] == '0') ++sj;
      if (ei - si != ej - sj) return ei - si < ej - sj;
      if (const int c = x.compare(si, ei - si, y, sj, ej - sj); c != 0) return c < 0;
      i = ei;
      j = ej;
    } else {
      if (x[i] != y[j]) return x[i] < y[j];
      ++i;
      ++j;
    }
  }
  if (i < x.size() || j < y.size()) return j < y.size();  // a prefix first
  return x < y;
}

bool is_batch_input(const std::string& input) {
  return is_tum_list(input) || fs::is_directory(input);
}

FrameList gather_frames(const std::vector<std::string>& inputs, const InputOptions& base) {
  FrameList list;
  list.options = base;
  bool tum = false;
  for (const std::string& input : inputs) {
    const fs::path p = input;
    if (is_tum_list(p)) {
      add_tum_frames(p, list.frames);
      tum = true;
    } else if (fs::is_directory(p)) {
      if (fs::exists(p / "depth.txt")) {
        add_tum_frames(p / "depth.txt", list.frames);
        tum = true;
      } else {
        add_directory_frames(p, list.frames);
      }
    } else if (fs::exists(p)) {
      list.frames.push_back({.path = input, .name = p.stem().string(), .error = {}});
    } else {
      // Reported with the other failures instead of stopping the batch.
      list.frames.push_back({.path = input,
                             .name = p.stem().string(),
                             .error = input + ": no such file or directory"});
    }
  }
  // TUM documents one conversion for all its sequences (the depth images are registered to the
  // colour camera by the factory calibration): fx = fy = 525, cx = 319.5, cy = 239.5, which are
  // the defaults of InputOptions at 640x480, and 5000 depth units per metre.
  list.tum_options = base;
  list.tum_options.tum_sequence = true;
  if (tum && !base.depth_scale_given) list.tum_options.depth_scale = kTumDepthScale;
  if (tum) {
    note("a TUM RGB-D sequence: depth in units of %g m%s, %s", list.tum_options.depth_scale,
         base.depth_scale_given ? " (--depth-scale)" : " (TUM's 5000 per metre)",
         camera_options_given(base) ? "the camera given"
                                    : "the camera TUM documents (fx = fy = 525 px, cx "
                                      "319.5, cy 239.5 at 640 x 480)");
  }
  // Unique folder names in input order: the second "a" becomes "a_2".
  std::map<std::string, int> seen;
  for (FrameSource& f : list.frames) {
    if (f.name.empty() || f.name == "." || f.name == "..") f.name = "frame";
    int& count = seen[f.name];
    if (++count == 1) continue;
    std::string candidate = f.name + "_" + std::to_string(count);
    while (seen.contains(candidate)) candidate = f.name + "_" + std::to_string(++count);
    seen[candidate] = 1;
    f.name = candidate;
  }
  return list;
}

}  // namespace rangeseg::cli
