#include "deformkit/numerics/sparse_cholesky.hpp"

#include "numerics/cholesky_factor.hpp"
#include "core/parallel.hpp"

#include <cholmod.h>

#include <new>
#include <stdexcept>
#include <vector>

namespace deformkit {

// CHOLMOD orders and factorises (64-bit indices, so that the factor of a large mesh's squared
// Laplacian cannot overflow its non-zero count); the factor is then copied into a CholeskyFactor,
// whose solve reads it once for all right-hand sides and runs on every core.
struct SparseCholesky::State {
  cholmod_common common;
  cholmod_factor* factor = nullptr;  // only during factorize()
  CholeskyFactor copy;
  bool ready = false;
  Stages stages;  // of the last factorize()

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

bool SparseCholesky::empty() const { return !state_->ready; }

const CholeskyFactor& SparseCholesky::factor() const { return state_->copy; }

const Stages& SparseCholesky::stages() const { return state_->stages; }

std::size_t SparseCholesky::factor_nonzeros() const { return state_->ready ? state_->copy.value.size() : 0; }

bool SparseCholesky::factorize(const SparseMatrix& a, CholeskyKind kind) {
  State& s = *state_;
  s.ready = false;
  s.copy = CholeskyFactor{};
  s.stages.clear();
  StageClock clock(s.stages);
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
  // CHOLMOD's supernodal numeric factorisation opens OpenMP regions, which hang in a child forked
  // after the parent started OpenMP's threads; its simplicial path has none.
  if (forked_after_threads()) kind = CholeskyKind::Simplicial;
  s.common.supernodal = kind == CholeskyKind::Supernodal ? CHOLMOD_SUPERNODAL : CHOLMOD_SIMPLICIAL;
  s.common.final_ll = kind == CholeskyKind::Supernodal;  // simplicial: LDL^T, no square roots
  // AMD only: METIS's nested dissection saves ~10% of the factor but costs more than that in time.
  s.common.nmethods = 1;
  s.common.method[0].ordering = CHOLMOD_AMD;
  s.common.postorder = 1;
  clock.mark("lower triangle");
  s.factor = cholmod_l_analyze(&m, &s.common);
  clock.mark("ordering + symbolic (cholmod_analyze)");
  if (!s.factor) {
    s.check_memory();
    throw std::runtime_error("CHOLMOD could not analyse the matrix");
  }
  struct FreeFactor {  // on every way out, a bad_alloc in the copy below included
    State& s;
    ~FreeFactor() {
      if (s.factor) cholmod_l_free_factor(&s.factor, &s.common);
    }
  } free_factor{s};
  cholmod_l_factorize(&m, s.factor, &s.common);
  clock.mark("numeric (cholmod_factorize)");
  if (s.common.status == CHOLMOD_NOT_POSDEF || s.factor->minor < s.factor->n) {
    cholmod_l_free_factor(&s.factor, &s.common);
    return false;
  }
  if (s.common.status < CHOLMOD_OK) {
    cholmod_l_free_factor(&s.factor, &s.common);
    s.check_memory();
    throw std::runtime_error("CHOLMOD could not factorise the matrix");
  }
  // Packed simplicial columns, diagonal first: L D L^T stays so, a supernodal L L^T becomes simplicial.
  cholmod_factor* f = s.factor;
  if (!cholmod_l_change_factor(CHOLMOD_REAL, f->is_ll, false, true, true, f, &s.common)) {
    cholmod_l_free_factor(&s.factor, &s.common);
    s.check_memory();
    throw std::runtime_error("CHOLMOD could not convert the factor");
  }
  clock.mark("to simplicial (cholmod_change_factor)");
  const auto* start = static_cast<const SuiteSparse_long*>(f->p);
  const auto* row = static_cast<const SuiteSparse_long*>(f->i);
  const auto* value = static_cast<const double*>(f->x);
  const auto* perm = static_cast<const SuiteSparse_long*>(f->Perm);
  CholeskyFactor& c = s.copy;
  c.unit_diagonal = !f->is_ll;
  // A supernodal factor carries the explicit zeros of its relaxed supernodes: dropped, except a
  // column's first off-diagonal entry, its parent in the elimination tree that schedule() reads.
  c.start.assign(1, 0);
  c.row.reserve(std::size_t(start[n]));
  c.value.reserve(std::size_t(start[n]));
  for (SuiteSparse_long j = 0; j < n; ++j) {
    SuiteSparse_long parent = -1;
    for (SuiteSparse_long e = start[j] + 1; e < start[j + 1]; ++e)
      if (parent < 0 || row[e] < row[parent]) parent = e;
    for (SuiteSparse_long e = start[j]; e < start[j + 1]; ++e)
      if (e == start[j] || e == parent || value[e] != 0.0)
        c.row.push_back(std::int32_t(row[e])), c.value.push_back(value[e]);
    c.start.push_back(std::int64_t(c.row.size()));
  }
  c.perm.assign(perm, perm + n);
  cholmod_l_free_factor(&s.factor, &s.common);
  if (c.unit_diagonal)  // CHOLMOD's L D L^T also factors indefinite matrices
    for (SuiteSparse_long j = 0; j < n; ++j)
      if (!(c.value[std::size_t(c.start[std::size_t(j)])] > 0.0)) {
        c = CholeskyFactor{};
        return false;
      }
  clock.mark("copy factor");
  c.schedule(forked_after_threads() ? 1 : parallel_threads());
  clock.mark("solve schedule");
  s.ready = true;
  return true;
}

Eigen::MatrixXd SparseCholesky::solve(const Eigen::MatrixXd& b) const {
  if (!state_->ready) throw std::logic_error("SparseCholesky::solve before a successful factorize");
  if (std::size_t(b.rows()) != state_->copy.size()) throw std::invalid_argument("SparseCholesky::solve: wrong row count");
  Eigen::MatrixXd x(b.rows(), b.cols());
  state_->copy.solve(b.data(), x.data(), int(b.cols()));
  return x;
}

}  // namespace deformkit
