// Compiled once per x86 target by Highway and dispatched at run time: no -march needed.
// MeanValueCage::weights (mean_value_cage.cpp) is the reference: every expression below is one of
// its expressions in the same order of operations, for a vector of points at once; only asin
// comes from Highway's vector math (a few ulps).
#include "cage/mean_value_rows.hpp"

#include <algorithm>
#include <vector>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cage/mean_value_rows.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"
#include "hwy/contrib/math/math-inl.h"

HWY_BEFORE_NAMESPACE();
namespace deformkit {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using D = hn::ScalableTag<double>;
using V = hn::Vec<D>;
using M = hn::Mask<D>;

struct V3 {
  V x, y, z;
};
HWY_INLINE V Dot(const V3& a, const V3& b) {
  return hn::Add(hn::Add(hn::Mul(a.x, b.x), hn::Mul(a.y, b.y)), hn::Mul(a.z, b.z));
}
HWY_INLINE V3 Cross(const V3& a, const V3& b) {
  return {hn::Sub(hn::Mul(a.y, b.z), hn::Mul(a.z, b.y)), hn::Sub(hn::Mul(a.z, b.x), hn::Mul(a.x, b.z)),
          hn::Sub(hn::Mul(a.x, b.y), hn::Mul(a.y, b.x))};
}

void MeanValueRows(const double* points, size_t n, const MeanValueCageView& cage, double* rows,
                   unsigned char* guarded) {
  const D d;
  const size_t N = hn::Lanes(d);
  const size_t m = cage.point_count, t = cage.triangle_count;
  thread_local std::vector<double> e, w;  // e: (x, y, z, |e|) per vertex per lane; w: weights per lane
  e.resize(4 * m * N);
  w.resize(m * N);
  std::vector<double> lane_x(3 * N), lane_flag(N);
  const V zero = hn::Zero(d), one = hn::Set(d, 1.0), two = hn::Set(d, 2.0), half = hn::Set(d, 0.5);
  const V on_cage = hn::Set(d, cage.on_cage), near_plane = hn::Set(d, cage.near_plane);
  auto ev = [&](size_t j) {
    const double* p = e.data() + 4 * j * N;
    return V3{hn::LoadU(d, p), hn::LoadU(d, p + N), hn::LoadU(d, p + 2 * N)};
  };
  auto dist = [&](size_t j) { return hn::LoadU(d, e.data() + (4 * j + 3) * N); };

  for (size_t base = 0; base < n; base += N) {
    const size_t used = std::min(N, n - base);
    for (size_t k = 0; k < N; ++k)  // spare lanes repeat the last point
      for (int c = 0; c < 3; ++c) lane_x[c * N + k] = points[3 * (base + std::min(k, used - 1)) + c];
    const V x = hn::LoadU(d, lane_x.data()), y = hn::LoadU(d, lane_x.data() + N), z = hn::LoadU(d, lane_x.data() + 2 * N);
    M special = hn::Lt(zero, zero);
    for (size_t j = 0; j < m; ++j) {  // e_j = p_j - x, d_j = |e_j|
      const double* p = cage.points + 3 * j;
      const V3 r{hn::Sub(hn::Set(d, p[0]), x), hn::Sub(hn::Set(d, p[1]), y), hn::Sub(hn::Set(d, p[2]), z)};
      const V dj = hn::Sqrt(Dot(r, r));
      special = hn::Or(special, hn::Le(dj, on_cage));  // on a vertex
      double* q = e.data() + 4 * j * N;
      hn::StoreU(r.x, d, q);
      hn::StoreU(r.y, d, q + N);
      hn::StoreU(r.z, d, q + 2 * N);
      hn::StoreU(dj, d, q + 3 * N);
    }
    std::fill(w.begin(), w.end(), 0.0);
    for (size_t tri = 0; tri < t; ++tri) {
      const int* v = cage.triangles + 3 * tri;
      const double* nt = cage.normals + 3 * tri;
      const V3 r[3] = {ev(v[0]), ev(v[1]), ev(v[2])};
      const V dv[3] = {dist(v[0]), dist(v[1]), dist(v[2])};
      const V h = Dot(V3{hn::Set(d, nt[0]), hn::Set(d, nt[1]), hn::Set(d, nt[2])}, r[0]);
      const V dmin = hn::Min(hn::Min(dv[0], dv[1]), dv[2]);
      special = hn::Or(special, hn::Le(hn::Abs(h), hn::Max(on_cage, hn::Mul(near_plane, dmin))));
      // Thiery, Memari, Boubekeur 2018, "simple code", as in MeanValueCage::weights.
      V3 u[3];
      for (int k = 0; k < 3; ++k) {
        const V inv = hn::Div(one, dv[k]);
        u[k] = {hn::Mul(r[k].x, inv), hn::Mul(r[k].y, inv), hn::Mul(r[k].z, inv)};
      }
      V theta[3], length[3];
      V3 normal[3];
      for (int k = 0; k < 3; ++k) {
        const V3& a = u[(k + 1) % 3];
        const V3& b = u[(k + 2) % 3];
        const V3 diff{hn::Sub(a.x, b.x), hn::Sub(a.y, b.y), hn::Sub(a.z, b.z)};
        const V halfchord = hn::Min(hn::Mul(hn::Sqrt(Dot(diff, diff)), half), one);  // rounding past a diameter
        theta[k] = hn::Mul(two, hn::Asin(d, halfchord));
        normal[k] = Cross(r[(k + 1) % 3], r[(k + 2) % 3]);
        length[k] = hn::Sqrt(Dot(normal[k], normal[k]));
      }
      const V det = Dot(r[0], normal[0]);
      for (int i = 0; i < 3; ++i) {
        V sum = zero;
        for (int j = 0; j < 3; ++j) {
          const V term = hn::Div(hn::Mul(theta[j], Dot(normal[i], normal[j])), hn::Mul(two, length[j]));
          sum = hn::Add(sum, hn::IfThenElse(hn::Gt(length[j], zero), term, zero));
        }
        double* acc = w.data() + size_t(v[i]) * N;
        hn::StoreU(hn::Add(hn::LoadU(d, acc), hn::Div(sum, det)), d, acc);
      }
    }
    hn::StoreU(hn::VecFromMask(d, special), d, lane_flag.data());
    for (size_t k = 0; k < used; ++k) {
      guarded[base + k] = lane_flag[k] != 0.0;
      if (guarded[base + k]) continue;
      double* row = rows + (base + k) * m;
      double total = 0.0;
      for (size_t j = 0; j < m; ++j) total += w[j * N + k];
      for (size_t j = 0; j < m; ++j) row[j] = w[j * N + k] / total;
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace deformkit
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit {

HWY_EXPORT(MeanValueRows);

void mean_value_rows(const double* points, std::size_t n, const MeanValueCageView& cage, double* rows,
                     unsigned char* guarded) {
  HWY_DYNAMIC_DISPATCH(MeanValueRows)(points, n, cage, rows, guarded);
}

}  // namespace deformkit
#endif  // HWY_ONCE
