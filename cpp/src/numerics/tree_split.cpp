#include "numerics/tree_split.hpp"

#include <algorithm>
#include <numeric>
#include <queue>

namespace deformkit {

TreeSplit split_tree(const std::vector<std::int32_t>& parent, const std::vector<std::int64_t>& own_work, int threads,
                     std::int64_t min_work) {
  const std::int32_t n = std::int32_t(parent.size());
  TreeSplit out;
  out.ranges.assign(std::size_t(std::max(threads, 1)), {});
  // Subtree work, first node and size; postordered when every subtree is a contiguous range.
  std::vector<std::int32_t> first(static_cast<std::size_t>(n));
  std::vector<std::int64_t> work = own_work, count(std::size_t(n), 1);
  std::iota(first.begin(), first.end(), 0);
  bool postordered = true;
  std::vector<std::vector<std::int32_t>> children(static_cast<std::size_t>(n));
  for (std::int32_t j = 0; j < n; ++j) {
    const std::int32_t p = parent[std::size_t(j)];
    if (p < 0) continue;
    postordered &= p > j;
    if (p <= j) continue;
    work[p] += work[j];
    first[p] = std::min(first[p], first[j]);
    children[p].push_back(j);
    count[p] += count[j];
  }
  for (std::int32_t j = 0; j < n && postordered; ++j) postordered = count[j] == j - first[j] + 1;
  std::int64_t total = 0;
  for (std::int64_t w : own_work) total += w;
  if (threads <= 1 || !postordered || total < min_work) {
    out.ranges.resize(1);
    if (n) out.ranges[0].emplace_back(0, n - 1);
    return out;
  }
  // Greedy: cut the heaviest subtree (its root joins the top) until the subtrees share out over
  // the cores within 5%, or the top holds 15% of the work.
  auto heavier = [&](std::int32_t a, std::int32_t b) { return work[a] < work[b]; };
  std::priority_queue<std::int32_t, std::vector<std::int32_t>, decltype(heavier)> open(heavier);
  for (std::int32_t j = 0; j < n; ++j)
    if (parent[std::size_t(j)] < 0) open.push(j);
  std::int64_t top_work = 0;
  std::vector<std::int32_t> chosen;
  for (int step = 0; step < 1024 && !open.empty(); ++step) {
    std::vector<std::int32_t> subtrees;
    for (auto copy = open; !copy.empty(); copy.pop()) subtrees.push_back(copy.top());
    std::vector<std::int64_t> load(out.ranges.size(), 0);
    for (std::int32_t r : subtrees) *std::min_element(load.begin(), load.end()) += work[r];
    const std::int64_t busiest = *std::max_element(load.begin(), load.end());
    const std::int64_t share = (total - top_work) / std::int64_t(out.ranges.size());
    if (busiest <= share + share / 20 || top_work * 100 > total * 15) {
      chosen = subtrees;
      break;
    }
    const std::int32_t r = open.top();
    open.pop();
    out.top.push_back(r);
    top_work += own_work[std::size_t(r)];
    for (std::int32_t c : children[r]) open.push(c);
  }
  if (chosen.empty())
    for (; !open.empty(); open.pop()) chosen.push_back(open.top());
  std::vector<std::int64_t> load(out.ranges.size(), 0);
  for (std::int32_t r : chosen) {  // heaviest first, each to the least loaded core
    const auto t = std::size_t(std::min_element(load.begin(), load.end()) - load.begin());
    load[t] += work[r];
    out.ranges[t].emplace_back(first[r], r);
  }
  for (auto& list : out.ranges) std::sort(list.begin(), list.end());
  std::sort(out.top.begin(), out.top.end());
  return out;
}

}  // namespace deformkit
