#include "deformkit/core/stages.hpp"

#include <sys/resource.h>

namespace deformkit {

namespace {

long minor_faults() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);  // the whole process: a worker's first touches count as well
  return u.ru_minflt;
}

}  // namespace

StageClock::StageClock(Stages& out) : out_(out), start_(std::chrono::steady_clock::now()), faults_(minor_faults()) {}

void StageClock::mark(std::string name) {
  const auto now = std::chrono::steady_clock::now();
  const long faults = minor_faults();
  out_.push_back({std::move(name), std::chrono::duration<double>(now - start_).count(), faults - faults_});
  start_ = now;
  faults_ = faults;
}

void StageClock::add(const Stages& inner, const std::string& prefix) {
  const auto now = std::chrono::steady_clock::now();
  const long faults = minor_faults();
  double seconds = std::chrono::duration<double>(now - start_).count();
  long touched = faults - faults_;
  for (const Stage& s : inner) {
    out_.push_back({prefix + s.name, s.seconds, s.page_faults});
    seconds -= s.seconds, touched -= s.page_faults;
  }
  if (seconds > 1e-4) out_.push_back({prefix + "(rest)", seconds, touched});  // the callee's untimed part
  start_ = now;
  faults_ = faults;
}

}  // namespace deformkit
