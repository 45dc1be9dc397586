#include "rangeseg/thread_pool.hpp"

#if defined(__linux__)
#include <sched.h>
#endif

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace rangeseg {
namespace {

/// First row of band b of `bands` over [0, rows): split evenly and rounded up to `align`.
int band_begin(int b, int rows, int align, int bands) {
  if (b <= 0) return 0;
  if (b >= bands) return rows;
  const long long even = static_cast<long long>(rows) * b / bands;
  const long long aligned = (even + align - 1) / align * align;
  return static_cast<int>(aligned < rows ? aligned : rows);
}

}  // namespace

/// Workers wait for a new generation of work, run their band and count down; the caller runs
/// band 0 and waits for the count to reach zero. Both sides spin for some microseconds before
/// sleeping on a condition variable: the bands of one frame follow each other within
/// microseconds, and waking a sleeping thread costs tens of them. While a KeepAwake guard
/// lives, both spin on.
struct ThreadPool::Workers {
  static constexpr unsigned kSpins = 4000;  // 10-150 us of pause instructions, by CPU

  std::mutex mutex;
  std::condition_variable work_ready;
  std::condition_variable work_done;
  std::atomic<std::uint64_t> generation{0};
  std::atomic<int> pending{0};
  std::atomic<int> keep_awake{0};  // live KeepAwake guards
  detail::CallFlag busy;           // held by the call running on the workers
  bool stopping = false;           // guarded by mutex
  BandFn fn = nullptr;
  void* context = nullptr;
  int rows = 0, align = 1, bands = 1;
  std::exception_ptr error;  // guarded by mutex
  std::vector<std::thread> threads;

  /// Rows of band b: [begin(b), begin(b + 1)).
  int begin(int b) const { return band_begin(b, rows, align, bands); }

  void run_band(int b) {
    try {
      fn(context, b, begin(b), begin(b + 1));
    } catch (...) {
      const std::lock_guard<std::mutex> lock(mutex);
      if (!error) error = std::current_exception();
    }
  }

  static void pause() {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#else
    std::this_thread::yield();
#endif
  }

  /// Spins until `done()` or kSpins pauses have passed, or as long as a KeepAwake guard lives
  /// (yielding the core every kSpins pauses).
  template <class Done>
  void spin_until(Done done) const {
    for (unsigned i = 1; !done(); ++i) {
      if (i >= kSpins) {
        if (keep_awake.load(std::memory_order_relaxed) == 0) return;
        if (i % kSpins == 0) std::this_thread::yield();
      }
      pause();
    }
  }

  void work(int band) {
    std::uint64_t seen = 0;
    for (;;) {
      std::uint64_t now = seen;
      spin_until([&] {
        now = generation.load(std::memory_order_acquire);
        return now != seen;
      });
      if (now == seen) {
        std::unique_lock<std::mutex> lock(mutex);
        work_ready.wait(
            lock, [&] { return stopping || generation.load(std::memory_order_acquire) != seen; });
        if (stopping) return;
        now = generation.load(std::memory_order_acquire);
      }
      seen = now;
      run_band(band);
      if (pending.fetch_sub(1, std::memory_order_acq_rel) == 1) {
        const std::lock_guard<std::mutex> lock(mutex);  // the caller may be about to sleep
        work_done.notify_one();
      }
    }
  }
};

int usable_cores() {
#if defined(__linux__)
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (sched_getaffinity(0, sizeof allowed, &allowed) == 0 && CPU_COUNT(&allowed) > 0) {
    return CPU_COUNT(&allowed);
  }
#endif
  return static_cast<int>(std::max(std::thread::hardware_concurrency(), 1u));
}

ThreadPool::ThreadPool(int threads) : threads_(threads), workers_(std::make_unique<Workers>()) {
  if (threads < 1 || threads > 256) {
    throw std::invalid_argument("ThreadPool: threads = " + std::to_string(threads) +
                                " must be in [1, 256]");
  }
  workers_->bands = threads;
  workers_->threads.reserve(static_cast<std::size_t>(threads - 1));
  for (int b = 1; b < threads; ++b) {
    workers_->threads.emplace_back([w = workers_.get(), b] { w->work(b); });
  }
}

ThreadPool::~ThreadPool() {
  {
    const std::lock_guard<std::mutex> lock(workers_->mutex);
    workers_->stopping = true;
  }
  workers_->work_ready.notify_all();
  for (std::thread& t : workers_->threads) t.join();
}

void ThreadPool::run_bands(int rows, int align, BandFn fn, void* context) {
  if (rows < 0 || align < 1) {
    throw std::invalid_argument("ThreadPool::for_each_band: rows = " + std::to_string(rows) +
                                ", align = " + std::to_string(align) +
                                " (need rows >= 0, align >= 1)");
  }
  Workers& w = *workers_;
  const detail::CallFlag::Hold workers(w.busy);
  if (threads_ == 1 || !workers.held()) {
    // The workers belong to another call (made on another thread, or this one is made from
    // inside one of its bands): the bands run here, one after another. Bands index their own
    // buffers and never wait for each other, so the results are the same.
    run_bands_here(rows, align, fn, context);
    return;
  }
  {
    // Workers read the job after seeing the new generation (release / acquire).
    const std::lock_guard<std::mutex> lock(w.mutex);
    w.fn = fn;
    w.context = context;
    w.rows = rows;
    w.align = align;
    w.error = nullptr;
    w.pending.store(threads_ - 1, std::memory_order_relaxed);
    w.generation.fetch_add(1, std::memory_order_release);
  }
  w.work_ready.notify_all();
  w.run_band(0);
  w.spin_until([&] { return w.pending.load(std::memory_order_acquire) == 0; });
  std::exception_ptr error;
  {
    std::unique_lock<std::mutex> lock(w.mutex);
    w.work_done.wait(lock, [&] { return w.pending.load(std::memory_order_acquire) == 0; });
    error = w.error;
    w.error = nullptr;
  }
  if (error) std::rethrow_exception(error);
}

void ThreadPool::run_bands_here(int rows, int align, BandFn fn, void* context) const {
  std::exception_ptr error;
  for (int b = 0; b < threads_; ++b) {
    try {
      fn(context, b, band_begin(b, rows, align, threads_),
         band_begin(b + 1, rows, align, threads_));
    } catch (...) {
      if (!error) error = std::current_exception();
    }
  }
  if (error) std::rethrow_exception(error);
}

ThreadPool::KeepAwake::KeepAwake(ThreadPool& pool) : pool_(pool) {
  pool_.workers_->keep_awake.fetch_add(1, std::memory_order_relaxed);
}

ThreadPool::KeepAwake::~KeepAwake() {
  pool_.workers_->keep_awake.fetch_sub(1, std::memory_order_relaxed);
}

}  // namespace rangeseg
