#pragma once
// Uniform subdivision of a control mesh with OpenSubdiv (Catmull-Clark or Loop).
#include "deformkit/subdivision/control_mesh.hpp"
#include "deformkit/subdivision/limit_surface.hpp"

#include <cstdint>
#include <memory>
#include <vector>

namespace deformkit {

constexpr int kMaxSubdivisionLevel = 8;
// 2^24 faces: about 1.3 GB of output points, faces and UVs at the largest.
constexpr std::int64_t kDefaultMaxFaces = std::int64_t(1) << 24;

struct SubdividedMesh {
  std::vector<double> points;       // 3 per vertex
  std::vector<int> faces;           // corners_per_face per face
  int corners_per_face = 4;
  std::vector<int> face_origin;     // base face of every output face
  std::vector<double> uvs;          // 2 per output corner; empty without UVs
  int level = 0;
  SubdivisionScheme scheme = SubdivisionScheme::CatmullClark;
};

// The refined topology of a control mesh at one level, kept to subdivide many cages of it
// (animation frames, deformations): only the points are interpolated again.
class Subdivider {
 public:
  // Throws std::invalid_argument naming `level` outside 1..kMaxSubdivisionLevel or when the
  // output would exceed max_faces faces (checked before any allocation). With limit_surface the
  // points are the limit surface at every refined vertex (Blender's "Use Limit Surface"), not
  // the refined points.
  Subdivider(const ControlMesh& mesh, int level, std::int64_t max_faces, bool limit_surface = false);
  ~Subdivider();
  Subdivider(const Subdivider&) = delete;
  Subdivider& operator=(const Subdivider&) = delete;

  // The refined points of this cage (3 per vertex); `points` must be finite.
  std::vector<double> subdivide(const double* points) const;
  // The result with faces, origins and UVs.
  SubdividedMesh mesh(const double* points) const;

  const ControlMesh& control() const { return control_; }
  int level() const { return level_; }
  std::size_t vertex_count() const;
  const std::vector<int>& faces() const { return faces_; }
  const std::vector<int>& face_origin() const { return origin_; }
  const std::vector<double>& uvs() const { return uvs_; }
  int corners_per_face() const { return control_.scheme == SubdivisionScheme::Loop ? 3 : 4; }
  bool limit_surface() const { return limit_ != nullptr; }
  // Where every refined vertex lies on the limit surface: its ptex face and (u, v) there, in the
  // ptex convention of LimitSurface (exact dyadic parameters).
  std::vector<PtexPoint> vertex_parameters() const;

 private:
  struct Osd;
  ControlMesh control_;
  int level_;
  std::unique_ptr<Osd> osd_;
  std::unique_ptr<LimitSurface> limit_;
  std::vector<int> limit_ptex_;
  std::vector<double> limit_uv_;
  std::vector<int> faces_, origin_;
  std::vector<double> uvs_;
};

// Faces a uniform refinement to `level` makes: n-gons split into n quads, then each face into 4.
std::int64_t subdivided_face_count(const ControlMesh& mesh, int level);

// One cage, once: Subdivider(mesh, level, max_faces, limit_surface).mesh(points).
SubdividedMesh subdivide(const ControlMesh& mesh, const double* points, int level, std::int64_t max_faces,
                         bool limit_surface = false);

}  // namespace deformkit
