// `rangeseg segment` over many frames: a directory, a list of files or a TUM RGB-D sequence,
// with one Pipeline per worker thread.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "input.hpp"
#include "rangeseg/pipeline.hpp"
#include "segment_output.hpp"

namespace rangeseg::cli {

/// The settings of a batch's frames.
struct BatchSettings {
  /// A preset name, or "auto": each frame's sensor preset (resolve_preset of the loaded input).
  std::string preset = "auto";
  /// The settings for a preset name (with the command's --model, --config, ...).
  std::function<PipelineSettings(const std::string& preset)> settings_for;
};

struct BatchOptions {
  std::string out_dir;  ///< one result folder per frame, named FrameSource::name
  FolderFiles files;    ///< the optional files of every folder
  int threads = 1;      ///< Pipelines running in parallel over the frames, >= 1
};

/// Segments every frame into `out_dir/<name>/`, skipping (and reporting on stderr) frames that
/// cannot be read or processed; shows progress on stderr, prints a summary on stdout and writes
/// it to `out_dir/summary.json` (with each frame's preset, whether it was organized and whether
/// an unorganized one ran on its restored pixel grid; the stage medians are over the frames that
/// ran the stage: `mesh` over those on a grid, `rings` over the others). Results do not depend
/// on `threads`.
/// Returns the number of frames that succeeded. Throws std::runtime_error only if `out_dir`
/// cannot be created or the summary cannot be written, and std::invalid_argument for invalid
/// settings (before any frame is read).
std::size_t segment_batch(const FrameList& frames, const BatchSettings& settings,
                          const BatchOptions& options);

/// A stage's name and time [ms].
struct StageTime {
  const char* name;
  double ms;
};

/// The stages a frame ran, with their times: for unorganized input "order" (StageTimes::input),
/// then mesh (a grid: organized, or the pixel grid restored) or rings (the k-nearest-neighbour
/// rings, StageTimes::mesh), normals, smoothing, segmentation, polygons, tracking (when the
/// frame's segments were tracked: StageTimes::tracking > 0) and total.
std::vector<StageTime> stage_times(const StageTimes& times, bool organized, bool rings);

/// Median of `values` (0 for none); the mean of the two middle values for an even count.
double median(std::vector<double> values);

}  // namespace rangeseg::cli
