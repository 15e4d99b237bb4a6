#include "core/parallel.hpp"

#include <Eigen/Core>

#include <pthread.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <thread>
#include <vector>

namespace deformkit {

namespace {
std::atomic<bool> g_forked{false};
// Eigen's own OpenMP regions (a row-major sparse matrix times a dense one) would hang too.
void mark_forked() {
  g_forked = true;
  Eigen::setNbThreads(1);
}
[[maybe_unused]] const int g_atfork = pthread_atfork(nullptr, nullptr, &mark_forked);

thread_local bool t_in_blocks = false;  // this thread is running a block (nested calls stay here)

// Workers that sleep until a job is posted, then claim its blocks with the caller. A claim is the
// job's generation and the next block in one 64-bit word, so a worker that wakes late can never
// claim a block of a newer job with an older job's task.
class Pool {
 public:
  explicit Pool(int workers) {
    for (int i = 0; i < workers; ++i) std::thread([this] { work(); }).detach();  // lives as long as the process
  }

  // False when another thread's job is running: the caller then runs its blocks alone.
  bool run(int count, void (*task)(void*, int), void* context) {
    std::unique_lock<std::mutex> busy(submit_, std::try_to_lock);
    if (!busy.owns_lock()) return false;
    std::uint64_t generation;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      generation = ++generation_;
      task_ = task, context_ = context, count_ = count;
      done_.store(0, std::memory_order_relaxed);
      claim_.store(generation << 32, std::memory_order_release);
    }
    wake_.notify_all();
    blocks(generation, count, task, context);
    // Only blocks a worker has claimed are waited for; they are running.
    while (done_.load(std::memory_order_acquire) < count) std::this_thread::yield();
    return true;
  }

 private:
  // Claims and runs blocks of job `generation` until none is left; false once it is another job's.
  void blocks(std::uint64_t generation, int count, void (*task)(void*, int), void* context) {
    std::uint64_t claim = claim_.load(std::memory_order_acquire);
    for (;;) {
      if ((claim >> 32) != generation || int(claim & 0xffffffffu) >= count) return;
      if (!claim_.compare_exchange_weak(claim, claim + 1, std::memory_order_acq_rel)) continue;
      t_in_blocks = true;
      task(context, int(claim & 0xffffffffu));
      t_in_blocks = false;
      done_.fetch_add(1, std::memory_order_release);
      claim = claim_.load(std::memory_order_acquire);
    }
  }

  void work() {
    std::uint64_t seen = 0;
    for (;;) {
      std::uint64_t generation;
      void (*task)(void*, int);
      void* context;
      int count;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return generation_ != seen; });
        seen = generation = generation_;
        task = task_, context = context_, count = count_;
      }
      blocks(generation, count, task, context);
    }
  }

  std::mutex submit_;  // one job at a time
  std::mutex mutex_;
  std::condition_variable wake_;
  std::uint64_t generation_ = 0;
  void (*task_)(void*, int) = nullptr;
  void* context_ = nullptr;
  int count_ = 0;
  std::atomic<std::uint64_t> claim_{0};
  std::atomic<int> done_{0};
};

Pool& pool() {
  static Pool* p = new Pool(std::max(1, parallel_threads() - 1));  // never destroyed: workers outlive exit
  return *p;
}

}  // namespace

bool forked_after_threads() { return g_forked.load(std::memory_order_relaxed); }

int parallel_threads() {
  static const int threads = std::max(1, omp_get_max_threads());
  return threads;
}

void run_blocks(int count, void (*task)(void*, int), void* context) {
  if (count <= 1 || t_in_blocks || forked_after_threads() || !pool().run(count, task, context))
    for (int b = 0; b < count; ++b) {
      const bool outer = !t_in_blocks;
      t_in_blocks = true;
      task(context, b);
      if (outer) t_in_blocks = false;
    }
}

}  // namespace deformkit
