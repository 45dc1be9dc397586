// Writing results: output folders, PLY meshes from the implicit mesh, JSON.
#pragma once

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

#include "rangeseg/colorize.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"

namespace rangeseg::cli {

/// Creates `dir` (and parents); throws std::runtime_error naming it on failure.
std::filesystem::path ensure_dir(const std::string& dir);

/// Writes the mesh as a binary PLY with vertex normals (if given) and colours from `colours`
/// (same size as the cloud, may be empty); unused vertices are removed.
void write_mesh_ply(const std::string& path, const OrganizedCloud& cloud, const Mesh& mesh,
                    const NormalMap* normals, const RgbImage* colours);

/// Pretty-printed JSON, written atomically.
void write_json(const std::string& path, const nlohmann::json& value);

/// Prints a progress line on stderr ("rangeseg: <what>").
void progress(const std::string& what);

}  // namespace rangeseg::cli
