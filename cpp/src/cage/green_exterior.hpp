#pragma once
// The exterior extension of Green coordinates: outside the cage, every face's continuation of
// Lipman et al. 2008, §3.3, blended by normalised inverse squared distances to the closed faces,
// so that the map is C^1 off the cage and continuous across it
// (docs/math/green_coordinates.md, "Exterior extension").
#include "cage/green_coordinates.hpp"

#include <cstddef>

namespace deformkit {

// Adds the blended continuation at x to the coordinates: phi_jk += vertex_weight w_j alpha^j_k and
// psi_j += w_j alpha^j_4, with x = sum_k alpha^j_k v_jk + alpha^j_4 n_j through face j (foot
// barycentrics and height above the face) and w_j = d_j^-2 / sum_l d_l^-2 (d_j: the distance from
// x to the closed triangle j). Their gradients go into dphi (3m) and dpsi (3t) when not null; the
// weights' derivatives included. Where x is on faces (d_j = 0) those faces share the weight
// equally; their continuations agree there. Returns the nearest face (lowest index among equals).
// tables (may be null) saves recomputing the faces' normals and hat gradients, to the same bits.
// Two passes over the faces; a per-thread scratch of t offsets, grown once.
std::size_t add_exterior_continuation(const double x[3], const TriangleCageView& cage, const GreenCageTables* tables,
                                      double vertex_weight, double* phi, double* psi, double* dphi, double* dpsi);

}  // namespace deformkit
