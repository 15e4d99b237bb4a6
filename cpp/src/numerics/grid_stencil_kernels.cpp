#include "numerics/grid_stencil_kernels.hpp"

namespace deformkit::numerics {

namespace {

// out = (base + sum_k w_k row_k) * scale over w columns; the six neighbour rows of a stencil row.
inline void stencil_row(const double* base, double base_factor, const std::array<double, 6>& w,
                        const std::array<const double*, 6>& r, double scale, int width, double* out) {
  const double w0 = w[0], w1 = w[1], w2 = w[2], w3 = w[3], w4 = w[4], w5 = w[5];
  const double *r0 = r[0], *r1 = r[1], *r2 = r[2], *r3 = r[3], *r4 = r[4], *r5 = r[5];
#pragma omp simd
  for (int c = 0; c < width; ++c)
    out[c] = (base_factor * base[c] + ((w0 * r0[c] + w1 * r1[c]) + (w2 * r2[c] + w3 * r3[c]) + (w4 * r4[c] + w5 * r5[c]))) * scale;
}

std::array<const double*, 6> neighbour_rows(const StencilLevel& a, const Block& x, std::size_t u) {
  std::array<const double*, 6> r;
  for (int k = 0; k < 6; ++k) r[k] = x.row(std::size_t(a.neighbour[u][k]));
  return r;
}

}  // namespace

void apply_stencil(const KernelRunner& run, const StencilLevel& a, const Block& x, Block& y) {
  const int w = x.width;
  for_chunks(run, a.size, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t u = begin; u < end; ++u) {
      // d x_u - sum w x_nb = -(-d x_u + sum w x_nb)
      stencil_row(x.row(u), -a.diagonal[u], a.coupling[u], neighbour_rows(a, x, u), -1.0, w, y.row(u));
    }
  });
}

void colour_sweep(const KernelRunner& run, const StencilLevel& a, int colour, const Block& b, Block& x, bool from_zero) {
  const std::vector<int>& rows = a.colour[std::size_t(colour)];
  const int w = x.width;
  for_chunks(run, rows.size(), [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const std::size_t u = std::size_t(rows[i]);
      const double inv = a.inverse_diagonal[u];
      double* out = x.row(u);
      const double* in = b.row(u);
      if (from_zero) {
#pragma omp simd
        for (int c = 0; c < w; ++c) out[c] = in[c] * inv;
      } else {
        stencil_row(in, 1.0, a.coupling[u], neighbour_rows(a, x, u), inv, w, out);
      }
    }
  });
}

void restrict_residual(const KernelRunner& run, const StencilLevel& a, const Block& b, const Block& x, Block& coarse_b) {
  const int w = x.width;
  const std::size_t coarse = a.child_start.size() - 1;
  for_chunks(run, coarse, [&](std::size_t, std::size_t begin, std::size_t end) {
    std::vector<double> r(std::size_t(w), 0.0);
    for (std::size_t g = begin; g < end; ++g) {
      double* sum = coarse_b.row(g);
      std::fill(sum, sum + w, 0.0);
      for (int k = a.child_start[g]; k < a.child_start[g + 1]; ++k) {
        const std::size_t u = std::size_t(a.child[std::size_t(k)]);
        // b - (d x - sum w x_nb) = (b - d x) + sum w x_nb
        const double* bu = b.row(u);
        const double* xu = x.row(u);
        const double d = a.diagonal[u];
        stencil_row(xu, -d, a.coupling[u], neighbour_rows(a, x, u), 1.0, w, r.data());
#pragma omp simd
        for (int c = 0; c < w; ++c) sum[c] += bu[c] + r[std::size_t(c)];
      }
    }
  });
}

void prolong_add(const KernelRunner& run, const StencilLevel& a, const Block& coarse_x, double scale, Block& x) {
  const int w = x.width;
  for_chunks(run, a.size, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t u = begin; u < end; ++u) {
      const double* e = coarse_x.row(std::size_t(a.parent[u]));
      double* out = x.row(u);
#pragma omp simd
      for (int c = 0; c < w; ++c) out[c] += scale * e[c];
    }
  });
}

void step_solution(const KernelRunner& run, const std::vector<double>& alpha, const Block& p, const Block& q, Block& x, Block& r) {
  const int w = x.width;
  const double* al = alpha.data();
  for_chunks(run, x.rows, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t u = begin; u < end; ++u) {
      const double* pu = p.row(u);
      const double* qu = q.row(u);
      double* xu = x.row(u);
      double* ru = r.row(u);
#pragma omp simd
      for (int c = 0; c < w; ++c) xu[c] += al[c] * pu[c], ru[c] -= al[c] * qu[c];
    }
  });
}

void step_direction(const KernelRunner& run, const std::vector<double>& beta, const Block& z, Block& p) {
  const int w = p.width;
  const double* be = beta.data();
  for_chunks(run, p.rows, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t u = begin; u < end; ++u) {
      const double* zu = z.row(u);
      double* pu = p.row(u);
#pragma omp simd
      for (int c = 0; c < w; ++c) pu[c] = zu[c] + be[c] * pu[c];
    }
  });
}

std::vector<double> column_dots(const KernelRunner& run, const Block& a, const Block& b) {
  const int w = a.width;
  const std::size_t chunks = chunk_count(a.rows);
  std::vector<double> partial(chunks * std::size_t(w), 0.0);
  for_chunks(run, a.rows, [&](std::size_t t, std::size_t begin, std::size_t end) {
    double* s = partial.data() + t * std::size_t(w);
    for (std::size_t u = begin; u < end; ++u) {
      const double* x = a.row(u);
      const double* y = b.row(u);
#pragma omp simd
      for (int c = 0; c < w; ++c) s[c] += x[c] * y[c];
    }
  });
  std::vector<double> total(std::size_t(w), 0.0);
  for (std::size_t t = 0; t < chunks; ++t)
    for (int c = 0; c < w; ++c) total[std::size_t(c)] += partial[t * std::size_t(w) + std::size_t(c)];
  return total;
}

}  // namespace deformkit::numerics
