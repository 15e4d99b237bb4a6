#pragma once
// Static split of [0, n) into contiguous blocks over the machine's cores (OpenMP).
#include <omp.h>

#include <algorithm>
#include <cstddef>
#include <exception>

namespace deformkit {

// Below this many points a second thread costs more than it saves.
constexpr std::size_t kParallelGrain = 8192;

// True in a child forked after OpenMP started its threads: libgomp's pool does not survive
// fork() (a child using it hangs), so such a child runs single-threaded.
bool forked_after_threads();

template <class Fn>
void parallel_blocks(std::size_t n, Fn&& fn) {
  const int threads =
      n < 2 * kParallelGrain || forked_after_threads() ? 1 : std::max(1, omp_get_max_threads());
  const std::size_t block = (n + threads - 1) / threads;
  // An exception may not leave an OpenMP region (std::terminate): the first one is carried out
  // and rethrown on the calling thread, so std::bad_alloc in a block is still a MemoryError.
  std::exception_ptr failure;
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int b = 0; b < threads; ++b) {
    const std::size_t begin = std::min(n, b * block), end = std::min(n, begin + block);
    if (begin >= end) continue;
    try {
      fn(begin, end);
    } catch (...) {
#pragma omp critical(deformkit_parallel_failure)
      if (!failure) failure = std::current_exception();
    }
  }
  if (failure) std::rethrow_exception(failure);
}

}  // namespace deformkit
