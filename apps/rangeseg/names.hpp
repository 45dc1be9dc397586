// Parsing of names given on the command line, shared by several commands.
#pragma once

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>

#include "rangeseg/mesh.hpp"
#include "rangeseg/pipeline.hpp"
#include "rangeseg/synth.hpp"

namespace rangeseg::cli {

/// "demo" (the scene of `rangeseg demo`: synth::demo_scene() with a can lying on the floor),
/// "boxes" or "mixed" (synth::random_scene); throws std::invalid_argument naming them otherwise.
synth::Scene scene_by_name(const std::string& name, std::uint64_t seed);
/// Render settings of `--noise` (none, kinect, constant:SIGMA) and `--camera` (kinect,
/// perceptron); throws std::invalid_argument naming a bad value.
synth::RenderSettings sensor_by_name(const std::string& noise, const std::string& camera);
/// Registers --noise and --camera (the arguments of sensor_by_name).
void add_sensor_options(CLI::App& cmd, std::string& noise, std::string& camera);
nlohmann::json surfaces_json(const synth::Rendering& rendering);

}  // namespace rangeseg::cli

namespace rangeseg::cli {
/// Registers --model, --preset, --config and --no-smooth (the arguments of settings_from);
/// `auto_preset`: the command resolves --preset auto per input (resolve_preset).
void add_settings_options(CLI::App& cmd, std::string& model, std::string& preset,
                          std::string& config, bool& no_smooth, bool auto_preset = false);
/// Settings from --preset, --model, --config and --no-smooth.
PipelineSettings settings_from(const std::string& preset, const std::string& model,
                               const std::string& config, bool no_smooth);
/// --preset auto: the preset of the input's sensor where the file tells it (SegComp ABW and
/// Perceptron images: abw, perceptron), else kinect. Any other name is returned unchanged.
std::string resolve_preset(const std::string& preset, const std::string& sensor_preset);
/// Throws std::invalid_argument naming `path` when `cloud` is unorganized (height 1) and
/// `settings` segment it with a model the k-nearest-neighbour rings do not have (only plane and
/// smooth: Pipeline::process).
void require_model_for(const OrganizedCloud& cloud, const PipelineSettings& settings,
                       const std::string& path);
/// Help text of a --preset option that takes auto.
extern const char* const kAutoPresetHelp;
}  // namespace rangeseg::cli
