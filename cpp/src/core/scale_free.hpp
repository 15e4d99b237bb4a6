#pragma once
// 3x3 and vector arithmetic that neither overflows nor underflows on its way to a representable
// answer: operands are brought near 1 by powers of two, which scale exactly.
#include "deformkit/core/types.hpp"

namespace deformkit {

// v / |v|, or zero for a zero vector, whatever the magnitude of v (1e-310 or 1e300 alike).
Vec3 normalized_or_zero(const Vec3& v);

// The direction of cof(J) n = det(J) J^-T n, normalised (zero where J collapses n's plane), for
// any finite J: where the products of its entries would leave the double range it works on
// J = D1 K D2 with power-of-two diagonals, since cof(J) is cof(D1) cof(K) cof(D2).
Vec3 normal_direction(const Mat3& j, const Vec3& n);

// det(J), computed on J = D1 K D2 as det(D1) det(K) det(D2) when the entries are so large or
// small that the products would overflow or underflow: infinite only when det(J) itself is.
double scaled_determinant(const Mat3& j);

}  // namespace deformkit
