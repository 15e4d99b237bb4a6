#include "numerics/normal_equations.hpp"

#include "core/parallel.hpp"

#include <algorithm>
#include <cstring>

namespace deformkit {

SymmetricLower lower_triangle(const SparseMatrix& a) {
  SymmetricLower out;
  out.n = a.cols();
  out.start.assign(std::size_t(out.n) + 1, 0);
  out.row.reserve(std::size_t(a.nonZeros() / 2 + a.cols()));
  out.value.reserve(out.row.capacity());
  for (Eigen::Index j = 0; j < a.cols(); ++j) {
    SparseMatrix::InnerIterator it(a, j);
    while (it && it.row() < j) ++it;  // rows ascending in a compressed Eigen matrix
    if (!it || it.row() != j) out.row.push_back(j), out.value.push_back(0.0);
    for (; it; ++it) out.row.push_back(it.row()), out.value.push_back(it.value());
    out.start[std::size_t(j) + 1] = std::int64_t(out.row.size());
  }
  return out;
}

namespace {

// m's rows as lists of (column, value): the transpose, by a counting sort over its entries.
struct RowLists {
  std::vector<std::int64_t> start;
  std::vector<std::int32_t> col;
  std::vector<double> value;
};

RowLists rows_of(const SparseMatrix& m) {
  RowLists r;
  r.start.assign(std::size_t(m.rows()) + 1, 0);
  const auto* outer = m.outerIndexPtr();
  const auto* inner = m.innerIndexPtr();
  const double* val = m.valuePtr();
  const auto* nnz = m.innerNonZeroPtr();  // null when compressed
  auto column_end = [&](Eigen::Index j) { return nnz ? outer[j] + nnz[j] : outer[j + 1]; };
  for (Eigen::Index j = 0; j < m.cols(); ++j)
    for (auto e = outer[j]; e < column_end(j); ++e) ++r.start[std::size_t(inner[e]) + 1];
  for (std::size_t i = 0; i + 1 < r.start.size(); ++i) r.start[i + 1] += r.start[i];
  r.col.resize(std::size_t(r.start.back()));
  r.value.resize(r.col.size());
  std::vector<std::int64_t> at(r.start.begin(), r.start.end() - 1);
  for (Eigen::Index j = 0; j < m.cols(); ++j)
    for (auto e = outer[j]; e < column_end(j); ++e) {
      const auto k = std::size_t(at[std::size_t(inner[e])]++);
      r.col[k] = std::int32_t(j), r.value[k] = val[e];
    }
  return r;
}

}  // namespace

// Column j of M^T M is sum over the rows k of column j of M_kj (row k of M): Gustavson's product,
// each block of columns into its own arrays, joined at the end.
SymmetricLower normal_equations(const SparseMatrix& m) {
  const RowLists rows = rows_of(m);
  const auto n = std::size_t(m.cols());
  const int blocks = n < 2 * kParallelGrain ? 1 : parallel_threads();
  struct Part {
    std::vector<std::int64_t> count;
    std::vector<std::int64_t> row;
    std::vector<double> value;
  };
  std::vector<Part> parts(static_cast<std::size_t>(blocks));
  const std::size_t per = (n + std::size_t(blocks) - 1) / std::size_t(blocks);
  parallel_tasks(blocks, [&](int b) {
    const std::size_t begin = std::min(n, std::size_t(b) * per), end = std::min(n, begin + per);
    Part& p = parts[std::size_t(b)];
    p.count.reserve(end - begin);
    std::vector<double> acc(n, 0.0);
    std::vector<char> seen(n, 0);
    std::vector<std::int64_t> touched;
    for (std::size_t j = begin; j < end; ++j) {
      touched.assign(1, std::int64_t(j));
      seen[j] = 1;
      for (SparseMatrix::InnerIterator it(m, Eigen::Index(j)); it; ++it) {
        const auto k = std::size_t(it.row());
        const double mkj = it.value();
        for (std::int64_t e = rows.start[k]; e < rows.start[k + 1]; ++e) {
          const auto i = std::size_t(rows.col[std::size_t(e)]);
          if (i < j) continue;
          if (!seen[i]) seen[i] = 1, touched.push_back(std::int64_t(i));
          acc[i] += rows.value[std::size_t(e)] * mkj;
        }
      }
      std::sort(touched.begin() + 1, touched.end());
      for (std::int64_t i : touched) {
        p.row.push_back(i), p.value.push_back(acc[std::size_t(i)]);
        acc[std::size_t(i)] = 0.0, seen[std::size_t(i)] = 0;
      }
      p.count.push_back(std::int64_t(touched.size()));
    }
  });
  SymmetricLower out;
  out.n = std::int64_t(n);
  out.start.assign(n + 1, 0);
  std::size_t total = 0;
  for (const Part& p : parts) total += p.row.size();
  out.row.resize(total);
  out.value.resize(total);
  std::size_t j = 0, at = 0;
  for (const Part& p : parts) {
    for (std::int64_t c : p.count) out.start[j + 1] = out.start[j] + c, ++j;
    std::copy(p.row.begin(), p.row.end(), out.row.begin() + std::ptrdiff_t(at));
    std::copy(p.value.begin(), p.value.end(), out.value.begin() + std::ptrdiff_t(at));
    at += p.row.size();
  }
  return out;
}

SparseMatrix select_columns(const SparseMatrix& m, const std::vector<int>& keep, Eigen::Index out_cols,
                            const std::vector<int>* rows, Eigen::Index out_rows) {
  SparseMatrix out(rows ? out_rows : m.rows(), out_cols);
  std::vector<SparseMatrix::StorageIndex> outer(std::size_t(out_cols) + 1, 0);
  std::vector<SparseMatrix::StorageIndex> inner;
  std::vector<double> value;
  inner.reserve(std::size_t(m.nonZeros()));
  value.reserve(std::size_t(m.nonZeros()));
  for (Eigen::Index col = 0; col < m.cols(); ++col) {
    const int to = keep[std::size_t(col)];
    if (to < 0) continue;
    for (SparseMatrix::InnerIterator it(m, col); it; ++it) {
      const int r = rows ? (*rows)[std::size_t(it.row())] : int(it.row());
      if (r >= 0) inner.push_back(r), value.push_back(it.value());
    }
    outer[std::size_t(to) + 1] = SparseMatrix::StorageIndex(inner.size());
  }
  for (std::size_t j = 0; j + 1 < outer.size(); ++j) outer[j + 1] = std::max(outer[j + 1], outer[j]);
  out.resizeNonZeros(Eigen::Index(inner.size()));
  std::copy(outer.begin(), outer.end(), out.outerIndexPtr());
  std::copy(inner.begin(), inner.end(), out.innerIndexPtr());
  std::copy(value.begin(), value.end(), out.valuePtr());
  return out;
}

std::uint64_t pattern_digest(const SparseMatrix& m) {
  std::uint64_t h = 0x9e3779b97f4a7c15ull;
  auto mix = [&h](std::uint64_t v) {
    h ^= v + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
    h *= 0xff51afd7ed558ccdull;
  };
  mix(std::uint64_t(m.rows())), mix(std::uint64_t(m.cols()));
  for (Eigen::Index j = 0; j < m.cols(); ++j) {
    mix(~std::uint64_t(j));
    for (SparseMatrix::InnerIterator it(m, j); it; ++it) mix(std::uint64_t(it.row()));
  }
  return h;
}

}  // namespace deformkit
