#pragma once
// Static split of [0, n) into contiguous blocks over the machine's cores. The calling thread runs
// blocks itself and waits only for blocks another thread has started, so a worker the scheduler
// has not woken (the other core busy with another program) costs nothing: its blocks run here.
// (An OpenMP region waits for every thread of its team at its end, a scheduler tick or two,
// 4-8 ms, whenever a core is taken.)
#include <omp.h>

#include <algorithm>
#include <cstddef>
#include <exception>
#include <mutex>

namespace deformkit {

// Below this many points a second thread costs more than it saves.
constexpr std::size_t kParallelGrain = 8192;

// True in a child forked after the worker threads started: they do not survive fork(), so such a
// child runs single-threaded.
bool forked_after_threads();

// Runs task(context, b) for b in [0, count), each exactly once, on the calling thread and the
// pool's workers; returns when all have run. Nested calls (from inside a task) and calls while
// another thread's blocks are running take the calling thread alone.
void run_blocks(int count, void (*task)(void*, int), void* context);

// The number of blocks parallel_blocks splits into: OMP_NUM_THREADS or the cores (at most that
// many blocks are ever made, so per-block state may be sized by it).
int parallel_threads();

// fn(t) for t in [0, count), each once, on the caller and the workers as parallel_blocks runs its
// blocks (at most parallel_threads() at a time); the first exception is rethrown here.
template <class Fn>
void parallel_tasks(int count, Fn&& fn) {
  struct Context {
    Fn* fn;
    std::exception_ptr failure;
    std::mutex failure_mutex;
  } context{&fn, nullptr, {}};
  run_blocks(count, [](void* c, int t) {
    Context& ctx = *static_cast<Context*>(c);
    try {
      (*ctx.fn)(t);
    } catch (...) {
      std::lock_guard<std::mutex> lock(ctx.failure_mutex);
      if (!ctx.failure) ctx.failure = std::current_exception();
    }
  }, &context);
  if (context.failure) std::rethrow_exception(context.failure);
}

template <class Fn>
void parallel_blocks(std::size_t n, Fn&& fn) {
  const int threads = n < 2 * kParallelGrain || forked_after_threads() ? 1 : parallel_threads();
  if (threads <= 1) {
    if (n > 0) fn(std::size_t(0), n);
    return;
  }
  struct Context {
    Fn* fn;
    std::size_t n, block;
    std::exception_ptr failure;
    std::mutex failure_mutex;
  } context{&fn, n, (n + threads - 1) / threads, nullptr, {}};
  // The first exception of a block is carried out and rethrown here, so std::bad_alloc in a
  // block is still a MemoryError.
  run_blocks(threads, [](void* c, int b) {
    Context& ctx = *static_cast<Context*>(c);
    const std::size_t begin = std::min(ctx.n, std::size_t(b) * ctx.block), end = std::min(ctx.n, begin + ctx.block);
    if (begin >= end) return;
    try {
      (*ctx.fn)(begin, end);
    } catch (...) {
      std::lock_guard<std::mutex> lock(ctx.failure_mutex);
      if (!ctx.failure) ctx.failure = std::current_exception();
    }
  }, &context);
  if (context.failure) std::rethrow_exception(context.failure);
}

}  // namespace deformkit
