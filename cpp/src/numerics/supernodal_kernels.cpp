// The dense part of a supernodal triangular solve, compiled once per x86 target by Highway and
// dispatched at run time: no -march needed.
#include "numerics/supernodal_kernels.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "numerics/supernodal_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace deformkit {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// v[c * rows + r]: right-hand side c at the supernode's row r. Column k of the block is read once,
// contiguous, for all K right-hand sides.
template <int K>
void Forward(const double* block, std::int64_t rows, std::int64_t cols, double* v) {
  const hn::ScalableTag<double> d;
  const auto lanes = std::int64_t(hn::Lanes(d));
  for (std::int64_t k = 0; k < cols; ++k) {
    const double* l = block + k * rows;
    double a[K];
    for (int c = 0; c < K; ++c) a[c] = v[c * rows + k] /= l[k];
    std::int64_t r = k + 1;
    for (; r + lanes <= rows; r += lanes) {
      const auto lr = hn::LoadU(d, l + r);
      for (int c = 0; c < K; ++c) {
        double* vc = v + c * rows + r;
        hn::StoreU(hn::NegMulAdd(lr, hn::Set(d, a[c]), hn::LoadU(d, vc)), d, vc);
      }
    }
    for (; r < rows; ++r)
      for (int c = 0; c < K; ++c) v[c * rows + r] -= l[r] * a[c];
  }
}

// The block is read from its end down, one descending stream (the backward solve visits the
// supernodes from the last): ascending runs inside blocks taken in descending order would be
// a string of short streams, each a restart for the prefetchers. Two accumulators per
// right-hand side: one chain of dependent FMAs would wait on each one's latency.
template <int K>
void Backward(const double* block, std::int64_t rows, std::int64_t cols, double* v) {
  const hn::ScalableTag<double> d;
  const auto lanes = std::int64_t(hn::Lanes(d));
  for (std::int64_t k = cols - 1; k >= 0; --k) {
    const double* l = block + k * rows;
    decltype(hn::Zero(d)) acc[2][K];
    for (int c = 0; c < K; ++c) acc[0][c] = acc[1][c] = hn::Zero(d);
    std::int64_t r = rows;  // [r, rows) done
    for (; r - 2 * lanes >= k + 1; r -= 2 * lanes)
      for (int u = 0; u < 2; ++u) {
        const std::int64_t at = r - (u + 1) * lanes;
        const auto lr = hn::LoadU(d, l + at);
        for (int c = 0; c < K; ++c) acc[u][c] = hn::MulAdd(lr, hn::LoadU(d, v + c * rows + at), acc[u][c]);
      }
    double tail[K] = {};
    for (; r > k + 1; --r)
      for (int c = 0; c < K; ++c) tail[c] += l[r - 1] * v[c * rows + r - 1];
    for (int c = 0; c < K; ++c) {
      const double sum = hn::GetLane(hn::SumOfLanes(d, hn::Add(acc[0][c], acc[1][c]))) + tail[c];
      v[c * rows + k] = (v[c * rows + k] - sum) / l[k];
    }
  }
}

void Forward1(const double* b, std::int64_t rows, std::int64_t cols, double* v) { Forward<1>(b, rows, cols, v); }
void Forward3(const double* b, std::int64_t rows, std::int64_t cols, double* v) { Forward<3>(b, rows, cols, v); }
void Forward6(const double* b, std::int64_t rows, std::int64_t cols, double* v) { Forward<6>(b, rows, cols, v); }
void Forward12(const double* b, std::int64_t rows, std::int64_t cols, double* v) { Forward<12>(b, rows, cols, v); }
void Backward1(const double* b, std::int64_t rows, std::int64_t cols, double* v) { Backward<1>(b, rows, cols, v); }
void Backward3(const double* b, std::int64_t rows, std::int64_t cols, double* v) { Backward<3>(b, rows, cols, v); }
void Backward6(const double* b, std::int64_t rows, std::int64_t cols, double* v) { Backward<6>(b, rows, cols, v); }
void Backward12(const double* b, std::int64_t rows, std::int64_t cols, double* v) { Backward<12>(b, rows, cols, v); }

}  // namespace HWY_NAMESPACE
}  // namespace deformkit
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit {

HWY_EXPORT(Forward1);
HWY_EXPORT(Forward3);
HWY_EXPORT(Forward6);
HWY_EXPORT(Forward12);
HWY_EXPORT(Backward1);
HWY_EXPORT(Backward3);
HWY_EXPORT(Backward6);
HWY_EXPORT(Backward12);

void supernode_forward(int k, const double* block, std::int64_t rows, std::int64_t cols, double* v) {
  switch (k) {
    case 12: return HWY_DYNAMIC_DISPATCH(Forward12)(block, rows, cols, v);
    case 6: return HWY_DYNAMIC_DISPATCH(Forward6)(block, rows, cols, v);
    case 3: return HWY_DYNAMIC_DISPATCH(Forward3)(block, rows, cols, v);
    default: return HWY_DYNAMIC_DISPATCH(Forward1)(block, rows, cols, v);
  }
}

void supernode_backward(int k, const double* block, std::int64_t rows, std::int64_t cols, double* v) {
  switch (k) {
    case 12: return HWY_DYNAMIC_DISPATCH(Backward12)(block, rows, cols, v);
    case 6: return HWY_DYNAMIC_DISPATCH(Backward6)(block, rows, cols, v);
    case 3: return HWY_DYNAMIC_DISPATCH(Backward3)(block, rows, cols, v);
    default: return HWY_DYNAMIC_DISPATCH(Backward1)(block, rows, cols, v);
  }
}

}  // namespace deformkit
#endif  // HWY_ONCE
