#pragma once
// SIMD kernel for one cell of a lattice: every point in the run shares the cell's control
// points, so they are broadcast and the points fill the vector lanes (Highway, run-time dispatch).
#include <cstddef>
#include <cstdint>

namespace deformkit {

enum class KernelBasis : int { Bernstein, CubicBSpline, Linear, Cardinal, Constant };

struct KernelAxis {
  KernelBasis basis = KernelBasis::Bernstein;
  int width = 4;      // weights along the axis (Bernstein: degree + 1)
  double tension = 0;  // cardinal fc
};

// out[order[i]] = base_i + sum_ijk w_i(t0) w_j(t1) w_k(t2) block[i][j][k] for i < count, where
// t and base are the run's structure-of-arrays coordinates and positions. With base null, the
// displacement alone (the sum), scaled by weights[order[i]] when weights is not null. Returns
// false if some result is not finite.
bool lattice_cell_kernel(const KernelAxis axes[3], const float* block, const float* const t[3],
                         const float* const base[3], const std::uint32_t* order, std::size_t count, float* out,
                         const double* weights = nullptr);
bool lattice_cell_kernel(const KernelAxis axes[3], const double* block, const double* const t[3],
                         const double* const base[3], const std::uint32_t* order, std::size_t count, double* out,
                         const double* weights = nullptr);

enum class CellDerivative : int { Jacobian, Normal, Determinant };

// One cell's run of points for the derivative kernels: its points are order[0..count), which
// index weights, normals, out and flags; t are their local coordinates, ds per axis d(t)/d(s)
// (0 where the axis is clamped, so the map does not vary along it).
template <class T>
struct CellRun {
  const T* block = nullptr;  // the cell's strength * (P - R), as lattice_cell_kernel's; null: J = I
  const T* t[3] = {};
  const T* ds[3] = {};
  const std::uint32_t* order = nullptr;
  std::size_t count = 0;
};

// J = I + w (D P) at each point of the run, where D's column a is ds_a d/dt_a sum w_ijk block_ijk
// and P the constant d(s)/dx of a box lattice (row-major); weights: null, or Blender's vertex
// group per point. Writes, per `what`, out[9p..9p+9) (J row-major), out[3p..3p+3) (the unit normal
// cof(J) n carried from normals[3p..]) or out[p] (det J). Returns false when some point needs the
// scalar path (a result not finite, a zero normal, a magnitude the lanes could underflow on), after
// setting flags[p] = 1 for each such point.
bool lattice_cell_derivatives(CellDerivative what, const KernelAxis axes[3], const double P[9], const double* weights,
                              const CellRun<double>& run, const double* normals, double* out, unsigned char* flags);
bool lattice_cell_derivatives(CellDerivative what, const KernelAxis axes[3], const double P[9], const double* weights,
                              const CellRun<float>& run, const float* normals, float* out, unsigned char* flags);

}  // namespace deformkit
