#include "deformkit/surface/cotangent_laplacian.hpp"

#include "deformkit/core/types.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace deformkit {

namespace {

struct Edge {
  int a, b;
  double w;
};

// L_ij = -(sum of the w of the records of edge ij), L_ii = sum of the w of i's records, each sum in
// record order (as Eigen's setFromTriplets sums duplicates), straight into compressed columns: a
// counting sort of the records by vertex, then each vertex's few entries sorted by neighbour.
SparseMatrix assemble(std::size_t n, const std::vector<Edge>& edges) {
  std::vector<std::int64_t> at(n + 1, 0);
  for (const Edge& e : edges)
    if (e.a != e.b) ++at[std::size_t(e.a) + 1], ++at[std::size_t(e.b) + 1];
  for (std::size_t i = 0; i < n; ++i) at[i + 1] += at[i];
  const std::vector<std::int64_t> start = at;
  std::vector<std::pair<int, double>> half(std::size_t(at[n]));
  for (const Edge& e : edges) {
    if (e.a == e.b) continue;  // a corner repeated in a face: its terms cancel
    half[std::size_t(at[std::size_t(e.a)]++)] = {e.b, e.w};
    half[std::size_t(at[std::size_t(e.b)]++)] = {e.a, e.w};
  }
  SparseMatrix l(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
  std::vector<SparseMatrix::StorageIndex> outer(n + 1, 0), inner;
  std::vector<double> value;
  inner.reserve(half.size() / 2 + n);
  value.reserve(half.size() / 2 + n);
  for (std::size_t i = 0; i < n; ++i) {
    auto first = half.begin() + std::ptrdiff_t(start[i]), last = half.begin() + std::ptrdiff_t(start[i + 1]);
    double diagonal = 0;
    for (auto it = first; it != last; ++it) diagonal += it->second;
    std::stable_sort(first, last, [](const auto& x, const auto& y) { return x.first < y.first; });
    bool placed = first == last;  // an isolated vertex has no row
    for (auto it = first; it != last;) {
      const int j = it->first;
      double w = 0;
      for (; it != last && it->first == j; ++it) w += it->second;
      if (!placed && j > int(i)) inner.push_back(SparseMatrix::StorageIndex(i)), value.push_back(diagonal), placed = true;
      inner.push_back(j), value.push_back(-w);
    }
    if (!placed) inner.push_back(SparseMatrix::StorageIndex(i)), value.push_back(diagonal);
    outer[i + 1] = SparseMatrix::StorageIndex(inner.size());
  }
  l.resizeNonZeros(Eigen::Index(inner.size()));
  std::copy(outer.begin(), outer.end(), l.outerIndexPtr());
  std::copy(inner.begin(), inner.end(), l.innerIndexPtr());
  std::copy(value.begin(), value.end(), l.valuePtr());
  return l;
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
  std::vector<Edge> entries;
  entries.reserve(3 * triangles);
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
      entries.push_back({b, c, 0.5 * cot});
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
  std::vector<Edge> entries;
  entries.reserve(edges.size());
  for (const auto& [a, b] : edges) entries.push_back({a, b, 1.0});
  return assemble(mesh.vertex_count(), entries);
}

}  // namespace deformkit
