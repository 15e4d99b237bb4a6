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

void apply_stencil(const KernelRunner& run, const StencilLevel& a, const Block& x, Block& y) {
  const int w = x.width;
  for_chunks(run, a.size, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t u = begin; u < end; ++u)  // d x_u - sum w x_nb = -(-d x_u + sum w x_nb)
      stencil_row(x.row(u), -a.diagonal[u], a.coupling[u], neighbour_rows(a, x, u), -1.0, w, y.row(u));
  });
}

template <class T>
void colour_sweep(const KernelRunner& run, const StencilLevel& a, int colour, const BlockOf<T>& b, BlockOf<T>& x, bool from_zero) {
  const std::vector<int>& rows = a.colour[std::size_t(colour)];
  const CoefficientView<T> k = coefficients(a, T());
  for_chunks(run, rows.size(), [&](std::size_t, std::size_t begin, std::size_t end) {
    sweep_rows(rows.data() + begin, end - begin, k.inverse_diagonal, k.coupling, a.neighbour.data(), b.data.data(), x.data.data(), x.width,
               from_zero);
  });
}

template <class T>
void restrict_residual(const KernelRunner& run, const StencilLevel& a, const BlockOf<T>& b, const BlockOf<T>& x, BlockOf<T>& coarse_b) {
  const CoefficientView<T> k = coefficients(a, T());
  for_chunks(run, a.child_start.size() - 1, [&](std::size_t, std::size_t begin, std::size_t end) {
    restrict_rows(a.child_start.data(), a.child.data(), begin, end, k.diagonal, k.coupling, a.neighbour.data(), b.data.data(), x.data.data(),
                  coarse_b.data.data(), x.width);
  });
}

template <class T>
void prolong_add(const KernelRunner& run, const StencilLevel& a, const BlockOf<T>& coarse_x, T scale, BlockOf<T>& x) {
  const int w = x.width;
  for_chunks(run, a.size, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t u = begin; u < end; ++u) {
      const T* e = coarse_x.row(std::size_t(a.parent[u]));
      T* out = x.row(u);
#pragma omp simd
      for (int c = 0; c < w; ++c) out[c] += scale * e[c];
    }
  });
}

template <class To, class From>
void convert_block(const KernelRunner& run, const BlockOf<From>& from, BlockOf<To>& to) {
  const std::size_t w = std::size_t(from.width);
  for_chunks(run, from.rows, [&](std::size_t, std::size_t begin, std::size_t end) {
    const From* f = from.data.data() + begin * w;
    To* t = to.data.data() + begin * w;
#pragma omp simd
    for (std::size_t i = 0; i < (end - begin) * w; ++i) t[i] = To(f[i]);
  });
}

template void colour_sweep<double>(const KernelRunner&, const StencilLevel&, int, const Block&, Block&, bool);
template void colour_sweep<float>(const KernelRunner&, const StencilLevel&, int, const BlockOf<float>&, BlockOf<float>&, bool);
template void restrict_residual<double>(const KernelRunner&, const StencilLevel&, const Block&, const Block&, Block&);
template void restrict_residual<float>(const KernelRunner&, const StencilLevel&, const BlockOf<float>&, const BlockOf<float>&, BlockOf<float>&);
template void prolong_add<double>(const KernelRunner&, const StencilLevel&, const Block&, double, Block&);
template void prolong_add<float>(const KernelRunner&, const StencilLevel&, const BlockOf<float>&, float, BlockOf<float>&);
template void convert_block<float, double>(const KernelRunner&, const Block&, BlockOf<float>&);
template void convert_block<double, float>(const KernelRunner&, const BlockOf<float>&, Block&);

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
