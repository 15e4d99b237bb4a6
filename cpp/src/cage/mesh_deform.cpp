#include "deformkit/cage/mesh_deform.hpp"

#include "cage/grid_stencil_direct.hpp"
#include "cage/harmonic_grid.hpp"
#include "cage/mesh_deform_solved.hpp"
#include "core/parallel.hpp"
#include "deformkit/core/validation.hpp"

#include <functional>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace deformkit {

namespace harmonic {

// Blender's thresholds, as the floats it compares with: a static weight is kept above the first,
// a cell's influence at or above the second.
const double kStaticMin = double(0.00001f);
const double kDynamicMin = double(0.0005f);
// Each column's relative residual. Against 1e-10 (Ogre, precisions 5-7, its deformed cage) 1e-8
// moved the positions by at most 3e-9 of the cage's diagonal, but for the 1-2 points of 26k where a
// weight crosses Blender's 1e-5 threshold (a jump at any tolerance). 1e-7 against 1e-8 (precision
// 8): 4e-8 of the diagonal at the 99th percentile, 2.4e-6 at the one point where a weight crosses,
// far inside the 1e-5 / 1e-4 Blender is matched to; one CG step of 8 fewer.
constexpr double kSolveTolerance = 1e-7;

namespace {

// The 8 cells around p and their trilinear weights (and, with `gradient`, the weights'
// gradients), as Blender finds them: the grid position truncated toward zero, the cells clamped.
struct Corners {
  std::int64_t cell[8];
  double weight[8];
  double gradient[8][3];
};

Corners corners_of(const HarmonicGrid& g, const double* p) {
  Corners c;
  int base[3];
  double frac[3];
  for (int a = 0; a < 3; ++a) {
    double x = (p[a] - g.min[a] - 0.5 * g.width) / g.width;
    x = std::clamp(x, -1.0, double(g.size));
    base[a] = static_cast<int>(x);  // toward zero, as Blender's int()
    frac[a] = x - base[a];
  }
  for (int k = 0; k < 8; ++k) {
    int idx[3];
    double w[3], dw[3];
    for (int a = 0; a < 3; ++a) {
      const bool up = k >> a & 1;
      idx[a] = std::clamp(base[a] + (up ? 1 : 0), 0, g.size - 1);
      w[a] = up ? frac[a] : 1.0 - frac[a];
      dw[a] = (up ? 1.0 : -1.0) / g.width;
    }
    c.cell[k] = g.index(idx[0], idx[1], idx[2]);
    c.weight[k] = w[0] * w[1] * w[2];
    c.gradient[k][0] = dw[0] * w[1] * w[2];
    c.gradient[k][1] = w[0] * dw[1] * w[2];
    c.gradient[k][2] = w[0] * w[1] * dw[2];
  }
  return c;
}

void require_unknowns(const Solved& s, int precision) {
  if (s.stencil.diagonal.empty())
    throw std::invalid_argument(
        "cage_points: cannot find a bind solution: no cell of the precision-" + std::to_string(precision) +
        " grid lies inside the cage (a cage thinner than the grid's cells); raise precision");
}

// Runs the grid solve over every cage vertex's column, `take` receiving blocks of solutions.
void solve_columns(const Solved& s, int precision,
                   const std::function<void(int, const Eigen::Ref<const Eigen::MatrixXd>&)>& take) {
  require_unknowns(s, precision);
  const int m = int(s.cage.vertex_count());
  const double unknowns = double(s.stencil.diagonal.size());
  // Multigrid: 16 columns a block (its SIMD lanes twice; docs/math/numerics.md). Cholesky: about
  // 128 MB of right-hand sides a block (one pass over the factor serves them all).
  const int block = s.solver == GridSolver::Multigrid ? std::min(m, 16)
                                                       : int(std::clamp(16.0e6 / unknowns, 1.0, double(m)));
  const PolygonMesh& poly = s.cage.polygons();
  auto fill = [&](int first, Eigen::Ref<Eigen::MatrixXd> rhs) {
    const int cols = int(rhs.cols());
    for (const BoundaryTerm& t : s.terms) {
      const int* corner = poly.face(std::size_t(t.face));
      const int k = poly.face_size(std::size_t(t.face));
      for (int i = 0; i < k; ++i) {
        const int col = corner[i] - first;
        if (col >= 0 && col < cols) rhs(t.unknown, col) += t.inverse_length * s.grid.cut_weights[std::size_t(t.weights + i)];
      }
    }
  };
  try {
    if (s.solver == GridSolver::Cholesky) numerics::solve_grid_stencil_direct(s.stencil, m, block, fill, take, 0.0);
    else numerics::solve_grid_stencil(s.stencil, m, block, fill, take, kSolveTolerance);
  } catch (const std::runtime_error&) {
    throw std::runtime_error("cage_points: cannot find a bind solution: the precision-" + std::to_string(precision) +
                             " grid's system around this cage is singular; try another precision");
  }
}

// Dynamic bind: every cell's coordinates at or above Blender's threshold, normalised per cell.
void solve_cells(Solved& s, int precision) {
  const HarmonicGrid& g = s.grid;
  const std::int64_t cells = g.cells();
  struct Entry {
    std::int64_t cell;
    std::int32_t vertex;
    double weight;
  };
  const int threads = parallel_threads();
  std::vector<std::vector<Entry>> found(static_cast<std::size_t>(threads));
  std::vector<std::int64_t> cell_of;
  cell_of.reserve(s.stencil.diagonal.size());
  for (std::int64_t c = 0; c < cells; ++c)
    if (s.stencil.unknown[std::size_t(c)] >= 0) cell_of.push_back(c);
  solve_columns(s, precision, [&](int first, const Eigen::Ref<const Eigen::MatrixXd>& x) {
    parallel_tasks(threads, [&](int task) {
      std::vector<Entry>& out = found[std::size_t(task)];
      const std::size_t n = cell_of.size(), lo = n * task / threads, hi = n * (task + 1) / threads;
      for (std::size_t u = lo; u < hi; ++u)
        for (Eigen::Index c = 0; c < x.cols(); ++c) {
          const double w = x(Eigen::Index(u), c);
          if (w >= kDynamicMin) out.push_back({cell_of[u], std::int32_t(first + c), w});
        }
    });
  });
  // The exterior cells' values come from the cuts alone.
  for (std::int64_t c = 0; c < cells; ++c) {
    if (!g.exterior[std::size_t(c)]) continue;
    bool near = g.semibound(c);
    for (int d = 0; d < 6 && !near; ++d) {
      const std::int64_t nb = g.neighbour(c, d);
      near = nb >= 0 && g.semibound(nb);
    }
    if (!near) continue;
    for (const auto& [vertex, w] : exterior_values(s.rays, g, c))
      if (w >= kDynamicMin) found[0].push_back({c, vertex, w});
  }
  std::size_t total = 0;
  for (const auto& f : found) total += f.size();
  if (total >= std::size_t(UINT32_MAX)) throw std::bad_alloc();
  s.cell_start.assign(std::size_t(cells) + 1, 0);
  for (const auto& f : found)
    for (const Entry& e : f) ++s.cell_start[std::size_t(e.cell) + 1];
  for (std::size_t c = 1; c < s.cell_start.size(); ++c) s.cell_start[c] += s.cell_start[c - 1];
  s.cell_vertex.resize(total);
  s.cell_weight.resize(total);
  std::vector<std::uint32_t> next(s.cell_start.begin(), s.cell_start.end() - 1);
  for (auto& f : found) {
    for (const Entry& e : f) {
      const std::uint32_t at = next[std::size_t(e.cell)]++;
      s.cell_vertex[at] = e.vertex;
      s.cell_weight[at] = e.weight;
    }
    f = std::vector<Entry>();
  }
  for (std::int64_t c = 0; c < cells; ++c) {
    double sum = 0.0;
    for (std::uint32_t k = s.cell_start[std::size_t(c)]; k < s.cell_start[std::size_t(c) + 1]; ++k) sum += s.cell_weight[k];
    if (sum > 0.0)
      for (std::uint32_t k = s.cell_start[std::size_t(c)]; k < s.cell_start[std::size_t(c) + 1]; ++k) s.cell_weight[k] /= sum;
  }
}

// Static bind: the cells the inside points reach and their values from the solve (memory is those
// cells x m, never unknowns x m), and per point its 8 corners and where each corner's values are.
struct ReachedCells {
  std::size_t m = 0;
  std::vector<double> weight;        // per inside point, its 8 corners' trilinear weights
  std::vector<double> gradient;      // and (when asked for) their gradients, 3 per corner
  std::vector<int> source;           // per point and corner: its slot in kept, or ~(its index in outer)
  std::vector<double> kept;          // slot-major: a reached unknown's m values side by side
  std::vector<SparseValues> outer;   // the reached exterior cells' values
};

ReachedCells reach_cells(const Solved& s, int precision, const std::vector<double>& points,
                         const std::vector<std::size_t>& inside, bool gradients) {
  ReachedCells r;
  const std::size_t m = r.m = s.cage.vertex_count(), n = inside.size();
  std::vector<std::int64_t> cell(8 * n);
  r.weight.resize(8 * n);
  if (gradients) r.gradient.resize(24 * n);
  parallel_blocks(n, [&](std::size_t lo, std::size_t hi) {
    for (std::size_t i = lo; i < hi; ++i) {
      const Corners c = corners_of(s.grid, points.data() + 3 * inside[i]);
      std::copy(c.cell, c.cell + 8, cell.begin() + std::ptrdiff_t(8 * i));
      std::copy(c.weight, c.weight + 8, r.weight.begin() + std::ptrdiff_t(8 * i));
      if (gradients) std::copy(&c.gradient[0][0], &c.gradient[0][0] + 24, r.gradient.begin() + std::ptrdiff_t(24 * i));
    }
  });
  r.source.resize(8 * n);
  std::vector<int> slot(s.stencil.diagonal.size(), -1);
  std::vector<int> slot_unknown;
  std::vector<std::int64_t> outer;
  for (std::size_t e = 0; e < 8 * n; ++e) {
    const int u = s.stencil.unknown[std::size_t(cell[e])];
    if (u < 0) {
      outer.push_back(cell[e]);
      continue;
    }
    if (slot[std::size_t(u)] < 0) {
      slot[std::size_t(u)] = int(slot_unknown.size());
      slot_unknown.push_back(u);
    }
    r.source[e] = slot[std::size_t(u)];
  }
  std::sort(outer.begin(), outer.end());
  outer.erase(std::unique(outer.begin(), outer.end()), outer.end());
  for (std::size_t e = 0; e < 8 * n; ++e)
    if (s.stencil.unknown[std::size_t(cell[e])] < 0)
      r.source[e] = ~int(std::lower_bound(outer.begin(), outer.end(), cell[e]) - outer.begin());
  r.outer.resize(outer.size());
  parallel_blocks(outer.size(), [&](std::size_t lo, std::size_t hi) {
    for (std::size_t k = lo; k < hi; ++k) r.outer[k] = exterior_values(s.rays, s.grid, outer[k]);
  });
  r.kept.resize(slot_unknown.size() * m);
  solve_columns(s, precision, [&](int first, const Eigen::Ref<const Eigen::MatrixXd>& x) {
    parallel_blocks(slot_unknown.size(), [&](std::size_t lo, std::size_t hi) {
      for (std::size_t k = lo; k < hi; ++k)
        for (Eigen::Index c = 0; c < x.cols(); ++c) r.kept[k * m + std::size_t(first + c)] = x(slot_unknown[k], c);
    });
  });
  return r;
}

// Inside point i's m coordinates, trilinear in its 8 cells (summed in corner order, from 0), into
// w; with dw (3 per coordinate), their gradients.
void trilinear_row(const ReachedCells& r, std::size_t i, double* w, double* dw) {
  const std::size_t m = r.m;
  const int* source = r.source.data() + 8 * i;
  const double* t = r.weight.data() + 8 * i;
  if (!dw && std::all_of(source, source + 8, [](int k) { return k >= 0; })) {
    // All 8 cells are unknowns (the usual case): one pass, the same sums in the same order.
    const double* v[8];
    for (int k = 0; k < 8; ++k) v[k] = r.kept.data() + std::size_t(source[k]) * m;
    for (std::size_t a = 0; a < m; ++a) {
      double x = 0.0;
      x += t[0] * v[0][a];
      x += t[1] * v[1][a];
      x += t[2] * v[2][a];
      x += t[3] * v[3][a];
      x += t[4] * v[4][a];
      x += t[5] * v[5][a];
      x += t[6] * v[6][a];
      x += t[7] * v[7][a];
      w[a] = x;
    }
    return;
  }
  std::fill(w, w + m, 0.0);
  if (dw) std::fill(dw, dw + 3 * m, 0.0);
  for (int k = 0; k < 8; ++k) {
    const double* g = dw ? r.gradient.data() + 24 * i + 3 * std::size_t(k) : nullptr;
    if (source[k] >= 0) {
      const double* value = r.kept.data() + std::size_t(source[k]) * m;
      for (std::size_t a = 0; a < m; ++a) w[a] += t[k] * value[a];
      if (dw)
        for (std::size_t a = 0; a < m; ++a)
          for (int q = 0; q < 3; ++q) dw[3 * a + q] += g[q] * value[a];
      continue;
    }
    for (const auto& [vertex, value] : r.outer[std::size_t(~source[k])]) {
      w[std::size_t(vertex)] += t[k] * value;
      if (dw)
        for (int q = 0; q < 3; ++q) dw[3 * std::size_t(vertex) + q] += g[q] * value;
    }
  }
}

// The float rows once more in blocks of 8 points (MeshDeformBinding::dense_weight) where that is
// at most 1.5 times the bytes of the rows with their cage vertices, starts and points: a block's
// weight costs less than a row's (no index, no sum across lanes, no finish per point), so up to
// there the blocks are faster (Bench at precision 4, 24 vertices, 13 of them a row: 0.16 ms a
// frame against 0.36), beyond it the bytes read decide.
void dense_rows(std::size_t m, MeshDeformBinding& b) {
  const std::size_t n = b.size(), blocks = (n + 7) / 8, rows = b.row_point.size();
  const double dense = 4.0 * double(m) * double(8 * blocks);
  const double sparse =
      double(b.weight_vertex.size()) * double(4 + b.weight_vertex.bytes_per_index()) + 8.0 * double(rows);
  if (!b.single_precision || rows == 0 || dense > 1.5 * sparse) return;
  b.dense_weight.assign(8 * m * blocks, 0.0f);
  for (std::size_t r = 0; r < rows; ++r) {
    const std::size_t i = b.row_point[r], at = 8 * m * (i / 8) + i % 8;
    for (std::uint32_t e = b.weight_start[r]; e < b.weight_start[r + 1]; ++e)
      b.dense_weight[at + 8 * std::size_t(b.weight_vertex[e])] = b.weight_value_f32[e];
  }
}

// The binding's rows for these lengths (per point: its kept coordinates), by length, points in
// order within a length (a counting sort), their starts, and room for their weights. Returns each
// point's row (valid where its length is not 0).
std::vector<std::uint32_t> ordered_rows(const std::vector<std::uint32_t>& length, std::size_t m, MeshDeformBinding& b) {
  const std::size_t n = length.size();
  std::vector<std::size_t> of_length(m + 2, 0);
  for (std::size_t i = 0; i < n; ++i) ++of_length[length[i] + 1];
  for (std::size_t k = 1; k < of_length.size(); ++k) of_length[k] += of_length[k - 1];
  const std::size_t empty = of_length[1];  // points without coordinates get no row
  b.row_point.assign(n - empty, 0);
  std::vector<std::uint32_t> row_of(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    if (length[i]) {
      row_of[i] = std::uint32_t(of_length[length[i]]++ - empty);
      b.row_point[row_of[i]] = std::uint32_t(i);
    }
  b.weight_start.assign(b.row_point.size() + 1, 0);
  std::uint64_t total = 0;
  for (std::size_t row = 0; row < b.row_point.size(); ++row) {
    total += length[b.row_point[row]];
    if (total >= std::uint64_t(UINT32_MAX)) throw std::bad_alloc();
    b.weight_start[row + 1] = std::uint32_t(total);
  }
  b.weight_vertex = WeightColumns(std::size_t(total), m);
  if (b.single_precision) b.weight_value_f32.resize(std::size_t(total));
  else b.weight_value.resize(std::size_t(total));
  return row_of;
}

// A saved bind's rows (point order, as weights_table exports them) checked as a static bind of
// b's points to m cage vertices, then laid out as kept_rows lays out a solve's.
void table_rows(const WeightTable& rows, std::size_t m, MeshDeformBinding& b) {
  const std::size_t n = b.size();
  rows.require_valid(m, "rows");
  if (rows.rows() != n)
    throw std::invalid_argument("rows: expected a row for each of the " + std::to_string(n) + " points, got " +
                                std::to_string(rows.rows()));
  std::vector<std::uint32_t> length(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const auto first = std::size_t(rows.indptr[i]), last = std::size_t(rows.indptr[i + 1]);
    if (last > first && !b.inside[i])
      throw std::invalid_argument("rows: point " + std::to_string(i) + " has a row but is outside the cage");
    double sum = 0.0;
    for (std::size_t e = first; e < last; ++e) {
      if (e > first && rows.indices[e] <= rows.indices[e - 1])
        throw std::invalid_argument("rows: the cage vertices of point " + std::to_string(i) + "'s row do not rise");
      if (!(rows.values[e] > 0.0 && rows.values[e] <= 1.0))
        throw std::invalid_argument("rows: weight " + std::to_string(e) + " is " + std::to_string(rows.values[e]) +
                                    ", not in (0, 1] as a bind's kept coordinates are");
      sum += rows.values[e];
    }
    if (last > first && std::abs(sum - 1.0) > 1e-4)
      throw std::invalid_argument("rows: point " + std::to_string(i) + "'s weights sum to " + std::to_string(sum) +
                                  ", not 1 as a bind's renormalised coordinates do");
    length[i] = std::uint32_t(last - first);
  }
  const std::vector<std::uint32_t> row_of = ordered_rows(length, m, b);
  std::vector<std::uint32_t> columns(m);
  for (std::size_t i = 0; i < n; ++i) {
    if (!length[i]) continue;
    const auto first = std::size_t(rows.indptr[i]);
    const std::size_t to = b.weight_start[row_of[i]];
    for (std::size_t e = 0; e < length[i]; ++e) {
      columns[e] = std::uint32_t(rows.indices[first + e]);
      if (b.single_precision) b.weight_value_f32[to + e] = float(rows.values[first + e]);
      else b.weight_value[to + e] = rows.values[first + e];
    }
    b.weight_vertex.assign(to, columns.data(), length[i]);
  }
  dense_rows(m, b);
}

// Blender's compaction of each inside point's row: weights above the threshold kept, scaled to
// sum to 1; outside points get no row. Each task writes its run of points into one buffer (no
// allocation per point), and the buffers are joined, then ordered by row length (the binding's
// layout, MeshDeformBinding).
void kept_rows(const ReachedCells& r, const std::vector<std::size_t>& inside, MeshDeformBinding& b) {
  const std::size_t m = r.m, count = inside.size(), n = b.size();
  const int tasks = count < 2 * kParallelGrain || forked_after_threads() ? 1 : parallel_threads();
  struct Run {
    std::vector<std::uint32_t> indices;
    std::vector<double> values;
    std::size_t used = 0;
  };
  std::vector<Run> runs(static_cast<std::size_t>(tasks));
  std::vector<std::uint32_t> length(n, 0);  // per point: its kept coordinates
  parallel_tasks(tasks, [&](int task) {
    const std::size_t lo = count * std::size_t(task) / std::size_t(tasks), hi = count * std::size_t(task + 1) / std::size_t(tasks);
    Run& run = runs[std::size_t(task)];
    std::vector<double> w(m);
    for (std::size_t i = lo; i < hi; ++i) {
      trilinear_row(r, i, w.data(), nullptr);
      if (run.values.size() < run.used + m) {
        const std::size_t grown = std::max(run.used + m, 2 * run.values.size());
        run.indices.resize(grown);
        run.values.resize(grown);
      }
      // Without branches (which weights are kept is unpredictable): every weight is written, the
      // next slot taken only when it is kept. Then the kept ones summed in order, and scaled.
      std::uint32_t* index = run.indices.data() + run.used;
      double* value = run.values.data() + run.used;
      std::size_t kept = 0;
      for (std::size_t a = 0; a < m; ++a) {
        index[kept] = std::uint32_t(a);
        value[kept] = w[a];
        kept += w[a] > kStaticMin;
      }
      double sum = 0.0;
      for (std::size_t e = 0; e < kept; ++e) sum += value[e];
      for (std::size_t e = 0; e < kept; ++e) value[e] /= sum;
      run.used += kept;
      length[inside[i]] = std::uint32_t(kept);
    }
  });
  // Each task's run copied to its rows' places.
  const std::vector<std::uint32_t> row_of = ordered_rows(length, m, b);
  parallel_tasks(tasks, [&](int task) {
    const std::size_t lo = count * std::size_t(task) / std::size_t(tasks), hi = count * std::size_t(task + 1) / std::size_t(tasks);
    Run& run = runs[std::size_t(task)];
    std::size_t from = 0;
    for (std::size_t i = lo; i < hi; ++i) {
      const std::size_t point = inside[i], kept = length[point];
      if (!kept) continue;
      const std::size_t to = b.weight_start[row_of[point]];
      b.weight_vertex.assign(to, run.indices.data() + from, kept);
      if (b.single_precision)
        for (std::size_t e = 0; e < kept; ++e) b.weight_value_f32[to + e] = float(run.values[from + e]);
      else
        std::copy(run.values.begin() + std::ptrdiff_t(from), run.values.begin() + std::ptrdiff_t(from + kept),
                  b.weight_value.begin() + std::ptrdiff_t(to));
      from += kept;
    }
    run = Run();
  });
  dense_rows(m, b);
}

// A binding of these points (checked finite, kept in their precision) to a deformer of this
// layout, before its inside flags and coordinates: what every way of binding starts from.
template <class T>
MeshDeformBinding binding_of(const T* in, std::size_t n, std::uint64_t layout) {
  require_finite_rows(in, n, "points");
  MeshDeformBinding b;
  b.point_count = n;
  b.single_precision = std::is_same<T, float>::value;
  b.layout = layout;
  if constexpr (std::is_same<T, float>::value) b.points_f32.assign(in, in + 3 * n);
  else b.points_f64.assign(in, in + 3 * n);
  return b;
}

template <class T>
std::vector<double> as_doubles(const T* in, std::size_t n) {
  return std::vector<double>(in, in + 3 * n);
}

template <class T>
bool finite_rows(const T* in, std::size_t n) {
  for (std::size_t i = 0; i < 3 * n; ++i)
    if (!std::isfinite(double(in[i]))) return false;
  return true;
}

// The displacement at p of a dynamic bind: sum over the 8 cells of their influences' weighted
// displacements over the weights' sum (0 where no cell has any); with `jac`, its Jacobian.
bool dynamic_offset(const Solved& s, const double* p, const double* disp, double* out, double* jac) {
  const Corners c = corners_of(s.grid, p);
  double num[3] = {0, 0, 0}, den = 0.0, dnum[3][3] = {{0}}, dden[3] = {0, 0, 0};
  for (int k = 0; k < 8; ++k) {
    double a[3] = {0, 0, 0}, b = 0.0;
    for (std::uint32_t e = s.cell_start[std::size_t(c.cell[k])]; e < s.cell_start[std::size_t(c.cell[k]) + 1]; ++e) {
      const double w = s.cell_weight[e];
      const double* d = disp + 3 * s.cell_vertex[e];
      for (int r = 0; r < 3; ++r) a[r] += w * d[r];
      b += w;
    }
    for (int r = 0; r < 3; ++r) num[r] += c.weight[k] * a[r];
    den += c.weight[k] * b;
    if (jac) {
      for (int r = 0; r < 3; ++r)
        for (int q = 0; q < 3; ++q) dnum[r][q] += a[r] * c.gradient[k][q];
      for (int q = 0; q < 3; ++q) dden[q] += b * c.gradient[k][q];
    }
  }
  if (!(den > 0.0)) {
    for (int r = 0; r < 3; ++r) out[r] = 0.0;
    if (jac) std::fill(jac, jac + 9, 0.0);
    return false;
  }
  for (int r = 0; r < 3; ++r) out[r] = num[r] / den;
  if (jac)
    for (int r = 0; r < 3; ++r)
      for (int q = 0; q < 3; ++q) jac[3 * r + q] = dnum[r][q] / den - num[r] * dden[q] / (den * den);
  return true;
}

}  // namespace
}  // namespace harmonic

WeightColumns::WeightColumns(std::size_t count, std::size_t vertex_count) {
  if (vertex_count <= std::size_t(UINT8_MAX) + 1) storage_ = std::vector<std::uint8_t>(count);
  else if (vertex_count <= std::size_t(UINT16_MAX) + 1) storage_ = std::vector<std::uint16_t>(count);
  else storage_ = std::vector<std::uint32_t>(count);
}

void WeightColumns::assign(std::size_t at, const std::uint32_t* vertices, std::size_t count) {
  std::visit([&](auto& c) {
    using Index = typename std::decay_t<decltype(c)>::value_type;
    for (std::size_t e = 0; e < count; ++e) c[at + e] = Index(vertices[e]);
  }, storage_);
}

MeshDeform::MeshDeform(CageMesh cage, int precision, bool dynamic, int bvh_arity, GridSolver solver)
    : cage_(std::move(cage)), precision_(precision), dynamic_(dynamic), bvh_arity_(bvh_arity), solver_(solver),
      current_(cage_.rest_points()) {
  if (precision < kMinPrecision || precision > kMaxPrecision)
    throw std::invalid_argument("precision: expected an integer from 2 to 10 (2^precision + 2 grid cells a side), got " +
                                std::to_string(precision));
  if (bvh_arity != 2 && bvh_arity != 4)
    throw std::invalid_argument("bvh_arity: expected 2 or 4, got " + std::to_string(bvh_arity));
  auto solved = std::make_shared<harmonic::Solved>(cage_, precision_, bvh_arity_, solver_);
  harmonic::require_unknowns(*solved, precision_);
  if (dynamic_) harmonic::solve_cells(*solved, precision_);
  solved_ = std::move(solved);
}

MeshDeform::~MeshDeform() = default;

std::size_t MeshDeform::unknown_count() const { return solved_->stencil.diagonal.size(); }

void MeshDeform::set_cage_points(std::vector<double> points) {
  if (points.size() != current_.size())
    throw std::invalid_argument("cage_points: expected " + std::to_string(vertex_count()) +
                                " points (the rest cage's), got " + std::to_string(points.size() / 3));
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!std::isfinite(points[i]))
      throw std::invalid_argument("cage_points: point " + std::to_string(i / 3) + " is not finite");
  at_rest_ = points == cage_.rest_points();
  current_ = std::move(points);
}

std::uint64_t MeshDeform::layout() const {
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a over what a binding depends on
  auto mix = [&h](const void* p, std::size_t bytes) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < bytes; ++i) h = (h ^ c[i]) * 1099511628211ull;
  };
  const char kind[] = "mesh deform";
  mix(kind, sizeof kind);
  mix(&precision_, sizeof precision_);
  mix(&dynamic_, sizeof dynamic_);
  mix(&bvh_arity_, sizeof bvh_arity_);
  mix(cage_.rest_points().data(), cage_.rest_points().size() * sizeof(double));
  mix(cage_.polygons().corners().data(), cage_.polygons().corners().size() * sizeof(int));
  return h;
}

std::vector<double> MeshDeform::displacements() const {
  std::vector<double> d(current_.size());
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = current_[i] - cage_.rest_points()[i];
  return d;
}

template <class T>
MeshDeformBinding MeshDeform::bind_points(const T* in, std::size_t n, const std::uint8_t* kept) const {
  if (kept && !dynamic_)
    throw std::invalid_argument("inside: only a dynamic MeshDeform takes the points' inside flags from Bind; a static "
                                "bind tests its points and keeps their coordinates");
  const harmonic::Solved& s = *solved_;
  MeshDeformBinding b = harmonic::binding_of(in, n, layout());
  b.dynamic = dynamic_;
  const std::vector<double> points = harmonic::as_doubles(in, n);
  b.inside.assign(n, 0);
  if (kept)  // Blender's dynverts: decided at Bind, not where the points are now
    for (std::size_t i = 0; i < n; ++i) b.inside[i] = kept[i] != 0;
  else parallel_blocks(n, [&](std::size_t lo, std::size_t hi) {
    std::vector<harmonic::RayCage::Hit> scratch;
    for (std::size_t i = lo; i < hi; ++i)
      b.inside[i] = harmonic::inside_cage(s.rays, s.grid, Vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]), scratch);
  });
  if (dynamic_) {
    b.corner_slot.assign(8 * n, 0);
    b.corner_weight.assign(8 * n, 0.0);
    for (std::size_t i = 0; i < n; ++i)
      if (b.inside[i]) {
        const harmonic::Corners c = harmonic::corners_of(s.grid, points.data() + 3 * i);
        for (int k = 0; k < 8; ++k) b.cells.push_back(c.cell[k]);
      }
    std::sort(b.cells.begin(), b.cells.end());
    b.cells.erase(std::unique(b.cells.begin(), b.cells.end()), b.cells.end());
    for (std::size_t i = 0; i < n; ++i)
      if (b.inside[i]) {
        const harmonic::Corners c = harmonic::corners_of(s.grid, points.data() + 3 * i);
        for (int k = 0; k < 8; ++k) {
          b.corner_slot[8 * i + std::size_t(k)] =
              std::uint32_t(std::lower_bound(b.cells.begin(), b.cells.end(), c.cell[k]) - b.cells.begin());
          b.corner_weight[8 * i + std::size_t(k)] = c.weight[k];
        }
      }
    return b;
  }
  std::vector<std::size_t> inside;
  for (std::size_t i = 0; i < n; ++i)
    if (b.inside[i]) inside.push_back(i);
  harmonic::kept_rows(harmonic::reach_cells(s, precision_, points, inside, false), inside, b);
  return b;
}

template <class T>
MeshDeformBinding MeshDeform::bound_rows(const T* in, std::size_t n, const std::uint8_t* inside,
                                         const WeightTable& rows) const {
  if (dynamic_)
    throw std::invalid_argument("rows: a dynamic MeshDeform keeps no rows (its coordinates are the grid's, read "
                                "where each point is): bind it without rows");
  MeshDeformBinding b = harmonic::binding_of(in, n, layout());
  b.inside.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    b.inside[i] = inside ? inside[i] != 0 : rows.rows() == n && rows.indptr[i + 1] > rows.indptr[i];
  harmonic::table_rows(rows, vertex_count(), b);
  return b;
}

MeshDeformBinding MeshDeform::bind_rows(const double* points, std::size_t n, const std::uint8_t* inside,
                                        const WeightTable& rows) const {
  return bound_rows(points, n, inside, rows);
}
MeshDeformBinding MeshDeform::bind_rows(const float* points, std::size_t n, const std::uint8_t* inside,
                                        const WeightTable& rows) const {
  return bound_rows(points, n, inside, rows);
}

MeshDeformBinding MeshDeform::bind(const double* points, std::size_t n, const std::uint8_t* inside) const {
  return bind_points(points, n, inside);
}
MeshDeformBinding MeshDeform::bind(const float* points, std::size_t n, const std::uint8_t* inside) const {
  return bind_points(points, n, inside);
}

WeightTable MeshDeform::weights_table(const MeshDeformBinding& b) const {
  check_binding(b);
  if (!b.dynamic) {  // the rows back in point order
    WeightTable t;
    t.indptr.assign(b.size() + 1, 0);
    for (std::size_t r = 0; r < b.row_point.size(); ++r) t.indptr[b.row_point[r] + 1] = b.weight_start[r + 1] - b.weight_start[r];
    for (std::size_t i = 0; i < b.size(); ++i) t.indptr[i + 1] += t.indptr[i];
    t.indices.resize(b.weight_vertex.size());
    t.values.resize(b.weight_vertex.size());
    for (std::size_t r = 0; r < b.row_point.size(); ++r)
      for (std::uint32_t e = b.weight_start[r], to = std::uint32_t(t.indptr[b.row_point[r]]); e < b.weight_start[r + 1]; ++e, ++to) {
        t.indices[to] = std::int32_t(b.weight_vertex[e]);
        t.values[to] = b.single_precision ? double(b.weight_value_f32[e]) : b.weight_value[e];
      }
    return t;
  }
  const harmonic::Solved& s = *solved_;
  const std::size_t m = vertex_count();
  WeightTable t;
  std::vector<double> row(m);
  for (std::size_t i = 0; i < b.size(); ++i) {
    if (b.inside[i]) {
      double p[3];
      for (int a = 0; a < 3; ++a) p[a] = b.single_precision ? double(b.points_f32[3 * i + a]) : b.points_f64[3 * i + a];
      std::fill(row.begin(), row.end(), 0.0);
      const harmonic::Corners c = harmonic::corners_of(s.grid, p);
      double total = 0.0;
      for (int k = 0; k < 8; ++k)
        for (std::uint32_t e = s.cell_start[std::size_t(c.cell[k])]; e < s.cell_start[std::size_t(c.cell[k]) + 1]; ++e) {
          row[std::size_t(s.cell_vertex[e])] += c.weight[k] * s.cell_weight[e];
          total += c.weight[k] * s.cell_weight[e];
        }
      for (std::size_t a = 0; a < m; ++a)
        if (row[a] != 0.0) {
          t.indices.push_back(std::int32_t(a));
          t.values.push_back(row[a] / total);
        }
    }
    t.indptr.push_back(std::int64_t(t.indices.size()));
  }
  return t;
}

void MeshDeform::check_binding(const PointBinding& binding) const {
  const auto* b = dynamic_cast<const MeshDeformBinding*>(&binding);
  if (!b || b->layout != layout())
    throw std::invalid_argument(
        "binding: was made by another MeshDeform (another rest cage, precision, bind mode or blender_version)");
}

void MeshDeform::bound_points(const PointBinding& binding, StoredPoints<float>& points) const {
  const auto& b = static_cast<const MeshDeformBinding&>(binding);
  points = {{b.points_f32.data(), b.points_f32.data() + 1, b.points_f32.data() + 2}, 3, nullptr};
}
void MeshDeform::bound_points(const PointBinding& binding, StoredPoints<double>& points) const {
  const auto& b = static_cast<const MeshDeformBinding&>(binding);
  points = {{b.points_f64.data(), b.points_f64.data() + 1, b.points_f64.data() + 2}, 3, nullptr};
}

template <class T>
bool MeshDeform::deform_points(const T* in, T* out, std::size_t n) const {
  if (!harmonic::finite_rows(in, n)) return false;
  const MeshDeformBinding b = bind_points(in, n, nullptr);
  return evaluate_bound(b, out, false, nullptr);
}

bool MeshDeform::deform_impl(const float* in, float* out, std::size_t n) const { return deform_points(in, out, n); }
bool MeshDeform::deform_impl(const double* in, double* out, std::size_t n) const { return deform_points(in, out, n); }

// J = I + sum_a d_a (grad w~_a)^T with w~ the kept weights over their sum (static), or the
// quotient rule through the 8 cells' sums (dynamic); outside the cage J = I.
bool MeshDeform::jacobian_impl(const double* in, double* jac, std::size_t n) const {
  if (!harmonic::finite_rows(in, n)) return false;
  const MeshDeformBinding b = bind_points(in, n, nullptr);
  const std::vector<double> disp = displacements();
  const harmonic::Solved& s = *solved_;
  for (std::size_t i = 0; i < n; ++i) {
    std::fill(jac + 9 * i, jac + 9 * i + 9, 0.0);
    for (int a = 0; a < 3; ++a) jac[9 * i + 4 * a] = 1.0;
  }
  std::vector<std::size_t> inside;
  for (std::size_t i = 0; i < n; ++i)
    if (b.inside[i]) inside.push_back(i);
  if (dynamic_) {
    for (std::size_t i : inside) {
      double offset[3], j[9];
      if (harmonic::dynamic_offset(s, in + 3 * i, disp.data(), offset, j))
        for (int k = 0; k < 9; ++k) jac[9 * i + k] += j[k];
    }
    return false;
  }
  const std::vector<double> points = harmonic::as_doubles(in, n);
  const std::size_t m = vertex_count();
  const harmonic::ReachedCells reached = harmonic::reach_cells(s, precision_, points, inside, true);
  parallel_blocks(inside.size(), [&](std::size_t lo, std::size_t hi) {
    std::vector<double> w(m), dw(3 * m);
    for (std::size_t r = lo; r < hi; ++r) {
      harmonic::trilinear_row(reached, r, w.data(), dw.data());
      double sum = 0.0, dsum[3] = {0, 0, 0}, num[3] = {0, 0, 0}, dnum[3][3] = {{0}};
      for (std::size_t a = 0; a < m; ++a) {
        if (!(w[a] > harmonic::kStaticMin)) continue;
        sum += w[a];
        for (int q = 0; q < 3; ++q) dsum[q] += dw[3 * a + q];
        for (int p = 0; p < 3; ++p) {
          num[p] += w[a] * disp[3 * a + p];
          for (int q = 0; q < 3; ++q) dnum[p][q] += disp[3 * a + p] * dw[3 * a + q];
        }
      }
      if (!(sum > 0.0)) continue;
      double* J = jac + 9 * inside[r];
      for (int p = 0; p < 3; ++p)
        for (int q = 0; q < 3; ++q) J[3 * p + q] += dnum[p][q] / sum - num[p] * dsum[q] / (sum * sum);
    }
  });
  return false;
}

}  // namespace deformkit
