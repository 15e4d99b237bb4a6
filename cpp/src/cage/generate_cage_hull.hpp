#pragma once
// The small linear program of progressive hulls (Sander, Gu, Gortler, Hoppe, Snyder 2000,
// "Silhouette clipping", Sec. 4; docs/cage.md, "Generated cages"): where a collapsed edge's vertex
// goes so that the coarser cage still encloses the finer one while adding the least volume.
#include "deformkit/core/types.hpp"

#include <optional>
#include <vector>

namespace deformkit::cage_generation {

// The closed half-space normal . x >= offset (normal of unit length).
struct HalfSpace {
  Vec3 normal;
  double offset = 0.0;
};

// The point of the box [lo, hi] inside every half-space that minimizes objective . x (Seidel's
// incremental linear programming in three, two and one dimensions), or nothing when none is.
std::optional<Vec3> lowest_point(const Vec3& objective, const std::vector<HalfSpace>& constraints,
                                 const Vec3& lo, const Vec3& hi);

}  // namespace deformkit::cage_generation
