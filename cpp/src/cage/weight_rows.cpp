// Compiled once per x86 target by Highway and dispatched at run time: no -march needed.
#include "cage/weight_rows.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cage/weight_rows.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace deformkit {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

template <class D>
HWY_INLINE hn::Vec<D> LoadWeights(D d, const double* w) {
  return hn::LoadU(d, w);
}
template <class D>
HWY_INLINE hn::Vec<D> LoadWeights(D d, const float* w) {
  const hn::Rebind<float, D> df;
  return hn::PromoteTo(d, hn::LoadU(df, w));
}

template <class W>
void Rows(const W* w, size_t rows, size_t m, const double* const c[3], double* out) {
  const hn::ScalableTag<double> d;
  const size_t lanes = hn::Lanes(d);
  for (size_t r = 0; r < rows; ++r) {
    const W* row = w + r * m;
    auto x = hn::Zero(d), y = hn::Zero(d), z = hn::Zero(d);
    size_t j = 0;
    for (; j + lanes <= m; j += lanes) {
      const auto wj = LoadWeights(d, row + j);
      x = hn::MulAdd(wj, hn::LoadU(d, c[0] + j), x);
      y = hn::MulAdd(wj, hn::LoadU(d, c[1] + j), y);
      z = hn::MulAdd(wj, hn::LoadU(d, c[2] + j), z);
    }
    double sx = hn::GetLane(hn::SumOfLanes(d, x)), sy = hn::GetLane(hn::SumOfLanes(d, y)),
           sz = hn::GetLane(hn::SumOfLanes(d, z));
    for (; j < m; ++j) {
      const double wj = double(row[j]);
      sx += wj * c[0][j], sy += wj * c[1][j], sz += wj * c[2][j];
    }
    out[3 * r] = sx, out[3 * r + 1] = sy, out[3 * r + 2] = sz;
  }
}

void RowsF64(const double* w, size_t rows, size_t m, const double* const* c, double* out) { Rows(w, rows, m, c, out); }
void RowsF32(const float* w, size_t rows, size_t m, const double* const* c, double* out) { Rows(w, rows, m, c, out); }

}  // namespace HWY_NAMESPACE
}  // namespace deformkit
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit {

HWY_EXPORT(RowsF64);
HWY_EXPORT(RowsF32);

void weight_rows_product(const double* w, std::size_t rows, std::size_t m, const double* const c[3], double* out) {
  HWY_DYNAMIC_DISPATCH(RowsF64)(w, rows, m, c, out);
}
void weight_rows_product(const float* w, std::size_t rows, std::size_t m, const double* const c[3], double* out) {
  HWY_DYNAMIC_DISPATCH(RowsF32)(w, rows, m, c, out);
}

}  // namespace deformkit
#endif  // HWY_ONCE
