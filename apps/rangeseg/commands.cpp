#include "commands.hpp"

namespace rangeseg::cli {
namespace {
int g_exit_code = kExitOk;
}

int exit_code() { return g_exit_code; }
void set_exit_code(int code) { g_exit_code = code; }

void register_commands(CLI::App& app) {
  add_info(app);
  add_noise(app);
  add_convert(app);
  add_synth(app);
  add_mesh(app);
  add_demo(app);
  add_segment(app);
  add_smooth(app);
  add_eval(app);
  add_eval_segcomp(app);
  add_eval_synth(app);
  add_bench(app);
  add_settings(app);
}

}  // namespace rangeseg::cli
