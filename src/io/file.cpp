#include "rangeseg/io/file.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <system_error>
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
constexpr int kTemporarySlots = 256;
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

// The innermost FileGroup of each thread: a plain pointer, so that no thread registers a
// destructor for it (glibc aborts when that registration finds no memory).
thread_local FileGroup* t_group = nullptr;

}  // namespace

FileGroup::FileGroup() : outer_(t_group) { t_group = this; }

FileGroup::~FileGroup() {
  t_group = outer_;
  if (!committed_) drop(0);
}

void FileGroup::add(Pending file) {
  // The same path written twice in a group shares one temporary, the later contents.
  for (const Pending& p : pending_) {
    if (p.tmp == file.tmp) {
      release_temporary(file.slot);
      return;
    }
  }
  pending_.push_back(std::move(file));
}

void FileGroup::drop(std::size_t from) {
  for (std::size_t i = from; i < pending_.size(); ++i) {
    std::remove(pending_[i].tmp.c_str());
    release_temporary(pending_[i].slot);
  }
  pending_.resize(std::min(from, pending_.size()));
}

void FileGroup::commit() {
  if (committed_) throw std::logic_error("FileGroup committed twice");
  if (outer_ != nullptr) {
    outer_->pending_.reserve(outer_->pending_.size() + pending_.size());
    for (Pending& p : pending_) outer_->add(std::move(p));
    pending_.clear();
    committed_ = true;
    return;
  }
  committed_ = true;
  // The one failure of a rename that is foreseeable: checked for all before any is renamed.
  for (const Pending& p : pending_) {
    std::error_code ec;
    if (std::filesystem::is_directory(p.path, ec)) {
      const std::string path = p.path;
      drop(0);
      throw std::runtime_error(path + ": cannot be written: a folder of that name exists");
    }
  }
  for (std::size_t i = 0; i < pending_.size(); ++i) {
    if (std::rename(pending_[i].tmp.c_str(), pending_[i].path.c_str()) != 0) {
      const int err = errno;
      const std::string path = pending_[i].path;
      drop(i);
      throw std::runtime_error(path + ": cannot rename temporary file: " + std::strerror(err));
    }
    release_temporary(pending_[i].slot);
  }
  pending_.clear();
}

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
    const int err = errno;
    release_temporary(slot_);
    const std::string name = std::filesystem::path(tmp_).filename().string();
    if (err == ENAMETOOLONG && name.size() > 255) {
      // The path itself may be fine: it is the temporary's suffix that is too much.
      throw std::runtime_error(path_ + ": cannot create: its temporary " + name + " is " +
                               std::to_string(name.size()) +
                               " bytes long, more than a file name may be (255): shorten the "
                               "name by " +
                               std::to_string(name.size() - 255) + " bytes");
    }
    throw std::runtime_error(path_ + ": cannot create: " + std::strerror(err));
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
    throw std::runtime_error(path_ + ": write error: " + std::strerror(errno));
  }
}

void AtomicFile::commit() {
  if (file_ == nullptr) throw std::runtime_error(path_ + ": committed twice");
  const bool closed = std::fclose(file_) == 0;
  const int close_error = errno;
  file_ = nullptr;
  if (!closed) {
    std::remove(tmp_.c_str());
    release_temporary(slot_);
    throw std::runtime_error(path_ + ": write error: " + std::strerror(close_error));
  }
  if (t_group != nullptr) {
    try {
      t_group->add({tmp_, path_, slot_});
    } catch (...) {
      std::remove(tmp_.c_str());
      throw;  // the destructor releases the slot
    }
    slot_ = -1;
    return;
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
