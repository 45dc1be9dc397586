// Running the rangeseg command-line tool from tests (RANGESEG_CLI is its path), and reading the
// normals of the PCD files it writes.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "rangeseg/camera.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/synth.hpp"

namespace rangeseg::test {

struct CliResult {
  int code = -1;
  std::string out;  ///< stdout and stderr together
};

/// Whether `text` contains `part` (a CLI's output, a message).
inline bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

/// Runs a shell command line (with its own redirections) and returns its exit code (-1 for a
/// signal) and what it printed on stdout.
inline CliResult run_shell(const std::string& command) {
  CliResult r;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return r;
  char buffer[4096];
  while (const std::size_t n = fread(buffer, 1, sizeof buffer, pipe)) r.out.append(buffer, n);
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

/// Runs `rangeseg ARGS` through the shell and returns its exit code and output.
inline CliResult run_cli(const std::string& args) {
  std::string command = RANGESEG_CLI;
  command.append(" ").append(args).append(" 2>&1");
  return run_shell(command);
}

inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline nlohmann::json read_json(const std::filesystem::path& p) {
  return nlohmann::json::parse(read_text(p));
}

/// A small noisy synthetic frame (160x120, Kinect optics scaled down) so batch tests stay fast.
inline OrganizedCloud small_frame(std::uint64_t seed) {
  const CameraIntrinsics camera{
      .fx = 131.25, .fy = 131.25, .cx = 79.5, .cy = 59.5, .width = 160, .height = 120};
  return synth::render(synth::random_scene(seed, false),
                       {.camera = camera, .noise = synth::Noise::kinect, .seed = seed})
      .cloud;
}

inline void write_small_pcd(const std::filesystem::path& path, std::uint64_t seed) {
  std::filesystem::create_directories(path.parent_path());
  io::write_pcd(path.string(), small_frame(seed), {.encoding = io::PcdEncoding::binary_compressed});
}

/// The normals of a PCD written with normal_x normal_y normal_z curvature, read with the library's
/// reader (which keeps only x y z, intensity, rgb and label): the header's field names are
/// renamed so that the normals are read as x y z and the curvature as intensity. The data
/// (any encoding) is unchanged.
inline OrganizedCloud read_normals(const std::filesystem::path& pcd) {
  std::ifstream in(pcd, std::ios::binary);
  std::stringstream whole;
  whole << in.rdbuf();
  std::string text = whole.str();
  const std::size_t begin = text.find("\nFIELDS ") + 1;
  const std::size_t end = text.find('\n', begin);
  std::istringstream fields(text.substr(begin, end - begin));
  const std::map<std::string, std::string> renamed = {{"x", "px"},
                                                      {"y", "py"},
                                                      {"z", "pz"},
                                                      {"normal_x", "x"},
                                                      {"normal_y", "y"},
                                                      {"normal_z", "z"},
                                                      {"curvature", "intensity"},
                                                      {"intensity", "i"}};
  std::string line, name;
  fields >> name;  // FIELDS
  line = name;
  while (fields >> name) line += " " + (renamed.contains(name) ? renamed.at(name) : name);
  text.replace(begin, end - begin, line);
  const auto* data = reinterpret_cast<const std::uint8_t*>(text.data());
  return io::parse_pcd(data, text.size(), pcd.string());
}

/// Expects a cloud of `points` points (organized or not) in `pcd`, with unit normals at more than
/// nine in ten of the `valid` points that have one and at no other.
inline void expect_unit_normals(const std::filesystem::path& pcd, std::size_t points,
                                std::size_t valid) {
  const OrganizedCloud normals = read_normals(pcd);
  ASSERT_EQ(normals.size(), points);
  std::size_t finite = 0, off = 0;
  for (int v = 0; v < normals.height(); ++v) {
    for (int u = 0; u < normals.width(); ++u) {
      if (!normals.valid(u, v)) continue;
      ++finite;
      const float nx = normals.x(u, v), ny = normals.y(u, v), nz = normals.z(u, v);
      if (std::abs(std::sqrt(nx * nx + ny * ny + nz * nz) - 1.0f) > 1e-4f) ++off;
    }
  }
  EXPECT_GT(finite, valid * 9 / 10) << "points with a normal";
  EXPECT_LE(finite, valid) << "normals where there is no point";
  EXPECT_EQ(off, 0u) << "normals not of unit length";
}

}  // namespace rangeseg::test
