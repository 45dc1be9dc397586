// Registration of the CLI subcommands; each one is defined in its own cmd_*.cpp.
#pragma once

#include <CLI/CLI.hpp>

namespace rangeseg::cli {

constexpr int kExitOk = 0;
constexpr int kExitInput = 2;  ///< bad input file or failed operation
constexpr int kExitUsage = 2;  ///< bad command line

void register_commands(CLI::App& app);
/// Exit code set by the command that ran (kExitOk unless it reported a failure).
int exit_code();
void set_exit_code(int code);

void add_info(CLI::App& app);
void add_noise(CLI::App& app);
void add_convert(CLI::App& app);
void add_synth(CLI::App& app);
void add_mesh(CLI::App& app);
void add_demo(CLI::App& app);
void add_segment(CLI::App& app);
void add_bench(CLI::App& app);
void add_smooth(CLI::App& app);
void add_eval(CLI::App& app);
void add_eval_segcomp(CLI::App& app);
void add_eval_synth(CLI::App& app);
void add_settings(CLI::App& app);

}  // namespace rangeseg::cli
