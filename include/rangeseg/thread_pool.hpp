// Worker threads for splitting the rows of one frame over cores (Pipeline, Smoother::run).
#pragma once

#include <atomic>
#include <memory>
#include <type_traits>

namespace rangeseg {

namespace detail {

/// A flag that one call at a time holds: the workers of a ThreadPool, the frame of a Pipeline.
/// A moved-to object's flag is free (a call never runs while its object is moved).
class CallFlag {
 public:
  CallFlag() = default;
  CallFlag(CallFlag&& /*other*/) noexcept {}
  CallFlag& operator=(CallFlag&& /*other*/) noexcept { return *this; }
  CallFlag(const CallFlag&) = delete;
  CallFlag& operator=(const CallFlag&) = delete;
  ~CallFlag() = default;

  /// Takes the flag, if it is free, for the hold's lifetime.
  class Hold {
   public:
    explicit Hold(CallFlag& flag)
        : flag_(flag.taken_.exchange(true, std::memory_order_acquire) ? nullptr : &flag) {}
    ~Hold() {
      if (flag_ != nullptr) flag_->taken_.store(false, std::memory_order_release);
    }
    Hold(const Hold&) = delete;
    Hold& operator=(const Hold&) = delete;
    Hold(Hold&&) = delete;
    Hold& operator=(Hold&&) = delete;
    /// Whether this hold took the flag (false: another call holds it).
    bool held() const { return flag_ != nullptr; }

   private:
    CallFlag* flag_;
  };

 private:
  std::atomic<bool> taken_{false};
};

}  // namespace detail

/// The cores this process may run on: its CPU affinity (as `taskset` or a container's CPU set
/// allows), else the machine's hardware threads; at least 1. More threads than these take
/// turns, and the threads of one frame spin while they wait for each other, so a frame on more
/// threads than cores runs slower than on one (256 threads on 2 cores: 17x slower).
int usable_cores();

/// A fixed set of threads that run one function on disjoint bands of image rows. Created once
/// and reused for every frame: dispatching a frame's bands allocates nothing.
class ThreadPool {
 public:
  /// `threads` >= 1 bands run concurrently: threads - 1 workers are started and the calling
  /// thread runs the first band. Throws std::invalid_argument for threads < 1 or > 256.
  explicit ThreadPool(int threads);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int threads() const { return threads_; }

  /// While one exists, idle workers (and a caller waiting for them) keep spinning instead of
  /// going to sleep some microseconds after their last band. For a run of `for_each_band` calls
  /// with serial work between them, as in the stages of one frame: waking a sleeping thread
  /// costs tens of microseconds a call, more in virtual machines. The spinning occupies the
  /// workers' cores meanwhile; it yields them to the scheduler now and then, so an
  /// oversubscribed machine still runs the caller. Guards may nest and overlap.
  class KeepAwake {
   public:
    explicit KeepAwake(ThreadPool& pool);
    ~KeepAwake();
    KeepAwake(const KeepAwake&) = delete;
    KeepAwake& operator=(const KeepAwake&) = delete;

   private:
    ThreadPool& pool_;
  };

  /// Calls fn(band, row_begin, row_end) for `threads()` disjoint bands covering rows [0, rows),
  /// concurrently; the first row of every non-empty band but the first is a multiple of `align`
  /// (>= 1), and bands may be empty. Returns when every band is done and rethrows the first
  /// exception a band threw. Throws std::invalid_argument for rows < 0 or align < 1.
  /// A pool may be shared: a call made while another one runs on the workers (from another
  /// thread, or from inside a band) runs its bands one after another on the calling thread, the
  /// same bands with the same results, without the parallelism.
  template <class F>
  void for_each_band(int rows, int align, F&& fn) {
    using Fn = std::remove_reference_t<F>;
    run_bands(
        rows, align,
        [](void* context, int band, int row_begin, int row_end) {
          (*static_cast<Fn*>(context))(band, row_begin, row_end);
        },
        const_cast<void*>(static_cast<const void*>(&fn)));
  }

 private:
  using BandFn = void (*)(void* context, int band, int row_begin, int row_end);
  void run_bands(int rows, int align, BandFn fn, void* context);
  void run_bands_here(int rows, int align, BandFn fn, void* context) const;

  struct Workers;
  int threads_ = 1;
  std::unique_ptr<Workers> workers_;
};

}  // namespace rangeseg
