// A frame of Mesh Deform: each bound point's displacement sum_a w_a (c_a - c_a at rest) / sum_a w_a
// (Blender's MOD_meshdeform.cc; docs/math/mesh_deform.md, "Binding and evaluation"), as the
// deformed point or as the offset w_i o_i an offset-based consumer adds (displacement_bound).
#include "cage/mesh_deform_solved.hpp"
#include "cage/mesh_deform_simd.hpp"
#include "core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <variant>
#include <vector>

namespace deformkit {

namespace {

// The 8 corners of a dynamic point: (d-weighted sums, weight sum) of its cells, trilinearly.
inline void corner_rows(const std::uint32_t* slot, const double* t, const double* cells4, double acc[4]) {
  for (int a = 0; a < 4; ++a) acc[a] = 0.0;
  for (int k = 0; k < 8; ++k)
    for (int a = 0; a < 4; ++a) acc[a] += t[k] * cells4[4 * std::size_t(slot[k]) + std::size_t(a)];
}

// Dynamic: per reached cell (d-weighted sum of its influences, their weight sum), once a frame.
std::vector<double> cell_sums(const harmonic::Solved& s, const std::vector<std::int64_t>& cells, const double* disp4) {
  std::vector<double> sums(4 * cells.size());
  parallel_blocks(cells.size(), [&](std::size_t lo, std::size_t hi) {
    for (std::size_t k = lo; k < hi; ++k) {
      const std::size_t cell = std::size_t(cells[k]);
      double* sum = sums.data() + 4 * k;
      for (std::uint32_t e = s.cell_start[cell]; e < s.cell_start[cell + 1]; ++e) {
        const double w = s.cell_weight[e];
        const double* d = disp4 + 4 * std::size_t(s.cell_vertex[e]);
        for (int a = 0; a < 4; ++a) sum[a] += w * d[a];
      }
    }
  });
  return sums;
}

}  // namespace

namespace {

// A point's result from its sums (Σ w_a d_a, Σ w_a): Blender's rule, no weight no displacement.
template <class T, class A>
bool finish(const A* sum, const T* p, T* out, bool offsets, double w) {
  const double scale = sum[3] > A(0) ? w / double(sum[3]) : 0.0;
  bool ok = true;
  for (int a = 0; a < 3; ++a) {
    const double o = double(sum[a]) * scale;
    out[a] = offsets ? static_cast<T>(o) : static_cast<T>(double(p[a]) + o);
    ok = ok && std::isfinite(out[a]);
  }
  return ok;
}

}  // namespace

template <class T>
bool MeshDeform::evaluate_bound(const MeshDeformBinding& b, T* out, bool offsets, const double* w) const {
  const std::vector<double> disp = displacements();
  const std::size_t m = vertex_count();
  // (d_a, 1) per cage vertex, in the binding's precision for the static rows (float: Blender's).
  std::vector<double> disp4(4 * m);
  std::vector<T> rows4(4 * m);
  for (std::size_t a = 0; a < m; ++a) {
    for (std::size_t c = 0; c < 3; ++c) disp4[4 * a + c] = disp[3 * a + c];
    disp4[4 * a + 3] = 1.0;
    for (std::size_t c = 0; c < 4; ++c) rows4[4 * a + c] = static_cast<T>(disp4[4 * a + c]);
  }
  const T* points = nullptr;
  if constexpr (std::is_same<T, float>::value) points = b.points_f32.data();
  else points = b.points_f64.data();
  auto weight_of = [&](std::size_t i) { return offsets && w ? w[i] : 1.0; };
  std::atomic<bool> finite{true};
  if (b.dynamic) {
    const std::vector<double> cells = cell_sums(*solved_, b.cells, disp4.data());
    parallel_blocks(b.size(), [&](std::size_t lo, std::size_t hi) {
      bool ok = true;
      for (std::size_t i = lo; i < hi; ++i) {
        double sum[4] = {0.0, 0.0, 0.0, 0.0};
        if (b.inside[i]) corner_rows(b.corner_slot.data() + 8 * i, b.corner_weight.data() + 8 * i, cells.data(), sum);
        ok = finish(sum, points + 3 * i, out + 3 * i, offsets, weight_of(i)) && ok;
      }
      if (!ok) finite = false;
    });
    return finite;
  }
  if constexpr (std::is_same<T, float>::value) {
    if (!b.dense_weight.empty()) {  // blocks of 8 points, each task a run of them
      // Below 4 MB of weights the pass is as fast on one core as on two, and a worker woken for it
      // costs more than it saves (WireSphere, 1.6 MB: 0.12 ms a frame alone, 0.14 pooled); above,
      // the second core helps (FireHydrant, 7.5 MB: 0.40 ms against 0.46 from memory).
      const std::size_t blocks = (b.size() + 7) / 8;
      const bool pooled = b.dense_weight.size() >= (std::size_t(1) << 20) && !forked_after_threads();
      const int tasks = pooled ? 4 * parallel_threads() : 1;
      parallel_tasks(tasks, [&](int task) {
        if (!harmonic::dense_blocks(b.dense_weight.data(), m, rows4.data(), offsets ? w : nullptr,
                                    offsets ? nullptr : points, blocks * std::size_t(task) / std::size_t(tasks),
                                    blocks * std::size_t(task + 1) / std::size_t(tasks), b.size(), out))
          finite = false;
      });
      return finite;
    }
  }
  // Static: the points without a row stay (offset 0); then the rows, in their order.
  parallel_blocks(b.size(), [&](std::size_t lo, std::size_t hi) {
    for (std::size_t i = 3 * lo; i < 3 * hi; ++i) out[i] = offsets ? T(0) : points[i];
  });
  const std::size_t rows = b.row_point.size();
  const std::uint32_t* start = b.weight_start.data();
  const T* weight = nullptr;
  if constexpr (std::is_same<T, float>::value) weight = b.weight_value_f32.data();
  else weight = b.weight_value.data();
  // The tasks split the weights, not the rows, evenly: the rows are ordered by length. Four tasks a
  // thread: a worker the scheduler wakes late (the other core busy) still takes the tasks left.
  const int tasks = b.size() < 2 * kParallelGrain || forked_after_threads() ? 1 : 4 * parallel_threads();
  const double total = double(start[rows]);
  parallel_tasks(tasks, [&](int task) {
    auto row_at = [&](int t) {
      const auto goal = std::uint32_t(total * t / tasks);
      return t == tasks ? rows : std::size_t(std::lower_bound(start, start + rows, goal) - start);
    };
    const std::size_t lo = row_at(task), hi = row_at(task + 1);
    constexpr std::size_t kChunk = 256;  // rows whose sums wait in `acc` (4 KB-8 KB) for their finish
    T acc[4 * kChunk];
    bool ok = true;
    for (std::size_t first = lo; first < hi; first += kChunk) {
      const std::size_t last = std::min(hi, first + kChunk);
      std::visit([&](const auto& column) { harmonic::weighted_rows(start, column.data(), weight, first, last, rows4.data(), acc); },
                 b.weight_vertex.storage());
      for (std::size_t r = first; r < last; ++r) {
        const std::size_t i = b.row_point[r];
        ok = finish(acc + 4 * (r - first), points + 3 * i, out + 3 * i, offsets, weight_of(i)) && ok;
      }
    }
    if (!ok) finite = false;
  });
  return finite;
}

template bool MeshDeform::evaluate_bound<float>(const MeshDeformBinding&, float*, bool, const double*) const;
template bool MeshDeform::evaluate_bound<double>(const MeshDeformBinding&, double*, bool, const double*) const;

bool MeshDeform::deform_bound_impl(const PointBinding& binding, float* out) const {
  return evaluate_bound(static_cast<const MeshDeformBinding&>(binding), out, false, nullptr);
}
bool MeshDeform::deform_bound_impl(const PointBinding& binding, double* out) const {
  return evaluate_bound(static_cast<const MeshDeformBinding&>(binding), out, false, nullptr);
}
bool MeshDeform::displacement_bound_impl(const PointBinding& binding, float* out, const double* weights) const {
  return evaluate_bound(static_cast<const MeshDeformBinding&>(binding), out, true, weights);
}
bool MeshDeform::displacement_bound_impl(const PointBinding& binding, double* out, const double* weights) const {
  return evaluate_bound(static_cast<const MeshDeformBinding&>(binding), out, true, weights);
}

}  // namespace deformkit
