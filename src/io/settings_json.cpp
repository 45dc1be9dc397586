#include "rangeseg/io/settings_json.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "detail/json_parse.hpp"
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
    bool fits = false;  // false for strings, fractions, ...
    if (value.is_number_float()) {
      // 200.0 (as Python's json writes a float that holds an integer) is the integer 200.
      const double v = value.get<double>();
      if (v == std::floor(v) && v >= static_cast<double>(std::numeric_limits<T>::min()) &&
          v <= static_cast<double>(std::numeric_limits<T>::max())) {
        field = static_cast<T>(v);
        return;
      }
    } else if (value.is_number_unsigned()) {
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
  if constexpr (std::is_same_v<T, bool>) {
    if (!value.is_boolean()) {
      throw std::runtime_error(where + ": key '" + key + "' must be true or false, got " +
                               value.dump());
    }
  } else if constexpr (std::is_floating_point_v<T>) {
    if (!value.is_number()) {
      throw std::runtime_error(where + ": key '" + key + "' must be a number, got " + value.dump());
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

void reject_unknown(const json& obj, const std::vector<const char*>& known,
                    const std::string& where) {
  if (!obj.is_object()) throw std::runtime_error(where + ": expected a JSON object");
  for (const auto& item : obj.items()) {
    bool ok = false;
    for (const char* k : known) ok = ok || item.key() == k;
    if (!ok) throw std::runtime_error(where + ": unknown key '" + item.key() + "'");
  }
}

/// Calls visit(section, key, field) for every key of the settings JSON but the noise model's,
/// in the order they are written; section "" is the top level. The one list of keys, for
/// reading and writing.
template <class Visit>
void for_each_key(PipelineSettings& s, Visit&& visit) {
  visit("", "smooth", s.smooth);
  visit("", "restore_grid", s.restore_grid);
  visit("", "track", s.track);
  visit("", "polygons", s.polygons);
  auto& m = s.mesh;
  visit("mesh", "type", m.type);
  visit("mesh", "eps_theta", m.eps_theta);
  visit("mesh", "jump_sigmas", m.jump_sigmas);
  visit("mesh", "max_edge_a", m.max_edge_a);
  visit("mesh", "max_edge_b", m.max_edge_b);
  visit("mesh", "max_edge_c", m.max_edge_c);
  visit("mesh", "pixel_stride", m.pixel_stride);
  auto& f = s.smoothing;
  visit("smoothing", "iterations", f.iterations);
  visit("smoothing", "use_distance", f.use_distance);
  visit("smoothing", "distance_scale", f.distance_scale);
  visit("smoothing", "pixel_angle", f.pixel_angle);
  visit("smoothing", "use_normals", f.use_normals);
  visit("smoothing", "normal_scale", f.normal_scale);
  visit("smoothing", "use_intensity", f.use_intensity);
  visit("smoothing", "intensity_scale", f.intensity_scale);
  visit("smoothing", "intensity_range", f.intensity_range);
  visit("smoothing", "move_along_ray", f.move_along_ray);
  visit("smoothing", "recompute_normals", f.recompute_normals);
  auto& g = s.segmentation;
  visit("segmentation", "model", g.model);
  visit("segmentation", "max_normal_angle", g.max_normal_angle);
  visit("segmentation", "max_distance_sigmas", g.max_distance_sigmas);
  visit("segmentation", "normal_noise_sigmas", g.normal_noise_sigmas);
  visit("segmentation", "min_normal_angle", g.min_normal_angle);
  visit("segmentation", "max_smooth_angle", g.max_smooth_angle);
  visit("segmentation", "max_curvature", g.max_curvature);
  visit("segmentation", "max_seed_curvature", g.max_seed_curvature);
  visit("segmentation", "seed_clearance", g.seed_clearance);
  visit("segmentation", "growth_bands", g.growth_bands);
  visit("segmentation", "min_region_size", g.min_region_size);
  visit("segmentation", "min_region_fx", g.min_region_fx);
  visit("segmentation", "merge_planes", g.merge_planes);
  visit("segmentation", "merge_angle", g.merge_angle);
  visit("segmentation", "merge_distance_sigmas", g.merge_distance_sigmas);
  visit("segmentation", "merge_rms_sigmas", g.merge_rms_sigmas);
  visit("segmentation", "merge_rms_max_angle", g.merge_rms_max_angle);
  visit("segmentation", "split_residual_factor", g.split_residual_factor);
  visit("segmentation", "boundary_refine_sigmas", g.boundary_refine_sigmas);
  visit("segmentation", "grazing_min_angle", g.grazing_min_angle);
  visit("segmentation", "grazing_max_angle", g.grazing_max_angle);
  visit("segmentation", "reassign_boundary", g.reassign_boundary);
  visit("segmentation", "reassign_max_normal_angle", g.reassign_max_normal_angle);
  visit("segmentation", "reassign_across_mesh_cuts", g.reassign_across_mesh_cuts);
  auto& r = s.rings;
  visit("rings", "k", r.k);
  visit("rings", "max_distance", r.max_distance);
  visit("rings", "eps_theta", r.eps_theta);
  visit("rings", "jump_sigmas", r.jump_sigmas);
  visit("rings", "by_direction", r.by_direction);
  visit("rings", "balanced", r.balanced);
  auto& p = s.polygon;
  visit("polygon", "simplify_tolerance", p.simplify_tolerance);
  visit("polygon", "simplify_tolerance_pixels", p.simplify_tolerance_pixels);
  visit("polygon", "simplify_inradius_fraction", p.simplify_inradius_fraction);
  visit("polygon", "convex_hull", p.convex_hull);
  visit("polygon", "min_segment_pixels", p.min_segment_pixels);
  visit("polygon", "planes_only", p.planes_only);
  visit("polygon", "min_loop_pixels", p.min_loop_pixels);
  visit("tracking", "min_overlap", s.tracking.min_overlap);
  visit("tracking", "max_normal_angle", s.tracking.max_normal_angle);
  visit("tracking", "max_distance", s.tracking.max_distance);
}

constexpr std::array<const char*, 6> kSections{"mesh",  "smoothing", "segmentation",
                                               "rings", "polygon",   "tracking"};

void read_settings(const json& j, const std::string& path, PipelineSettings& s) {
  std::vector<const char*> top{"noise"};
  top.insert(top.end(), kSections.begin(), kSections.end());
  for_each_key(s, [&](const char* section, const char* key, auto&) {
    if (*section == 0) top.push_back(key);
  });
  reject_unknown(j, top, path);
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
  for (const char* section : kSections) {
    if (!j.contains(section)) continue;
    std::vector<const char*> known;
    for_each_key(s, [&](const char* in, const char* key, auto&) {
      if (std::strcmp(in, section) == 0) known.push_back(key);
    });
    reject_unknown(j[section], known, path + " [" + section + "]");
  }
  for_each_key(s, [&](const char* section, const char* key, auto& field) {
    const bool top_level = *section == 0;
    if (!top_level && !j.contains(section)) return;
    const json& obj = top_level ? j : j[section];
    const std::string where = top_level ? path : path + " [" + section + "]";
    using T = std::remove_reference_t<decltype(field)>;
    if constexpr (std::is_same_v<T, MeshType>) {
      take_name(obj, key, field, mesh_type_from_string, where);
    } else if constexpr (std::is_same_v<T, RegionModel>) {
      take_name(obj, key, field, region_model_from_string, where);
    } else {
      take(obj, key, field, where);
    }
  });
  // As `smooth --iterations N`: a count turns the filter on (N > 0) or off, also under a
  // preset without it (abw, ideal), unless "smooth" says otherwise.
  if (j.contains("smoothing") && j["smoothing"].contains("iterations") && !j.contains("smooth")) {
    s.smooth = s.smoothing.iterations > 0;
  }
}

/// A float setting as the decimal it was written as (0.2182f, not 0.21819999814033508).
double decimal(float value) {
  std::array<char, 32> text{};
  const auto end = std::to_chars(text.data(), text.data() + text.size(), value).ptr;
  return std::strtod(std::string(text.data(), end).c_str(), nullptr);
}

}  // namespace

void apply_settings_json(std::string_view text, const std::string& path,
                         PipelineSettings& settings) {
  json j;
  try {
    j = detail::parse_json_keys_once(text);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": " + e.what());
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

std::string settings_to_json(const PipelineSettings& settings) {
  nlohmann::ordered_json j;
  PipelineSettings s = settings;  // for_each_key takes mutable fields
  const SensorNoise& noise = s.segmentation.noise;
  j["noise"] = {{"a", noise.a}, {"b", noise.b}, {"z0", noise.z0}};
  for_each_key(s, [&](const char* section, const char* key, auto& field) {
    nlohmann::ordered_json& obj = *section == 0 ? j : j[section];
    using T = std::remove_reference_t<decltype(field)>;
    if constexpr (std::is_same_v<T, MeshType> || std::is_same_v<T, RegionModel>) {
      obj[key] = to_string(field);
    } else if constexpr (std::is_same_v<T, float>) {
      obj[key] = decimal(field);
    } else {
      obj[key] = field;
    }
  });
  return j.dump(2) + "\n";
}

}  // namespace rangeseg::io
