// Loading any supported input file into an organized cloud, with the options every command shares.
#pragma once

#include <CLI/CLI.hpp>

#include <array>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "rangeseg/camera.hpp"
#include "rangeseg/cloud.hpp"
#include "rangeseg/image.hpp"
#include "rangeseg/sensor.hpp"

namespace rangeseg::cli {

struct InputOptions {
  std::string path;
  std::string intrinsics;  ///< camera file for depth PNGs (io::read_camera_file)
  double fx = 525, fy = 525, cx = 319.5, cy = 239.5;
  bool fx_given = false, fy_given = false, cx_given = false, cy_given = false;
  double depth_scale = 0.001;  ///< metres per raw depth unit
  bool depth_scale_given = false;
  /// A frame listed in a TUM sequence's depth.txt: the camera, unless one is given, and the
  /// depth scale are TUM's documented ones, so such a PNG gets no note about the default camera.
  bool tum_sequence = false;
  /// Move a PCD's points into the frame of the sensor its VIEWPOINT names (off by default:
  /// PCL's OpenNI grabber writes VIEWPOINT 0 0 0 0 1 0 0 for points in the camera's frame).
  bool apply_viewpoint = false;
};

struct LoadedInput {
  OrganizedCloud cloud;
  std::string format;  ///< e.g. "PCD binary_compressed"
  std::string fields;  ///< e.g. "x y z rgba"
  std::string units = "m";
  /// fx of the camera of a depth image [pixel] (for the smoothing's pixel angle), else 0
  double camera_fx = 0;
  CameraIntrinsics camera;  ///< a depth image's camera, else zeros
  /// Where a depth image's camera came from (a file's name, "--fx / --fy", "TUM's", or the
  /// default), else empty.
  std::string camera_source;
  LabelImage ground_truth;  ///< from a SegComp .gt-seg beside a .range, or a PCD label field
  /// The smallest label of `ground_truth` that is a region (a .gt-seg's 1 and 2 are unlabelled
  /// pixels: 10).
  int ground_truth_min_label = 1;
  /// The preset of the sensor when the file tells it (SegComp images: "abw" or "perceptron"),
  /// else empty.
  std::string sensor_preset;
  /// A PCD's VIEWPOINT or a PLY's PCL camera pose (tx ty tz qw qx qy qz) as the points are
  /// now: the file's, or the identity when InputOptions::apply_viewpoint moved them into that
  /// sensor's frame (and for other files) ...
  std::array<double, 7> pose{0, 0, 0, 1, 0, 0, 0};
  /// ... and the file's VIEWPOINT as text when it is not the identity, else empty.
  std::string viewpoint;
};

void add_input_options(CLI::App& cmd, InputOptions& opts, bool positional = true);

/// The focal lengths (fx, fy) [pixel] the options give a depth PNG: one given alone is both.
std::pair<double, double> focal_lengths(const InputOptions& opts);
/// Where a depth PNG's camera comes from: the camera file, the options, TUM's convention or the
/// default.
std::string camera_source(const InputOptions& opts);
LoadedInput load_input(const InputOptions& opts);

/// With --preset auto (`preset_option`), an organized cloud that no pinhole camera explains (a
/// scanner's grid) takes the kinect preset, whose depth noise a laser scanner's exceeds at short
/// range: a note, once per run, names --preset laser. Only the first organized point cloud of a
/// run is checked.
void note_auto_preset(const std::string& preset_option, const LoadedInput& in,
                      const std::string& path);

/// A warning on stderr, for the first cloud of a run only, when the noise model `noise` (the
/// preset's, or the --config's) cannot tell the cloud's surfaces apart (noise_scale_problem).
void check_noise_scale(const std::string& path, const OrganizedCloud& cloud,
                       const SensorNoise& noise);

/// Throws std::invalid_argument naming `path` and `extensions` unless `path` ends in one of them
/// (any case): `command` checks its outputs before any work, so that e.g. `-o x.ply` does not
/// get PCD bytes.
void require_output_extension(const std::string& path, const std::vector<std::string>& extensions,
                              const std::string& command);

/// Throws std::invalid_argument unless the `outputs` (empty ones skipped) are distinct files and
/// none of them is the input file `input` (none when empty) (by device and inode once they exist,
/// else by their absolute, normalised paths): a run never writes its result over its own input, nor
/// two of its results over each other. `command` names the command in the message.
void require_distinct_outputs(const std::string& input, const std::vector<std::string>& outputs,
                              const std::string& command);

/// For the commands that need a pixel grid (`what`, e.g. "a mesh"): an organized cloud stays as
/// it is; an unorganized one (height 1) whose points lie on a camera's pixel grid (a depth
/// camera's valid points, find_pixel_grid) is put on it, with a note on stderr naming the grid;
/// any other throws std::runtime_error naming `path`, with `instead` suggesting what works.
void require_grid(OrganizedCloud& cloud, const std::string& path, const std::string& what,
                  const std::string& instead);

/// One frame of a batch: the file to read and the name of its result folder.
struct FrameSource {
  std::string path;
  std::string name;   ///< file stem, or the TUM timestamp; unique within the batch
  std::string error;  ///< the file and why, when the frame is unreadable before loading
  bool tum = false;   ///< listed in a TUM sequence's depth.txt: loaded with FrameList::tum_options
};

/// The frames of a batch and the options to load them with.
struct FrameList {
  std::vector<FrameSource> frames;
  /// The options to load the frames with (`base`; `path` is unused) ...
  InputOptions options;
  /// ... and those of the frames of a TUM sequence: `base` with TUM's depth scale unless
  /// --depth-scale was given, and TUM's camera unless one was.
  InputOptions tum_options;
  const InputOptions& options_for(const FrameSource& frame) const {
    return frame.tum ? tum_options : options;
  }
};

/// Expands the positional inputs of a batch, in order: a file is one frame; a directory holding
/// `depth.txt` (or a path to a depth.txt) is a TUM RGB-D sequence: its frames in the order of
/// the lines "timestamp path" ('#' comments), named by the timestamp, depth PNGs at 5000 units
/// per metre unless --depth-scale is given, and the intrinsics TUM documents for all its
/// sequences (fx = fy = 525, cx = 319.5, cy = 239.5: the defaults) unless --intrinsics / --fx..
/// are given; any other directory contributes its .pcd, .ply, .png, .range and text cloud files
/// in natural order (`natural_less`: frame2 before frame10; not recursive). Missing files and
/// malformed depth.txt lines, a directory without frame files and a depth.txt that lists none
/// become frames with `error` set, so the batch reports them and goes on. Duplicate names get
/// "_2", "_3", ... in input order.
FrameList gather_frames(const std::vector<std::string>& inputs, const InputOptions& base);

/// True if the input is a directory or a TUM depth.txt, i.e. it needs batch processing.
bool is_batch_input(const std::string& input);

/// Orders file names as people number frames: runs of digits by their value ("frame2" before
/// "frame10", "abw.test.2" before "abw.test.10"), the rest by character; names equal so (e.g.
/// "f01" and "f1") by their text.
bool natural_less(const std::filesystem::path& a, const std::filesystem::path& b);

}  // namespace rangeseg::cli
