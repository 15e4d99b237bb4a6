#pragma once
// Anderson acceleration of a fixed-point iteration x <- G(x) (Walker and Ni 2011; for geometry
// solvers, Peng et al. 2018, Alg. 1): the next iterate combines the last m+1 values of G so that
// their residuals G(x) - x cancel in the least-squares sense. The caller keeps or rejects it (an
// energy safeguard); this only mixes.
#include <Eigen/Dense>

#include <cstddef>
#include <vector>

namespace deformkit {

class AndersonMixing {
 public:
  explicit AndersonMixing(int window);  // m >= 1 previous differences
  // x and g = G(x), flattened. Returns g - dG theta, theta = argmin |f - dF theta| over the
  // window's residual differences (f = g - x); g itself on the first call.
  Eigen::VectorXd next(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& g);
  std::size_t history() const { return columns_; }  // differences held, 0..m

 private:
  int window_;
  std::size_t columns_ = 0, newest_ = 0;  // dF, dG are rings of `window_` columns
  Eigen::MatrixXd df_, dg_;
  Eigen::VectorXd last_f_, last_g_;
};

}  // namespace deformkit
