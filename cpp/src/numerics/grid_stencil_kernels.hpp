#pragma once
// The row kernels of the grid solver, each over all columns of a Block. Rows go in fixed chunks,
// whichever thread runs them, and reductions add the chunks in order: the results are the same bit
// for bit on any number of threads.
#include "numerics/grid_stencil_level.hpp"
#include "core/parallel.hpp"

#include <algorithm>
#include <cstddef>
#include <vector>

namespace deformkit::numerics {

// serial: run every chunk on the calling thread (the tests compare it with the pool).
struct KernelRunner {
  bool serial = false;
};

constexpr std::size_t kChunkRows = 1024;

inline std::size_t chunk_count(std::size_t n) { return (n + kChunkRows - 1) / kChunkRows; }

// fn(chunk, begin, end) for every chunk of [0, n); on the pool when there is enough work.
template <class Fn>
void for_chunks(const KernelRunner& run, std::size_t n, Fn&& fn) {
  const std::size_t chunks = chunk_count(n);
  auto one = [&](std::size_t t) { fn(t, t * kChunkRows, std::min(n, (t + 1) * kChunkRows)); };
  if (run.serial || chunks < 4) {
    for (std::size_t t = 0; t < chunks; ++t) one(t);
    return;
  }
  parallel_tasks(int(chunks), [&](int t) { one(std::size_t(t)); });
}

// The multigrid cycle's kernels, in single precision (the level's `single` coefficients).
// Red-black Gauss-Seidel over the rows of one colour (their neighbours all have the other one);
// from_zero: the previous x is zero, so the rows are b / diagonal.
void colour_sweep(const KernelRunner& run, const StencilLevel& a, int colour, const BlockOf<float>& b, BlockOf<float>& x, bool from_zero);
// coarse_b = P^T (b - A x): the residual summed over each aggregate, never stored on the fine level.
void restrict_residual(const KernelRunner& run, const StencilLevel& a, const BlockOf<float>& b, const BlockOf<float>& x,
                       BlockOf<float>& coarse_b);
// x += scale P coarse_x
void prolong_add(const KernelRunner& run, const StencilLevel& a, const BlockOf<float>& coarse_x, float scale, BlockOf<float>& x);

// Conjugate gradients' kernels, in double, each fused with what reads the same rows next: every
// pass over a block is a pass over memory.
// q = A p; returns p . q per column.
std::vector<double> apply_stencil(const KernelRunner& run, const StencilLevel& a, const Block& p, Block& q);
// The squared norms of r per column, plain then row-normalised: [sum r^2 ..., sum (r / d)^2 ...].
std::vector<double> residual_norms(const KernelRunner& run, const StencilLevel& a, const Block& r);
// x += alpha p, r -= alpha q, r_single = r rounded to single; returns residual_norms(r).
std::vector<double> step_solution(const KernelRunner& run, const StencilLevel& a, const std::vector<double>& alpha, const Block& p,
                                  const Block& q, Block& x, Block& r, BlockOf<float>& r_single);
// p = z + beta p, beta per column, z the cycle's output.
void step_direction(const KernelRunner& run, const std::vector<double>& beta, const BlockOf<float>& z, Block& p);
// Per column: sum over rows of a * b.
std::vector<double> column_dots(const KernelRunner& run, const Block& a, const Block& b);
std::vector<double> column_dots(const KernelRunner& run, const Block& a, const BlockOf<float>& b);

}  // namespace deformkit::numerics
