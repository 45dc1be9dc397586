// Whole-file reading and atomic writing, shared by every format.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace rangeseg::io {

/// Reads a whole file. Throws std::runtime_error naming the file if it cannot be opened or read,
/// or if it is larger than `max_bytes`.
std::vector<std::uint8_t> read_file(const std::string& path,
                                    std::uint64_t max_bytes = std::uint64_t{1} << 32);

/// A file written in pieces under a temporary name beside `path` and renamed over `path` by
/// `commit()`, so a reader never sees a half-written file; destroyed without a commit (e.g. by an
/// exception while encoding), it removes the temporary. Errors throw std::runtime_error naming
/// the file. For outputs too large to encode in memory first.
class AtomicFile {
 public:
  explicit AtomicFile(std::string path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void write(const void* bytes, std::size_t size);
  /// Closes the temporary and renames it to `path`; within a FileGroup, the group renames it.
  void commit();

 private:
  std::string path_, tmp_;
  std::FILE* file_ = nullptr;
  int slot_ = -1;  ///< its entry in the table remove_temporary_files() reads, or -1
};

/// Makes the files that this thread writes while it lives (by AtomicFile, write_file_atomic and
/// every writer built on them) one unit: each is written to its temporary as usual, but the
/// temporaries are renamed over their paths only by `commit()`, after all of them are complete.
/// Destroyed without a commit (an exception while one of them was written), it removes the
/// temporaries, so the files at those paths keep their earlier contents: outputs that belong
/// together (a frame's labels and its segments.json) are never left half of one run, half of
/// another. `commit()` checks first that no path is a folder; a rename that fails after that
/// (rare: the data is written by then) throws, and the files renamed before it stay. Groups nest:
/// an inner group's files are renamed by the outermost group's commit, and dropped if the inner
/// group ends without its own commit. Not thread-safe; each thread has its own groups (as scoped
/// objects: a group ends on its thread, inner before outer).
class FileGroup {
 public:
  FileGroup();
  ~FileGroup();
  FileGroup(const FileGroup&) = delete;
  FileGroup& operator=(const FileGroup&) = delete;

  /// Renames the group's temporaries over their paths (in the order written); for an inner
  /// group, leaves that to the outermost. Throws std::runtime_error naming the file if one
  /// cannot be renamed; the temporaries not yet renamed are removed.
  void commit();

 private:
  friend class AtomicFile;
  /// A closed temporary that the group renames when it commits.
  struct Pending {
    std::string tmp, path;
    int slot;  ///< its entry in remove_temporary_files()'s table, or -1
  };
  void add(Pending file);
  void drop(std::size_t from);

  std::vector<Pending> pending_;
  FileGroup* outer_;  ///< the group this one is nested in, or nullptr
  bool committed_ = false;
};

/// Removes the temporaries of every AtomicFile of this process not yet committed or destroyed,
/// and those of FileGroups not yet committed (up to 256 at once; more are not tracked).
/// Async-signal-safe: for a program's SIGINT / SIGTERM handler, so that an interrupted run leaves
/// no temporary behind.
void remove_temporary_files() noexcept;

/// Writes `bytes` to a temporary file beside `path`, then renames it over `path`, so a reader
/// never sees a half-written file. Throws std::runtime_error naming the file on failure and
/// leaves no temporary behind.
void write_file_atomic(const std::string& path, const void* bytes, std::size_t size);
inline void write_file_atomic(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  write_file_atomic(path, bytes.data(), bytes.size());
}
inline void write_file_atomic(const std::string& path, const std::string& text) {
  write_file_atomic(path, text.data(), text.size());
}

/// Lower-case extension of a path including the dot ("" if none), e.g. ".pcd".
std::string extension(const std::string& path);

}  // namespace rangeseg::io
