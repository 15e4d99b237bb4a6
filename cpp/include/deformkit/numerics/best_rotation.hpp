#pragma once
// The rotation R maximising tr(R S) for a 3x3 S: the ARAP local step (Sorkine and Alexa 2007,
// sec. 3). With S = U Sigma V^T it is V U^T, the orthogonal polar factor of S^T, taken with the
// reflection fix when det(V U^T) < 0.
#include "deformkit/core/types.hpp"

#include <cstddef>

namespace deformkit {

// One matrix: Higham's scaled Newton iteration on S^T; a (near-)singular or reflected S (a flat
// one-ring) takes the SVD with the reflection fix instead.
Mat3 best_rotation(const Mat3& s);

// Many matrices in structure-of-arrays form: component k = 3 * row + col of matrix i at
// s[k * count + i]; r has the same layout. The Newton iteration runs in SIMD lanes (run-time
// dispatch); lanes that need the SVD are finished one by one.
void best_rotations(const double* s, double* r, std::size_t count);

}  // namespace deformkit
