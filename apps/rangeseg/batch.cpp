#include "batch.hpp"

#include <nlohmann/json.hpp>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <new>
#include <set>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "names.hpp"
#include "output.hpp"
#include "rangeseg/io/file.hpp"
#include "rangeseg/version.hpp"
#include "segment_output.hpp"

namespace rangeseg::cli {
namespace {

struct FrameResult {
  bool ran = false;  ///< false for the frames after a stop (StopAfterCurrentFrames)
  bool ok = false;
  bool first = false;  ///< its pipeline's first frame, which allocated the buffers
  std::string error;
  bool out_of_memory = false;  ///< memory is still short after the frame failed for lack of it
  std::string preset;
  StageTimes times;
  std::size_t segments = 0;
  bool organized = true;
  bool pixel_grid = false;  ///< unorganized, run on its restored pixel grid
};

/// A worker's pipelines, one per preset its frames need (with --preset auto a folder may mix
/// sensors), made when first needed: frames of one sensor reuse one pipeline's buffers.
class WorkerPipelines {
 public:
  WorkerPipelines(const BatchSettings& settings, int frame_threads)
      : settings_(settings), frame_threads_(frame_threads) {}
  Pipeline& operator()(const std::string& preset) {
    std::unique_ptr<Pipeline>& p = by_preset_[preset];
    if (!p) {
      PipelineSettings s = settings_.settings_for(preset);
      s.threads = frame_threads_;
      p = std::make_unique<Pipeline>(s);
    }
    return *p;
  }
  /// Whether the pipeline of `preset` runs its first frame (then counted as run).
  bool first_frame(const std::string& preset) { return ran_.insert(preset).second; }

 private:
  const BatchSettings& settings_;
  int frame_threads_;
  std::map<std::string, std::unique_ptr<Pipeline>> by_preset_;
  std::set<std::string> ran_;
};

/// Every stage name in the order of summary.json: a frame on a grid has no rings, one over rings
/// no mesh; "order" is an unorganized frame's move into spatial order or onto its pixel grid
/// and back.
constexpr const char* kStages[] = {"mesh",         "order",    "rings",    "normals", "smoothing",
                                   "segmentation", "polygons", "tracking", "total"};

/// Loads, segments and writes one frame; every failure is caught and returned as the reason.
/// `sequence_preset` (tracked sequences only): the preset of the frames so far, which every
/// frame must share, as one pipeline's tracks must not skip over another sensor's frames.
FrameResult run_frame(const FrameSource& frame, const InputOptions& load_options,
                      const std::string& preset, WorkerPipelines& pipelines,
                      const BatchOptions& options, std::string* sequence_preset) {
  FrameResult r;
  r.ran = true;
  try {
    if (!frame.error.empty()) throw std::runtime_error(frame.error);
    InputOptions o = load_options;
    o.path = frame.path;
    const LoadedInput in = load_input(o);
    note_auto_preset(preset, in, frame.path);
    r.preset = resolve_preset(preset, in.sensor_preset);
    if (sequence_preset != nullptr && sequence_preset->empty()) *sequence_preset = r.preset;
    if (sequence_preset != nullptr && *sequence_preset != r.preset) {
      throw std::invalid_argument("a tracked sequence is one sensor's: this frame takes preset " +
                                  r.preset + ", the frames before it " + *sequence_preset +
                                  " (give --preset, or segment it apart)");
    }
    Pipeline& pipeline = pipelines(r.preset);
    require_model_for(in.cloud, pipeline.settings(), frame.path);
    check_noise_scale(frame.path, in.cloud, pipeline.settings().segmentation.noise);
    pipeline.process(in.cloud, in.camera_fx);
    r.first = pipelines.first_frame(r.preset);
    warn_if_no_segments(pipeline, frame.path);
    FolderFiles files = options.files;
    files.pose = in.pose;
    write_segmentation_folder((std::filesystem::path(options.out_dir) / frame.name).string(),
                              in.cloud, pipeline, files);
    r.ok = true;
    r.times = pipeline.times();
    r.segments = pipeline.segmentation().segments.size();
    r.organized = in.cloud.is_organized();
    r.pixel_grid = pipeline.pixel_grid().found();
  } catch (const std::bad_alloc&) {
    r.error = "out of memory";  // short enough to need no allocation
    r.out_of_memory = !reserve_memory_for_errors();
  } catch (const std::exception& e) {
    r.error = e.what();
  } catch (...) {
    r.error = "unknown error";
  }
  // Readers name the file in their messages; other failures get it here.
  if (!r.ok && r.error.find(frame.path) == std::string::npos) r.error = frame.path + ": " + r.error;
  return r;
}

/// The signal that asked the running batch to stop (SIGINT, SIGTERM, SIGHUP); 0 while none has.
std::atomic<int> stop_signal{0};

extern "C" void stop_after_current_frames(int signal) {
  // A second signal ends the process at once, as it would have without a batch.
  if (stop_signal.exchange(signal) != 0) {
    io::remove_temporary_files();
    std::signal(signal, SIG_DFL);
    std::raise(signal);
  }
}

/// While one exists, SIGINT, SIGTERM and SIGHUP stop the batch after the frames being processed:
/// their folders are complete, and the summary says which frames ran.
class StopAfterCurrentFrames {
 public:
  StopAfterCurrentFrames() {
    stop_signal.store(0);
    for (std::size_t k = 0; k < kSignals.size(); ++k) {
      previous_[k] = std::signal(kSignals[k], stop_after_current_frames);
    }
  }
  ~StopAfterCurrentFrames() {
    for (std::size_t k = 0; k < kSignals.size(); ++k) std::signal(kSignals[k], previous_[k]);
  }
  StopAfterCurrentFrames(const StopAfterCurrentFrames&) = delete;
  StopAfterCurrentFrames& operator=(const StopAfterCurrentFrames&) = delete;

 private:
  static constexpr std::array<int, 3> kSignals{SIGINT, SIGTERM, SIGHUP};
  std::array<void (*)(int), 3> previous_{};
};

const char* signal_name(int signal) {
  return signal == SIGINT ? "SIGINT" : signal == SIGTERM ? "SIGTERM" : "SIGHUP";
}

/// Every frame allocates its input cloud and output buffers anew (the readers and encoders
/// return fresh objects), several MB each. By default glibc serves those with mmap and gives
/// them back at free, so every frame page-faults all of them in again (112k faults and a third
/// of the CPU time for 12 Kinect frames with mesh.ply; worse with threads, which contend on the
/// kernel's address-space lock). Keeping freed memory in the heap for the next frame cuts this
/// to 17k faults; the peak stays that of one frame per thread.
void keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // the largest glibc accepts on 64-bit
  mallopt(M_TRIM_THRESHOLD, 128 << 20);
#endif
}

}  // namespace

std::vector<StageTime> stage_times(const StageTimes& t, bool organized, bool rings) {
  std::vector<StageTime> stages{
      {rings ? "rings" : "mesh", t.mesh}, {"normals", t.normals},   {"smoothing", t.smoothing},
      {"segmentation", t.segmentation},   {"polygons", t.polygons}, {"total", t.total}};
  if (!organized) stages.insert(stages.begin(), {"order", t.input});
  if (t.tracking > 0) stages.insert(stages.end() - 1, {"tracking", t.tracking});
  return stages;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const std::size_t n = v.size(), mid = n / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  if (n % 2 == 1) return v[mid];
  const double upper = v[mid];
  return 0.5 * (*std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid)) + upper);
}

std::size_t segment_batch(const FrameList& list, const BatchSettings& settings,
                          const BatchOptions& options) {
  const auto out_dir = ensure_writable_dir(options.out_dir);
  keep_freed_memory_for_reuse();
  const std::size_t n = list.frames.size();
  // Tracked segments need the frames in order, on one pipeline: the threads then work inside
  // each frame.
  const bool track = settings.settings_for(resolve_preset(settings.preset, "")).track;
  for (std::size_t i = 1; track && i < n; ++i) {
    // A shell's glob sorts frame10 before frame2; tracks would then jump back and forth.
    const FrameSource& before = list.frames[i - 1];
    const FrameSource& after = list.frames[i];
    if (!natural_less(after.path, before.path)) continue;
    if (before.tum && after.tum) {
      note(
          "warning: --track runs the frames in the order of depth.txt, which lists %s before %s: "
          "sort its lines by timestamp",
          before.path.c_str(), after.path.c_str());
    } else {
      note(
          "warning: --track runs the frames in the order given, and %s comes before %s (a "
          "folder runs in natural order: give the folder, or sort the list with `ls -v`)",
          before.path.c_str(), after.path.c_str());
    }
    break;
  }
  const int frame_threads = track ? std::max(options.threads, 1) : 1;
  const std::size_t threads =
      track ? 1
            : std::clamp<std::size_t>(static_cast<std::size_t>(std::max(options.threads, 1)), 1,
                                      std::max<std::size_t>(n, 1));
  warn_if_more_threads_than_cores(options.threads);
  // The first pipeline of each worker is made here, so that invalid settings throw before any
  // work starts.
  std::vector<WorkerPipelines> pipelines;
  for (std::size_t t = 0; t < threads; ++t) {
    pipelines.emplace_back(settings, frame_threads)(resolve_preset(settings.preset, ""));
  }
  // The clean-up of result folders never removes a frame of this batch (an input folder given
  // as the output folder holds both).
  std::vector<std::string> paths;
  for (const FrameSource& frame : list.frames) paths.push_back(frame.path);
  const InputFiles inputs(paths);
  BatchOptions frame_options = options;
  frame_options.files.inputs = &inputs;
  // An earlier run's summary would describe folders this run is replacing.
  remove_earlier_result(out_dir / "summary.json", &inputs);

  std::vector<FrameResult> results(n);
  std::string sequence_preset;  // tracked: the one worker's
  std::atomic<std::size_t> next{0};
  const StopAfterCurrentFrames stop;
  ProgressBar bar(n);
  // Each worker takes the next unclaimed frame; a frame's result depends only on the frame, so
  // the outputs are the same for any number of threads.
  // What ends the batch from a worker (an allocation failing outside a frame's own handler,
  // e.g. while reporting it): the first is thrown again here once the workers have stopped.
  std::exception_ptr fatal;
  std::mutex fatal_mutex;
  std::atomic<bool> failed{false};
  const auto work = [&](WorkerPipelines& worker) {
    try {
      for (std::size_t i = next++; i < n && stop_signal.load() == 0 && !failed.load(); i = next++) {
        const FrameSource& frame = list.frames[i];
        results[i] = run_frame(frame, list.options_for(frame), settings.preset, worker,
                               frame_options, track ? &sequence_preset : nullptr);
        if (results[i].out_of_memory) throw std::bad_alloc();  // later frames would fail too
        if (!results[i].ok) bar.message("skipped " + results[i].error);
        bar.advance(frame.name);
      }
    } catch (...) {
      const std::lock_guard lock(fatal_mutex);
      if (!fatal) fatal = std::current_exception();
      failed = true;
    }
  };
  const auto start = std::chrono::steady_clock::now();
  if (threads == 1) {
    work(pipelines[0]);
  } else {
    std::vector<std::jthread> workers;
    try {
      for (std::size_t t = 0; t < threads; ++t) workers.emplace_back(work, std::ref(pipelines[t]));
    } catch (const std::system_error& e) {
      failed = true;  // the workers started stop after their frames; they are joined here
      workers.clear();
      throw std::runtime_error("cannot start " + std::to_string(threads) +
                               " threads for the batch (" + e.what() + "): give fewer --threads");
    }
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  bar.finish();
  if (fatal) std::rethrow_exception(fatal);
  const int stopped_by = stop_signal.load();

  // Medians over the frames after each pipeline's first, which allocates its buffers (all
  // frames when every one was a first).
  std::map<std::string, std::vector<double>> per_stage, warm_per_stage;
  nlohmann::json frames = nlohmann::json::array(), failures = nlohmann::json::array();
  std::size_t ok = 0, run = 0;
  bool any_png = false, any_tum = false;
  for (std::size_t i = 0; i < n; ++i) {
    const FrameSource& f = list.frames[i];
    const FrameResult& r = results[i];
    if (!r.ran) continue;
    ++run;
    if (io::extension(f.path) == ".png") (f.tum ? any_tum : any_png) = true;
    if (r.ok) {
      ++ok;
      nlohmann::json ms;
      for (const StageTime& s : stage_times(r.times, r.organized, !r.organized && !r.pixel_grid)) {
        per_stage[s.name].push_back(s.ms);
        if (!r.first) warm_per_stage[s.name].push_back(s.ms);
        ms[s.name] = s.ms;
      }
      frames.push_back({{"name", f.name},
                        {"input", f.path},
                        {"ok", true},
                        {"organized", r.organized},
                        {"pixel_grid", r.pixel_grid},
                        {"preset", r.preset},
                        {"segments", r.segments},
                        {"first_of_pipeline", r.first},
                        {"ms", ms}});
    } else {
      frames.push_back({{"name", f.name}, {"input", f.path}, {"ok", false}, {"error", r.error}});
      failures.push_back({{"name", f.name}, {"input", f.path}, {"error", r.error}});
    }
  }
  const bool warm = !warm_per_stage.empty();
  nlohmann::json medians = nlohmann::json::object();
  for (const char* stage : kStages) {
    auto& times = warm ? warm_per_stage : per_stage;
    if (times.contains(stage)) medians[stage] = median(times[stage]);
  }
  nlohmann::json summary{
      {"rangeseg_version", RANGESEG_VERSION_STRING},
      {"frames", n},
      {"run", run},
      {"succeeded", ok},
      {"failed", run - ok},
      {"threads", track ? frame_threads : static_cast<int>(threads)},
      {"tracked", track},
      {"wall_seconds", wall_s},
      // Of the frames segmented: failures are often cut short by a bad header.
      {"frames_per_second", wall_s > 0 ? static_cast<double>(ok) / wall_s : 0.0},
      {"median_ms", medians},
      {"median_of", warm ? "the frames after each pipeline's first (which allocates its buffers)"
                         : "every frame (each its pipeline's first)"},
      {"failures", failures},
      {"per_frame", frames}};
  // How the depth PNGs among the frames became points (the focal lengths when no file gives
  // them): those of a TUM sequence, and the others.
  const auto depth_png = [](const InputOptions& o) {
    nlohmann::json entry{{"depth_scale_m_per_unit", o.depth_scale}, {"camera", camera_source(o)}};
    if (o.intrinsics.empty()) {
      const auto [fx, fy] = focal_lengths(o);
      entry["fx"] = fx;
      entry["fy"] = fy;
    }
    return entry;
  };
  if (any_png) summary["depth_png"] = depth_png(list.options);
  if (any_tum) summary["tum_depth_png"] = depth_png(list.tum_options);
  if (stopped_by != 0) summary["stopped_by"] = signal_name(stopped_by);
  write_json((out_dir / "summary.json").string(), summary);
  remove_earlier_results(out_dir, {(out_dir / "summary.json").string()}, &inputs);

  if (stopped_by != 0) {
    std::printf("stopped by %s after %zu of %zu frames: ", signal_name(stopped_by), run, n);
  } else {
    std::printf("%zu frames: ", n);
  }
  if (track) {
    std::printf("%zu ok, %zu failed; %.2f s, in order with %d thread%s per frame, segments tracked",
                ok, run - ok, wall_s, frame_threads, frame_threads == 1 ? "" : "s");
  } else {
    std::printf("%zu ok, %zu failed; %.2f s with %zu thread%s", ok, run - ok, wall_s, threads,
                threads == 1 ? "" : "s");
  }
  if (ok > 0) std::printf(" (%.1f frames/s)", summary["frames_per_second"].get<double>());
  std::printf("\n");
  if (ok > 0) {
    std::printf("median per frame%s:", warm ? " after each pipeline's first" : "");
    const char* separator = " ";
    for (const char* stage : kStages) {
      if (!medians.contains(stage)) continue;
      std::printf("%s%s %.2f ms", separator, stage, medians[stage].get<double>());
      separator = ", ";
    }
    std::printf("\n");
  }
  for (const auto& f : failures) std::printf("failed: %s\n", f["error"].get<std::string>().c_str());
  if (ok > 0) std::printf("results in %s, ", (out_dir / "<frame>" / "").string().c_str());
  std::printf("summary in %s\n", (out_dir / "summary.json").string().c_str());
  if (stopped_by != 0) {
    // Ended by the signal, as the caller (a shell: status 128 + signal) expects.
    std::fflush(stdout);
    std::fflush(stderr);
    std::signal(stopped_by, SIG_DFL);
    std::raise(stopped_by);
  }
  return ok;
}

}  // namespace rangeseg::cli
