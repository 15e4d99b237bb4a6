#pragma once
// Green coordinates of a closed triangle cage in 3D (Lipman, Levin, Cohen-Or 2008), as free
// functions on raw arrays, with exact gradients and an exterior extension that blends the paper's
// per-face continuations (§3.3).
// The formulas as implemented: docs/math/green_coordinates.md.
//
// Every function here is allocation-free and re-entrant: the coordinates of one point write only
// into the caller's arrays, so a parallel loop over points needs no locking and no scratch.
#include <cstddef>

namespace deformkit {

struct GreenCageTables;  // cage/green_rows.hpp

// A closed, consistently oriented triangle cage: points m x 3 (row-major) and triangles t x 3
// whose vertices run counter-clockwise seen from outside (outward normals). Validation (closed,
// manifold, non-degenerate) is the caller's: a zero-area triangle here contributes nothing.
struct TriangleCageView {
  const double* points = nullptr;
  std::size_t point_count = 0;
  const int* triangles = nullptr;
  std::size_t triangle_count = 0;
};

// Where a point's coordinates came from: inside, the Green integrals alone; outside, the
// integrals plus the exterior extension (every face's continuation, weighted by inverse squared
// distance; `face` is the nearest triangle, the one of largest weight); on the cage surface
// (where the winding number is fractional), the integrals' limit from inside
// (docs/math/green_coordinates.md, "Exterior extension"; docs/math/green_coordinates.md, "On the cage").
struct GreenSide {
  bool outside = false;
  bool on_surface = false;
  std::size_t face = 0;  // the nearest triangle when outside or on the surface
  double winding = 1.0;  // sum of the raw phi: the cage's winding number about x
};

// The raw Green integrals at x: phi (m) and psi (t), overwritten; their gradients
// with respect to x into dphi (3m: dphi[3i + c] = d phi_i / d x_c) and dpsi (3t) when not null.
// Inside the cage they reproduce x (sum phi_i v_i + sum psi_j n_j = x, sum phi_i = 1); outside both
// sums are 0. Finite everywhere; on the cage surface, the principal value (a face's own double
// layer is 0 on its plane), so sum phi there is the fractional winding number.
void green_integrals(const double x[3], const TriangleCageView& cage, double* phi, double* psi, double* dphi,
                     double* dpsi);

// Green coordinates at x, inside, on and outside the cage: the raw integrals, and for a point
// outside the cage (winding number 0) the blend of §3.3's continuations: with
// x = sum_k alpha^j_k v_jk + alpha^j_4 n_j through each triangle j and w_j = d_j^-2 / sum d^-2
// (d_j the distance to the closed triangle), phi_jk += w_j alpha^j_k, psi_j += w_j alpha^j_4
// (on the cage: phi_jk += (1 - winding) alpha_k of the faces through x, the inside limit). Linear
// reproduction then holds everywhere, and the deformed point is C^1 outside and continuous across
// the cage surface. On the cage's
// edges and vertices the map is continuous but not differentiable: the gradients there are finite
// (the log-singular edge terms are dropped) but not derivatives. The cage's tables (green_cage_tables,
// may be null) save the extension recomputing each face's normal and hat gradients; same result.
GreenSide green_coordinates(const double x[3], const TriangleCageView& cage, double* phi, double* psi, double* dphi,
                            double* dpsi, const GreenCageTables* tables = nullptr);

// What green_coordinates() adds to the raw integrals at x (values only), given their winding
// number: nothing inside, else the exterior extension or the on-surface limit.
GreenSide green_extension(const double x[3], const TriangleCageView& cage, double winding, double* phi,
                          double* psi, const GreenCageTables* tables = nullptr);

// Lipman's per-triangle stretch factors s_j into out (t), from the edges u, v of t_j at rest and
// u', v' deformed: 1 at rest, sigma under a similarity of scale sigma
// (docs/math/green_coordinates.md, "Stretch factor").
void green_stretch_factors(const double* rest_points, const double* deformed_points, const int* triangles,
                           std::size_t triangle_count, double* out);

// The face control values s_j n(t'_j) (3t; unit outward normals of the deformed triangles),
// with s_j = 1 for every triangle when stretch is null.
void green_scaled_normals(const double* deformed_points, const int* triangles, std::size_t triangle_count,
                          const double* stretch, double* out);

// F = sum_i phi_i v'_i + sum_j psi_j s_j n(t'_j) (Lipman et al. 2008, §3) into out[3], and its Jacobian
// (row-major 3 x 3, dF_r / dx_c) into jacobian when not null (then dphi and dpsi are required).
// The face terms come precomputed from green_scaled_normals.
void green_deform_point(const double* phi, const double* psi, const double* dphi, const double* dpsi,
                        const double* deformed_points, std::size_t point_count, const double* scaled_normals,
                        std::size_t triangle_count, double out[3], double* jacobian);

// The same from the deformed cage and stretch factors (null: s = 1), computing the normals here:
// for one point; a loop over points calls green_scaled_normals once and the overload above.
void green_deform_point(const double* phi, const double* psi, const double* dphi, const double* dpsi,
                        const TriangleCageView& deformed, const double* stretch, double out[3], double* jacobian);

}  // namespace deformkit
