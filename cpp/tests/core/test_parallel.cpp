// parallel_blocks (cpp/src/core/parallel.hpp) against its contract: every index in exactly one
// block, blocks contiguous and at most parallel_threads() of them, an exception in a block
// rethrown on the caller, nested calls and calls from several threads at once completing.
#include "core/parallel.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <thread>
#include <vector>

using namespace deformkit;

namespace {

// Counts how often each index is visited and how many blocks ran.
void cover(std::size_t n, std::vector<int>& visits, int& blocks) {
  visits.assign(n, 0);
  std::atomic<int> count{0};
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    ASSERT_LT(begin, end);
    ++count;
    for (std::size_t i = begin; i < end; ++i) ++visits[i];
  });
  blocks = count.load();
}

}  // namespace

TEST(ParallelBlocks, EveryIndexOnceInAtMostOneBlockPerThread) {
  for (std::size_t n : {std::size_t(0), std::size_t(1), 2 * kParallelGrain - 1, 2 * kParallelGrain,
                        2 * kParallelGrain + 1, std::size_t(1000003)}) {
    std::vector<int> visits;
    int blocks = 0;
    cover(n, visits, blocks);
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(visits[i], 1) << "n = " << n << ", index " << i;
    EXPECT_LE(blocks, parallel_threads());
    if (n < 2 * kParallelGrain) EXPECT_LE(blocks, 1);
  }
}

TEST(ParallelBlocks, ManyJobsInARowEachCompleteBeforeTheNext) {
  // Workers that wake late must never take a block of a newer job with an older job's task.
  const std::size_t n = 2 * kParallelGrain + 7;
  std::vector<int> visits(n);
  for (int job = 0; job < 3000; ++job) {
    parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) visits[i] += 1;
    });
  }
  for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(visits[i], 3000) << "index " << i;
}

TEST(ParallelBlocks, AnExceptionInABlockReachesTheCaller) {
  const std::size_t n = 4 * kParallelGrain;
  std::atomic<std::size_t> done{0};
  EXPECT_THROW(parallel_blocks(n,
                               [&](std::size_t begin, std::size_t end) {
                                 if (begin == 0) throw std::runtime_error("first block");
                                 done += end - begin;
                               }),
               std::runtime_error);
  std::vector<int> visits;
  int blocks = 0;
  cover(n, visits, blocks);  // the pool is usable afterwards
  for (int v : visits) ASSERT_EQ(v, 1);
}

TEST(ParallelBlocks, NestedCallsAndCallsFromSeveralThreadsComplete) {
  const std::size_t n = 4 * kParallelGrain;
  std::vector<std::atomic<int>> visits(n);
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    parallel_blocks(end - begin, [&](std::size_t b, std::size_t e) {  // nested: runs on this thread
      for (std::size_t i = b; i < e; ++i) ++visits[begin + i];
    });
  });
  for (auto& v : visits) ASSERT_EQ(v.load(), 1);
  std::vector<std::thread> callers;
  std::vector<std::vector<int>> results(6);
  for (int t = 0; t < 6; ++t)
    callers.emplace_back([&, t] {
      for (int repeat = 0; repeat < 50; ++repeat) {
        std::vector<int>& r = results[std::size_t(t)];
        r.assign(n, 0);
        parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
          for (std::size_t i = begin; i < end; ++i) r[i] += t + 1;
        });
        for (int v : r) ASSERT_EQ(v, t + 1);
      }
    });
  for (auto& c : callers) c.join();
}
