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
// t and base are the run's structure-of-arrays coordinates and positions. Returns false if some
// result is not finite.
bool lattice_cell_kernel(const KernelAxis axes[3], const float* block, const float* const t[3],
                         const float* const base[3], const std::uint32_t* order, std::size_t count, float* out);
bool lattice_cell_kernel(const KernelAxis axes[3], const double* block, const double* const t[3],
                         const double* const base[3], const std::uint32_t* order, std::size_t count, double* out);

}  // namespace deformkit
