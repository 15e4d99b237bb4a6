#include "deformkit/core/stages.hpp"

#include <sys/resource.h>
#include <time.h>

namespace deformkit {

namespace {

long minor_faults() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);  // the whole process: a worker's first touches count as well
  return u.ru_minflt;
}

double thread_cpu() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

}  // namespace

StageClock::StageClock(Stages& out)
    : out_(out), start_(std::chrono::steady_clock::now()), cpu_(thread_cpu()), faults_(minor_faults()) {}

void StageClock::mark(std::string name) {
  const auto now = std::chrono::steady_clock::now();
  const double cpu = thread_cpu();
  const long faults = minor_faults();
  out_.push_back({std::move(name), std::chrono::duration<double>(now - start_).count(), cpu - cpu_, faults - faults_});
  start_ = now;
  cpu_ = cpu;
  faults_ = faults;
}

void StageClock::add(const Stages& inner, const std::string& prefix) {
  const auto now = std::chrono::steady_clock::now();
  const double cpu = thread_cpu();
  const long faults = minor_faults();
  double seconds = std::chrono::duration<double>(now - start_).count(), cpu_seconds = cpu - cpu_;
  long touched = faults - faults_;
  for (const Stage& s : inner) {
    out_.push_back({prefix + s.name, s.seconds, s.cpu_seconds, s.page_faults});
    seconds -= s.seconds, cpu_seconds -= s.cpu_seconds, touched -= s.page_faults;
  }
  if (seconds > 1e-4) out_.push_back({prefix + "(rest)", seconds, cpu_seconds, touched});  // the callee's untimed part
  start_ = now;
  cpu_ = cpu;
  faults_ = faults;
}

}  // namespace deformkit
