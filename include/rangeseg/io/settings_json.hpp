// Pipeline settings from JSON: the command line's --config files and the Python module's
// `config` dictionaries.
#pragma once

#include <string>
#include <string_view>

#include "rangeseg/pipeline.hpp"

namespace rangeseg::io {

/// Applies a JSON object on top of `settings`. Every key is optional:
///   {"smooth": bool, "restore_grid": bool, "track": bool,
///    "noise": {"a", "b", "z0"} (SensorNoise, set in every stage: set_noise),
///    "mesh": {"type": "adaptive"|"quad"|"left"|"right", "eps_theta", "jump_sigmas",
///             "max_edge_a", "max_edge_b", "max_edge_c", "pixel_stride"},
///    "smoothing": {SmoothingSettings' fields by name but noise (top-level "noise") and
///                  viewpoint; "iterations" also turns the filter on (> 0) or off (0) unless
///                  "smooth" is given},
///    "segmentation": {SegmentationSettings' fields by name but noise, coarse_cells and
///                     compute_area; "model": "plane"|"smooth"|"incremental_plane"|"auto"},
///    "rings": {"k", "max_distance", "eps_theta", "jump_sigmas", "by_direction", "balanced"},
///    "polygons": bool (outline plane segments),
///    "polygon": {PolygonSettings' fields by name but viewpoint: "simplify_tolerance",
///                "simplify_tolerance_pixels", "simplify_inradius_fraction", "convex_hull",
///                "min_segment_pixels", "planes_only", "min_loop_pixels"},
///    "tracking": {"min_overlap", "max_normal_angle", "max_distance"}}
/// (`rangeseg settings` prints every key),
/// with the units of the settings structs (metres, radians). Throws std::runtime_error naming
/// `source` (a file name, or what the text came from) and the key for text that is not JSON,
/// unknown keys, values of the wrong type or out of an integer's range, and values the library
/// rejects (`validate(PipelineSettings)`); `settings` is then left unchanged.
void apply_settings_json(std::string_view text, const std::string& source,
                         PipelineSettings& settings);

/// The same for a file of at most 1 MiB; errors name the file.
void apply_settings_file(const std::string& path, PipelineSettings& settings);

/// Every key that apply_settings_json reads, with the values of `settings` (the noise model:
/// the segmentation's), as indented JSON text: applied to any settings, it gives these back.
/// For showing a preset's values and for writing a config file to edit.
std::string settings_to_json(const PipelineSettings& settings);

}  // namespace rangeseg::io
