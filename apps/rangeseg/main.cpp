// rangeseg: command-line front end. Every subcommand lives in its own file (cmd_*.cpp).
#include <CLI/CLI.hpp>

#include <csignal>
#include <cstdio>
#include <exception>

#include "commands.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/version.hpp"

namespace {

// An interrupted run (Ctrl-C, a kill from a launcher or systemd) leaves no temporary file: they
// are removed, then the signal ends the process as it would have.
extern "C" void remove_temporaries_and_exit(int signal) {
  rangeseg::io::remove_temporary_files();
  std::signal(signal, SIG_DFL);
  std::raise(signal);
}

}  // namespace

int main(int argc, char** argv) {
  for (const int signal : {SIGINT, SIGTERM, SIGHUP}) {
    std::signal(signal, remove_temporaries_and_exit);
  }
  try {
    CLI::App app{"rangeseg: fast range image meshing, smoothing and segmentation"};
    app.require_subcommand(1);
    app.set_version_flag("--version", "rangeseg " RANGESEG_VERSION_STRING);
    rangeseg::cli::register_commands(app);
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      const int rc = app.exit(e);
      return rc == 0 ? 0 : rangeseg::cli::kExitUsage;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rangeseg: error: %s\n", e.what());
    return rangeseg::cli::kExitInput;
  }
  return rangeseg::cli::exit_code();
}
