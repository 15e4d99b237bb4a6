#pragma once
// Fill-reducing orderings (AMD), remembered by the pattern they were computed for: a rebind with
// the same connectivity (another method, other iterations, the file reloaded, other anchors and
// handles) skips the ordering, which on a 100k-vertex mesh costs about as much as the assembly.
// Any permutation gives a correct factorisation, so a colliding key could only cost fill.
#include "deformkit/numerics/sparse_cholesky.hpp"

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

namespace deformkit {

using Ordering = std::vector<std::int64_t>;  // new position k holds old index ordering[k]

// AMD on the pattern of a (its lower triangle).
Ordering amd_ordering(const SymmetricLower& a);

// The ordering stored under key, else compute() stored under it (the last few keys are kept).
// hit: set to whether it was stored.
std::shared_ptr<const Ordering> remembered_ordering(std::uint64_t key, const std::function<Ordering()>& compute,
                                                    bool* hit = nullptr);

// Forgets every remembered ordering (benchmarks: the next bind of any connectivity is a first one).
void forget_remembered_orderings();

// An ordering of n unknowns restricted to those with new_index[i] >= 0, each becoming `width`
// consecutive ones (new_index[i] * width + 0 .. width - 1), in the same relative order: removing
// unknowns from an elimination order never adds fill.
Ordering restricted_ordering(const Ordering& ordering, const std::vector<int>& new_index, int width = 1);

}  // namespace deformkit
