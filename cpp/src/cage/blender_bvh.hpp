#pragma once
// The order in which Blender's ray casts meet a cage's triangles. Blender's Mesh Deform keeps the
// first hit its BVH traversal reports, and after a hit it prunes boxes by the hit's distance
// divided by the ray's length (a normalised distance compared with world ones), so on a long ray
// the hit it keeps is not always the nearest one. To give the same answer, the tree is built as
// Blender builds its float AABB tree over the triangles (BLI_kdopbvh: leaves split by the
// largest axis of each branch, at implicit-tree positions, by quickselect on the boxes' maxima)
// and traversed in its order with its pruning (docs/math/mesh_deform.md, "The grid").
#include <algorithm>
#include <array>
#include <cfloat>
#include <vector>

namespace deformkit::harmonic {

class BlenderBvh {
 public:
  // Triangles given by their corners' coordinates (float, as Blender holds them), in Blender's
  // order; arity: children per branch (Blender 4.2 and later: 2; before: 4).
  BlenderBvh(const std::vector<std::array<std::array<float, 3>, 3>>& triangles, int arity);

  // The deepest traversal stack: (arity - 1) pending siblings per level of at most 32 levels.
  static constexpr int kMaxStack = 3 * 32 + 1;

  // The ray from origin along +axis (sign 1) or -axis (sign -1), `length` long. meets(t, dist)
  // returns whether triangle t is hit at distance dist (>= 0, <= length) along the ray. Returns the
  // triangle Blender's traversal keeps, or -1.
  template <class Meets>
  int first_hit(const float origin[3], int axis, int sign, float length, Meets&& meets) const;

 private:
  struct Node {
    float box[6];   // min x, max x, min y, max y, min z, max z
    int main_axis = 0;
    int children[4] = {-1, -1, -1, -1};  // node indices
    int child_count = 0;
    int triangle = -1;                   // a leaf's triangle
  };
  std::vector<Node> nodes_;
  int root_ = -1;
};

template <class Meets>
int BlenderBvh::first_hit(const float origin[3], int axis, int sign, float length, Meets&& meets) const {
  if (root_ < 0) return -1;
  // The ray's slab factors as Blender precomputes them: 1/direction, FLT_MAX across the ray.
  float inverse[3] = {FLT_MAX, FLT_MAX, FLT_MAX};
  inverse[axis] = 1.0f / float(sign);
  int near[3], far[3];
  for (int a = 0; a < 3; ++a) {
    near[a] = 2 * a + (inverse[a] < 0.0f ? 1 : 0);
    far[a] = 2 * a + (inverse[a] < 0.0f ? 0 : 1);
  }
  float best = FLT_MAX / 2.0f;  // normalised by `length` once a hit is kept
  int found = -1;
  // Blender's recursion in preorder: a node's children pushed last to first, so the first is
  // visited first (last first when the ray runs against the node's main axis).
  int stack[kMaxStack];
  int top = 0;
  stack[top++] = root_;
  while (top > 0) {
    const Node& n = nodes_[std::size_t(stack[--top])];
    float t1[3], t2[3];  // float as Blender computes them (overflow to inf included)
    for (int a = 0; a < 3; ++a) {
      t1[a] = (n.box[near[a]] - origin[a]) * inverse[a];
      t2[a] = (n.box[far[a]] - origin[a]) * inverse[a];
    }
    if (t1[0] > t2[1] || t2[0] < t1[1] || t1[0] > t2[2] || t2[0] < t1[2] || t1[1] > t2[2] || t2[1] < t1[2]) continue;
    if (t2[0] < 0.0f || t2[1] < 0.0f || t2[2] < 0.0f) continue;
    if (t1[0] > best || t1[1] > best || t1[2] > best) continue;
    const float entry = std::max({t1[0], t1[1], t1[2]});
    if (entry >= best) continue;
    if (n.triangle >= 0) {
      double at = 0.0;
      if (!meets(n.triangle, at) || !(at >= 0.0) || at > double(length)) continue;
      const float normalised = float(at) / length;
      if (normalised < best) {
        best = normalised;
        found = n.triangle;
      }
      continue;
    }
    const bool forward = (n.main_axis == axis ? float(sign) : 0.0f) > 0.0f;
    for (int c = 0; c < n.child_count; ++c) stack[top++] = n.children[forward ? n.child_count - 1 - c : c];
  }
  return found;
}

}  // namespace deformkit::harmonic
