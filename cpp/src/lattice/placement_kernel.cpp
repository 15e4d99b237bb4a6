// Compiled once per x86 target by Highway and dispatched at run time, with -ffp-contract=off (see
// CMakeLists.txt): a fused multiply-add would round differently from the per-point formulas.
#include "lattice/placement_kernel.hpp"

#include <cmath>
#include <cstring>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "lattice/placement_kernel.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace deformkit {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

template <class T>
bool Place(const Placement3& p, const T* in, size_t n, double* parameters, std::uint8_t* status, std::uint64_t* key,
           double* local, double* ds) {
  const hn::ScalableTag<double> d;
  using V = hn::Vec<decltype(d)>;
  constexpr size_t kMax = HWY_MAX_BYTES / sizeof(double);
  const size_t N = hn::Lanes(d);
  auto set = [&](double v) { return hn::Set(d, v); };
  HWY_ALIGN double row[3 * kMax], lane[10][kMax];
  const V zero = hn::Zero(d), one = set(1.0);
  bool finite = true;
  for (size_t i = 0; i < n; i += N) {
    const size_t m = n - i < N ? n - i : N;
    for (size_t e = 0; e < 3 * N; ++e) row[e] = static_cast<double>(in[3 * i + (e < 3 * m ? e : e % 3)]);
    V x[3];
    hn::LoadInterleaved3(d, row, x[0], x[1], x[2]);
    for (int a = 0; a < 3; ++a) x[a] = hn::Sub(x[a], set(p.origin[a]));
    V s[3];
    for (int a = 0; a < 3; ++a)  // LatticeBox::coordinates, term by term
      s[a] = hn::Add(hn::Add(hn::Mul(set(p.to_parameters[3 * a]), x[0]), hn::Mul(set(p.to_parameters[3 * a + 1]), x[1])),
                     hn::Mul(set(p.to_parameters[3 * a + 2]), x[2]));
    auto inside_all = hn::Eq(zero, zero);
    V k = zero;
    for (int a = 0; a < 3; ++a) {  // AxisBasis::locate
      const PlacementAxis& ax = p.axes[a];
      const auto inside = hn::And(hn::Ge(s[a], set(ax.lo - 1e-12)), hn::Le(s[a], set(ax.hi + 1e-12)));
      inside_all = hn::And(inside_all, inside);
      V piece = zero, t = zero, frozen = zero;
      if (ax.blender && ax.count == 1) {
        frozen = one;
      } else if (ax.blender) {
        const V g = hn::Min(hn::Max(hn::Mul(s[a], set(ax.count - 1.0)), set(-3.0)), set(ax.count + 1.0));
        const V f = hn::Floor(g);
        t = hn::Sub(g, f);
        piece = hn::Min(hn::Max(f, set(-2.0)), set(double(ax.count)));
        frozen = hn::IfThenElseZero(hn::Or(hn::Le(f, set(-2.0)), hn::Ge(f, set(double(ax.count)))), one);
      } else {
        const auto clamped = p.outside != 2 ? hn::Not(inside) : hn::Ne(zero, zero);
        const V c = hn::IfThenElse(clamped, hn::Min(hn::Max(s[a], set(ax.lo)), set(ax.hi)), s[a]);
        frozen = hn::IfThenElseZero(clamped, one);
        const V g = hn::Mul(hn::Sub(c, set(ax.lo)), set(ax.scale));
        const V last = set(ax.pieces - 1.0);
        piece = hn::IfThenElse(hn::Le(g, zero), zero, hn::IfThenElse(hn::Ge(g, last), last, hn::Floor(g)));
        t = hn::Sub(g, piece);
      }
      k = hn::Add(hn::Mul(k, set(ax.count + 4.0)), hn::Add(piece, set(2.0)));
      hn::Store(t, d, lane[a]);
      hn::Store(hn::IfThenElse(hn::Eq(frozen, one), zero, set(ax.scale)), d, lane[3 + a]);
      hn::Store(s[a], d, lane[6 + a]);
    }
    // Outside: displaced unless the policy is 'unchanged'; those keep still's key.
    const auto moves = p.outside == 1 ? inside_all : hn::Eq(zero, zero);
    hn::Store(hn::IfThenElse(moves, k, set(-1.0)), d, lane[9]);
    HWY_ALIGN double in_lane[kMax];
    hn::Store(hn::IfThenElseZero(inside_all, one), d, in_lane);
    for (size_t l = 0; l < m; ++l) {
      const size_t r = i + l;
      for (int a = 0; a < 3; ++a) {
        parameters[3 * r + a] = lane[6 + a][l];
        local[3 * r + a] = lane[a][l];
        if (ds) ds[3 * r + a] = lane[3 + a][l];
        finite = finite && std::isfinite(lane[6 + a][l]);
      }
      if (status) status[r] = in_lane[l] != 0.0 ? 0 : 1;
      key[r] = lane[9][l] < 0.0 ? p.still : static_cast<std::uint64_t>(lane[9][l]);
    }
  }
  return finite;
}

bool PlaceF64(const Placement3& p, const double* in, size_t n, double* parameters, std::uint8_t* status,
              std::uint64_t* key, double* local, double* ds) {
  return Place(p, in, n, parameters, status, key, local, ds);
}
bool PlaceF32(const Placement3& p, const float* in, size_t n, double* parameters, std::uint8_t* status,
              std::uint64_t* key, double* local, double* ds) {
  return Place(p, in, n, parameters, status, key, local, ds);
}

}  // namespace HWY_NAMESPACE
}  // namespace deformkit
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit {

HWY_EXPORT(PlaceF64);
HWY_EXPORT(PlaceF32);

bool place_in_box(const Placement3& p, const double* in, std::size_t n, double* parameters, std::uint8_t* status,
                  std::uint64_t* key, double* local, double* ds) {
  return HWY_DYNAMIC_DISPATCH(PlaceF64)(p, in, n, parameters, status, key, local, ds);
}
bool place_in_box(const Placement3& p, const float* in, std::size_t n, double* parameters, std::uint8_t* status,
                  std::uint64_t* key, double* local, double* ds) {
  return HWY_DYNAMIC_DISPATCH(PlaceF32)(p, in, n, parameters, status, key, local, ds);
}

}  // namespace deformkit
#endif  // HWY_ONCE
