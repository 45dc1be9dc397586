#include "rangeseg/io/settings_json.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "rangeseg/io/file.hpp"

namespace rangeseg::io {
namespace {

using nlohmann::json;

template <class T>
void take(const json& obj, const char* key, T& field, const std::string& where) {
  if (!obj.contains(key)) return;
  const json& value = obj.at(key);
  // json's own conversion truncates 2.5 to 2 and wraps integers that do not fit.
  if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
    bool fits = false;  // false for floats, strings, ...
    if (value.is_number_unsigned()) {
      fits =
          value.get<std::uint64_t>() <= static_cast<std::uint64_t>(std::numeric_limits<T>::max());
    } else if (value.is_number_integer()) {
      const auto v = value.get<std::int64_t>();
      fits = v >= static_cast<std::int64_t>(std::numeric_limits<T>::min()) &&
             v <= static_cast<std::int64_t>(std::numeric_limits<T>::max());
    }
    if (!fits) {
      throw std::runtime_error(where + ": key '" + key + "' must be an integer in [" +
                               std::to_string(std::numeric_limits<T>::min()) + ", " +
                               std::to_string(std::numeric_limits<T>::max()) + "], got " +
                               value.dump());
    }
  }
  try {
    field = value.get<T>();
  } catch (const json::exception& e) {
    throw std::runtime_error(where + ": key '" + key + "' has the wrong type: " + e.what());
  }
}

/// A key whose value is a name: `by_name` maps it, and throws std::invalid_argument naming the
/// valid names.
template <class T, class ByName>
void take_name(const json& obj, const char* key, T& field, ByName by_name,
               const std::string& where) {
  if (!obj.contains(key)) return;
  std::string name;
  take(obj, key, name, where);
  try {
    field = by_name(name);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(where + ": key '" + key + "': " + e.what());
  }
}

void reject_unknown(const json& obj, std::initializer_list<const char*> known,
                    const std::string& where) {
  if (!obj.is_object()) throw std::runtime_error(where + ": expected a JSON object");
  for (const auto& item : obj.items()) {
    bool ok = false;
    for (const char* k : known) ok = ok || item.key() == k;
    if (!ok) throw std::runtime_error(where + ": unknown key '" + item.key() + "'");
  }
}

void read_settings(const json& j, const std::string& path, PipelineSettings& s) {
  reject_unknown(
      j, {"noise", "mesh", "smoothing", "segmentation", "rings", "smooth", "restore_grid"}, path);
  take(j, "smooth", s.smooth, path);
  take(j, "restore_grid", s.restore_grid, path);
  if (j.contains("noise")) {
    const json& m = j["noise"];
    const std::string where = path + " [noise]";
    reject_unknown(m, {"a", "b", "z0"}, where);
    SensorNoise noise = s.segmentation.noise;
    take(m, "a", noise.a, where);
    take(m, "b", noise.b, where);
    take(m, "z0", noise.z0, where);
    set_noise(s, noise);
  }
  if (j.contains("mesh")) {
    const json& m = j["mesh"];
    const std::string where = path + " [mesh]";
    reject_unknown(m,
                   {"type", "eps_theta", "jump_sigmas", "max_edge_a", "max_edge_b", "max_edge_c",
                    "pixel_stride"},
                   where);
    take_name(m, "type", s.mesh.type, mesh_type_from_string, where);
    take(m, "eps_theta", s.mesh.eps_theta, where);
    take(m, "jump_sigmas", s.mesh.jump_sigmas, where);
    take(m, "max_edge_a", s.mesh.max_edge_a, where);
    take(m, "max_edge_b", s.mesh.max_edge_b, where);
    take(m, "max_edge_c", s.mesh.max_edge_c, where);
    take(m, "pixel_stride", s.mesh.pixel_stride, where);
  }
  if (j.contains("smoothing")) {
    const json& m = j["smoothing"];
    const std::string where = path + " [smoothing]";
    reject_unknown(m,
                   {"iterations", "use_distance", "distance_scale", "pixel_angle", "use_normals",
                    "normal_scale", "use_intensity", "intensity_scale", "intensity_range",
                    "move_along_ray", "recompute_normals"},
                   where);
    auto& t = s.smoothing;
    take(m, "iterations", t.iterations, where);
    // As `smooth --iterations N`: a count turns the filter on (N > 0) or off, also under a
    // preset without it (abw, ideal), unless "smooth" says otherwise.
    if (m.contains("iterations") && !j.contains("smooth")) s.smooth = t.iterations > 0;
    take(m, "use_distance", t.use_distance, where);
    take(m, "distance_scale", t.distance_scale, where);
    take(m, "pixel_angle", t.pixel_angle, where);
    take(m, "use_normals", t.use_normals, where);
    take(m, "normal_scale", t.normal_scale, where);
    take(m, "use_intensity", t.use_intensity, where);
    take(m, "intensity_scale", t.intensity_scale, where);
    take(m, "intensity_range", t.intensity_range, where);
    take(m, "move_along_ray", t.move_along_ray, where);
    take(m, "recompute_normals", t.recompute_normals, where);
  }
  if (j.contains("segmentation")) {
    const json& m = j["segmentation"];
    const std::string where = path + " [segmentation]";
    reject_unknown(m,
                   {"model",
                    "max_normal_angle",
                    "max_distance_sigmas",
                    "normal_noise_sigmas",
                    "min_normal_angle",
                    "max_smooth_angle",
                    "max_curvature",
                    "max_seed_curvature",
                    "seed_clearance",
                    "growth_bands",
                    "min_region_size",
                    "merge_planes",
                    "merge_angle",
                    "merge_distance_sigmas",
                    "merge_rms_sigmas",
                    "merge_rms_max_angle",
                    "split_residual_factor",
                    "boundary_refine_sigmas",
                    "grazing_min_angle",
                    "grazing_max_angle",
                    "reassign_boundary",
                    "reassign_max_normal_angle",
                    "reassign_across_mesh_cuts"},
                   where);
    auto& t = s.segmentation;
    take_name(m, "model", t.model, region_model_from_string, where);
    take(m, "max_normal_angle", t.max_normal_angle, where);
    take(m, "max_distance_sigmas", t.max_distance_sigmas, where);
    take(m, "normal_noise_sigmas", t.normal_noise_sigmas, where);
    take(m, "min_normal_angle", t.min_normal_angle, where);
    take(m, "max_smooth_angle", t.max_smooth_angle, where);
    take(m, "max_curvature", t.max_curvature, where);
    take(m, "max_seed_curvature", t.max_seed_curvature, where);
    take(m, "seed_clearance", t.seed_clearance, where);
    take(m, "growth_bands", t.growth_bands, where);
    take(m, "min_region_size", t.min_region_size, where);
    take(m, "merge_planes", t.merge_planes, where);
    take(m, "merge_angle", t.merge_angle, where);
    take(m, "merge_distance_sigmas", t.merge_distance_sigmas, where);
    take(m, "merge_rms_sigmas", t.merge_rms_sigmas, where);
    take(m, "merge_rms_max_angle", t.merge_rms_max_angle, where);
    take(m, "split_residual_factor", t.split_residual_factor, where);
    take(m, "boundary_refine_sigmas", t.boundary_refine_sigmas, where);
    take(m, "grazing_min_angle", t.grazing_min_angle, where);
    take(m, "grazing_max_angle", t.grazing_max_angle, where);
    take(m, "reassign_boundary", t.reassign_boundary, where);
    take(m, "reassign_max_normal_angle", t.reassign_max_normal_angle, where);
    take(m, "reassign_across_mesh_cuts", t.reassign_across_mesh_cuts, where);
  }
  if (j.contains("rings")) {
    const json& m = j["rings"];
    const std::string where = path + " [rings]";
    reject_unknown(m, {"k", "max_distance", "eps_theta", "jump_sigmas", "by_direction", "balanced"},
                   where);
    take(m, "k", s.rings.k, where);
    take(m, "max_distance", s.rings.max_distance, where);
    take(m, "eps_theta", s.rings.eps_theta, where);
    take(m, "jump_sigmas", s.rings.jump_sigmas, where);
    take(m, "by_direction", s.rings.by_direction, where);
    take(m, "balanced", s.rings.balanced, where);
  }
}

}  // namespace

void apply_settings_json(std::string_view text, const std::string& path,
                         PipelineSettings& settings) {
  json j;
  try {
    j = json::parse(text.begin(), text.end());
  } catch (const json::exception& e) {
    throw std::runtime_error(path + ": not valid JSON: " + e.what());
  }
  PipelineSettings s = settings;  // `settings` stays as it was when anything is wrong
  read_settings(j, path, s);
  try {
    validate(s);  // before any input is read
  } catch (const std::invalid_argument& e) {
    // The library names the field as its struct spells it (e.g. SmoothingSettings::noise_a for
    // noise.a): name the key of the file that the error is about, the one without which the
    // settings pass or, when another key is invalid too, the error changes.
    const auto error_without = [&](const std::string& section, const std::string& key) {
      json rest = j;
      rest[section].erase(key);
      PipelineSettings t = settings;
      read_settings(rest, path, t);
      try {
        validate(t);
      } catch (const std::invalid_argument& other) {
        return std::string(other.what());
      }
      return std::string();
    };
    for (const bool pass : {true, false}) {
      for (const auto& section : j.items()) {
        if (!section.value().is_object()) continue;
        for (const auto& item : section.value().items()) {
          const std::string other = error_without(section.key(), item.key());
          if (pass ? !other.empty() : other == e.what()) continue;
          throw std::runtime_error(path + " [" + section.key() + "]: key '" + item.key() +
                                   "' = " + item.value().dump() + " is invalid (" + e.what() + ")");
        }
      }
    }
    throw std::runtime_error(path + ": invalid settings (" + e.what() + ")");
  }
  settings = s;
}

void apply_settings_file(const std::string& path, PipelineSettings& settings) {
  const std::vector<std::uint8_t> bytes = read_file(path, 1 << 20);
  apply_settings_json(std::string(bytes.begin(), bytes.end()), path, settings);
}

}  // namespace rangeseg::io
