// Compiled once per x86 target by Highway and dispatched at run time: no -march needed.
#include "cage/mesh_deform_simd.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cage/mesh_deform_simd.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace deformkit::harmonic {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// A row of 4 doubles is one vector (AVX2 and wider, capped), two (SSE) or four: one multiply-add
// per weight and part. Two accumulators (even and odd weights) halve the chain of dependent adds.
void WeightedRowsT(const std::uint32_t* start, const std::uint32_t* column, const double* weight, size_t begin, size_t end,
                   const double* rows4, double* acc) {
  const hn::CappedTag<double, 4> d;
  using V = hn::Vec<decltype(d)>;
  constexpr size_t kMaxParts = 4;
  const size_t lanes = hn::Lanes(d), parts = 4 / lanes;
  for (size_t i = begin; i < end; ++i) {
    V even[kMaxParts], odd[kMaxParts];
    for (size_t p = 0; p < kMaxParts; ++p) even[p] = odd[p] = hn::Zero(d);
    std::uint32_t e = start[i];
    const std::uint32_t stop = start[i + 1];
    for (; e + 2 <= stop; e += 2) {
      const auto w0 = hn::Set(d, weight[e]), w1 = hn::Set(d, weight[e + 1]);
      const double* r0 = rows4 + 4 * size_t(column[e]);
      const double* r1 = rows4 + 4 * size_t(column[e + 1]);
      for (size_t p = 0; p < parts; ++p) {
        even[p] = hn::MulAdd(w0, hn::LoadU(d, r0 + p * lanes), even[p]);
        odd[p] = hn::MulAdd(w1, hn::LoadU(d, r1 + p * lanes), odd[p]);
      }
    }
    if (e < stop) {
      const auto w0 = hn::Set(d, weight[e]);
      const double* r0 = rows4 + 4 * size_t(column[e]);
      for (size_t p = 0; p < parts; ++p) even[p] = hn::MulAdd(w0, hn::LoadU(d, r0 + p * lanes), even[p]);
    }
    double* out = acc + 4 * (i - begin);
    for (size_t p = 0; p < parts; ++p) hn::StoreU(hn::Add(even[p], odd[p]), d, out + p * lanes);
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace deformkit::harmonic
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit::harmonic {

HWY_EXPORT(WeightedRowsT);

void weighted_rows(const std::uint32_t* start, const std::uint32_t* column, const double* weight, std::size_t begin,
                   std::size_t end, const double* rows4, double* acc) {
  HWY_DYNAMIC_DISPATCH(WeightedRowsT)(start, column, weight, begin, end, rows4, acc);
}

}  // namespace deformkit::harmonic
#endif  // HWY_ONCE
