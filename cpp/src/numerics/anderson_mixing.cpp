#include "numerics/anderson_mixing.hpp"

#include <cmath>
#include <stdexcept>

namespace deformkit {

AndersonMixing::AndersonMixing(int window) : window_(window) {
  if (window < 1) throw std::invalid_argument("anderson: window must be >= 1");
}

Eigen::VectorXd AndersonMixing::next(const Eigen::Ref<const Eigen::VectorXd>& x,
                                     const Eigen::Ref<const Eigen::VectorXd>& g) {
  Eigen::VectorXd f = g - x;
  if (last_f_.size() == 0) {
    df_.resize(f.size(), window_);
    dg_.resize(f.size(), window_);
  } else {
    newest_ = columns_ == 0 ? 0 : (newest_ + 1) % std::size_t(window_);
    df_.col(Eigen::Index(newest_)) = f - last_f_;
    dg_.col(Eigen::Index(newest_)) = g - last_g_;
    columns_ = std::min(columns_ + 1, std::size_t(window_));
  }
  last_f_ = f;
  last_g_ = g;
  if (columns_ == 0) return g;
  const auto k = Eigen::Index(columns_);
  // The window's normal equations (k x k), solved rank-revealing: differences that have become
  // parallel near convergence get theta 0 instead of a blown-up combination.
  // theta does not change when df and f are scaled alike: beyond 2^+-200, where the products
  // could overflow or underflow, by a power of two near df's largest entry. Powers of two scale
  // exactly, so no bit of theta depends on the scale either way.
  const double largest = df_.leftCols(k).cwiseAbs().maxCoeff();
  Eigen::MatrixXd gram;
  Eigen::VectorXd rhs;
  if (largest >= 0x1p-200 && largest <= 0x1p200) {
    gram = df_.leftCols(k).transpose() * df_.leftCols(k);
    rhs = df_.leftCols(k).transpose() * f;
  } else {
    const double unit = largest > 0 && std::isfinite(largest) ? std::ldexp(1.0, -std::ilogb(largest)) : 1.0;
    const Eigen::MatrixXd scaled = unit * df_.leftCols(k);
    gram = scaled.transpose() * scaled;
    rhs = scaled.transpose() * (unit * f);
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(gram);
  qr.setThreshold(1e-12);
  const Eigen::VectorXd theta = qr.solve(rhs);
  if (!theta.allFinite()) return g;
  return g - dg_.leftCols(k) * theta;
}

}  // namespace deformkit
