#include "deformkit/surface/cotangent_laplacian.hpp"

#include "deformkit/core/types.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace deformkit {

namespace {

SparseMatrix assemble(std::size_t n, std::vector<Eigen::Triplet<double>>& entries) {
  SparseMatrix l(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
  l.setFromTriplets(entries.begin(), entries.end());  // duplicates (shared edges) are summed
  l.makeCompressed();
  return l;
}

void add_edge(std::vector<Eigen::Triplet<double>>& e, int i, int j, double w) {
  e.emplace_back(i, j, -w);
  e.emplace_back(j, i, -w);
  e.emplace_back(i, i, w);
  e.emplace_back(j, j, w);
}

// A cotangent is scale-free: edges whose products would leave the double range are brought near
// 1 by a power of two (exact) first, so a mesh at 1e200 gets the weights it has at 1.
void rescale_if_extreme(Vec3& u, Vec3& w) {
  const double top = std::max(u.cwiseAbs().maxCoeff(), w.cwiseAbs().maxCoeff());
  if (top >= 0x1p-250 && top <= 0x1p250) return;  // squared cross products stay in range
  if (!(top > 0.0)) return;
  const double s = std::ldexp(1.0, -std::ilogb(top));
  u *= s, w *= s;
}

}  // namespace

SparseMatrix cotangent_laplacian(const PolygonMesh& polygons) {
  const PolygonMesh fanned = polygons.all_triangles() ? PolygonMesh() : polygons.triangulate();
  const PolygonMesh& mesh = polygons.all_triangles() ? polygons : fanned;
  const std::size_t triangles = mesh.face_count();
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(12 * triangles);
  // Halved (exactly), so that an edge between coordinates near +-DBL_MAX cannot overflow.
  const double* points = mesh.points().data();
  auto p = [&](int v) -> Vec3 { return 0.5 * Vec3(points[3 * v], points[3 * v + 1], points[3 * v + 2]); };
  for (std::size_t t = 0; t < triangles; ++t) {
    const int* v = mesh.face(t);
    for (int k = 0; k < 3; ++k) {
      // The angle at corner k is opposite the edge (k+1, k+2).
      const int a = v[k], b = v[(k + 1) % 3], c = v[(k + 2) % 3];
      Vec3 u = p(b) - p(a), w = p(c) - p(a);
      rescale_if_extreme(u, w);
      const double cross = u.cross(w).norm(), dot = u.dot(w);
      double cot = cross > 0.0 ? dot / cross : (dot >= 0.0 ? kMaxCotangent : -kMaxCotangent);
      cot = std::clamp(cot, -kMaxCotangent, kMaxCotangent);
      add_edge(entries, b, c, 0.5 * cot);
    }
  }
  return assemble(mesh.vertex_count(), entries);
}

SparseMatrix uniform_laplacian(const PolygonMesh& polygons) {
  const PolygonMesh fanned = polygons.all_triangles() ? PolygonMesh() : polygons.triangulate();
  const PolygonMesh& mesh = polygons.all_triangles() ? polygons : fanned;
  // Each interior edge appears in two triangles: collect unique edges first.
  std::vector<std::pair<int, int>> edges;
  edges.reserve(3 * mesh.face_count());
  for (std::size_t t = 0; t < mesh.face_count(); ++t)
    for (int k = 0; k < 3; ++k) {
      int a = mesh.face(t)[k], b = mesh.face(t)[(k + 1) % 3];
      if (a > b) std::swap(a, b);
      edges.emplace_back(a, b);
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(4 * edges.size());
  for (const auto& [a, b] : edges) add_edge(entries, a, b, 1.0);
  return assemble(mesh.vertex_count(), entries);
}

}  // namespace deformkit
