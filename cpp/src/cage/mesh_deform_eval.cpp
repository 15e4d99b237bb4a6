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

template <class T>
bool MeshDeform::evaluate_bound(const MeshDeformBinding& b, T* out, bool offsets, const double* w) const {
  const std::vector<double> disp = displacements();
  std::vector<double> disp4(4 * vertex_count());
  for (std::size_t a = 0; a < vertex_count(); ++a) {
    for (int c = 0; c < 3; ++c) disp4[4 * a + std::size_t(c)] = disp[3 * a + std::size_t(c)];
    disp4[4 * a + 3] = 1.0;
  }
  const std::vector<double> cells = b.dynamic ? cell_sums(*solved_, b.cells, disp4.data()) : std::vector<double>();
  const T* points = nullptr;
  if constexpr (std::is_same<T, float>::value) points = b.points_f32.data();
  else points = b.points_f64.data();
  std::atomic<bool> finite{true};
  parallel_blocks(b.size(), [&](std::size_t lo, std::size_t hi) {
    bool ok = true;
    constexpr std::size_t kChunk = 256;  // points whose sums wait in `acc` (8 KB) for their finish
    double acc[4 * kChunk];
    for (std::size_t first = lo; first < hi; first += kChunk) {
      const std::size_t last = std::min(hi, first + kChunk);
      if (b.dynamic) {
        for (std::size_t i = first; i < last; ++i)
          corner_rows(b.corner_slot.data() + 8 * i, b.corner_weight.data() + 8 * i, cells.data(), acc + 4 * (i - first));
      } else {
        harmonic::weighted_rows(b.weight_start.data(), b.weight_vertex.data(), b.weight_value.data(), first, last,
                                disp4.data(), acc);
      }
      for (std::size_t i = first; i < last; ++i) {
        const double* sum = acc + 4 * (i - first);
        // Blender's rule: no weight (a point outside the cage), no displacement.
        const double scale = b.inside[i] && sum[3] > 0.0 ? (offsets && w ? w[i] : 1.0) / sum[3] : 0.0;
        for (int a = 0; a < 3; ++a) {
          const double o = sum[a] * scale;
          const T v = offsets ? static_cast<T>(o) : static_cast<T>(double(points[3 * i + a]) + o);
          out[3 * i + a] = v;
          ok = ok && std::isfinite(v);
        }
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
