#include "deformkit/stack.hpp"

#include "deformkit/parallel.hpp"

#include <stdexcept>
#include <string>

namespace deformkit {

Stack::Stack(std::vector<DeformerPtr> deformers) : deformers_(std::move(deformers)) {
  for (std::size_t i = 0; i < deformers_.size(); ++i)
    if (!deformers_[i]) throw std::invalid_argument("deformers: entry " + std::to_string(i) + " is None, not a deformer");
}

template <class T>
bool Stack::deform_any(const T* in, T* out, std::size_t n) const {
  if (deformers_.empty()) {
    if (in != out) std::copy(in, in + 3 * n, out);
    require_finite_rows(in, n, "points");
    return true;
  }
  deformers_.front()->deform(in, out, n);
  for (std::size_t i = 1; i < deformers_.size(); ++i) deformers_[i]->deform_verified(out, out, n);
  return true;
}

bool Stack::deform_impl(const float* in, float* out, std::size_t n) const { return deform_any(in, out, n); }
bool Stack::deform_impl(const double* in, double* out, std::size_t n) const { return deform_any(in, out, n); }

void Stack::jacobian_impl(const double* in, double* jac, std::size_t n) const {
  for (std::size_t i = 0; i < n; ++i)
    for (int e = 0; e < 9; ++e) jac[9 * i + e] = (e % 4 == 0) ? 1.0 : 0.0;
  std::vector<double> points(in, in + 3 * n), stage(9 * n);
  for (std::size_t s = 0; s < deformers_.size(); ++s) {
    // Chain rule: J <- J_s(F_s-1(...(x))) * J.
    deformers_[s]->jacobian(points.data(), stage.data(), n);
    parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> js(&stage[9 * i]);
        Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> total(&jac[9 * i]);
        total = (js * total).eval();
      }
    });
    if (s + 1 < deformers_.size()) deformers_[s]->deform_verified(points.data(), points.data(), n);
  }
}

}  // namespace deformkit
