#include "deformkit/parallel.hpp"

#include <pthread.h>

#include <atomic>

namespace deformkit {

namespace {
std::atomic<bool> g_forked{false};
void mark_forked() { g_forked = true; }
[[maybe_unused]] const int g_atfork = pthread_atfork(nullptr, nullptr, &mark_forked);
}  // namespace

bool forked_after_threads() { return g_forked.load(std::memory_order_relaxed); }

}  // namespace deformkit
