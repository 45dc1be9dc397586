#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "batch.hpp"
#include "commands.hpp"
#include "input.hpp"
#include "names.hpp"
#include "output.hpp"

namespace rangeseg::cli {
namespace {

struct BenchOptions {
  InputOptions in;
  std::string preset = "auto";
  std::string config;
  int repeat = 50;
  bool json = false;
  std::string sizes;        ///< "160x120,320x240,640x480"
  std::vector<int> scales;  ///< take every k-th pixel, e.g. 4,2,1
  int threads = 1;
};

struct SizeResult {
  int scale = 1, width = 0, height = 0;
  int grid_width = 0, grid_height = 0;  ///< an unorganized cloud's restored pixel grid, if any
  std::vector<StageTime> median_ms;     ///< per stage (stage_times: rings for unorganized input)
  double fps_single = 0;                ///< frames/s of the timed single-thread runs
  double fps_threads = 0;  ///< frames/s of `threads` pipelines in parallel (0 if threads == 1)
  std::vector<StageTime> in_frame_ms;  ///< medians with `threads` threads inside each frame
  double in_frame_speedup = 0;    ///< median over frame pairs of 1-thread / in-frame total time
  double throughput_speedup = 0;  ///< frames/s of `threads` pipelines over one pipeline's

  double total_ms() const { return median_ms.back().ms; }
  double in_frame_total_ms() const { return in_frame_ms.back().ms; }
};

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// The stages `pipeline` ran on its last frame (`organized`: whether that was organized).
std::vector<StageTime> stages_of(const Pipeline& pipeline, bool organized) {
  return stage_times(pipeline.times(), organized, !organized && !pipeline.pixel_grid().found());
}

/// Appends the stage times of the pipeline's last frame to `samples` (one list per stage).
void record(const Pipeline& pipeline, bool organized, std::vector<std::vector<double>>& samples) {
  const std::vector<StageTime> stages = stages_of(pipeline, organized);
  samples.resize(stages.size());
  for (std::size_t s = 0; s < stages.size(); ++s) samples[s].push_back(stages[s].ms);
}

/// `names` with each stage's median of `samples`.
std::vector<StageTime> medians(std::vector<StageTime> names,
                               const std::vector<std::vector<double>>& samples) {
  for (std::size_t s = 0; s < names.size(); ++s) names[s].ms = median(samples[s]);
  return names;
}

/// Frames per pipeline in each block of the throughput measurement.
constexpr int kThroughputBlock = 5;

/// Stage medians over `repeat` frames after one warm-up frame (buffers are allocated there).
/// With threads > 1 a pipeline with `threads` threads inside the frame runs each frame right
/// after the single-thread one, and `threads` pipelines in parallel run blocks of frames in turn
/// with blocks of one pipeline: a host whose speed drifts (a virtual machine; 1.6x within a day
/// on the project's) slows both sides of each comparison alike.
SizeResult measure(const OrganizedCloud& cloud, const PipelineSettings& settings, int repeat,
                   int threads) {
  SizeResult r;
  r.width = cloud.width();
  r.height = cloud.height();
  const bool organized = cloud.is_organized();
  Pipeline single(settings);
  std::unique_ptr<Pipeline> in_frame;
  if (threads > 1) {
    PipelineSettings s = settings;
    s.threads = threads;
    in_frame = std::make_unique<Pipeline>(s);
    in_frame->process(cloud);
  }
  single.process(cloud);
  std::vector<std::vector<double>> single_ms, in_frame_ms;
  std::vector<double> ratios;
  double single_seconds = 0;
  for (int i = 0; i < repeat; ++i) {
    const Clock::time_point start = Clock::now();
    single.process(cloud);
    single_seconds += seconds_since(start);
    record(single, organized, single_ms);
    if (!in_frame) continue;
    in_frame->process(cloud);
    record(*in_frame, organized, in_frame_ms);
    ratios.push_back(single_ms.back().back() / in_frame_ms.back().back());
  }
  r.median_ms = medians(stages_of(single, organized), single_ms);
  r.grid_width = single.pixel_grid().width;
  r.grid_height = single.pixel_grid().height;
  r.fps_single = repeat / single_seconds;
  if (!in_frame) return r;
  r.in_frame_ms = medians(stages_of(*in_frame, organized), in_frame_ms);
  r.in_frame_speedup = median(ratios);

  std::vector<std::unique_ptr<Pipeline>> pipelines;
  for (int t = 0; t < threads; ++t) {
    pipelines.push_back(std::make_unique<Pipeline>(settings));
    pipelines.back()->process(cloud);  // warm-up outside the timed part
  }
  double one_seconds = 0, parallel_seconds = 0;
  for (int done = 0; done < repeat; done += kThroughputBlock) {
    const int block = std::min(kThroughputBlock, repeat - done);
    Clock::time_point start = Clock::now();
    for (int i = 0; i < block; ++i) pipelines.front()->process(cloud);
    one_seconds += seconds_since(start);
    const int frames = block * threads;
    std::atomic<int> next{0};
    start = Clock::now();
    {
      std::vector<std::jthread> workers;
      workers.reserve(static_cast<std::size_t>(threads));
      for (int t = 0; t < threads; ++t) {
        workers.emplace_back([&, t] {
          while (next++ < frames) pipelines[static_cast<std::size_t>(t)]->process(cloud);
        });
      }
    }
    parallel_seconds += seconds_since(start);
  }
  r.fps_threads = repeat * threads / parallel_seconds;
  r.throughput_speedup = r.fps_threads / (repeat / one_seconds);
  return r;
}

/// Scales (every k-th pixel) from --scales or --sizes, for an input of w x h pixels.
std::vector<int> scales_for(const BenchOptions& o, int w, int h) {
  if (!o.sizes.empty()) {
    std::vector<int> scales;
    std::stringstream list(o.sizes);
    std::string item;
    while (std::getline(list, item, ',')) {
      int sw = 0, sh = 0;
      char x = 0;
      std::istringstream parse(item);
      if (!(parse >> sw >> x >> sh) || x != 'x' || sw < 1 || sh < 1) {
        throw std::invalid_argument("--sizes: expected WIDTHxHEIGHT, got '" + item + "'");
      }
      const int k = w / sw;
      if (k < 1 || (w + k - 1) / k != sw || (h + k - 1) / k != sh) {
        throw std::invalid_argument("--sizes: " + std::to_string(w) + "x" + std::to_string(h) +
                                    " cannot be reduced to " + item +
                                    " by taking every k-th pixel");
      }
      scales.push_back(k);
    }
    if (scales.empty()) throw std::invalid_argument("--sizes: no size given");
    return scales;
  }
  return o.scales.empty() ? std::vector<int>{1} : o.scales;
}

nlohmann::json stages_json(const SizeResult& r) {
  nlohmann::json j;
  for (const StageTime& s : r.median_ms) j[s.name] = s.ms;
  return j;
}

}  // namespace

void add_bench(CLI::App& app) {
  auto o = std::make_shared<BenchOptions>();
  auto* cmd = app.add_subcommand(
      "bench", "Median milliseconds per stage over repeated runs (single thread)");
  add_input_options(*cmd, o->in);
  cmd->add_option("--preset", o->preset, kAutoPresetHelp)->capture_default_str();
  cmd->add_option("--config", o->config, "JSON settings overriding the preset");
  cmd->add_option("--repeat", o->repeat, "Number of timed runs (after one warm-up run)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  cmd->add_flag("--json", o->json, "Print one JSON object {stage: median ms} on stdout");
  auto* sizes = cmd->add_option(
      "--sizes", o->sizes,
      "Comma-separated sizes WxH to time, made by taking every k-th pixel of the input "
      "(e.g. 160x120,320x240,640x480; organized inputs only); --json then prints {\"sizes\": "
      "[{size, width, height, scale, <stage>..., frames_per_second}]}");
  cmd->add_option("--scales", o->scales,
                  "Like --sizes, as pixel steps k (e.g. 4,2,1 = every 4th, 2nd, every pixel)")
      ->delimiter(',')
      ->check(CLI::Range(1, 1024))
      ->excludes(sizes);
  cmd->add_option("--threads", o->threads,
                  "Also measure N threads inside each frame (stage medians; each frame right after "
                  "the single-thread one, the speed-up is the median ratio of the pairs) and the "
                  "frame rate of N pipelines in parallel (one per thread; blocks of " +
                      std::to_string(kThroughputBlock) + " frames in turn with one pipeline's)")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  cmd->callback([o] {
    settings_from(resolve_preset(o->preset, ""), "plane", o->config, false);  // bad options first
    const LoadedInput in = load_input(o->in);
    PipelineSettings settings =
        settings_from(resolve_preset(o->preset, in.sensor_preset), "plane", o->config, false);
    // One smoothing iteration is the unit the stage is measured in.
    settings.smoothing.iterations = 1;
    const bool multi_size = !o->sizes.empty() || !o->scales.empty();
    if (multi_size && !in.cloud.is_organized()) {
      throw std::invalid_argument(o->in.path +
                                  ": --sizes and --scales take every k-th pixel of the grid, "
                                  "which an unorganized cloud (height 1) does not have");
    }
    require_model_for(in.cloud, settings, o->in.path);
    warn_if_more_threads_than_cores(o->threads);
    std::vector<SizeResult> results;
    for (const int k : scales_for(*o, in.cloud.width(), in.cloud.height())) {
      PipelineSettings scaled = settings;
      // Every k-th pixel: neighbouring rays are k times further apart. Without an angle or a
      // camera the pipeline fits the camera to each frame's points, as for a user's cloud.
      if (settings.smoothing.pixel_angle > 0 || in.camera_fx > 0) {
        scaled.smoothing.pixel_angle =
            pixel_angle_for(settings.smoothing, in.camera_fx) * static_cast<float>(k);
      }
      SizeResult r = k == 1 ? measure(in.cloud, scaled, o->repeat, o->threads)
                            : measure(downsample(in.cloud, k), scaled, o->repeat, o->threads);
      r.scale = k;
      results.push_back(r);
    }

    if (!multi_size) {
      const SizeResult& r = results.front();
      nlohmann::json result = stages_json(r);
      if (o->threads > 1) {
        result["threads"] = o->threads;
        result["frames_per_second"] = r.fps_threads;
        result["frames_per_second_single_thread"] = r.fps_single;
        nlohmann::json in_frame;
        for (const StageTime& s : r.in_frame_ms) in_frame[s.name] = s.ms;
        result["in_frame"] = in_frame;
        result["in_frame_speedup"] = r.in_frame_speedup;
        result["throughput_speedup"] = r.throughput_speedup;
      }
      if (o->json) {
        std::printf("%s\n", json_text(result).c_str());
        return;
      }
      const std::string size =
          in.cloud.is_organized()
              ? std::to_string(in.cloud.width()) + " x " + std::to_string(in.cloud.height())
              : std::to_string(in.cloud.size()) + " points (unorganized" +
                    (r.grid_width > 0 ? ", on its " + std::to_string(r.grid_width) + " x " +
                                            std::to_string(r.grid_height) + " pixel grid"
                                      : std::string(", over rings")) +
                    ")";
      std::printf("%s: %s, median of %d runs, single thread\n", o->in.path.c_str(), size.c_str(),
                  o->repeat);
      for (std::size_t s = 0; s < r.median_ms.size(); ++s) {
        std::printf("  %-13s %8.3f ms", r.median_ms[s].name, r.median_ms[s].ms);
        if (o->threads > 1) {
          std::printf("   %8.3f ms with %d threads in the frame", r.in_frame_ms[s].ms, o->threads);
        }
        std::printf("\n");
      }
      if (o->threads > 1) {
        std::printf("  in-frame      x%.2f faster with %d threads (median over frame pairs)\n",
                    r.in_frame_speedup, o->threads);
        std::printf("  throughput    %8.1f frames/s with %d pipelines in parallel, x%.2f one's\n",
                    r.fps_threads, o->threads, r.throughput_speedup);
      }
      return;
    }

    if (o->json) {
      nlohmann::json list = nlohmann::json::array();
      for (const SizeResult& r : results) {
        nlohmann::json j = stages_json(r);
        j["size"] = std::to_string(r.width) + "x" + std::to_string(r.height);
        j["width"] = r.width;
        j["height"] = r.height;
        j["scale"] = r.scale;
        j["frames_per_second"] = r.fps_single;
        if (o->threads > 1) {
          j["frames_per_second_threads"] = r.fps_threads;
          j["in_frame_total_ms"] = r.in_frame_total_ms();
          j["in_frame_speedup"] = r.in_frame_speedup;
          j["throughput_speedup"] = r.throughput_speedup;
        }
        list.push_back(std::move(j));
      }
      std::printf("%s\n", json_text({{"input", o->in.path},
                                     {"repeat", o->repeat},
                                     {"threads", o->threads},
                                     {"sizes", list}})
                              .c_str());
      return;
    }
    std::printf("%s: median ms of %d runs per stage, single thread%s\n", o->in.path.c_str(),
                o->repeat,
                o->threads > 1 ? "; frames/s with one thread and in parallel" : "; frames/s");
    std::printf("%-9s", "size");
    for (const StageTime& s : results.front().median_ms) std::printf(" %12s", s.name);
    std::printf(" %10s", "frames/s");
    const std::string n = std::to_string(o->threads);
    if (o->threads > 1) {
      std::printf(" %14s %18s %10s %11s", ("frames/s x" + n).c_str(),
                  ("total, " + n + " in frame").c_str(), "in-frame x", "pipelines x");
    }
    std::printf("\n");
    for (const SizeResult& r : results) {
      std::printf("%-9s", (std::to_string(r.width) + "x" + std::to_string(r.height)).c_str());
      for (const StageTime& s : r.median_ms) std::printf(" %12.3f", s.ms);
      std::printf(" %10.1f", r.fps_single);
      if (o->threads > 1) {
        std::printf(" %14.1f %18.3f %10.2f %11.2f", r.fps_threads, r.in_frame_total_ms(),
                    r.in_frame_speedup, r.throughput_speedup);
      }
      std::printf("\n");
    }
  });
}

}  // namespace rangeseg::cli
