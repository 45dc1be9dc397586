// Writing a segmentation result folder (labels.png, segments.json, overlay.png, mesh.ply,
// cloud.pcd; for an unorganized cloud segments.json and cloud.pcd).
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "rangeseg/colorize.hpp"
#include "rangeseg/pipeline.hpp"

namespace rangeseg::cli {

/// segments.json: every segment, with its polygons when `polygons` is given, and a plane's
/// coplanar group (coplanar_groups under `settings`).
nlohmann::json segments_json(const Segmentation& segmentation, const PolygonSet* polygons,
                             const SegmentationSettings& settings);

/// The segments coloured by surface type (planes grey, cylinders blue, spheres red, smooth
/// green): `shaded` = colorize_labels(segmentation.labels, &input), recoloured with its shading.
/// Throws std::invalid_argument if its size is not the labels'.
RgbImage colorize_surface_types(const Segmentation& segmentation, RgbImage shaded);

/// The files a run reads, by device and inode (hard links and other spellings of a path
/// included): a result folder's clean-up never removes one.
class InputFiles {
 public:
  /// Paths that do not exist (yet) are left out.
  explicit InputFiles(const std::vector<std::string>& paths);
  bool contains(const std::filesystem::path& path) const;

 private:
  std::vector<std::pair<std::uint64_t, std::uint64_t>> ids_;  ///< sorted (device, inode)
};

/// The optional files of a result folder.
struct FolderFiles {
  bool mesh = true;    ///< mesh.ply (an organized frame)
  bool cloud = false;  ///< cloud.pcd of an organized frame (an unorganized one always has it)
  /// The input's sensor pose (LoadedInput::pose), cloud.pcd's VIEWPOINT: its points are the
  /// input's, in the same frame.
  std::array<double, 7> pose{0, 0, 0, 1, 0, 0, 0};
  const InputFiles* inputs = nullptr;  ///< never removed as an earlier run's files
};

/// Writes the results of the pipeline's last frame into `dir` (each file atomically) and returns
/// their paths, joined by ", ". cloud.pcd: the processed points (Pipeline::cloud(); organized
/// as the input, NaN where there is no point) with their normals, curvature, label and rgb, the
/// label's colour (label 0: dark grey; no point: black). An organized frame: labels.png,
/// segments.json, polygons.obj, overlay.png with the polygons drawn, types.png and, as `files`
/// says, mesh.ply and cloud.pcd; `input` is the cloud the pipeline processed (for the overlay's
/// shading). An unorganized frame (nothing to draw): segments.json, polygons.obj and cloud.pcd.
/// Those of these files that this call does not write (left by an earlier run into `dir`) are
/// removed, so that the folder holds one frame's results only.
std::string write_segmentation_folder(const std::string& dir, const OrganizedCloud& input,
                                      const Pipeline& pipeline, FolderFiles files);

/// A warning on stderr, once per run, when the pipeline's frame from `path` gave no segment
/// for a reason of its input (Pipeline::why_no_segments), and, where one helps, what to change.
void warn_if_no_segments(const Pipeline& pipeline, const std::string& path);

/// Removes the result files (those of write_segmentation_folder, and a batch's summary.json)
/// in `dir` that are not among the paths in `written`: a folder written again (a re-run, a
/// batch into a single frame's folder or the other way round) keeps no result of an earlier run
/// beside this one's. Only files that rangeseg wrote (written_by_rangeseg) and that are not
/// among `inputs` go; other files and folders stay (a file of a result's name that rangeseg did
/// not write gets a warning).
void remove_earlier_results(const std::filesystem::path& dir,
                            const std::vector<std::string>& written,
                            const InputFiles* inputs = nullptr);

/// One file of remove_earlier_results: removed if rangeseg wrote it and it is not among
/// `inputs`; kept with a warning if rangeseg did not write it.
void remove_earlier_result(const std::filesystem::path& path, const InputFiles* inputs);

/// Whether the file at `path` names rangeseg as its writer: PNG (a Software text chunk), PLY,
/// OBJ and PCD (a header comment), a batch's summary.json (its keys).
bool written_by_rangeseg(const std::filesystem::path& path);

}  // namespace rangeseg::cli
