// Shared by the comparison tools (rangeseg_pcl_segment, rangeseg_open3d_segment): their input
// and their exit codes, as the rangeseg CLI has them (2 for bad input or options).
#pragma once

#include <CLI/CLI.hpp>

#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iostream>
#include <stdexcept>
#include <string>

#include "rangeseg/cloud.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/rasterfile.hpp"

namespace rangeseg::compare {

/// An organized cloud from a .pcd or an ABW .range (in metres).
inline OrganizedCloud read_organized(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  OrganizedCloud cloud;
  if (ext == ".range") {
    cloud = io::read_abw_range(path);
  } else if (ext == ".pcd") {
    cloud = io::read_pcd(path);
  } else {
    throw std::invalid_argument(path + ": unknown input type '" + ext + "' (.pcd or ABW .range)");
  }
  if (!cloud.is_organized()) throw std::invalid_argument(path + ": not an organized cloud");
  return cloud;
}

/// CLI11 check for a number > 0 (CLI::PositiveNumber's message names the largest double).
inline CLI::Validator positive() {
  return {[](std::string& text) -> std::string {
            char* end = nullptr;
            const double value = std::strtod(text.c_str(), &end);
            const bool ok = end != text.c_str() && *end == '\0' && value > 0;
            return ok ? std::string{} : text + " is not a number > 0";
          },
          "> 0"};
}

/// Builds the command line (`options(app)`), parses it, then runs `work()`: 0 when it returns
/// (or for --help), 2 for a bad option or any exception, whose message is printed after the
/// tool's name.
template <class Options, class Work>
int run_tool(const char* tool, const char* description, int argc, char** argv, Options&& options,
             Work&& work) noexcept {
  try {
    CLI::App app{description};
    options(app);
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      return app.exit(e) == 0 ? 0 : 2;
    }
    work();
    return 0;
  } catch (const std::exception& e) {
    std::cerr << tool << ": " << e.what() << "\n";
  } catch (...) {
    std::cerr << tool << ": unexpected error\n";
  }
  return 2;
}

}  // namespace rangeseg::compare
