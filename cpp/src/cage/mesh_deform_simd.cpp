// Compiled once per x86 target by Highway and dispatched at run time: no -march needed.
#include "cage/mesh_deform_simd.hpp"

// Highway 1.0 exports plain functions only: one per column and weight type, each the one
// template below (X is given the function's name, the column type and the weight type).
#ifndef DEFORMKIT_WEIGHTED_ROWS_TYPES
#define DEFORMKIT_WEIGHTED_ROWS_TYPES(X)                                                                      \
  X(RowsU8F64, std::uint8_t, double) X(RowsU16F64, std::uint16_t, double) X(RowsU32F64, std::uint32_t, double) \
  X(RowsU8F32, std::uint8_t, float) X(RowsU16F32, std::uint16_t, float) X(RowsU32F32, std::uint32_t, float)
#endif

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cage/mesh_deform_simd.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"

#include <type_traits>

HWY_BEFORE_NAMESPACE();
namespace deformkit::harmonic {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// A row of 4 values is one vector (AVX2 and wider for doubles, capped), two (SSE) or four: one
// multiply-add per weight and part. Two accumulators (even and odd weights) halve the chain of
// dependent adds.
template <class Column, class T>
void WeightedRowsOf(const std::uint32_t* start, const Column* column, const T* weight, size_t begin, size_t end,
                    const T* rows4, T* acc) {
  const hn::CappedTag<T, 4> d;
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
      const T* r0 = rows4 + 4 * size_t(column[e]);
      const T* r1 = rows4 + 4 * size_t(column[e + 1]);
      for (size_t p = 0; p < parts; ++p) {
        even[p] = hn::MulAdd(w0, hn::LoadU(d, r0 + p * lanes), even[p]);
        odd[p] = hn::MulAdd(w1, hn::LoadU(d, r1 + p * lanes), odd[p]);
      }
    }
    if (e < stop) {
      const auto w0 = hn::Set(d, weight[e]);
      const T* r0 = rows4 + 4 * size_t(column[e]);
      for (size_t p = 0; p < parts; ++p) even[p] = hn::MulAdd(w0, hn::LoadU(d, r0 + p * lanes), even[p]);
    }
    T* out = acc + 4 * (i - begin);
    for (size_t p = 0; p < parts; ++p) hn::StoreU(hn::Add(even[p], odd[p]), d, out + p * lanes);
  }
}

// Float rows of 4: two weights' rows side by side in one 8-lane vector where the target has
// them (AVX2 and wider; four accumulators, then the halves and the last weights added), else
// as the doubles. The loop is bound by its instructions, not by memory (on Ogre the column
// width changes it by a few percent): four weights are one load, spread to (w0 x4 | w1 x4) and
// (w2 x4 | w3 x4) by byte shuffles within each half, not four broadcasts and two inserts.
template <class Column>
void WeightedRowsF32(const std::uint32_t* start, const Column* column, const float* weight, size_t begin, size_t end,
                     const float* rows4, float* acc) {
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX2
  const hn::FixedTag<float, 8> d8;
  const hn::FixedTag<float, 4> d4;
  const hn::Repartition<std::uint8_t, decltype(d8)> du8;
  alignas(32) static constexpr std::uint8_t kSpread01[32] = {0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3,
                                                             4, 5, 6, 7, 4, 5, 6, 7, 4, 5, 6, 7, 4, 5, 6, 7};
  alignas(32) static constexpr std::uint8_t kSpread23[32] = {8, 9, 10, 11, 8, 9, 10, 11, 8, 9, 10, 11, 8, 9, 10, 11,
                                                             12, 13, 14, 15, 12, 13, 14, 15, 12, 13, 14, 15, 12, 13, 14, 15};
  const auto spread01 = hn::Load(du8, kSpread01), spread23 = hn::Load(du8, kSpread23);
  // (w_e r_e | w_e+1 r_e+1) into a, (w_e+2 r_e+2 | w_e+3 r_e+3) into b.
  auto add_four = [&](std::uint32_t e, hn::Vec<decltype(d8)>& a, hn::Vec<decltype(d8)>& b) {
    const float* r0 = rows4 + 4 * size_t(column[e]);
    const float* r1 = rows4 + 4 * size_t(column[e + 1]);
    const float* r2 = rows4 + 4 * size_t(column[e + 2]);
    const float* r3 = rows4 + 4 * size_t(column[e + 3]);
    const auto w = hn::BitCast(du8, hn::LoadDup128(d8, weight + e));
    a = hn::MulAdd(hn::BitCast(d8, hn::TableLookupBytes(w, spread01)),
                   hn::Combine(d8, hn::LoadU(d4, r1), hn::LoadU(d4, r0)), a);
    b = hn::MulAdd(hn::BitCast(d8, hn::TableLookupBytes(w, spread23)),
                   hn::Combine(d8, hn::LoadU(d4, r3), hn::LoadU(d4, r2)), b);
  };
  for (size_t i = begin; i < end; ++i) {
    auto s0 = hn::Zero(d8), s1 = hn::Zero(d8), s2 = hn::Zero(d8), s3 = hn::Zero(d8);
    auto last = hn::Zero(d4);
    std::uint32_t e = start[i];
    const std::uint32_t stop = start[i + 1];
    for (; e + 8 <= stop; e += 8) {
      add_four(e, s0, s1);
      add_four(e + 4, s2, s3);
    }
    if (e + 4 <= stop) {
      add_four(e, s0, s1);
      e += 4;
    }
    for (; e < stop; ++e) last = hn::MulAdd(hn::Set(d4, weight[e]), hn::LoadU(d4, rows4 + 4 * size_t(column[e])), last);
    const auto all = hn::Add(hn::Add(s0, s1), hn::Add(s2, s3));
    hn::StoreU(hn::Add(hn::Add(hn::LowerHalf(d4, all), hn::UpperHalf(d4, all)), last), d4, acc + 4 * (i - begin));
  }
#else
  WeightedRowsOf(start, column, weight, begin, end, rows4, acc);
#endif
}

template <class Column, class T>
void WeightedRows(const std::uint32_t* start, const Column* column, const T* weight, size_t begin, size_t end,
                  const T* rows4, T* acc) {
  if constexpr (std::is_same_v<T, float>) WeightedRowsF32(start, column, weight, begin, end, rows4, acc);
  else WeightedRowsOf(start, column, weight, begin, end, rows4, acc);
}

#define DEFORMKIT_TARGET_ROWS(Name, Column, T)                                                                  \
  void Name(const std::uint32_t* start, const Column* column, const T* weight, size_t begin, size_t end,        \
            const T* rows4, T* acc) {                                                                           \
    WeightedRows(start, column, weight, begin, end, rows4, acc);                                                \
  }
DEFORMKIT_WEIGHTED_ROWS_TYPES(DEFORMKIT_TARGET_ROWS)
#undef DEFORMKIT_TARGET_ROWS

}  // namespace HWY_NAMESPACE
}  // namespace deformkit::harmonic
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit::harmonic {

#define DEFORMKIT_DISPATCH_ROWS(Name, Column, T)                                                              \
  HWY_EXPORT(Name);                                                                                            \
  void weighted_rows(const std::uint32_t* start, const Column* column, const T* weight, std::size_t begin,      \
                     std::size_t end, const T* rows4, T* acc) {                                                \
    HWY_DYNAMIC_DISPATCH(Name)(start, column, weight, begin, end, rows4, acc);                                 \
  }
DEFORMKIT_WEIGHTED_ROWS_TYPES(DEFORMKIT_DISPATCH_ROWS)
#undef DEFORMKIT_DISPATCH_ROWS

}  // namespace deformkit::harmonic
#endif  // HWY_ONCE
