#pragma once
// The one polygon mesh every family takes (surface deformers, subdivision, mesh volume; cages
// next): points and faces, checked once at construction, so that what holds one holds a valid mesh.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace deformkit {

// A polygon mesh read where its arrays are kept: for a one-shot computation on the caller's
// arrays (mesh_volume), which must not pay for a copy of the mesh. PolygonMesh::view() gives one
// of a checked mesh; borrowed() checks arrays it does not own, exactly as PolygonMesh does.
struct PolygonMeshView {
  const double* points = nullptr;
  std::size_t vertex_count = 0;
  const int* corners = nullptr;
  std::size_t corner_count = 0;
  const std::int64_t* offsets = nullptr;  // face f starts at offsets[f]; null when uniform > 0
  int uniform = 0;                        // every face has this many corners
  std::size_t faces = 0;

  std::size_t face_count() const { return faces; }
  int face_size(std::size_t f) const { return uniform ? uniform : int(offsets[f + 1] - offsets[f]); }
  const int* face(std::size_t f) const { return corners + (uniform ? f * std::size_t(uniform) : std::size_t(offsets[f])); }

  // m faces of k corners each at faces[f k ..]: throws as PolygonMesh's constructor does.
  static PolygonMeshView borrowed(const double* points, std::size_t n, const int* faces, std::size_t m, int k);
};

class PolygonMesh {
 public:
  PolygonMesh() = default;
  // n points (3 values each) and faces as a flat corner list with offsets: face f is
  // corners[offsets[f] .. offsets[f + 1]). Throws std::invalid_argument naming `points` for a
  // non-finite row, and `faces` for no faces, a face of fewer than 3 corners or a corner index
  // outside 0..n-1. A vertex repeated within a face is left to require_distinct_corners.
  PolygonMesh(const double* points, std::size_t n, const std::vector<std::int64_t>& corners,
              const std::vector<std::int64_t>& offsets);
  // m faces of k corners each, face f at faces[f k .. f k + k) (an (m, k) array, read in place
  // and checked as above): no offsets are stored for a mesh whose faces all have one size.
  template <class Index>
  PolygonMesh(const double* points, std::size_t n, const Index* faces, std::size_t m, int k);

  std::size_t vertex_count() const { return points_.size() / 3; }
  std::size_t face_count() const {
    return uniform_ ? corners_.size() / std::size_t(uniform_) : offsets_.empty() ? 0 : offsets_.size() - 1;
  }
  std::size_t corner_count() const { return corners_.size(); }
  const std::vector<double>& points() const { return points_; }
  // The vertex of every corner, face after face.
  const std::vector<int>& corners() const { return corners_; }
  int face_size(std::size_t f) const { return uniform_ ? uniform_ : int(offsets_[f + 1] - offsets_[f]); }
  const int* face(std::size_t f) const {
    return corners_.data() + (uniform_ ? f * std::size_t(uniform_) : std::size_t(offsets_[f]));
  }
  bool all_triangles() const;
  PolygonMeshView view() const;

  // Every face fanned from its first corner into triangles (c0, ci, ci+1), in face order: the
  // same points, triangles only (a triangle mesh is returned as it is).
  PolygonMesh triangulate() const&;
  PolygonMesh triangulate() &&;

 private:
  std::vector<double> points_;
  std::vector<int> corners_;
  std::vector<std::int64_t> offsets_;  // face f starts at offsets_[f]; empty when uniform_ > 0
  int uniform_ = 0;                    // every face has this many corners
};

// Throws std::invalid_argument "faces: face f repeats vertex v" for the first face (and in it the
// first corner) that visits a vertex twice: every mesh entry point refuses such a face (the
// surface deformers, subdivision, cages, mesh_volume), so that one mesh is valid everywhere or
// nowhere.
void require_distinct_corners(const PolygonMeshView& mesh);
inline void require_distinct_corners(const PolygonMesh& mesh) { require_distinct_corners(mesh.view()); }

// The connected component of each vertex (through faces; an isolated vertex is its own), numbered
// in order of their first vertex; *count gets the number of components.
std::vector<int> connected_components(const PolygonMesh& mesh, int* count);

}  // namespace deformkit
