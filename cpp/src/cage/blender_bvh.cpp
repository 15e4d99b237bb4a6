#include "cage/blender_bvh.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>

namespace deformkit::harmonic {

namespace {

// Where the leaves of each branch of an implicit tree of kArity children per branch start, for
// `leaves` leaves all at the two deepest levels (Blender's "min-leaf generalized implicit tree").
struct ImplicitTree {
  ImplicitTree(int leaves, int kArity) : leaves(leaves) {
    per_child[0] = 1;
    while (per_child[0] < leaves) per_child[0] *= kArity;
    on_level[0] = 1;
    for (int d = 1; d < 32 && per_child[d - 1]; ++d) {
      on_level[d] = on_level[d - 1] * kArity;
      per_child[d] = per_child[d - 1] / kArity;
    }
    const int remain = leaves - per_child[1];
    const int extra = (remain + kArity - 2) / (kArity - 1);
    remain_leaves = remain + extra;
  }
  int first_leaf(int depth, int child) const {
    const int lo = child * per_child[depth - 1];
    if (lo <= remain_leaves) return lo;
    if (per_child[depth]) return leaves - (on_level[depth - 1] - child) * per_child[depth];
    return remain_leaves;
  }
  int leaves;
  int per_child[32] = {0};
  int on_level[32] = {0};
  int remain_leaves = 0;
};

int branches_needed(int leaves, int kArity) { return std::max(1, (leaves + kArity - 3) / (kArity - 1)); }

// Quickselect as Blender's BVH does it (median of three, Hoare partition, insertion sort below
// four elements): which elements end up on which side of n, ties included, depends on these steps.
struct Selector {
  std::vector<int>& order;
  const std::vector<float>& key;
  float k(int slot) const { return key[std::size_t(order[std::size_t(slot)])]; }
  void insertion_sort(int lo, int hi) {
    for (int i = lo; i < hi; ++i) {
      const int moving = order[std::size_t(i)];
      int j = i;
      while (j != lo && key[std::size_t(moving)] < k(j - 1)) {
        order[std::size_t(j)] = order[std::size_t(j - 1)];
        --j;
      }
      order[std::size_t(j)] = moving;
    }
  }
  float median_of_three(int lo, int mid, int hi) const {
    const float a = k(lo), b = k(mid), c = k(hi);
    if (b < a) {
      if (c < b) return b;
      if (c < a) return c;
      return a;
    }
    if (c < b) {
      if (c < a) return a;
      return c;
    }
    return b;
  }
  int partition(int lo, int hi, float pivot) {
    int i = lo, j = hi;
    for (;;) {
      while (k(i) < pivot) ++i;
      --j;
      while (pivot < k(j)) --j;
      if (!(i < j)) return i;
      std::swap(order[std::size_t(i)], order[std::size_t(j)]);
      ++i;
    }
  }
  void nth_element(int begin, int end, int n) {
    while (end - begin > 3) {
      const int cut = partition(begin, end, median_of_three(begin, (begin + end) / 2, end - 1));
      if (cut <= n) begin = cut;
      else end = cut;
    }
    insertion_sort(begin, end);
  }
};

}  // namespace

BlenderBvh::BlenderBvh(const std::vector<std::array<std::array<float, 3>, 3>>& triangles, int arity) {
  const int kArity = arity;
  const int leaves = int(triangles.size());
  if (leaves == 0) return;
  // Leaves first (their boxes widened by FLT_EPSILON, Blender's smallest tree epsilon), then
  // branch j (1-based, as the implicit tree numbers them) at leaves + j - 1.
  const int branches = branches_needed(leaves, kArity);
  nodes_.resize(std::size_t(leaves + branches));
  for (int t = 0; t < leaves; ++t) {
    Node& n = nodes_[std::size_t(t)];
    n.triangle = t;
    for (int a = 0; a < 3; ++a) {
      float lo = FLT_MAX, hi = -FLT_MAX;
      for (const auto& p : triangles[std::size_t(t)]) {
        lo = std::min(lo, p[std::size_t(a)]);
        hi = std::max(hi, p[std::size_t(a)]);
      }
      n.box[2 * a] = lo - FLT_EPSILON;
      n.box[2 * a + 1] = hi + FLT_EPSILON;
    }
  }
  auto branch = [&](int j) -> Node& { return nodes_[std::size_t(leaves + j - 1)]; };
  std::vector<int> order(static_cast<std::size_t>(leaves));
  for (int t = 0; t < leaves; ++t) order[std::size_t(t)] = t;
  root_ = leaves;
  if (leaves == 1) {
    Node& r = branch(1);
    std::copy(nodes_[0].box, nodes_[0].box + 6, r.box);
    r.children[0] = 0;
    r.child_count = 1;
    return;
  }
  const ImplicitTree tree(leaves, kArity);
  std::vector<float> key(static_cast<std::size_t>(leaves));
  for (int first = 1, depth = 1; first <= branches; first = first * kArity + 2 - kArity, ++depth) {
    const int next_level = first * kArity + 2 - kArity;
    const int stop = std::min(next_level, branches + 1);
    for (int j = first; j < stop; ++j) {
      Node& parent = branch(j);
      const int begin = tree.first_leaf(depth, j - first), end = tree.first_leaf(depth, j - first + 1);
      for (int a = 0; a < 3; ++a) {
        parent.box[2 * a] = FLT_MAX;
        parent.box[2 * a + 1] = -FLT_MAX;
      }
      for (int s = begin; s < end; ++s) {
        const Node& leaf = nodes_[std::size_t(order[std::size_t(s)])];
        for (int a = 0; a < 3; ++a) {
          parent.box[2 * a] = std::min(leaf.box[2 * a], parent.box[2 * a]);
          parent.box[2 * a + 1] = std::max(leaf.box[2 * a + 1], parent.box[2 * a + 1]);
        }
      }
      const float ex = parent.box[1] - parent.box[0], ey = parent.box[3] - parent.box[2],
                  ez = parent.box[5] - parent.box[4];
      const int axis = ex > ey ? (ex > ez ? 0 : 2) : (ey > ez ? 1 : 2);
      parent.main_axis = axis;
      for (int t = 0; t < leaves; ++t) key[std::size_t(t)] = nodes_[std::size_t(t)].box[2 * axis + 1];
      int nth[33];
      nth[0] = begin;
      nth[kArity] = end;
      for (int c = 1; c < kArity; ++c) nth[c] = tree.first_leaf(depth + 1, j * kArity + 2 - kArity + c - next_level);
      Selector select{order, key};
      for (int c = 0; c < kArity - 1; ++c) {
        if (nth[c] >= nth[kArity]) break;
        select.nth_element(nth[c], nth[kArity], nth[c + 1]);
      }
      int c = 0;
      for (; c < kArity; ++c) {
        const int child = j * kArity + 2 - kArity + c;
        const int cb = tree.first_leaf(depth + 1, child - next_level), ce = tree.first_leaf(depth + 1, child - next_level + 1);
        if (ce - cb > 1) parent.children[c] = leaves + child - 1;
        else if (ce - cb == 1) parent.children[c] = order[std::size_t(cb)];
        else break;
      }
      parent.child_count = c;
    }
  }
}

}  // namespace deformkit::harmonic
