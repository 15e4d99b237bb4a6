#include "deformkit/cage/cage_deformer.hpp"

#include "cage/sparse_rows.hpp"
#include "cage/weight_rows.hpp"
#include "core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace deformkit {

namespace {

// The control values as three columns (x, y, z), which the row products stream through.
struct ControlColumns {
  std::vector<double> c[3];
};

ControlColumns control_columns(const CageDeformer& d) {
  const std::size_t m = d.columns();
  std::vector<double> rows(3 * m);
  d.control_values(rows.data());
  ControlColumns cc;
  for (int a = 0; a < 3; ++a) {
    cc.c[a].resize(m);
    for (std::size_t j = 0; j < m; ++j) cc.c[a][j] = rows[3 * j + a];
  }
  return cc;
}

// sum_j w_j c_j for one row of weights (float or double), accumulated in double.
template <class W>
void row_product(const W* w, const ControlColumns& cc, std::size_t m, double* out) {
  const double* c[3] = {cc.c[0].data(), cc.c[1].data(), cc.c[2].data()};
  weight_rows_product(w, 1, m, c, out);
}

// The first row noted in an OpenMP region, reported after it (exceptions may not leave one).
class FirstRow {
 public:
  void note(std::size_t i) {
    std::size_t cur = first_.load();
    while (i < cur && !first_.compare_exchange_weak(cur, i)) {
    }
  }
  bool any() const { return first_.load() != kNone; }
  std::size_t row() const { return first_.load(); }

 private:
  static constexpr std::size_t kNone = ~std::size_t(0);
  std::atomic<std::size_t> first_{kNone};
};

// Rows of results (count x 3) into out as T; false if one is not finite there.
template <class T>
bool store_rows(const double* y, std::size_t count, T* out) {
  bool ok = true;
  for (std::size_t k = 0; k < 3 * count; ++k) {
    out[k] = static_cast<T>(y[k]);
    ok = ok && std::isfinite(out[k]);
  }
  return ok;
}

template <class T>
bool row_finite(const T* v, std::size_t m) {
  T acc = 0;
  for (std::size_t j = 0; j < m; ++j) acc += v[j] * T(0);
  return acc == acc;
}

}  // namespace

CageDeformer::CageDeformer(CageMesh cage) : cage_(std::move(cage)), current_(cage_.rest_points()) {}

void CageDeformer::set_cage_points(std::vector<double> points) {
  if (points.size() != current_.size())
    throw std::invalid_argument("cage_points: expected " + std::to_string(vertex_count()) + " points (the rest cage's), got " +
                                std::to_string(points.size() / 3));
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!std::isfinite(points[i]))
      throw std::invalid_argument("cage_points: point " + std::to_string(i / 3) + " is not finite");
  // Bit for bit, so that a cage moved back to rest is the identity again (-0.0 == 0.0 moves nothing).
  at_rest_ = points == cage_.rest_points();
  current_ = std::move(points);
}

std::uint64_t CageDeformer::layout() const {
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a
  auto mix = [&h](const void* p, std::size_t bytes) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < bytes; ++i) h = (h ^ c[i]) * 1099511628211ull;
  };
  mix(kind(), std::strlen(kind()));
  mix(cage_.rest_points().data(), cage_.rest_points().size() * sizeof(double));
  mix(cage_.triangles().data(), cage_.triangles().size() * sizeof(CageTriangle));
  return h;
}

void CageDeformer::coordinate_rows(const double* points, std::size_t n, double* w) const {
  const std::size_t m = columns();
  for (std::size_t i = 0; i < n; ++i)
    coordinates(Vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]), w + i * m, nullptr);
}

namespace {

// Points go to coordinate_rows() this many at a time: enough for the SIMD lanes of any target,
// few enough that a chunk's rows stay in the L2 cache.
constexpr std::size_t kChunk = 64;

// Rows [lo, lo + count) of `in` as double (n x 3); a non-finite row becomes the origin and is
// reported through `finite` (false), so that the chunk can still be computed as a whole.
template <class T>
void chunk_points(const T* in, std::size_t lo, std::size_t count, double* x, bool& finite) {
  for (std::size_t k = 0; k < count; ++k) {
    bool ok = true;
    for (int a = 0; a < 3; ++a) ok = ok && std::isfinite(double(in[3 * (lo + k) + a]));
    for (int a = 0; a < 3; ++a) x[3 * k + a] = ok ? double(in[3 * (lo + k) + a]) : 0.0;
    finite = finite && ok;
  }
}

}  // namespace

template <class T>
bool CageDeformer::deform_points(const T* in, T* out, std::size_t n) const {
  const ControlColumns cc = control_columns(*this);
  const std::size_t m = columns();
  std::atomic<bool> finite{true};
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    std::vector<double> w(kChunk * m), x(3 * kChunk);
    bool ok = true;
    for (std::size_t lo = begin; lo < end; lo += kChunk) {
      const std::size_t count = std::min(kChunk, end - lo);
      chunk_points(in, lo, count, x.data(), ok);
      coordinate_rows(x.data(), count, w.data());
      for (std::size_t k = 0; k < count; ++k) {
        double y[3];
        row_product(w.data() + k * m, cc, m, y);
        for (int a = 0; a < 3; ++a) {
          out[3 * (lo + k) + a] = static_cast<T>(y[a]);
          ok = ok && std::isfinite(out[3 * (lo + k) + a]);
        }
      }
    }
    if (!ok) finite = false;
  });
  return finite;
}

bool CageDeformer::deform_impl(const float* in, float* out, std::size_t n) const { return deform_points(in, out, n); }
bool CageDeformer::deform_impl(const double* in, double* out, std::size_t n) const { return deform_points(in, out, n); }

// J = sum_j c_j (grad w_j)^T, with the coordinate kind's exact gradients.
bool CageDeformer::jacobian_impl(const double* in, double* jac, std::size_t n) const {
  const std::size_t m = columns();
  std::vector<double> c(3 * m);
  control_values(c.data());
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    std::vector<double> w(m), dw(3 * m);
    for (std::size_t i = begin; i < end; ++i) {
      coordinates(Vec3(in[3 * i], in[3 * i + 1], in[3 * i + 2]), w.data(), dw.data());
      double j[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
      for (std::size_t k = 0; k < m; ++k)
        for (int r = 0; r < 3; ++r)
          for (int col = 0; col < 3; ++col) j[3 * r + col] += c[3 * k + r] * dw[3 * k + col];
      std::copy(j, j + 9, jac + 9 * i);
    }
  });
  return false;
}

template <class T>
CageBinding CageDeformer::bind_points(const T* in, std::size_t n, const CageBindOptions& options) const {
  require_finite_rows(in, n, "points");
  const bool sparse = options.storage == WeightStorage::Sparse;
  if (sparse && !(options.sparsify_threshold > 0.0 && std::isfinite(options.sparsify_threshold)))
    throw std::invalid_argument("sparsify: expected a positive finite threshold, got " +
                                std::to_string(options.sparsify_threshold));
  const std::size_t m = columns();
  CageBinding b;
  b.point_count = n;
  b.single_precision = std::is_same<T, float>::value;
  b.layout = layout();
  b.storage = options.storage;
  b.columns = m;
  if constexpr (std::is_same<T, float>::value) b.points_f32.assign(in, in + 3 * n);
  else b.points_f64.assign(in, in + 3 * n);
  if (options.storage == WeightStorage::Float64) b.weights_f64.resize(n * m);
  if (options.storage == WeightStorage::Float32) b.weights_f32.resize(n * m);

  // Sparse: the vertex columns keep their sum; the others' changes are charged by kappa.
  const std::size_t vertex_columns = this->vertex_columns();
  std::vector<double> kappa(m - vertex_columns);
  if (sparse) vector_column_bounds(kappa.data());
  FirstRow overflow, emptied;
  // Sparse rows per block, joined in block order afterwards.
  struct Rows {
    std::size_t begin = 0;
    std::vector<std::int64_t> counts;
    std::vector<std::int32_t> indices;
    std::vector<double> values;
    double dropped = 0.0, change = 0.0;
  };
  std::vector<Rows> blocks;
  std::atomic<std::size_t> block_count{0};
  const int threads = parallel_threads();
  blocks.resize(std::size_t(threads) + 1);
  std::atomic<double> rounding{0.0};
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    std::vector<double> chunk(kChunk * m), x(3 * kChunk);
    Rows& rows = blocks[block_count++];
    rows.begin = begin;
    double round_max = 0.0;
    for (std::size_t i = begin; i < end; ++i) {
      const std::size_t k = (i - begin) % kChunk;
      if (k == 0) {  // the next chunk's coordinates at once (the points are finite: checked above)
        const std::size_t count = std::min(kChunk, end - i);
        bool finite = true;
        chunk_points(in, i, count, x.data(), finite);
        coordinate_rows(x.data(), count, chunk.data());
      }
      double* w = chunk.data() + k * m;
      if (!row_finite(w, m)) {
        overflow.note(i);
        std::fill(w, w + m, 0.0);
      }
      if (options.storage == WeightStorage::Float64) {
        std::copy(w, w + m, b.weights_f64.data() + i * m);
      } else if (options.storage == WeightStorage::Float32) {
        float* row = b.weights_f32.data() + i * m;
        double change = 0.0;
        for (std::size_t j = 0; j < m; ++j) {
          row[j] = static_cast<float>(w[j]);
          change += std::abs(double(row[j]) - w[j]);
        }
        round_max = std::max(round_max, change);
      } else {
        // Drop the small weights; scale the kept vertex weights so that they keep their sum
        // (docs/math/cage.md, "Sparsified bindings").
        double total = 0.0, kept = 0.0, dropped = 0.0, change = 0.0;
        for (std::size_t j = 0; j < m; ++j) {
          const bool keep = std::abs(w[j]) >= options.sparsify_threshold;
          if (j < vertex_columns) {
            total += w[j];
            if (keep) kept += w[j];
          }
          if (!keep) {
            dropped += std::abs(w[j]);
            change += (j < vertex_columns ? 1.0 : kappa[j - vertex_columns]) * std::abs(w[j]);
          }
        }
        const double scale = total / kept;
        if (!(kept != 0.0 && std::isfinite(scale))) {
          emptied.note(i);
          rows.counts.push_back(0);
          continue;
        }
        std::int64_t count = 0;
        double rounded = 0.0;
        for (std::size_t j = 0; j < m; ++j)
          if (std::abs(w[j]) >= options.sparsify_threshold) {
            const double kept = j < vertex_columns ? w[j] * scale : w[j];
            // float32 points keep float32 values (CageBinding::sparse_values_f32); held here as the
            // doubles they widen to, so the join below is exact.
            const double stored = std::is_same<T, float>::value ? double(static_cast<float>(kept)) : kept;
            if (!std::isfinite(stored)) overflow.note(i);  // beyond float's range
            rows.indices.push_back(std::int32_t(j));
            rows.values.push_back(stored);
            change += std::abs(kept - w[j]);
            rounded += std::abs(stored - kept);
            ++count;
          }
        rows.counts.push_back(count);
        rows.dropped = std::max(rows.dropped, dropped);
        rows.change = std::max(rows.change, change);
        round_max = std::max(round_max, rounded);
      }
    }
    double cur = rounding.load();
    while (round_max > cur && !rounding.compare_exchange_weak(cur, round_max)) {
    }
  });
  if (overflow.any())
    throw std::invalid_argument("points: row " + std::to_string(overflow.row()) +
                                " lies so far from the cage that its coordinates overflow");
  if (emptied.any())
    throw std::invalid_argument("sparsify: threshold " + std::to_string(options.sparsify_threshold) +
                                " leaves the weights of point " + std::to_string(emptied.row()) +
                                " summing to zero; use a smaller threshold");
  b.float32_rounding_max = rounding.load();
  if (sparse) {
    blocks.resize(block_count.load());
    std::sort(blocks.begin(), blocks.end(), [](const Rows& x, const Rows& y) { return x.begin < y.begin; });
    b.sparse.indptr.reserve(n + 1);
    for (const Rows& r : blocks) {
      for (std::int64_t c : r.counts) b.sparse.indptr.push_back(b.sparse.indptr.back() + c);
      b.sparse.indices.insert(b.sparse.indices.end(), r.indices.begin(), r.indices.end());
      if constexpr (std::is_same<T, float>::value)
        b.sparse_values_f32.insert(b.sparse_values_f32.end(), r.values.begin(), r.values.end());
      else
        b.sparse.values.insert(b.sparse.values.end(), r.values.begin(), r.values.end());
      b.dropped_weight_max = std::max(b.dropped_weight_max, r.dropped);
      b.weight_change_max = std::max(b.weight_change_max, r.change);
    }
  }
  return b;
}

CageBinding CageDeformer::bind(const double* points, std::size_t n, const CageBindOptions& options) const {
  return bind_points(points, n, options);
}
CageBinding CageDeformer::bind(const float* points, std::size_t n, const CageBindOptions& options) const {
  return bind_points(points, n, options);
}

void CageDeformer::check_binding(const PointBinding& binding) const {
  const auto* b = dynamic_cast<const CageBinding*>(&binding);
  if (!b) throw std::invalid_argument("binding: was not made by a cage; bind the points to this cage");
  if (b->layout != layout())
    throw std::invalid_argument("binding: was made by a cage of another coordinate kind or rest cage; "
                                "bind the points to this cage");
}

void CageDeformer::bound_points(const PointBinding& b, StoredPoints<float>& points) const {
  const float* p = static_cast<const CageBinding&>(b).points_f32.data();
  points = StoredPoints<float>{{p, p + 1, p + 2}, 3, nullptr};
}
void CageDeformer::bound_points(const PointBinding& b, StoredPoints<double>& points) const {
  const double* p = static_cast<const CageBinding&>(b).points_f64.data();
  points = StoredPoints<double>{{p, p + 1, p + 2}, 3, nullptr};
}

// out = W c, one row at a time in parallel (docs/math/cage.md, "Binding").
template <class T>
bool CageDeformer::multiply(const CageBinding& b, T* out) const {
  const ControlColumns cc = control_columns(*this);
  const std::size_t m = b.columns, n = b.size();
  std::atomic<bool> finite{true};
  // Each chunk's rows, y = W c, by the storage's kernel.
  std::optional<PaddedControlRows> c4;
  if (b.storage == WeightStorage::Sparse) {
    std::vector<double> control(3 * m);
    for (std::size_t j = 0; j < m; ++j)
      for (int a = 0; a < 3; ++a) control[3 * j + a] = cc.c[a][j];
    c4.emplace(control.data(), m);
  }
  const double* c[3] = {cc.c[0].data(), cc.c[1].data(), cc.c[2].data()};
  auto rows = [&](std::size_t lo, std::size_t count, double* y) {
    if (b.storage == WeightStorage::Sparse) {
      const std::int64_t* indptr = b.sparse.indptr.data() + lo;
      if (b.single_precision)
        sparse_rows_product(indptr, b.sparse.indices.data(), b.sparse_values_f32.data(), count, c4->rows(), y);
      else
        sparse_rows_product(indptr, b.sparse.indices.data(), b.sparse.values.data(), count, c4->rows(), y);
    } else if (b.storage == WeightStorage::Float64) {
      weight_rows_product(b.weights_f64.data() + lo * m, count, m, c, y);
    } else {
      weight_rows_product(b.weights_f32.data() + lo * m, count, m, c, y);
    }
  };
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    constexpr std::size_t kRows = 256;  // rows per kernel call: results stay in the L1 cache
    double y[3 * kRows];
    bool ok = true;
    for (std::size_t lo = begin; lo < end; lo += kRows) {
      const std::size_t count = std::min(kRows, end - lo);
      rows(lo, count, y);
      ok = store_rows(y, count, out + 3 * lo) && ok;
    }
    if (!ok) finite = false;
  });
  return finite;
}

bool CageDeformer::deform_bound_impl(const PointBinding& b, float* out) const {
  return multiply(static_cast<const CageBinding&>(b), out);
}
bool CageDeformer::deform_bound_impl(const PointBinding& b, double* out) const {
  return multiply(static_cast<const CageBinding&>(b), out);
}

WeightTable CageDeformer::weights_table(const CageBinding& b) const {
  check_binding(b);
  if (b.storage == WeightStorage::Sparse && !b.single_precision) return b.sparse;
  if (b.storage == WeightStorage::Sparse) {
    WeightTable t{b.sparse.indptr, b.sparse.indices, {}};
    t.values.assign(b.sparse_values_f32.begin(), b.sparse_values_f32.end());
    return t;
  }
  WeightTable t;
  const std::size_t m = b.columns;
  t.indptr.reserve(b.size() + 1);
  for (std::size_t i = 0; i < b.size(); ++i) {
    for (std::size_t j = 0; j < m; ++j) {
      const double w = b.storage == WeightStorage::Float64 ? b.weights_f64[i * m + j] : double(b.weights_f32[i * m + j]);
      if (w != 0.0) {
        t.indices.push_back(std::int32_t(j));
        t.values.push_back(w);
      }
    }
    t.indptr.push_back(std::int64_t(t.indices.size()));
  }
  return t;
}

}  // namespace deformkit
