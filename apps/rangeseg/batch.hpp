// `rangeseg segment` over many frames: a directory, a list of files or a TUM RGB-D sequence,
// with one Pipeline per worker thread.
#pragma once

#include <string>

#include "input.hpp"
#include "rangeseg/pipeline.hpp"

namespace rangeseg::cli {

struct BatchOptions {
  std::string out_dir;     ///< one result folder per frame, named FrameSource::name
  bool write_mesh = true;  ///< mesh.ply in every folder
  int threads = 1;         ///< Pipelines running in parallel over the frames, >= 1
};

/// Segments every frame into `out_dir/<name>/`, skipping (and reporting on stderr) frames that
/// cannot be read or processed; shows progress on stderr, prints a summary on stdout and writes
/// it to `out_dir/summary.json`. Results do not depend on `threads`. Returns the number of frames
/// that succeeded. Throws std::runtime_error only if `out_dir` cannot be created or the summary
/// cannot be written.
std::size_t segment_batch(const FrameList& frames, const PipelineSettings& settings,
                          const BatchOptions& options);

/// Median of `values` (0 for none); the mean of the two middle values for an even count.
double median(std::vector<double> values);

}  // namespace rangeseg::cli
