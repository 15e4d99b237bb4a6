#include "deformkit/core/polygon_mesh.hpp"

#include "deformkit/core/validation.hpp"

#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

namespace deformkit {

[[noreturn]] static void throw_corner_out_of_range(std::size_t face, std::int64_t index, std::size_t n) {
  throw std::invalid_argument("faces: face " + std::to_string(face) + " has corner index " + std::to_string(index) +
                              ", outside 0.." + std::to_string(std::int64_t(n) - 1));
}

// The checks of a mesh whose faces all have k corners (the same, in the same order, for a copied
// and a borrowed mesh).

PolygonMesh::PolygonMesh(const double* points, std::size_t n, const std::vector<std::int64_t>& corners,
                         const std::vector<std::int64_t>& offsets) {
  require_finite_rows(points, n, "points");
  if (offsets.size() < 2) throw std::invalid_argument("faces: no faces");
  // One pass: each corner checked as it is copied.
  corners_.resize(std::size_t(offsets.back() - offsets.front()));
  offsets_.resize(offsets.size());
  offsets_[0] = 0;
  int* out = corners_.data();
  for (std::size_t f = 0; f + 1 < offsets.size(); ++f) {
    const std::int64_t begin = offsets[f], end = offsets[f + 1];
    if (end - begin < 3) throw std::invalid_argument("faces: face " + std::to_string(f) + " has fewer than 3 corners");
    for (std::int64_t c = begin; c < end; ++c) {
      if (corners[c] < 0 || std::size_t(corners[c]) >= n) throw_corner_out_of_range(f, corners[c], n);
      *out++ = int(corners[c]);
    }
    offsets_[f + 1] = end - offsets.front();
  }
  points_.assign(points, points + 3 * n);
}

static void require_uniform_faces(const double* points, std::size_t n, std::size_t m, int k) {
  require_finite_rows(points, n, "points");
  if (m == 0) throw std::invalid_argument("faces: no faces");
  if (k < 3) throw std::invalid_argument("faces: face 0 has fewer than 3 corners");
}

PolygonMeshView PolygonMeshView::borrowed(const double* points, std::size_t n, const int* faces, std::size_t m, int k) {
  require_uniform_faces(points, n, m, k);
  for (std::size_t c = 0; c < m * std::size_t(k); ++c)
    if (faces[c] < 0 || std::size_t(faces[c]) >= n) throw_corner_out_of_range(c / std::size_t(k), faces[c], n);
  PolygonMeshView v;
  v.points = points, v.vertex_count = n, v.corners = faces, v.corner_count = m * std::size_t(k), v.uniform = k;
  v.faces = m;
  return v;
}

template <class Index>
PolygonMesh::PolygonMesh(const double* points, std::size_t n, const Index* faces, std::size_t m, int k) : uniform_(k) {
  require_uniform_faces(points, n, m, k);
  corners_.resize(m * std::size_t(k));
  for (std::size_t c = 0; c < corners_.size(); ++c) {
    if (faces[c] < 0 || std::uint64_t(faces[c]) >= n) throw_corner_out_of_range(c / std::size_t(k), faces[c], n);
    corners_[c] = int(faces[c]);
  }
  points_.assign(points, points + 3 * n);
}
template PolygonMesh::PolygonMesh(const double*, std::size_t, const std::int32_t*, std::size_t, int);
template PolygonMesh::PolygonMesh(const double*, std::size_t, const std::int64_t*, std::size_t, int);

PolygonMeshView PolygonMesh::view() const {
  PolygonMeshView v;
  v.points = points_.data(), v.vertex_count = vertex_count();
  v.corners = corners_.data(), v.corner_count = corners_.size();
  v.offsets = uniform_ ? nullptr : offsets_.data(), v.uniform = uniform_;
  v.faces = face_count();
  return v;
}

bool PolygonMesh::all_triangles() const {
  if (uniform_) return uniform_ == 3;
  for (std::size_t f = 0; f < face_count(); ++f)
    if (face_size(f) != 3) return false;
  return true;
}

PolygonMesh PolygonMesh::triangulate() const& { return PolygonMesh(*this).triangulate(); }

PolygonMesh PolygonMesh::triangulate() && {
  if (all_triangles()) return std::move(*this);
  PolygonMesh out;
  out.points_ = std::move(points_);
  out.corners_.reserve(3 * (corners_.size() - 2 * face_count()));
  for (std::size_t f = 0; f < face_count(); ++f) {
    const int* c = face(f);
    for (int k = 1; k + 1 < face_size(f); ++k) out.corners_.insert(out.corners_.end(), {c[0], c[k], c[k + 1]});
  }
  out.uniform_ = 3;
  *this = PolygonMesh();
  return out;
}

// One pass over the corners with the face that last visited each vertex: linear in the corners
// however large a face is.
void require_distinct_corners(const PolygonMeshView& mesh) {
  std::vector<std::int64_t> last_face(mesh.vertex_count, -1);
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const int* c = mesh.face(f);
    for (int k = 0; k < mesh.face_size(f); ++k) {
      if (last_face[c[k]] == std::int64_t(f))
        throw std::invalid_argument("faces: face " + std::to_string(f) + " repeats vertex " + std::to_string(c[k]));
      last_face[c[k]] = std::int64_t(f);
    }
  }
}

std::vector<int> connected_components(const PolygonMesh& mesh, int* count) {
  const std::size_t n = mesh.vertex_count();
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const int* c = mesh.face(f);
    for (int k = 1; k < mesh.face_size(f); ++k) {
      const int a = find(c[0]), b = find(c[k]);
      if (a != b) parent[b] = a;
    }
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
