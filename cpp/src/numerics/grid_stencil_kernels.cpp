#include "numerics/grid_stencil_kernels.hpp"

#include "numerics/grid_stencil_simd.hpp"

namespace deformkit::numerics {

namespace {

// out = (base_factor base + sum_k w_k row_k) * scale over the columns; the six neighbour rows of a
// stencil row.
template <class T>
inline void stencil_row(const T* base, T base_factor, const std::array<T, 6>& w, const std::array<const T*, 6>& r, T scale, int width,
                        T* out) {
  const T w0 = w[0], w1 = w[1], w2 = w[2], w3 = w[3], w4 = w[4], w5 = w[5];
  const T *r0 = r[0], *r1 = r[1], *r2 = r[2], *r3 = r[3], *r4 = r[4], *r5 = r[5];
#pragma omp simd
  for (int c = 0; c < width; ++c)
    out[c] = (base_factor * base[c] + ((w0 * r0[c] + w1 * r1[c]) + (w2 * r2[c] + w3 * r3[c]) + (w4 * r4[c] + w5 * r5[c]))) * scale;
}

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
                       BlockOf<float>& coarse_b) {
  for_chunks(run, a.child_start.size() - 1, [&](std::size_t, std::size_t begin, std::size_t end) {
    restrict_rows(a.child_start.data(), a.child.data(), begin, end, a.single.diagonal.data(), a.single.coupling.data(), a.neighbour.data(),
                  b.data.data(), x.data.data(), coarse_b.data.data(), x.width);
  });
}

void prolong_add(const KernelRunner& run, const StencilLevel& a, const BlockOf<float>& coarse_x, float scale, BlockOf<float>& x) {
  const int w = x.width;
  for_chunks(run, a.size, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t u = begin; u < end; ++u) {
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

std::vector<double> apply_stencil(const KernelRunner& run, const StencilLevel& a, const Block& p, Block& q) {
  const int w = p.width;
  return chunk_sums(run, a.size, w, [&](std::size_t begin, std::size_t end, double* s) {
    for (std::size_t u = begin; u < end; ++u) {
      double* qu = q.row(u);
      const double* pu = p.row(u);
      // d p_u - sum w p_nb = -(-d p_u + sum w p_nb)
      stencil_row(pu, -a.diagonal[u], a.coupling[u], neighbour_rows(a, p, u), -1.0, w, qu);
#pragma omp simd
      for (int c = 0; c < w; ++c) s[c] += pu[c] * qu[c];
    }
  });
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

std::vector<double> step_solution(const KernelRunner& run, const StencilLevel& a, const std::vector<double>& alpha, const Block& p,
                                  const Block& q, Block& x, Block& r, BlockOf<float>& r_single) {
  const int w = x.width;
  const double* al = alpha.data();
  return chunk_sums(run, x.rows, 2 * w, [&](std::size_t begin, std::size_t end, double* s) {
    for (std::size_t u = begin; u < end; ++u) {
      const double* pu = p.row(u);
      const double* qu = q.row(u);
      double* xu = x.row(u);
      double* ru = r.row(u);
      float* fu = r_single.row(u);
      const double inv = a.inverse_diagonal[u];
#pragma omp simd
      for (int c = 0; c < w; ++c) {
        xu[c] += al[c] * pu[c];
        ru[c] -= al[c] * qu[c];
        fu[c] = float(ru[c]);
        s[c] += ru[c] * ru[c];
        s[w + c] += (ru[c] * inv) * (ru[c] * inv);
      }
    }
  });
}

void step_direction(const KernelRunner& run, const std::vector<double>& beta, const BlockOf<float>& z, Block& p) {
  const int w = p.width;
  const double* be = beta.data();
  for_chunks(run, p.rows, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t u = begin; u < end; ++u) {
      const float* zu = z.row(u);
      double* pu = p.row(u);
#pragma omp simd
      for (int c = 0; c < w; ++c) pu[c] = double(zu[c]) + be[c] * pu[c];
    }
  });
}

namespace {

template <class T>
std::vector<double> dots(const KernelRunner& run, const Block& a, const BlockOf<T>& b) {
  const int w = a.width;
  return chunk_sums(run, a.rows, w, [&](std::size_t begin, std::size_t end, double* s) {
    for (std::size_t u = begin; u < end; ++u) {
      const double* x = a.row(u);
      const T* y = b.row(u);
#pragma omp simd
      for (int c = 0; c < w; ++c) s[c] += x[c] * double(y[c]);
    }
  });
}

}  // namespace

std::vector<double> column_dots(const KernelRunner& run, const Block& a, const Block& b) { return dots(run, a, b); }
std::vector<double> column_dots(const KernelRunner& run, const Block& a, const BlockOf<float>& b) { return dots(run, a, b); }

}  // namespace deformkit::numerics
