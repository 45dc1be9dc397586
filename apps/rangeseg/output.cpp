#include "output.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <stdexcept>
#include <string>
#include <system_error>

#include "rangeseg/io/file.hpp"
#include "rangeseg/io/pcd.hpp"
#include "rangeseg/io/ply.hpp"
#include "rangeseg/thread_pool.hpp"

namespace rangeseg::cli {

std::filesystem::path ensure_dir(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir)) {
    // create_directories says "File exists" for a link to nothing and for a file.
    std::error_code link_error;
    const std::filesystem::path target = std::filesystem::read_symlink(dir, link_error);
    if (!link_error) {
      throw std::runtime_error(dir + ": cannot create output directory: a symbolic link to '" +
                               target.string() + "', which is no directory");
    }
    if (std::filesystem::exists(dir, link_error)) {
      throw std::runtime_error(dir +
                               ": cannot create output directory: a file of that name "
                               "exists");
    }
    throw std::runtime_error(dir + ": cannot create output directory: " + ec.message());
  }
  return dir;
}

std::filesystem::path ensure_writable_dir(const std::string& dir) {
  auto path = ensure_dir(dir);
  if (::access(path.c_str(), W_OK | X_OK) != 0) {
    throw std::runtime_error(path.string() + ": cannot write into the output folder (" +
                             std::strerror(errno) + ")");
  }
  return path;
}

void write_mesh_ply(const std::string& path, const OrganizedCloud& cloud, const Mesh& mesh,
                    const NormalMap* normals, const RgbImage* colours) {
  TriangleList faces;
  extract_faces(mesh, /*remove_unused_vertices=*/true, faces);
  const bool with_colour = colours != nullptr && !colours->rgb.empty();
  const std::size_t n = faces.vertex_pixel.size();
  // Streamed from the planes: a copy of the vertices would add ~8 MB at 640x480.
  io::PlyWriter ply(
      path, {.vertices = n,
             .faces = faces.indices.size() / static_cast<std::size_t>(faces.vertices_per_face),
             .vertices_per_face = faces.vertices_per_face,
             .normals = normals != nullptr && n > 0,
             .rgb = with_colour && n > 0});
  const int w = cloud.width();
  for (const std::int32_t pixel : faces.vertex_pixel) {
    const int u = pixel % w, v = pixel / w;
    const float xyz[3] = {cloud.x(u, v), cloud.y(u, v), cloud.z(u, v)};
    if (normals == nullptr) {
      ply.vertex(xyz, nullptr, with_colour ? colours->pixel(u, v) : nullptr);
      continue;
    }
    const float normal[3] = {normals->nx(u, v), normals->ny(u, v), normals->nz(u, v)};
    ply.vertex(xyz, normal, with_colour ? colours->pixel(u, v) : nullptr);
  }
  for (std::size_t f = 0; f < faces.indices.size();
       f += static_cast<std::size_t>(faces.vertices_per_face)) {
    ply.face(&faces.indices[f]);
  }
  ply.commit();
}

void write_pcd_with_normals(const std::string& path, const OrganizedCloud& cloud,
                            const NormalMap& normals, const std::array<double, 7>& pose) {
  io::write_pcd(path, cloud,
                {.encoding = io::PcdEncoding::binary_compressed,
                 .viewpoint = pose,
                 .extra_float_fields = {{"normal_x", &normals.nx},
                                        {"normal_y", &normals.ny},
                                        {"normal_z", &normals.nz},
                                        {"curvature", &normals.curvature}}});
}

std::string json_text(const nlohmann::json& value, int indent) {
  return value.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

void write_json(const std::string& path, const nlohmann::json& value) {
  io::write_file_atomic(path, json_text(value, 2) + "\n");
}

void remove_stale_temporaries(const std::filesystem::path& dir,
                              const std::function<bool(const std::string&)>& is_output) {
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(dir, error)) {
    const std::string name = entry.path().filename().string();
    const std::size_t mark = name.rfind(".tmp.");
    if (mark == std::string::npos || !is_output(name.substr(0, mark))) continue;
    const std::string pid_text = name.substr(mark + 5);
    if (pid_text.empty() || pid_text.size() > 9 ||
        pid_text.find_first_not_of("0123456789") != std::string::npos) {
      continue;
    }
    const auto pid = static_cast<pid_t>(std::stol(pid_text));
    if (::kill(pid, 0) == 0 || errno != ESRCH) continue;  // its writer may still run
    std::error_code removed;
    if (std::filesystem::remove(entry.path(), removed)) {
      note("removed %s, left by an interrupted run", entry.path().c_str());
    }
  }
}

void remove_stale_temporaries(const std::string& path) {
  const std::filesystem::path p(path);
  const std::string name = p.filename().string();
  remove_stale_temporaries(p.parent_path().empty() ? "." : p.parent_path(),
                           [&](const std::string& base) { return base == name; });
}

namespace {

// Blocks a failing allocation frees one at a time before it throws: each failure's unwinding
// has one, also when two threads run out of memory together.
constexpr std::size_t kErrorReserveBlocks = 4, kErrorReserveBytes = std::size_t{4} << 20;
std::array<std::atomic<void*>, kErrorReserveBlocks> error_reserve{};

void release_reserve_and_throw() {
  for (auto& block : error_reserve) {
    if (void* memory = block.exchange(nullptr)) {
      std::free(memory);
      break;
    }
  }
  throw std::bad_alloc();
}

}  // namespace

bool reserve_memory_for_errors() {
  bool complete = true;
  for (auto& block : error_reserve) {
    if (block.load() != nullptr) continue;
    void* memory = std::malloc(kErrorReserveBytes);
    void* none = nullptr;
    if (memory == nullptr) {
      complete = false;
    } else if (!block.compare_exchange_strong(none, memory)) {
      std::free(memory);
    }
  }
  std::set_new_handler(release_reserve_and_throw);
  return complete;
}

void warn_if_more_threads_than_cores(int threads) {
  const int cores = usable_cores();
  if (threads > cores) {
    note(
        "warning: --threads %d on %d core%s: the threads take turns, and the times include the "
        "waits",
        threads, cores, cores == 1 ? "" : "s");
  }
}

void progress(const std::string& what) { std::fprintf(stderr, "rangeseg: %s\n", what.c_str()); }

namespace {
/// The progress bar drawn on the terminal, if any: notes go above it.
std::atomic<ProgressBar*> drawn_bar{nullptr};
}  // namespace

void note(const char* format, ...) {
  std::va_list args;
  va_start(args, format);
  std::va_list again;
  va_copy(again, args);
  const int length = std::vsnprintf(nullptr, 0, format, args);
  va_end(args);
  std::string line(static_cast<std::size_t>(std::max(length, 0)) + 1, '\0');
  std::vsnprintf(line.data(), line.size(), format, again);
  va_end(again);
  line.pop_back();
  if (ProgressBar* bar = drawn_bar.load()) {
    bar->message(line);
  } else {
    std::fprintf(stderr, "rangeseg: %s\n", line.c_str());
  }
}

ProgressBar::ProgressBar(std::size_t total)
    : total_(total), terminal_(::isatty(::fileno(stderr)) == 1) {
  if (terminal_) drawn_bar.store(this);
}

ProgressBar::~ProgressBar() {
  finish();
  ProgressBar* self = this;
  drawn_bar.compare_exchange_strong(self, nullptr);
}

void ProgressBar::draw(const std::string& item) {
  constexpr int kWidth = 30;
  const std::size_t filled = total_ == 0 ? kWidth : done_ * kWidth / total_;
  std::string bar(filled, '=');
  bar.resize(kWidth, ' ');
  // \33[K clears the rest of the line left by a longer item name.
  std::fprintf(stderr, "\rrangeseg: [%s] %zu/%zu %.40s\33[K", bar.c_str(), done_, total_,
               item.c_str());
  std::fflush(stderr);
  drawn_ = true;
  last_item_ = item;
}

void ProgressBar::advance(const std::string& item) {
  const std::lock_guard lock(mutex_);
  ++done_;
  if (terminal_) {
    draw(item);
  } else if (const std::size_t tenth = done_ * 10 / std::max<std::size_t>(total_, 1);
             tenth > last_line_ || done_ == total_) {
    last_line_ = tenth;
    std::fprintf(stderr, "rangeseg: %zu/%zu frames processed (last: %s)\n", done_, total_,
                 item.c_str());
  }
}

void ProgressBar::message(const std::string& line) {
  const std::lock_guard lock(mutex_);
  std::fprintf(stderr, "%srangeseg: %s\n", terminal_ && drawn_ ? "\r\33[K" : "", line.c_str());
  if (terminal_ && drawn_ && !finished_) draw(last_item_);
}

void ProgressBar::finish() {
  const std::lock_guard lock(mutex_);
  if (finished_) return;
  finished_ = true;
  if (terminal_ && drawn_) std::fputc('\n', stderr);
}

}  // namespace rangeseg::cli
