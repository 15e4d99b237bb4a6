#pragma once
// Static split of [0, n) into contiguous blocks over the machine's cores (OpenMP).
#include <omp.h>

#include <algorithm>
#include <cstddef>

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
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int b = 0; b < threads; ++b) {
    const std::size_t begin = std::min(n, b * block), end = std::min(n, begin + block);
    if (begin < end) fn(begin, end);
  }
}

}  // namespace deformkit
