#pragma once
// The RBF system of a set of controls, factorised once: for any displacements of the controls,
// the coefficients alpha and beta follow by solves (docs/math/rbf.md, "Solving").
#include "deformkit/numerics/sparse.hpp"
#include "deformkit/numerics/sparse_cholesky.hpp"
#include "deformkit/rbf/rbf_deformer.hpp"

#include <Eigen/Dense>

#include <cstddef>
#include <memory>

namespace deformkit {

// The polynomial term's basis: the monomials of degree <= degree in u = (x - centre) / scale,
// with centre and scale the controls' bounding box's centre and largest half side (scipy shifts
// and scales likewise; the space of polynomials, and so the fit, does not depend on it).
struct RbfPolynomial {
  int degree = -1;
  double centre[3] = {0, 0, 0};
  double scale = 1.0;
  int terms() const { return degree < 0 ? 0 : degree == 0 ? 1 : degree == 1 ? 4 : 10; }
  // q[k] for k < terms(): 1, u_x, u_y, u_z, u_x^2, u_x u_y, u_x u_z, u_y^2, u_y u_z, u_z^2.
  void basis(const double x[3], double* q) const;
  // dq[3 k + c] = d q_k / d x_c.
  void gradient(const double x[3], double* dq) const;
};

class RbfFit {
 public:
  RbfFit(const double* controls, std::size_t m, const RbfOptions& options, const RbfGrid* grid);
  // alpha (m x 3) and beta (terms x 3) for the displacements (m x 3) of the controls.
  void solve(const double* displacements, double* alpha, double* beta) const;
  const RbfPolynomial& polynomial() const { return polynomial_; }
  double condition_estimate() const { return condition_; }

 private:
  std::size_t m_ = 0;
  RbfPolynomial polynomial_;
  double condition_ = 1.0;
  bool sparse_ = false;
  // Dense (global kernels): the null-space method, P = Q R, A = Q2^T K Q2 = L L^T.
  Eigen::MatrixXd kernel_;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr_;
  Eigen::MatrixXd q_;  // Q, m x m (only with a polynomial)
  Eigen::LLT<Eigen::MatrixXd> reduced_;
  // Sparse (compact kernels): K = L L^T by CHOLMOD, the polynomial by the Schur complement.
  std::shared_ptr<SparseCholesky> cholesky_;
  Eigen::MatrixXd kinv_p_;  // K^-1 P, m x terms
  Eigen::MatrixXd p_;       // P, m x terms
  Eigen::LLT<Eigen::MatrixXd> schur_;  // P^T K^-1 P
};

}  // namespace deformkit
