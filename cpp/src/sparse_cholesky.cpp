#include "deformkit/sparse_cholesky.hpp"

#include <cholmod.h>

#include <mutex>
#include <new>
#include <stdexcept>
#include <vector>

namespace deformkit {

// The 64-bit index interface, so that the factor of a large mesh's squared Laplacian cannot
// overflow its non-zero count. CHOLMOD's common block holds workspace that solves write to,
// hence the mutex.
struct SparseCholesky::State {
  cholmod_common common;
  cholmod_factor* factor = nullptr;
  std::mutex solving;

  State() {
    cholmod_l_start(&common);
    common.print = 0;  // failures are reported through the return value, not on stderr
  }
  ~State() {
    if (factor) cholmod_l_free_factor(&factor, &common);
    cholmod_l_finish(&common);
  }
  void check_memory() const {
    if (common.status == CHOLMOD_OUT_OF_MEMORY || common.status == CHOLMOD_TOO_LARGE) throw std::bad_alloc();
  }
};

SparseCholesky::SparseCholesky() : state_(std::make_unique<State>()) {}
SparseCholesky::~SparseCholesky() = default;

bool SparseCholesky::empty() const { return state_->factor == nullptr; }

std::size_t SparseCholesky::factor_nonzeros() const {
  const cholmod_factor* f = state_->factor;
  if (!f) return 0;
  if (f->is_super) return std::size_t(f->xsize);
  return std::size_t(f->nzmax);
}

bool SparseCholesky::factorize(const SparseMatrix& a, CholeskyKind kind) {
  State& s = *state_;
  if (s.factor) cholmod_l_free_factor(&s.factor, &s.common);
  const SuiteSparse_long n = a.rows();
  // The lower triangle as CHOLMOD's compressed columns (stype -1).
  std::vector<SuiteSparse_long> p(std::size_t(n) + 1, 0), rows;
  std::vector<double> values;
  rows.reserve(std::size_t(a.nonZeros()));
  values.reserve(std::size_t(a.nonZeros()));
  for (SuiteSparse_long k = 0; k < n; ++k) {
    for (SparseMatrix::InnerIterator it(a, Eigen::Index(k)); it; ++it)
      if (it.row() >= k) rows.push_back(it.row()), values.push_back(it.value());
    p[std::size_t(k) + 1] = SuiteSparse_long(rows.size());
  }
  cholmod_sparse m{};
  m.nrow = m.ncol = std::size_t(n);
  m.nzmax = rows.size();
  m.p = p.data();
  m.i = rows.data();
  m.x = values.data();
  m.stype = -1;
  m.itype = CHOLMOD_LONG;
  m.xtype = CHOLMOD_REAL;
  m.dtype = CHOLMOD_DOUBLE;
  m.sorted = 1;
  m.packed = 1;
  s.common.supernodal = kind == CholeskyKind::Supernodal ? CHOLMOD_SUPERNODAL : CHOLMOD_SIMPLICIAL;
  s.common.final_ll = kind == CholeskyKind::Supernodal;  // simplicial: LDL^T, no square roots
  // AMD only: METIS's nested dissection saves ~10% of the factor but costs more than that in time.
  s.common.nmethods = 1;
  s.common.method[0].ordering = CHOLMOD_AMD;
  s.common.postorder = 1;
  s.factor = cholmod_l_analyze(&m, &s.common);
  if (!s.factor) {
    s.check_memory();
    throw std::runtime_error("CHOLMOD could not analyse the matrix");
  }
  cholmod_l_factorize(&m, s.factor, &s.common);
  if (s.common.status == CHOLMOD_NOT_POSDEF || s.factor->minor < s.factor->n) {
    cholmod_l_free_factor(&s.factor, &s.common);
    return false;
  }
  if (s.common.status < CHOLMOD_OK) {
    cholmod_l_free_factor(&s.factor, &s.common);
    s.check_memory();
    throw std::runtime_error("CHOLMOD could not factorise the matrix");
  }
  return true;
}

Eigen::MatrixXd SparseCholesky::solve(const Eigen::MatrixXd& b) const {
  State& s = *state_;
  if (!s.factor) throw std::logic_error("SparseCholesky::solve before a successful factorize");
  cholmod_dense rhs{};
  rhs.nrow = std::size_t(b.rows());
  rhs.ncol = std::size_t(b.cols());
  rhs.nzmax = rhs.d = rhs.nrow;
  rhs.nzmax *= rhs.ncol;
  rhs.x = const_cast<double*>(b.data());  // read only: cholmod_l_solve returns a new matrix
  rhs.xtype = CHOLMOD_REAL;
  rhs.dtype = CHOLMOD_DOUBLE;
  const std::lock_guard<std::mutex> lock(s.solving);
  cholmod_dense* x = cholmod_l_solve(CHOLMOD_A, s.factor, &rhs, &s.common);
  if (!x) {
    s.check_memory();
    throw std::runtime_error("CHOLMOD could not solve");
  }
  Eigen::MatrixXd out = Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(x->x), b.rows(), b.cols());
  cholmod_l_free_dense(&x, &s.common);
  return out;
}

}  // namespace deformkit
