#pragma once
// A CHOLMOD view (no copy) of a symmetric matrix's lower triangle, as its routines take it.
#include "deformkit/numerics/sparse_cholesky.hpp"

#include <cholmod.h>

namespace deformkit {

// values: false for the pattern alone (an ordering), true for the numeric factorisation.
inline cholmod_sparse cholmod_view(const SymmetricLower& a, bool values) {
  cholmod_sparse m{};
  m.nrow = m.ncol = std::size_t(a.n);
  m.nzmax = a.row.size();
  m.p = const_cast<std::int64_t*>(a.start.data());
  m.i = const_cast<std::int64_t*>(a.row.data());
  if (values) m.x = const_cast<double*>(a.value.data());
  m.stype = -1;
  m.itype = CHOLMOD_LONG;
  m.xtype = values ? CHOLMOD_REAL : CHOLMOD_PATTERN;
  m.dtype = CHOLMOD_DOUBLE;
  m.sorted = 1;
  m.packed = 1;
  return m;
}

}  // namespace deformkit
