// rangeseg: command-line front end. Every subcommand lives in its own file (cmd_*.cpp).
#include <CLI/CLI.hpp>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <new>
#include <string>
#include <system_error>

#include "commands.hpp"
#include "output.hpp"
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

// CLI11 reads every argument that starts with '-' as an option, so a file of such a name gave
// "input is required" or "not expected" alone.
void note_files_taken_for_options(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--") break;
    std::error_code ec;
    if (arg.size() > 1 && arg[0] == '-' && std::filesystem::exists(arg, ec)) {
      std::fprintf(stderr, "rangeseg: note: '%s' is a file, read as an option here; name it ./%s\n",
                   arg.c_str(), arg.c_str());
    }
  }
}

int run(int argc, char** argv) {
  try {
    CLI::App app{"rangeseg: fast range image meshing, smoothing and segmentation"};
    app.require_subcommand(1);
    // Usage errors as every other error (subcommands take this from their parent when added).
    app.failure_message([](const CLI::App* from, const CLI::Error& e) {
      return "rangeseg: error: " + CLI::FailureMessage::simple(from, e);
    });
    app.set_version_flag("--version", "rangeseg " RANGESEG_VERSION_STRING);
    rangeseg::cli::register_commands(app);
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      const int rc = app.exit(e);
      if (rc != 0) note_files_taken_for_options(argc, argv);
      return rc == 0 ? 0 : rangeseg::cli::kExitUsage;
    }
  } catch (const std::bad_alloc&) {
    std::fputs("rangeseg: error: out of memory\n", stderr);
    return rangeseg::cli::kExitInput;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rangeseg: error: %s\n", e.what());
    return rangeseg::cli::kExitInput;
  }
  return rangeseg::cli::exit_code();
}

}  // namespace

int main(int argc, char** argv) {
  for (const int signal : {SIGINT, SIGTERM, SIGHUP}) {
    std::signal(signal, remove_temporaries_and_exit);
  }
  // A file size limit (ulimit -f) then fails the write (EFBIG), an error that names the file,
  // instead of ending the process with a core dump and its temporaries.
  std::signal(SIGXFSZ, SIG_IGN);
  rangeseg::cli::reserve_memory_for_errors();
  const int rc = run(argc, argv);
  // What a command printed on stdout (JSON, tables) is its result: a redirection to a full disk
  // must not end in success with a truncated file.
  if (std::fflush(stdout) != 0 || std::ferror(stdout) != 0) {
    std::fprintf(stderr, "rangeseg: error: cannot write standard output (%s)\n",
                 std::strerror(errno));
    return rc == 0 ? rangeseg::cli::kExitInput : rc;
  }
  return rc;
}
