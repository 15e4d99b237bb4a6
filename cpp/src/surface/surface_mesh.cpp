#include "deformkit/surface/surface_mesh.hpp"

#include "deformkit/core/types.hpp"
#include "deformkit/core/validation.hpp"

#include <numeric>
#include <stdexcept>
#include <string>

namespace deformkit {

TriangleMesh triangulate(const double* points, std::size_t n, const std::vector<std::int64_t>& corners,
                         const std::vector<std::int64_t>& offsets) {
  require_finite_rows(points, n, "points");
  if (offsets.size() < 2) throw std::invalid_argument("faces: no faces");
  TriangleMesh mesh;
  mesh.points.assign(points, points + 3 * n);
  for (std::size_t f = 0; f + 1 < offsets.size(); ++f) {
    const std::int64_t begin = offsets[f], end = offsets[f + 1];
    const std::string face = "faces: face " + std::to_string(f);
    if (end - begin < 3) throw std::invalid_argument(face + " has fewer than 3 corners");
    for (std::int64_t c = begin; c < end; ++c) {
      if (corners[c] < 0 || std::size_t(corners[c]) >= n)
        throw std::invalid_argument(face + " has corner index " + std::to_string(corners[c]) + ", outside 0.." +
                                    std::to_string(n - 1));
      for (std::int64_t d = begin; d < c; ++d)
        if (corners[d] == corners[c])
          throw std::invalid_argument(face + " repeats vertex " + std::to_string(corners[c]));
    }
    for (std::int64_t c = begin + 1; c + 1 < end; ++c)
      mesh.triangles.insert(mesh.triangles.end(), {int(corners[begin]), int(corners[c]), int(corners[c + 1])});
  }
  return mesh;
}

std::vector<int> connected_components(const TriangleMesh& mesh, int* count) {
  const std::size_t n = mesh.vertex_count();
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t)
    for (int k = 1; k < 3; ++k) {
      const int a = find(mesh.triangles[3 * t]), b = find(mesh.triangles[3 * t + k]);
      if (a != b) parent[b] = a;
    }
  std::vector<int> id(n, -1), component(n);
  int next = 0;
  for (std::size_t v = 0; v < n; ++v) {
    const int r = find(int(v));
    if (id[r] < 0) id[r] = next++;
    component[v] = id[r];
  }
  if (count) *count = next;
  return component;
}

}  // namespace deformkit
