// Writing results: output folders, PLY meshes from the implicit mesh, JSON.
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <mutex>
#include <string>

#include "rangeseg/colorize.hpp"
#include "rangeseg/mesh.hpp"
#include "rangeseg/normals.hpp"

namespace rangeseg::cli {

/// Creates `dir` (and parents); throws std::runtime_error naming it on failure.
std::filesystem::path ensure_dir(const std::string& dir);

/// ensure_dir, and throws std::runtime_error naming it unless this process may write into it
/// (a read-only file system, no permission): found before any input is read, not after all.
std::filesystem::path ensure_writable_dir(const std::string& dir);

/// Writes the mesh as a binary PLY with vertex normals (if given) and colours from `colours`
/// (same size as the cloud, may be empty); unused vertices are removed.
void write_mesh_ply(const std::string& path, const OrganizedCloud& cloud, const Mesh& mesh,
                    const NormalMap* normals, const RgbImage* colours);

/// Writes `cloud` (its own fields: x y z, [intensity], [rgb], [label]) with the normals as
/// normal_x normal_y normal_z curvature, binary_compressed, atomically (io::write_pcd), with the
/// sensor pose `pose` (tx ty tz qw qx qy qz) as VIEWPOINT.
void write_pcd_with_normals(const std::string& path, const OrganizedCloud& cloud,
                            const NormalMap& normals, const std::array<double, 7>& pose);

/// JSON text (`indent` as nlohmann::json::dump: -1 compact). A string that is not UTF-8 (a
/// file name in Latin-1) gets U+FFFD for its invalid bytes instead of failing the output.
std::string json_text(const nlohmann::json& value, int indent = -1);

/// Pretty-printed JSON (json_text), written atomically.
void write_json(const std::string& path, const nlohmann::json& value);

/// Removes the temporaries a killed run (SIGKILL, a power cut: no handler ran) left in `dir`:
/// files NAME.tmp.PID of a process PID that no longer runs, for the NAMEs `is_output` accepts.
/// Each removal is noted on stderr.
void remove_stale_temporaries(const std::filesystem::path& dir,
                              const std::function<bool(const std::string&)>& is_output);

/// The same for the one output file `path` (its folder's `NAME.tmp.PID` of that name).
void remove_stale_temporaries(const std::string& path);

/// Sets aside memory that a failing allocation frees (a block of it) before std::bad_alloc is
/// thrown (a std::new_handler), so that unwinding and the error report have memory: some
/// destructors allocate (nlohmann::json's), and an exception there would end the process. Call
/// once at start and again after an out-of-memory error was handled (a batch's frame); returns
/// whether all of the reserve could be set aside (if not, memory is still short).
bool reserve_memory_for_errors();

/// Prints a progress line on stderr ("rangeseg: <what>").
void progress(const std::string& what);

/// Warns (`note`) when `threads` exceed `usable_cores()`.
void warn_if_more_threads_than_cores(int threads);

/// Prints "rangeseg: " and the printf-formatted line on stderr; while a progress bar is drawn
/// on the terminal, above it. Thread-safe.
[[gnu::format(printf, 1, 2)]] void note(const char* format, ...);

/// Progress of `total` items on stderr: a bar redrawn in place on a terminal, otherwise a line at
/// every tenth of the items (logs stay short). Thread-safe.
class ProgressBar {
 public:
  explicit ProgressBar(std::size_t total);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  /// One more item is done; `item` names it on the bar.
  void advance(const std::string& item);
  /// Prints a whole line (e.g. a failure) without breaking the bar.
  void message(const std::string& line);
  /// Ends the bar with a newline (also done by the destructor).
  void finish();

 private:
  void draw(const std::string& item);  // caller holds mutex_

  std::mutex mutex_;
  std::string last_item_;
  std::size_t total_, done_ = 0, last_line_ = 0;
  bool terminal_, drawn_ = false, finished_ = false;
};

}  // namespace rangeseg::cli
