#include "numerics/grid_stencil_kernels.hpp"

#include "numerics/grid_stencil_simd.hpp"

namespace deformkit::numerics {

namespace {

template <class T>
std::array<const T*, 6> neighbour_rows(const StencilLevel& a, const BlockOf<T>& x, std::size_t u) {
  std::array<const T*, 6> r;
  for (int k = 0; k < 6; ++k) r[std::size_t(k)] = x.row(std::size_t(a.neighbour[u][std::size_t(k)]));
  return r;
}

}  // namespace

void colour_sweep(const KernelRunner& run, const StencilLevel& a, int colour, const BlockOf<float>& b, BlockOf<float>& x, bool from_zero) {
  const std::vector<int>& rows = a.colour[std::size_t(colour)];
  for_chunks(run, rows.size(), [&](std::size_t, std::size_t begin, std::size_t end) {
    sweep_rows(rows.data() + begin, end - begin, a.single.inverse_diagonal.data(), a.single.coupling.data(), a.neighbour.data(), b.data.data(),
               x.data.data(), x.width, from_zero);
  });
}

void restrict_residual(const KernelRunner& run, const StencilLevel& a, const BlockOf<float>& b, const BlockOf<float>& x,
                       BlockOf<float>& coarse_b, bool colour0_only) {
  const int* child_end = colour0_only ? a.colour0_end.data() : a.child_start.data() + 1;
  for_chunks(run, a.child_start.size() - 1, [&](std::size_t, std::size_t begin, std::size_t end) {
    restrict_rows(a.child_start.data(), child_end, a.child.data(), begin, end, a.single.diagonal.data(), a.single.coupling.data(), a.neighbour.data(),
                  b.data.data(), x.data.data(), coarse_b.data.data(), x.width);
  });
}

void prolong_add(const KernelRunner& run, const StencilLevel& a, const BlockOf<float>& coarse_x, float scale, BlockOf<float>& x,
                 bool colour0_only) {
  const int w = x.width;
  const std::vector<int>& rows = a.colour[0];
  const std::size_t n = colour0_only ? rows.size() : a.size;
  for_chunks(run, n, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const std::size_t u = colour0_only ? std::size_t(rows[i]) : i;
      const float* e = coarse_x.row(std::size_t(a.parent[u]));
      float* out = x.row(u);
#pragma omp simd
      for (int c = 0; c < w; ++c) out[c] += scale * e[c];
    }
  });
}

namespace {

// Per column, the sum over rows of what fn(begin, end, sums) adds into sums: per chunk, then the
// chunks in order, so the sums do not depend on the threads.
template <class Fn>
std::vector<double> chunk_sums(const KernelRunner& run, std::size_t rows, int width, Fn&& fn) {
  const std::size_t w = std::size_t(width), chunks = chunk_count(rows);
  std::vector<double> partial(chunks * w, 0.0);
  for_chunks(run, rows, [&](std::size_t t, std::size_t begin, std::size_t end) { fn(begin, end, partial.data() + t * w); });
  std::vector<double> total(w, 0.0);
  for (std::size_t t = 0; t < chunks; ++t)
    for (std::size_t c = 0; c < w; ++c) total[c] += partial[t * w + c];
  return total;
}

}  // namespace

namespace {

// q = A p in double, whichever precision p is stored in; returns p . q per column.
template <class T>
std::vector<double> apply_stencil_of(const KernelRunner& run, const StencilLevel& a, const BlockOf<T>& p, Block& q) {
  const int w = p.width;
  return chunk_sums(run, a.size, w, [&](std::size_t begin, std::size_t end, double* s) {
    for (std::size_t u = begin; u < end; ++u) {
      double* qu = q.row(u);
      const T* pu = p.row(u);
      const std::array<const T*, 6> r = neighbour_rows(a, p, u);
      const T *r0 = r[0], *r1 = r[1], *r2 = r[2], *r3 = r[3], *r4 = r[4], *r5 = r[5];
      const double d = a.diagonal[u];
      const std::array<double, 6>& k = a.coupling[u];
#pragma omp simd
      for (int c = 0; c < w; ++c) {
        const double nb = (k[0] * double(r0[c]) + k[1] * double(r1[c])) + (k[2] * double(r2[c]) + k[3] * double(r3[c])) +
                          (k[4] * double(r4[c]) + k[5] * double(r5[c]));
        qu[c] = d * double(pu[c]) - nb;
        s[c] += double(pu[c]) * qu[c];
      }
    }
  });
}

}  // namespace

std::vector<double> apply_stencil(const KernelRunner& run, const StencilLevel& a, const Block& p, Block& q) { return apply_stencil_of(run, a, p, q); }
std::vector<double> apply_stencil(const KernelRunner& run, const StencilLevel& a, const BlockOf<float>& p, Block& q) {
  return apply_stencil_of(run, a, p, q);
}

std::vector<double> residual_norms(const KernelRunner& run, const StencilLevel& a, const Block& r) {
  const int w = r.width;
  return chunk_sums(run, a.size, 2 * w, [&](std::size_t begin, std::size_t end, double* s) {
    for (std::size_t u = begin; u < end; ++u) {
      const double* ru = r.row(u);
      const double inv = a.inverse_diagonal[u];
#pragma omp simd
      for (int c = 0; c < w; ++c) s[c] += ru[c] * ru[c], s[w + c] += (ru[c] * inv) * (ru[c] * inv);
    }
  });
}

std::vector<double> step_solution(const KernelRunner& run, const StencilLevel& a, const std::vector<double>& alpha, const BlockOf<float>& p,
                                  const Block& q, Block& x, Block& r, BlockOf<float>& r_single) {
  const int w = x.width;
  const double* al = alpha.data();
  return chunk_sums(run, x.rows, 2 * w, [&](std::size_t begin, std::size_t end, double* s) {
    for (std::size_t u = begin; u < end; ++u) {
      const float* pu = p.row(u);
      const double* qu = q.row(u);
      double* xu = x.row(u);
      double* ru = r.row(u);
      float* fu = r_single.row(u);
      const double inv = a.inverse_diagonal[u];
#pragma omp simd
      for (int c = 0; c < w; ++c) {
        xu[c] += al[c] * double(pu[c]);
        ru[c] -= al[c] * qu[c];
        fu[c] = float(ru[c]);
        s[c] += ru[c] * ru[c];
        s[w + c] += (ru[c] * inv) * (ru[c] * inv);
      }
    }
  });
}

void step_direction(const KernelRunner& run, const std::vector<double>& beta, const BlockOf<float>& z, BlockOf<float>& p) {
  const int w = p.width;
  const double* be = beta.data();
  for_chunks(run, p.rows, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t u = begin; u < end; ++u) {
      const float* zu = z.row(u);
      float* pu = p.row(u);
#pragma omp simd
      for (int c = 0; c < w; ++c) pu[c] = float(double(zu[c]) + be[c] * double(pu[c]));
    }
  });
}

namespace {

template <class S, class T>
std::vector<double> dots(const KernelRunner& run, const BlockOf<S>& a, const BlockOf<T>& b) {
  const int w = a.width;
  return chunk_sums(run, a.rows, w, [&](std::size_t begin, std::size_t end, double* s) {
    for (std::size_t u = begin; u < end; ++u) {
      const S* x = a.row(u);
      const T* y = b.row(u);
#pragma omp simd
      for (int c = 0; c < w; ++c) s[c] += double(x[c]) * double(y[c]);
    }
  });
}

}  // namespace

std::vector<double> column_dots(const KernelRunner& run, const Block& a, const Block& b) { return dots(run, a, b); }
std::vector<double> column_dots(const KernelRunner& run, const Block& a, const BlockOf<float>& b) { return dots(run, a, b); }
std::vector<double> column_dots(const KernelRunner& run, const BlockOf<float>& a, const BlockOf<float>& b) { return dots(run, a, b); }

}  // namespace deformkit::numerics
