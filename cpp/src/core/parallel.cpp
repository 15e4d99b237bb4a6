#include "core/parallel.hpp"

#include <Eigen/Core>

#include <pthread.h>

#include <atomic>

namespace deformkit {

namespace {
std::atomic<bool> g_forked{false};
// Eigen's own OpenMP regions (a row-major sparse matrix times a dense one) would hang too.
void mark_forked() {
  g_forked = true;
  Eigen::setNbThreads(1);
}
[[maybe_unused]] const int g_atfork = pthread_atfork(nullptr, nullptr, &mark_forked);
}  // namespace

bool forked_after_threads() { return g_forked.load(std::memory_order_relaxed); }

}  // namespace deformkit
