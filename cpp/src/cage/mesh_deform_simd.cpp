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

#include <algorithm>
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

// Dense blocks (a small cage): lane k is point 8 block + k, so a cage vertex's weights for 8
// points are one load and its displacement three broadcasts: 3 multiply-adds per weight and 8
// points, no indices, no gather, and the results stored interleaved as x y z.
bool DenseBlocksF32(const float* weight, size_t columns, const float* rows4, const double* scale, const float* points,
                    size_t first, size_t last, size_t n, float* out) {
  const hn::CappedTag<float, 8> d;
  const size_t lanes = hn::Lanes(d), parts = 8 / lanes;
  auto guard = hn::Zero(d);  // v - v is 0 for every finite v: it stays 0 unless a result is not
  for (size_t block = first; block < last; ++block) {
    const size_t base = 8 * block, count = n - base < 8 ? n - base : 8;
    alignas(64) float scale8[8] = {0, 0, 0, 0, 0, 0, 0, 0}, from8[24] = {0}, to8[24];
    if (scale)
      for (size_t k = 0; k < count; ++k) scale8[k] = float(scale[base + k]);
    const float* from = points ? points + 3 * base : nullptr;
    if (points && count < 8) from = std::copy(from, from + 3 * count, from8) - 3 * count;
    float* to = count < 8 ? to8 : out + 3 * base;
    for (size_t p = 0; p < parts; ++p) {
      const float* w = weight + 8 * columns * block + p * lanes;
      auto x = hn::Zero(d), y = hn::Zero(d), z = hn::Zero(d);
      for (size_t a = 0; a < columns; ++a) {
        const auto wa = hn::LoadU(d, w + 8 * a);
        x = hn::MulAdd(wa, hn::Set(d, rows4[4 * a]), x);
        y = hn::MulAdd(wa, hn::Set(d, rows4[4 * a + 1]), y);
        z = hn::MulAdd(wa, hn::Set(d, rows4[4 * a + 2]), z);
      }
      if (scale) {
        const auto s = hn::LoadU(d, scale8 + p * lanes);
        x = hn::Mul(x, s), y = hn::Mul(y, s), z = hn::Mul(z, s);
      }
      if (from) {
        hn::Vec<decltype(d)> px, py, pz;
        hn::LoadInterleaved3(d, from + 3 * p * lanes, px, py, pz);
        x = hn::Add(px, x), y = hn::Add(py, y), z = hn::Add(pz, z);
      }
      guard = hn::Add(guard, hn::Add(hn::Sub(x, x), hn::Add(hn::Sub(y, y), hn::Sub(z, z))));
      hn::StoreInterleaved3(x, y, z, d, to + 3 * p * lanes);
    }
    if (count < 8) std::copy(to8, to8 + 3 * count, out + 3 * base);
  }
  alignas(64) float left[8];
  hn::StoreU(guard, d, left);
  for (size_t k = 0; k < lanes; ++k)
    if (left[k] != 0.0f) return false;
  return true;
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

HWY_EXPORT(DenseBlocksF32);
bool dense_blocks(const float* weight, std::size_t columns, const float* rows4, const double* scale,
                  const float* points, std::size_t first, std::size_t last, std::size_t n, float* out) {
  return HWY_DYNAMIC_DISPATCH(DenseBlocksF32)(weight, columns, rows4, scale, points, first, last, n, out);
}

}  // namespace deformkit::harmonic
#endif  // HWY_ONCE
