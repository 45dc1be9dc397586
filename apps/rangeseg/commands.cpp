#include "commands.hpp"

namespace rangeseg::cli {
namespace {
int g_exit_code = kExitOk;
}

int exit_code() { return g_exit_code; }
void set_exit_code(int code) { g_exit_code = code; }

void register_commands(CLI::App& app) {
  add_info(app);
}

}  // namespace rangeseg::cli
