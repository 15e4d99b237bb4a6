#pragma once
// Sharing a triangular solve over cores: disjoint subtrees of the elimination tree never touch
// each other's rows, so each core takes whole subtrees and one core solves the rest (the top of
// the tree, the last separators).
#include <cstdint>
#include <utility>
#include <vector>

namespace deformkit {

struct TreeSplit {
  // Per core, node ranges [first, root], each a whole subtree in a postordered tree.
  std::vector<std::vector<std::pair<std::int32_t, std::int32_t>>> ranges;
  std::vector<std::int32_t> top;  // the other nodes, ascending
};

// parent[j]: j's parent (> j in a postorder) or -1; work[j]: j's own work. One range over all
// nodes when threads <= 1, the tree is not postordered, or the total work is below min_work.
TreeSplit split_tree(const std::vector<std::int32_t>& parent, const std::vector<std::int64_t>& work, int threads,
                     std::int64_t min_work);

}  // namespace deformkit
