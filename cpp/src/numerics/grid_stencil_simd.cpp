// Compiled once per x86 target by Highway and dispatched at run time: no -march needed.
#include "numerics/grid_stencil_simd.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "numerics/grid_stencil_simd.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace deformkit::numerics {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// base + sum_k w_k r_k over columns [0, width): full vectors, then the last columns one by one.
// Two accumulators halve the chain of dependent multiply-adds.
template <class T>
HWY_INLINE void NeighbourSum(const T* base, const std::array<T, 6>& w, const T* const r[6], size_t width, T scale, T* out) {
  const hn::ScalableTag<T> d;
  const size_t lanes = hn::Lanes(d);
  const auto w0 = hn::Set(d, w[0]), w1 = hn::Set(d, w[1]), w2 = hn::Set(d, w[2]), w3 = hn::Set(d, w[3]), w4 = hn::Set(d, w[4]),
             w5 = hn::Set(d, w[5]), s = hn::Set(d, scale);
  size_t c = 0;
  for (; c + lanes <= width; c += lanes) {
    auto a = hn::MulAdd(w0, hn::LoadU(d, r[0] + c), hn::LoadU(d, base + c));
    auto e = hn::Mul(w1, hn::LoadU(d, r[1] + c));
    a = hn::MulAdd(w2, hn::LoadU(d, r[2] + c), a);
    e = hn::MulAdd(w3, hn::LoadU(d, r[3] + c), e);
    a = hn::MulAdd(w4, hn::LoadU(d, r[4] + c), a);
    e = hn::MulAdd(w5, hn::LoadU(d, r[5] + c), e);
    hn::StoreU(hn::Mul(hn::Add(a, e), s), d, out + c);
  }
  for (; c < width; ++c)
    out[c] = ((base[c] + w[0] * r[0][c] + w[2] * r[2][c] + w[4] * r[4][c]) + (w[1] * r[1][c] + w[3] * r[3][c] + w[5] * r[5][c])) * scale;
}

template <class T>
void SweepRowsT(const int* rows, size_t count, const T* inverse_diagonal, const std::array<T, 6>* coupling,
                const std::array<int, 6>* neighbour, const T* b, T* x, int width_in, bool from_zero) {
  const hn::ScalableTag<T> d;
  const size_t lanes = hn::Lanes(d), width = size_t(width_in);
  for (size_t i = 0; i < count; ++i) {
    const size_t u = size_t(rows[i]);
    const T* in = b + u * width;
    T* out = x + u * width;
    if (from_zero) {
      const auto s = hn::Set(d, inverse_diagonal[u]);
      size_t c = 0;
      for (; c + lanes <= width; c += lanes) hn::StoreU(hn::Mul(hn::LoadU(d, in + c), s), d, out + c);
      for (; c < width; ++c) out[c] = in[c] * inverse_diagonal[u];
      continue;
    }
    const T* r[6];
    for (int k = 0; k < 6; ++k) r[k] = x + size_t(neighbour[u][size_t(k)]) * width;
    NeighbourSum(in, coupling[u], r, width, inverse_diagonal[u], out);
  }
}

template <class T>
void RestrictRowsT(const int* child_start, const int* child_end, const int* child, size_t begin, size_t end, const T* diagonal,
                   const std::array<T, 6>* coupling, const std::array<int, 6>* neighbour, const T* b, const T* x, T* coarse_b,
                   int width_in) {
  const hn::ScalableTag<T> d;
  const size_t lanes = hn::Lanes(d), width = size_t(width_in);
  HWY_ALIGN T residual[256];  // one row's residual, up to 256 columns at a time
  for (size_t g = begin; g < end; ++g) {
    T* sum = coarse_b + g * width;
    for (size_t c = 0; c < width; ++c) sum[c] = T(0);
    for (int k = child_start[g]; k < child_end[g]; ++k) {
      const size_t u = size_t(child[k]);
      const T* r[6];
      for (int j = 0; j < 6; ++j) r[j] = x + size_t(neighbour[u][size_t(j)]) * width;
      const T dg = diagonal[u];
      for (size_t first = 0; first < width; first += 256) {
        const size_t n = width - first < 256 ? width - first : 256;
        // b - (d x - sum w x_nb): the base row is b - d x, then the neighbours.
        size_t c = 0;
        const auto vd = hn::Set(d, dg);
        for (; c + lanes <= n; c += lanes)
          hn::Store(hn::NegMulAdd(vd, hn::LoadU(d, x + u * width + first + c), hn::LoadU(d, b + u * width + first + c)), d, residual + c);
        for (; c < n; ++c) residual[c] = b[u * width + first + c] - dg * x[u * width + first + c];
        const T* shifted[6];
        for (int j = 0; j < 6; ++j) shifted[j] = r[j] + first;
        NeighbourSum(residual, coupling[u], shifted, n, T(1), residual);
        for (c = 0; c < n; ++c) sum[first + c] += residual[c];
      }
    }
  }
}

void SweepRowsF32(const int* rows, size_t count, const float* inv, const std::array<float, 6>* coupling, const std::array<int, 6>* nb,
                  const float* b, float* x, int width, bool from_zero) {
  SweepRowsT(rows, count, inv, coupling, nb, b, x, width, from_zero);
}
void RestrictRowsF32(const int* start, const int* child_end, const int* child, size_t begin, size_t end, const float* diagonal, const std::array<float, 6>* coupling,
                     const std::array<int, 6>* nb, const float* b, const float* x, float* coarse_b, int width) {
  RestrictRowsT(start, child_end, child, begin, end, diagonal, coupling, nb, b, x, coarse_b, width);
}

}  // namespace HWY_NAMESPACE
}  // namespace deformkit::numerics
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit::numerics {

HWY_EXPORT(SweepRowsF32);
HWY_EXPORT(RestrictRowsF32);

void sweep_rows(const int* rows, std::size_t count, const float* inv, const std::array<float, 6>* coupling,
                       const std::array<int, 6>* nb, const float* b, float* x, int width, bool from_zero) {
  HWY_DYNAMIC_DISPATCH(SweepRowsF32)(rows, count, inv, coupling, nb, b, x, width, from_zero);
}
void restrict_rows(const int* start, const int* child_end, const int* child, std::size_t begin, std::size_t end, const float* diagonal,
                          const std::array<float, 6>* coupling, const std::array<int, 6>* nb, const float* b, const float* x,
                          float* coarse_b, int width) {
  HWY_DYNAMIC_DISPATCH(RestrictRowsF32)(start, child_end, child, begin, end, diagonal, coupling, nb, b, x, coarse_b, width);
}
}  // namespace deformkit::numerics
#endif  // HWY_ONCE
