#include "rangeseg/thread_pool.hpp"

#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace rangeseg {

/// Workers wait for a new generation of work, run their band and count down; the caller runs
/// band 0 and waits for the count to reach zero. One mutex guards the whole job description.
struct ThreadPool::Workers {
  std::mutex mutex;
  std::condition_variable work_ready;
  std::condition_variable work_done;
  std::uint64_t generation = 0;
  int pending = 0;
  bool stopping = false;
  BandFn fn = nullptr;
  void* context = nullptr;
  int rows = 0, align = 1, bands = 1;
  std::exception_ptr error;
  std::vector<std::thread> threads;

  /// Rows of band b: [begin(b), begin(b + 1)), split evenly and rounded to `align`.
  int begin(int b) const {
    if (b <= 0) return 0;
    if (b >= bands) return rows;
    const long long even = static_cast<long long>(rows) * b / bands;
    const long long aligned = (even + align - 1) / align * align;
    return static_cast<int>(aligned < rows ? aligned : rows);
  }

  void run_band(int b) {
    try {
      fn(context, b, begin(b), begin(b + 1));
    } catch (...) {
      const std::lock_guard<std::mutex> lock(mutex);
      if (!error) error = std::current_exception();
    }
  }

  void work(int band) {
    std::uint64_t seen = 0;
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(mutex);
        work_ready.wait(lock, [&] { return stopping || generation != seen; });
        if (stopping) return;
        seen = generation;
      }
      run_band(band);
      const std::lock_guard<std::mutex> lock(mutex);
      if (--pending == 0) work_done.notify_one();
    }
  }
};

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
  {
    const std::lock_guard<std::mutex> lock(w.mutex);
    w.fn = fn;
    w.context = context;
    w.rows = rows;
    w.align = align;
    w.error = nullptr;
    w.pending = threads_ - 1;
    ++w.generation;
  }
  w.work_ready.notify_all();
  w.run_band(0);
  std::exception_ptr error;
  {
    std::unique_lock<std::mutex> lock(w.mutex);
    w.work_done.wait(lock, [&] { return w.pending == 0; });
    error = w.error;
    w.error = nullptr;
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace rangeseg
