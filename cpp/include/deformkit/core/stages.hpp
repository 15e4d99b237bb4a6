#pragma once
// Where a long set-up (a bind's assembly, ordering and factorisation) spends its time: one entry
// per stage, wall time, the calling thread's CPU time (below the wall time when other programs
// take the core; the pool's workers not counted) and the minor page faults (first touches of
// fresh memory) taken in it.
#include <chrono>
#include <string>
#include <vector>

namespace deformkit {

struct Stage {
  std::string name;
  double seconds = 0, cpu_seconds = 0;
  long page_faults = 0;
};
using Stages = std::vector<Stage>;

// mark(name) closes the stage that began at the previous mark (or at construction).
class StageClock {
 public:
  explicit StageClock(Stages& out);
  void mark(std::string name);
  // Closes the stage since the previous mark as `inner`, a callee's stages, named with `prefix`
  // (and what they leave out of the elapsed time as prefix + "(rest)").
  void add(const Stages& inner, const std::string& prefix);

 private:
  Stages& out_;
  std::chrono::steady_clock::time_point start_;
  double cpu_;
  long faults_;
};

}  // namespace deformkit
