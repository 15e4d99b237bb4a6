// Compiled once per x86 target by Highway and dispatched at run time: no -march needed.
#include "cage/sparse_rows.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cage/sparse_rows.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace deformkit {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Four accumulators, kept weights k, k + 1, k + 2, k + 3 into separate ones: a row is one chain of
// dependent FMAs otherwise, bound by the FMA latency (4 cycles) rather than by the loads.
template <class V>
void Rows(const int64_t* indptr, const int32_t* idx, const V* val, size_t rows, const double* c4, double* out) {
  const hn::CappedTag<double, 4> d;
  if (hn::Lanes(d) < 4) {  // 128-bit targets: x, y, z in scalars
    for (size_t r = 0; r < rows; ++r) {
      double s[3] = {0.0, 0.0, 0.0};
      for (int64_t k = indptr[r]; k < indptr[r + 1]; ++k) {
        const double* c = c4 + 4 * size_t(idx[k]);
        const double w = double(val[k]);
        s[0] += w * c[0], s[1] += w * c[1], s[2] += w * c[2];
      }
      out[3 * r] = s[0], out[3 * r + 1] = s[1], out[3 * r + 2] = s[2];
    }
    return;
  }
  HWY_ALIGN double t[4];
  for (size_t r = 0; r < rows; ++r) {
    int64_t k = indptr[r];
    const int64_t end = indptr[r + 1];
    auto a0 = hn::Zero(d), a1 = hn::Zero(d), a2 = hn::Zero(d), a3 = hn::Zero(d);
    for (; k + 4 <= end; k += 4) {
      a0 = hn::MulAdd(hn::Set(d, double(val[k])), hn::Load(d, c4 + 4 * size_t(idx[k])), a0);
      a1 = hn::MulAdd(hn::Set(d, double(val[k + 1])), hn::Load(d, c4 + 4 * size_t(idx[k + 1])), a1);
      a2 = hn::MulAdd(hn::Set(d, double(val[k + 2])), hn::Load(d, c4 + 4 * size_t(idx[k + 2])), a2);
      a3 = hn::MulAdd(hn::Set(d, double(val[k + 3])), hn::Load(d, c4 + 4 * size_t(idx[k + 3])), a3);
    }
    for (; k < end; ++k) a0 = hn::MulAdd(hn::Set(d, double(val[k])), hn::Load(d, c4 + 4 * size_t(idx[k])), a0);
    hn::Store(hn::Add(hn::Add(a0, a1), hn::Add(a2, a3)), d, t);
    out[3 * r] = t[0], out[3 * r + 1] = t[1], out[3 * r + 2] = t[2];
  }
}

void RowsF64(const int64_t* indptr, const int32_t* idx, const double* val, size_t rows, const double* c4,
             double* out) {
  Rows(indptr, idx, val, rows, c4, out);
}
void RowsF32(const int64_t* indptr, const int32_t* idx, const float* val, size_t rows, const double* c4,
             double* out) {
  Rows(indptr, idx, val, rows, c4, out);
}

}  // namespace HWY_NAMESPACE
}  // namespace deformkit
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit {

HWY_EXPORT(RowsF64);
HWY_EXPORT(RowsF32);

PaddedControlRows::PaddedControlRows(const double* control, std::size_t columns) : storage_(4 * columns + 4, 0.0) {
  // The first 32-byte boundary in the storage (malloc gives at least 8-byte alignment, so at most
  // three doubles of slack).
  const auto addr = reinterpret_cast<std::uintptr_t>(storage_.data());
  rows_ = storage_.data() + ((32 - addr % 32) % 32) / sizeof(double);
  for (std::size_t j = 0; j < columns; ++j)
    for (int a = 0; a < 3; ++a) rows_[4 * j + a] = control[3 * j + a];
}

void sparse_rows_product(const std::int64_t* indptr, const std::int32_t* indices, const double* values,
                         std::size_t rows, const double* c4, double* out) {
  HWY_DYNAMIC_DISPATCH(RowsF64)(indptr, indices, values, rows, c4, out);
}
void sparse_rows_product(const std::int64_t* indptr, const std::int32_t* indices, const float* values,
                         std::size_t rows, const double* c4, double* out) {
  HWY_DYNAMIC_DISPATCH(RowsF32)(indptr, indices, values, rows, c4, out);
}

}  // namespace deformkit
#endif  // HWY_ONCE
