#pragma once
// The order in which Blender's ray casts meet a cage's triangles. Blender's Mesh Deform keeps the
// first hit its BVH traversal reports, and after a hit it prunes boxes by the hit's distance
// divided by the ray's length (a normalised distance compared with world ones), so on a long ray
// the hit it keeps is not always the nearest one. To give the same answer, the tree is built as
// Blender builds its float AABB tree over the triangles (BLI_kdopbvh: leaves split by the
// largest axis of each branch, at implicit-tree positions, by quickselect on the boxes' maxima)
// and traversed in its order with its pruning (docs/math/mesh_deform.md, "The grid").
#include <array>
#include <functional>
#include <vector>

namespace deformkit::harmonic {

class BlenderBvh {
 public:
  // Triangles given by their corners' coordinates (float, as Blender holds them), in Blender's
  // order; arity: children per branch (Blender 4.2 and later: 2; before: 4).
  BlenderBvh(const std::vector<std::array<std::array<float, 3>, 3>>& triangles, int arity);

  // The ray from origin along +axis (sign 1) or -axis (sign -1), `length` long. meets(t, dist)
  // returns whether triangle t is hit at distance dist (>= 0, <= length) along the ray. Returns the
  // triangle Blender's traversal keeps, or -1.
  int first_hit(const float origin[3], int axis, int sign, float length,
                const std::function<bool(int, double&)>& meets) const;

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

}  // namespace deformkit::harmonic
