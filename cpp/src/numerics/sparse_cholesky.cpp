#include "deformkit/numerics/sparse_cholesky.hpp"

#include "numerics/cholesky_factor.hpp"
#include "numerics/cholmod_view.hpp"
#include "numerics/normal_equations.hpp"
#include "numerics/supernodal_factor.hpp"
#include "core/parallel.hpp"

#include <cholmod.h>
#include <omp.h>

#include <cstdio>
#include <mutex>
#include <new>
#include <stdexcept>
#include <vector>

namespace deformkit {

// CHOLMOD orders and factorises (64-bit indices, so that the factor of a large mesh's squared
// Laplacian cannot overflow its non-zero count). A supernodal factor stays CHOLMOD's, solved in
// place (SupernodalFactor); a simplicial one is copied into a CholeskyFactor. Both solves read the
// factor once for all right-hand sides and run on every core.
struct SparseCholesky::State {
  cholmod_common common;
  cholmod_factor* factor = nullptr;  // during factorize(), and after it when supernodal
  SupernodalFactor super;            // a view of `factor` (supernodal), else empty
  CholeskyFactor copy;               // simplicial; for a supernodal factor made by factor() on demand
  bool ready = false, supernodal = false;
  Stages stages;  // of the last factorize()
  std::mutex copying;

  State() {
    cholmod_l_start(&common);
    common.print = 0;  // failures are reported through the return value, not on stderr
  }
  ~State() { release(); cholmod_l_finish(&common); }
  void release() {
    if (factor) cholmod_l_free_factor(&factor, &common);
    super = SupernodalFactor{};
    copy = CholeskyFactor{};
    ready = supernodal = false;
  }
  void check_memory() const {
    if (common.status == CHOLMOD_OUT_OF_MEMORY || common.status == CHOLMOD_TOO_LARGE) throw std::bad_alloc();
  }
};

namespace {

// CHOLMOD's supernodal factorisation opens OpenMP regions of a fixed 4 threads (its compile-time
// CHOLMOD_OMP_NUM_THREADS) around small scatters: on 2 cores, and more so with another program
// running, their start-up and barriers cost more than the work (the numeric step of L^T L at 104k
// vertices took 660-770 ms with them, 380-430 ms without, on one core). Inside this guard every
// region the calling thread opens runs on it alone.
struct SerialOpenMP {
  const int before = omp_get_max_active_levels();
  SerialOpenMP() { omp_set_max_active_levels(0); }
  ~SerialOpenMP() { omp_set_max_active_levels(before); }
  SerialOpenMP(const SerialOpenMP&) = delete;
  SerialOpenMP& operator=(const SerialOpenMP&) = delete;
};

// The supernodal factor's columns one by one, diagonal first; the explicit zeros of its relaxed
// supernodes dropped, except a column's first off-diagonal entry, its parent in the elimination
// tree that schedule() reads.
CholeskyFactor simplicial_copy(const SupernodalFactor& f) {
  CholeskyFactor c;
  c.unit_diagonal = false;
  c.start.assign(1, 0);
  for (std::int64_t s = 0; s < f.supernodes; ++s) {
    const std::int64_t j0 = f.column[s], cols = f.column[s + 1] - j0, rows = f.row_start[s + 1] - f.row_start[s];
    const double* block = f.value + f.value_start[s];
    for (std::int64_t k = 0; k < cols; ++k) {
      for (std::int64_t r = k; r < rows; ++r)
        if (r <= k + 1 || block[k * rows + r] != 0.0)
          c.row.push_back(std::int32_t(f.row[f.row_start[s] + r])), c.value.push_back(block[k * rows + r]);
      c.start.push_back(std::int64_t(c.row.size()));
    }
  }
  c.perm.assign(f.perm, f.perm + f.n);
  return c;
}

}  // namespace

SparseCholesky::SparseCholesky() : state_(std::make_unique<State>()) {}
SparseCholesky::~SparseCholesky() = default;

bool SparseCholesky::empty() const { return !state_->ready; }

const CholeskyFactor& SparseCholesky::factor() const {
  State& s = *state_;
  const std::lock_guard<std::mutex> lock(s.copying);
  if (s.ready && s.supernodal && s.copy.perm.empty()) {
    s.copy = simplicial_copy(s.super);
    s.copy.schedule(forked_after_threads() ? 1 : parallel_threads());
  }
  return s.copy;
}

const SupernodalFactor* SparseCholesky::supernodal_factor() const {
  return state_->ready && state_->supernodal ? &state_->super : nullptr;
}

const Stages& SparseCholesky::stages() const { return state_->stages; }

std::size_t SparseCholesky::factor_nonzeros() const {
  const State& s = *state_;
  return !s.ready ? 0 : s.supernodal ? s.super.stored() : s.copy.value.size();
}

bool SparseCholesky::factorize(const SparseMatrix& a, CholeskyKind kind) { return factorize(lower_triangle(a), kind); }

bool SparseCholesky::factorize(const SymmetricLower& a, CholeskyKind kind, const std::vector<std::int64_t>* ordering) {
  State& s = *state_;
  s.release();
  s.stages.clear();
  StageClock clock(s.stages);
  const SuiteSparse_long n = a.n;
  if (ordering && ordering->size() != std::size_t(n))
    throw std::invalid_argument("SparseCholesky::factorize: the ordering must have one entry per row");
  // CHOLMOD's compressed columns (stype -1: the lower triangle), a view of a.
  cholmod_sparse m = cholmod_view(a, true);
  // CHOLMOD's supernodal numeric factorisation opens OpenMP regions, which hang in a child forked
  // after the parent started OpenMP's threads; its simplicial path has none.
  if (forked_after_threads()) kind = CholeskyKind::Simplicial;
  s.common.supernodal = kind == CholeskyKind::Supernodal ? CHOLMOD_SUPERNODAL : CHOLMOD_SIMPLICIAL;
  s.common.final_ll = kind == CholeskyKind::Supernodal;  // simplicial: LDL^T, no square roots
  // AMD only: METIS's nested dissection saves ~10% of the factor but costs more than that in time.
  s.common.nmethods = 1;
  s.common.method[0].ordering = ordering ? CHOLMOD_GIVEN : CHOLMOD_AMD;
  s.common.postorder = 1;
  const SerialOpenMP serial;
  s.factor = ordering ? cholmod_l_analyze_p(&m, const_cast<SuiteSparse_long*>(
                                                    reinterpret_cast<const SuiteSparse_long*>(ordering->data())),
                                            nullptr, 0, &s.common)
                      : cholmod_l_analyze(&m, &s.common);
  clock.mark(ordering ? "symbolic (cholmod_analyze_p, ordering given)" : "ordering + symbolic (cholmod_analyze)");
  if (!s.factor) {
    s.check_memory();
    throw std::runtime_error("CHOLMOD could not analyse the matrix");
  }
  struct Release {  // on every way out but success, a bad_alloc in the copy below included
    State& s;
    bool keep = false;
    ~Release() {
      if (!keep) s.release();
    }
  } release{s};
  const double flops = s.common.fl;
  cholmod_l_factorize(&m, s.factor, &s.common);
  char label[96];
  std::snprintf(label, sizeof label, "numeric (cholmod_factorize, %.2f GFlop)", flops * 1e-9);
  clock.mark(label);
  if (s.common.status == CHOLMOD_NOT_POSDEF || s.factor->minor < s.factor->n) return false;
  if (s.common.status < CHOLMOD_OK) {
    s.check_memory();
    throw std::runtime_error("CHOLMOD could not factorise the matrix");
  }
  cholmod_factor* f = s.factor;
  if (f->is_super) {
    SupernodalFactor& v = s.super;
    v.n = n;
    v.supernodes = SuiteSparse_long(f->nsuper);
    v.column = static_cast<const std::int64_t*>(f->super);
    v.row_start = static_cast<const std::int64_t*>(f->pi);
    v.row = static_cast<const std::int64_t*>(f->s);
    v.value_start = static_cast<const std::int64_t*>(f->px);
    v.value = static_cast<const double*>(f->x);
    v.perm = static_cast<const std::int64_t*>(f->Perm);
    v.schedule(forked_after_threads() ? 1 : parallel_threads());
    clock.mark("solve schedule");
    s.supernodal = s.ready = release.keep = true;
    return true;
  }
  // Simplicial L D L^T: packed columns, diagonal first, copied.
  if (!cholmod_l_change_factor(CHOLMOD_REAL, f->is_ll, false, true, true, s.factor, &s.common)) {
    s.check_memory();
    throw std::runtime_error("CHOLMOD could not convert the factor");
  }
  const auto* start = static_cast<const SuiteSparse_long*>(f->p);
  const auto* row = static_cast<const SuiteSparse_long*>(f->i);
  const auto* value = static_cast<const double*>(f->x);
  const auto* perm = static_cast<const SuiteSparse_long*>(f->Perm);
  CholeskyFactor& c = s.copy;
  c.unit_diagonal = !f->is_ll;
  c.start.assign(1, 0);
  c.row.reserve(std::size_t(start[n]));
  c.value.reserve(std::size_t(start[n]));
  for (SuiteSparse_long j = 0; j < n; ++j) {
    for (SuiteSparse_long e = start[j]; e < start[j + 1]; ++e) c.row.push_back(std::int32_t(row[e])), c.value.push_back(value[e]);
    c.start.push_back(std::int64_t(c.row.size()));
  }
  c.perm.assign(perm, perm + n);
  cholmod_l_free_factor(&s.factor, &s.common);
  if (c.unit_diagonal)  // CHOLMOD's L D L^T also factors indefinite matrices
    for (SuiteSparse_long j = 0; j < n; ++j)
      if (!(c.value[std::size_t(c.start[std::size_t(j)])] > 0.0)) return false;
  clock.mark("copy factor");
  c.schedule(forked_after_threads() ? 1 : parallel_threads());
  clock.mark("solve schedule");
  s.ready = release.keep = true;
  return true;
}

Eigen::MatrixXd SparseCholesky::solve(const Eigen::MatrixXd& b) const {
  const State& s = *state_;
  if (!s.ready) throw std::logic_error("SparseCholesky::solve before a successful factorize");
  const std::size_t n = s.supernodal ? std::size_t(s.super.n) : s.copy.size();
  if (std::size_t(b.rows()) != n) throw std::invalid_argument("SparseCholesky::solve: wrong row count");
  Eigen::MatrixXd x(b.rows(), b.cols());
  if (s.supernodal) s.super.solve(b.data(), x.data(), int(b.cols()));
  else s.copy.solve(b.data(), x.data(), int(b.cols()));
  return x;
}

}  // namespace deformkit
