#pragma once
// Signs decided exactly on a cage's input doubles (CGAL's exact predicates): the family's one use
// of CGAL lives in exact_geometry.cpp, so no CGAL type reaches a header (docs/cage.md, "Cage validity").
#include "deformkit/core/types.hpp"

namespace deformkit::cage_exact {

// The exact sign (-1, 0 or 1) of component `axis` of (b - a) x (c - a): the turn of a, b, c seen
// from +axis, i.e. the orientation of their projection onto the plane that drops that coordinate.
int turn_along(const Vec3& a, const Vec3& b, const Vec3& c, int axis);

}  // namespace deformkit::cage_exact
