// Writing a segmentation result folder (labels.png, segments.json, overlay.png, mesh.ply; for an
// unorganized cloud segments.json and cloud.pcd).
#pragma once

#include <nlohmann/json.hpp>

#include <string>

#include "rangeseg/colorize.hpp"
#include "rangeseg/pipeline.hpp"

namespace rangeseg::cli {

/// segments.json: every segment, with its polygons when `polygons` is given.
nlohmann::json segments_json(const Segmentation& segmentation, const PolygonSet* polygons);

/// The segments coloured by surface type (planes grey, cylinders blue, spheres red, smooth
/// green): `shaded` = colorize_labels(segmentation.labels, &input), recoloured with its shading.
/// Throws std::invalid_argument if its size is not the labels'.
RgbImage colorize_surface_types(const Segmentation& segmentation, RgbImage shaded);

/// Writes the results of the pipeline's last frame into `dir` (each file atomically) and returns
/// their paths, joined by ", ". An organized frame: labels.png, segments.json, polygons.obj,
/// overlay.png with the polygons drawn, types.png and optionally mesh.ply; `input` is the cloud
/// the pipeline processed (for the overlay's shading). An unorganized frame (nothing to draw):
/// segments.json, polygons.obj and cloud.pcd, the processed points (Pipeline::cloud())
/// with their normals, curvature, label and rgb, the label's colour (label 0: dark grey; no
/// point: black).
std::string write_segmentation_folder(const std::string& dir, const OrganizedCloud& input,
                                      const Pipeline& pipeline, bool write_mesh);

}  // namespace rangeseg::cli
