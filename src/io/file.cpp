#include "rangeseg/io/file.hpp"

#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <utility>

namespace rangeseg::io {

std::vector<std::uint8_t> read_file(const std::string& path, std::uint64_t max_bytes) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw std::runtime_error(path + ": is a directory, expected a file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open: " + std::strerror(errno));
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw std::runtime_error(path + ": cannot determine the file size");
  if (static_cast<std::uint64_t>(size) > max_bytes) {
    throw std::runtime_error(path + ": file of " + std::to_string(size) +
                             " bytes exceeds the limit of " + std::to_string(max_bytes));
  }
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
  in.seekg(0, std::ios::beg);
  if (size > 0 && !in.read(reinterpret_cast<char*>(bytes.data()), size)) {
    throw std::runtime_error(path + ": read error");
  }
  return bytes;
}

namespace {

// The temporaries being written, for remove_temporary_files(), which a signal handler calls:
// fixed storage and lock-free atomics only. A slot is 0 (free), 1 (being filled or emptied) or
// 2 (holds a path).
constexpr int kTemporarySlots = 64;
constexpr std::size_t kMaxTemporaryPath = 1024;
struct TemporarySlot {
  std::atomic<int> state{0};
  char path[kMaxTemporaryPath];
};
TemporarySlot g_temporaries[kTemporarySlots];
static_assert(std::atomic<int>::is_always_lock_free);

int register_temporary(const std::string& path) {
  if (path.size() >= kMaxTemporaryPath) return -1;
  for (int i = 0; i < kTemporarySlots; ++i) {
    int expected = 0;
    if (g_temporaries[i].state.compare_exchange_strong(expected, 1)) {
      std::memcpy(g_temporaries[i].path, path.c_str(), path.size() + 1);
      g_temporaries[i].state.store(2);
      return i;
    }
  }
  return -1;
}

void release_temporary(int& slot) {
  if (slot >= 0) g_temporaries[slot].state.store(0);
  slot = -1;
}

}  // namespace

void remove_temporary_files() noexcept {
  for (TemporarySlot& slot : g_temporaries) {
    int expected = 2;
    if (slot.state.compare_exchange_strong(expected, 1)) {
      ::unlink(slot.path);
      slot.state.store(0);
    }
  }
}

AtomicFile::AtomicFile(std::string path)
    : path_(std::move(path)), tmp_(path_ + ".tmp." + std::to_string(::getpid())) {
  slot_ = register_temporary(tmp_);
  file_ = std::fopen(tmp_.c_str(), "wb");
  if (file_ == nullptr) {
    release_temporary(slot_);
    throw std::runtime_error(path_ + ": cannot create: " + std::strerror(errno));
  }
}

AtomicFile::~AtomicFile() {
  if (file_ != nullptr) {
    std::fclose(file_);
    std::remove(tmp_.c_str());
  }
  release_temporary(slot_);
}

void AtomicFile::write(const void* bytes, std::size_t size) {
  if (file_ == nullptr) throw std::runtime_error(path_ + ": write after commit");
  if (size != 0 && std::fwrite(bytes, 1, size, file_) != size) {
    throw std::runtime_error(path_ + ": write error (disk full?)");
  }
}

void AtomicFile::commit() {
  if (file_ == nullptr) throw std::runtime_error(path_ + ": committed twice");
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!closed) {
    std::remove(tmp_.c_str());
    release_temporary(slot_);
    throw std::runtime_error(path_ + ": write error (disk full?)");
  }
  // Released after the rename: a signal in between removes a name that no longer exists.
  const bool renamed = std::rename(tmp_.c_str(), path_.c_str()) == 0;
  const int err = errno;
  if (!renamed) std::remove(tmp_.c_str());
  release_temporary(slot_);
  if (!renamed) {
    throw std::runtime_error(path_ + ": cannot rename temporary file: " + std::strerror(err));
  }
}

void write_file_atomic(const std::string& path, const void* bytes, std::size_t size) {
  AtomicFile file(path);
  file.write(bytes, size);
  file.commit();
}

std::string extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace rangeseg::io
