// As-rigid-as-possible surface deformation (Sorkine and Alexa 2007): local rotations, and the
// global step on the factorised constrained quadratic of L.
#include "deformkit/surface/surface_deformer.hpp"

#include "deformkit/numerics/best_rotation.hpp"
#include "numerics/anderson_mixing.hpp"
#include "core/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <mutex>

namespace deformkit {

double SurfaceDeformer::length_unit(const Matrix& rows) {
  if (rows.rows() == 0) return 1.0;
  const double side = (rows.colwise().maxCoeff() - rows.colwise().minCoeff()).maxCoeff();
  return side > 0 && std::isfinite(side) ? std::ldexp(1.0, std::ilogb(side)) : 1.0;
}

// Local step: R_i maximising tr(R_i S_i), S_i = sum_j w_ij e_ij e'_ij^T. The rotation does not
// change when S_i is scaled, so the edges are taken in units of each mesh's length_unit: S_i
// neither overflows nor underflows at any scale, and scaling both by 2^k changes no bit.
void SurfaceDeformer::fit_rotations(const Matrix& x, std::vector<Mat3>& rotations) const {
  const double rest_scale = 1.0 / length_unit_, x_scale = 1.0 / length_unit(x);
  parallel_blocks(rest_.rows(), [&](std::size_t begin, std::size_t end) {
    constexpr std::size_t kChunk = 512;  // S and R of a chunk, component-major for the SIMD polar step
    std::vector<double> s(9 * kChunk), r(9 * kChunk);
    for (std::size_t first = begin; first < end; first += kChunk) {
      const std::size_t count = std::min(kChunk, end - first);
      for (std::size_t i = first; i < first + count; ++i) {
        Mat3 si = Mat3::Zero();
        const Vec3 xi = x.row(i).transpose(), pi = rest_.row(i).transpose();
        for (const auto& [j, w] : neighbors_[i])
          si.noalias() += (w * rest_scale * (pi - rest_.row(j).transpose())) * (x_scale * (xi - x.row(j).transpose())).transpose();
        for (int k = 0; k < 9; ++k) s[std::size_t(k) * count + (i - first)] = si(k / 3, k % 3);
      }
      best_rotations(s.data(), r.data(), count);
      for (std::size_t i = 0; i < count; ++i)
        for (int k = 0; k < 9; ++k) rotations[first + i](k / 3, k % 3) = r[std::size_t(k) * count + i];
    }
  });
}

// b_i = sum_j w_ij / 2 (R_i + R_j)(p_i - p_j), on the free rows (Sorkine and Alexa 2007, eq. 8).
SurfaceDeformer::Matrix SurfaceDeformer::arap_rhs(const std::vector<Mat3>& rotations) const {
  const std::vector<int>& free = split_.free();
  Matrix b(Eigen::Index(free.size()), 3);
  parallel_blocks(free.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t f = begin; f < end; ++f) {
      const int i = free[f];
      Vec3 acc = Vec3::Zero();
      for (const auto& [j, w] : neighbors_[i])
        acc += 0.5 * w * (rotations[i] + rotations[j]) * (rest_.row(i) - rest_.row(j)).transpose();
      b.row(Eigen::Index(f)) = acc.transpose();
    }
  });
  return b;
}

double SurfaceDeformer::arap_energy(const Matrix& x, const std::vector<Mat3>& rotations) const {
  const double unit = 1.0 / length_unit_;
  double total = 0;
  std::mutex add;
  parallel_blocks(rest_.rows(), [&](std::size_t begin, std::size_t end) {
    double e = 0;
    for (std::size_t i = begin; i < end; ++i)
      for (const auto& [j, w] : neighbors_[i])
        e += w * (unit * ((x.row(i) - x.row(j)).transpose() - rotations[i] * (rest_.row(i) - rest_.row(j)).transpose()))
                     .squaredNorm();
    const std::lock_guard<std::mutex> lock(add);
    total += e;
  });
  return total;
}

SurfaceDeformer::Matrix SurfaceDeformer::deform_arap(const Matrix& fixed, const Matrix& pulls, const double* initial) {
  if (split_.free().empty()) return with_fixed(fixed);
  const std::vector<int>& soft = laplacian_system_.soft().unknowns;
  const std::vector<double>& w2 = laplacian_system_.soft().weights;
  std::vector<Mat3> rotations(rest_.rows(), Mat3::Identity());
  const Eigen::MatrixXd held = laplacian_system_.constraint_term(fixed, pulls);
  auto global_step = [&] { return Matrix(laplacian_system_.assemble(laplacian_system_.solve_free_with(arap_rhs(rotations), held), fixed)); };
  // A warm start: the rotations of the given positions (Sorkine and Alexa 2007 start from the
  // previous frame the same way), else R = I.
  if (initial)
    fit_rotations(Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(initial, rest_.rows(), 3), rotations);
  Matrix x = global_step();
  auto energy_of = [&](const Matrix& y, const std::vector<Mat3>& r) {
    double e = arap_energy(y, r);
    const double unit = 1.0 / length_unit_;  // arap_energy's units
    for (std::size_t k = 0; k < soft.size(); ++k)
      e += 2 * w2[k] * (unit * (y.row(soft[k]) - pulls.row(Eigen::Index(k)))).squaredNorm();
    return e;
  };
  auto converged = [&] {
    const std::size_t k = energy_.size();
    return settings_.tolerance > 0 && k > 1 && energy_[k - 2] - energy_[k - 1] <= settings_.tolerance * energy_[k - 2];
  };
  if (settings_.anderson > 0) return accelerate_arap(x, rotations, global_step, energy_of, converged);
  for (int it = 0; it < settings_.iterations; ++it) {
    fit_rotations(x, rotations);
    x = global_step();
    energy_.push_back(energy_of(x, rotations));
    if (converged()) break;
  }
  return x;
}

// Anderson-accelerated local/global (Peng et al. 2018, Alg. 1): x <- G(x) = global(local(x)) mixed
// over the last `anderson` steps; a mixed iterate is kept only if E(x, R(x)) falls, else the plain
// step G(x) is taken, which never raises it, so the energy stays monotone.
SurfaceDeformer::Matrix SurfaceDeformer::accelerate_arap(Matrix x, std::vector<Mat3>& rotations,
                                                         const std::function<Matrix()>& global_step,
                                                         const std::function<double(const Matrix&, const std::vector<Mat3>&)>& energy_of,
                                                         const std::function<bool()>& converged) {
  AndersonMixing mixing(settings_.anderson);
  fit_rotations(x, rotations);
  double e = energy_of(x, rotations);
  std::vector<Mat3> trial_rotations(rotations.size());
  const auto n = Eigen::Index(x.size());
  for (int it = 0; it < settings_.iterations; ++it) {
    Matrix g = global_step();
    Matrix trial(x.rows(), 3);
    Eigen::Map<Eigen::VectorXd>(trial.data(), n) =
        mixing.next(Eigen::Map<const Eigen::VectorXd>(x.data(), n), Eigen::Map<const Eigen::VectorXd>(g.data(), n));
    const bool mixed = mixing.history() > 0;
    fit_rotations(trial, trial_rotations);
    double et = energy_of(trial, trial_rotations);
    if (mixed && !(et < e)) {
      trial = g;
      fit_rotations(trial, trial_rotations);
      et = energy_of(trial, trial_rotations);
    }
    x = std::move(trial);
    rotations.swap(trial_rotations);
    e = et;
    energy_.push_back(e);
    if (converged()) break;
  }
  return x;
}

}  // namespace deformkit
