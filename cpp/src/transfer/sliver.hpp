#pragma once
// Triangles too thin for a deformation gradient: the rest frame's normal (Sumner and Popovic 2004,
// eq. 1) and the gradient's inverse (eq. 3) are set by rounding once the area is a tiny fraction
// of the longest edge squared (docs/math/transfer.md, "Thin triangles").
#include "deformkit/core/polygon_mesh.hpp"

#include <cstddef>

namespace deformkit {

// Area over longest edge squared below this is refused: the rest normal's rounding (about
// 1e-16 / shape) would pass 1e-8 of it, and a smooth pose's gradient grows as 1 / shape.
constexpr double kThinnestTriangle = 1e-8;

// Area over longest edge squared (an equilateral triangle: sqrt(3) / 4), for any finite corners:
// the edges are divided by their largest coordinate first, so nothing overflows or underflows.
double triangle_shape(const double* a, const double* b, const double* c);

// Throws std::invalid_argument naming `argument`, the first triangle thinner than
// kThinnestTriangle and its vertices. `triangles` holds triangles only.
void require_no_sliver(const PolygonMesh& triangles, const char* argument);

}  // namespace deformkit
