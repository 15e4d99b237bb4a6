// The lattice's derivative paths: J = I + strength dD/ds ds/dx, by the per-point formulas or, for a
// box lattice (ds/dx constant), in SIMD lanes over the points of one cell at a time, sorted by
// cell chunk by chunk as deform() sorts them (docs/math/lattice.md, "Derivatives in SIMD lanes").
#include "deformkit/lattice/control_lattice.hpp"

#include "core/parallel.hpp"
#include "core/scale_free.hpp"
#include "lattice/cell_runs.hpp"
#include "lattice/lattice_kernel.hpp"

#include <algorithm>
#include <atomic>
#include <vector>

namespace deformkit {

Mat3 ControlLattice::jacobian_at(const Vec3& x, bool& overflow) const {
  Vec3 p;
  const PointStatus status = place(x, p);
  // A non-finite input is jacobian()'s to name; a finite one too far out to extrapolate is refused.
  overflow = x.allFinite() && (!p.allFinite() || too_far(p));
  Mat3 j = Mat3::Identity();
  if (!overflow && displaces(status)) {
    Mat3 d;
    displacement_at(p, &d);
    j += strength_ * d * parameter_jacobian(p);
  }
  return j;
}

void ControlLattice::reference_jacobian(const double* in, double* jac, std::size_t n) const {
  OverflowRows overflow;
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      bool over = false;
      const Mat3 j = jacobian_at(Vec3(in[3 * i], in[3 * i + 1], in[3 * i + 2]), over);
      if (over) overflow.note(i);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) jac[9 * i + 3 * r + c] = j(r, c);
    }
  });
  if (overflow.any()) refuse_row(in, overflow.first());
}

namespace {

constexpr int kJacobian = static_cast<int>(CellDerivative::Jacobian);
constexpr int kNormal = static_cast<int>(CellDerivative::Normal);
constexpr int kDeterminant = static_cast<int>(CellDerivative::Determinant);

}  // namespace

// Rows [0, n) of `what` through the lanes. weights are applied for normals and det J (jacobian()
// blends J itself); a row the lanes flag goes through the per-point formulas. False leaves the
// call to the generic path: a lattice that is not a box, too many cells to sort by counting, an
// input not finite or one whose lattice coordinates overflow (the generic path names it).
// all_lanes: set when every row went through the lanes, which saw each input and result finite.
template <class T>
bool ControlLattice::derivative_lanes(int what, const T* in, const T* normals, T* out, std::size_t n,
                                      bool* all_lanes) const {
  if (all_lanes) *all_lanes = false;
  const std::uint64_t still = still_key();
  if (!affine_ || still + 1 > kCountingSortKeys) return false;
  const CellDerivative kind = static_cast<CellDerivative>(what);
  double P[9];
  for (int e = 0; e < 9; ++e) P[e] = to_parameters_(e / 3, e % 3);
  const KernelAxis kaxes[3] = {kernel_axis(axes_[0]), kernel_axis(axes_[1]), kernel_axis(axes_[2])};
  const std::size_t block_size = 3 * std::size_t(kaxes[0].width) * kaxes[1].width * kaxes[2].width;
  const std::vector<double>& w = weights();
  const double* weight = what == kJacobian || w.empty() ? nullptr : w.data();
  std::vector<unsigned char> flags(n, 0);
  std::atomic<bool> usable{true}, flagged{false};
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    constexpr std::size_t kChunk = 8192;
    ChunkByCell chunk(still + 1, kChunk);
    std::vector<double> local(6 * kChunk), params(3 * kChunk);  // local: t then ds, 3 per row each
    std::vector<T> soa(6 * kChunk), block(block_size);
    for (std::size_t c = begin; c < end && usable; c += kChunk) {
      const std::size_t m = std::min(kChunk, end - c);
      if (!place_rows(in + 3 * c, m, params.data(), nullptr, chunk.key.data(), local.data(), &local[3 * kChunk])) {
        usable = false;  // an input not finite, or one whose coordinates overflow: the generic path names it
        return;
      }
      chunk.sort(c, m, [&](std::size_t i, std::size_t to) {
        const bool still_row = chunk.key[i] == still;
        for (int a = 0; a < 3; ++a) {
          soa[a * kChunk + to] = still_row ? T(0) : static_cast<T>(local[3 * i + a]);
          soa[(3 + a) * kChunk + to] = still_row ? T(0) : static_cast<T>(local[3 * kChunk + 3 * i + a]);
        }
      });
      chunk.runs(m, [&](std::uint64_t k, std::size_t lo, std::size_t hi) {
        CellRun<T> run;
        if (k != still) {
          cell_block(cell_of_key(k), block.data());
          run.block = block.data();
        }
        for (int a = 0; a < 3; ++a) {
          run.t[a] = &soa[a * kChunk + lo];
          run.ds[a] = &soa[(3 + a) * kChunk + lo];
        }
        run.order = &chunk.order[lo];
        run.count = hi - lo;
        if (!lattice_cell_derivatives(kind, kaxes, P, weight, run, normals, out, flags.data())) flagged = true;
      });
    }
  });
  if (!usable) return false;
  if (!flagged) {
    if (all_lanes) *all_lanes = true;
    return true;
  }
  // Flagged rows through the per-point formulas, blended and scale-free as the generic path is. A
  // row whose Jacobian is not finite leaves the whole call to the generic path, so that normals
  // and det J are refused exactly where jacobian() is, with its message.
  std::atomic<bool> all_finite_jacobians{true};
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end && all_finite_jacobians; ++i) {
      if (!flags[i]) continue;
      bool over = false;
      Mat3 j = jacobian_at(Vec3(in[3 * i], in[3 * i + 1], in[3 * i + 2]), over);
      if (over || !j.allFinite()) {
        all_finite_jacobians = false;
        return;
      }
      if (weight) j = (1.0 - weight[i]) * Mat3::Identity() + weight[i] * j;
      if (what == kJacobian) {
        for (int e = 0; e < 9; ++e) out[9 * i + e] = static_cast<T>(j(e / 3, e % 3));
      } else if (what == kDeterminant) {
        out[i] = static_cast<T>(scaled_determinant(j));
      } else {
        const Vec3 q = normal_direction(j, Vec3(normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]));
        for (int a = 0; a < 3; ++a) out[3 * i + a] = static_cast<T>(q[a]);
      }
    }
  });
  return all_finite_jacobians;
}

bool ControlLattice::jacobian_impl(const double* in, double* jac, std::size_t n) const {
  bool all_lanes = false;
  if (!derivative_lanes(kJacobian, in, static_cast<const double*>(nullptr), jac, n, &all_lanes))
    reference_jacobian(in, jac, n);
  return all_lanes;
}

bool ControlLattice::normals_impl(const double* points, const double* normals, double* out, std::size_t n) const {
  return all_finite(normals, n, 3) && derivative_lanes(kNormal, points, normals, out, n);
}
bool ControlLattice::normals_impl(const float* points, const float* normals, float* out, std::size_t n) const {
  return all_finite(normals, n, 3) && derivative_lanes(kNormal, points, normals, out, n);
}
bool ControlLattice::volume_ratio_impl(const double* points, double* out, std::size_t n) const {
  return derivative_lanes(kDeterminant, points, static_cast<const double*>(nullptr), out, n);
}

}  // namespace deformkit
