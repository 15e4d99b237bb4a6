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
// colour0_only: the rows of colour 1 are taken as solved (a colour-1 sweep came last: their
// residuals are zero but for rounding) and not read.
void restrict_residual(const KernelRunner& run, const StencilLevel& a, const BlockOf<float>& b, const BlockOf<float>& x,
                       BlockOf<float>& coarse_b, bool colour0_only);
// x += scale P coarse_x; colour0_only: on the rows of colour 0 alone (a colour-1 sweep, which does
// not read the old values of its rows, comes next).
void prolong_add(const KernelRunner& run, const StencilLevel& a, const BlockOf<float>& coarse_x, float scale, BlockOf<float>& x,
                 bool colour0_only);

// Conjugate gradients' kernels, in double, each fused with what reads the same rows next: every
// pass over a block is a pass over memory.
// q = A p in double; returns p . q per column.
std::vector<double> apply_stencil(const KernelRunner& run, const StencilLevel& a, const Block& p, Block& q);
std::vector<double> apply_stencil(const KernelRunner& run, const StencilLevel& a, const BlockOf<float>& p, Block& q);
// The squared norms of r per column, plain then row-normalised: [sum r^2 ..., sum (r / d)^2 ...].
std::vector<double> residual_norms(const KernelRunner& run, const StencilLevel& a, const Block& r);
// x += alpha p, r -= alpha q, r_single = r rounded to single; returns residual_norms(r).
std::vector<double> step_solution(const KernelRunner& run, const StencilLevel& a, const std::vector<double>& alpha, const BlockOf<float>& p,
                                  const Block& q, Block& x, Block& r, BlockOf<float>& r_single);
// p = z + beta p, beta per column, z the cycle's output; p rounded to single (see grid_stencil.cpp).
void step_direction(const KernelRunner& run, const std::vector<double>& beta, const BlockOf<float>& z, BlockOf<float>& p);
// Per column: sum over rows of a * b.
std::vector<double> column_dots(const KernelRunner& run, const Block& a, const Block& b);
std::vector<double> column_dots(const KernelRunner& run, const Block& a, const BlockOf<float>& b);
std::vector<double> column_dots(const KernelRunner& run, const BlockOf<float>& a, const BlockOf<float>& b);

}  // namespace deformkit::numerics
