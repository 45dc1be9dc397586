#include <cstdio>
#include <memory>
#include <string>

#include "commands.hpp"
#include "names.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/io/settings_json.hpp"

namespace rangeseg::cli {
namespace {

struct SettingsOptions {
  std::string model = "plane";
  std::string preset = "kinect";
  std::string config;
  std::string out;
  bool no_smooth = false;
};

}  // namespace

void add_settings(CLI::App& app) {
  auto o = std::make_shared<SettingsOptions>();
  auto* cmd = app.add_subcommand(
      "settings",
      "Print every setting of a preset (with --model, --config, --no-smooth applied) as a "
      "--config file: units metres and radians, see the headers for each key");
  add_settings_options(*cmd, o->model, o->preset, o->config, o->no_smooth);
  cmd->add_option("-o,--output", o->out, "Write the JSON to this file instead of stdout");
  cmd->callback([o] {
    const PipelineSettings s = settings_from(o->preset, o->model, o->config, o->no_smooth);
    const std::string text = io::settings_to_json(s);
    if (o->out.empty()) {
      std::fputs(text.c_str(), stdout);
    } else {
      io::write_file_atomic(o->out, text);
    }
  });
}

}  // namespace rangeseg::cli
