#include "deformkit/subdivide.hpp"

#include "deformkit/deformer.hpp"
#include "deformkit/parallel.hpp"
#include "osd_refiner.hpp"

#include <opensubdiv/far/primvarRefiner.h>

#include <stdexcept>
#include <string>

namespace deformkit {

namespace {

using namespace OpenSubdiv;

struct Uv {
  double u, v;
  void Clear(void* = nullptr) { u = v = 0.0; }
  void AddWithWeight(const Uv& p, double w) {
    u += w * p.u;
    v += w * p.v;
  }
};

void check_level(int level) {
  if (level < 1 || level > kMaxSubdivisionLevel)
    throw std::invalid_argument("level: must be 1.." + std::to_string(kMaxSubdivisionLevel) + ", got " +
                                std::to_string(level) + (level == 0 ? " (level 0 is the control mesh itself)" : ""));
}

}  // namespace

struct Subdivider::Osd {
  std::unique_ptr<Refiner> refiner;
};

std::int64_t subdivided_face_count(const ControlMesh& mesh, int level) {
  std::int64_t faces = mesh.scheme == SubdivisionScheme::Loop ? std::int64_t(mesh.face_count())
                                                              : std::int64_t(mesh.face_vertices.size());
  for (int l = mesh.scheme == SubdivisionScheme::Loop ? 0 : 1; l < level; ++l) {
    if (faces > (std::int64_t(1) << 56)) return faces;  // far past any cap; avoid overflow
    faces *= 4;
  }
  return faces;
}

Subdivider::Subdivider(const ControlMesh& mesh, int level, std::int64_t max_faces)
    : control_(mesh), level_(level), osd_(std::make_unique<Osd>()) {
  check_level(level);
  const std::int64_t faces = subdivided_face_count(mesh, level);
  if (faces > max_faces)
    throw std::invalid_argument("level: " + std::to_string(level) + " would make " + std::to_string(faces) +
                                " faces, more than max_faces=" + std::to_string(max_faces) +
                                " (lower the level or raise max_faces)");
  const bool with_uvs = !mesh.uv_indices.empty();
  osd_->refiner = make_refiner(mesh, with_uvs);
  Far::TopologyRefiner::UniformOptions options(level);
  options.fullTopologyInLastLevel = false;  // faces and their parents are all the output needs
  osd_->refiner->RefineUniform(options);
  const Refiner& refiner = *osd_->refiner;

  const Far::TopologyLevel& last = refiner.GetLevel(level);
  const int face_count = last.GetNumFaces(), k = corners_per_face();
  faces_.resize(std::size_t(face_count) * k);
  origin_.resize(face_count);
  parallel_blocks(std::size_t(face_count), [&](std::size_t begin, std::size_t end) {
    for (std::size_t f = begin; f < end; ++f) {
      const Far::ConstIndexArray fv = last.GetFaceVertices(int(f));
      std::copy(fv.begin(), fv.end(), faces_.begin() + f * k);
      int g = int(f);  // chase the parents down to the control mesh
      for (int l = level; l >= 1; --l) g = refiner.GetLevel(l).GetFaceParentFace(g);
      origin_[f] = g;
    }
  });
  if (!with_uvs) return;
  std::vector<Uv> values(refiner.GetNumFVarValuesTotal(0));
  for (std::size_t i = 0; i < mesh.uvs.size() / 2; ++i) values[i] = {mesh.uvs[2 * i], mesh.uvs[2 * i + 1]};
  const Far::PrimvarRefinerReal<double> primvar(refiner);
  Uv* src = values.data();
  for (int l = 1; l <= level; ++l) {
    Uv* dst = src + refiner.GetLevel(l - 1).GetNumFVarValues(0);
    primvar.InterpolateFaceVarying(l, src, dst, 0);
    src = dst;
  }
  uvs_.resize(faces_.size() * 2);
  for (int f = 0; f < face_count; ++f) {
    const Far::ConstIndexArray fuv = last.GetFaceFVarValues(f, 0);
    for (int c = 0; c < fuv.size(); ++c) {
      const std::size_t corner = std::size_t(f) * k + c;
      uvs_[2 * corner] = src[fuv[c]].u;
      uvs_[2 * corner + 1] = src[fuv[c]].v;
    }
  }
}

Subdivider::~Subdivider() = default;

std::size_t Subdivider::vertex_count() const { return std::size_t(osd_->refiner->GetLevel(level_).GetNumVertices()); }

std::vector<double> Subdivider::subdivide(const double* points) const {
  require_finite_rows(points, control_.vertex_count, "points");
  const Refiner& refiner = *osd_->refiner;
  // Every level's points in one buffer, coarse first (algorithms.md A.3).
  std::vector<Point3> buffer(refiner.GetNumVerticesTotal());
  for (std::size_t i = 0; i < control_.vertex_count; ++i) buffer[i] = {points[3 * i], points[3 * i + 1], points[3 * i + 2]};
  const Far::PrimvarRefinerReal<double> primvar(refiner);
  Point3* src = buffer.data();
  for (int l = 1; l <= level_; ++l) {
    Point3* dst = src + refiner.GetLevel(l - 1).GetNumVertices();
    primvar.Interpolate(l, src, dst);
    src = dst;
  }
  const std::size_t n = vertex_count();
  std::vector<double> out(3 * n);
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t v = begin; v < end; ++v) {
      out[3 * v] = src[v].x;
      out[3 * v + 1] = src[v].y;
      out[3 * v + 2] = src[v].z;
    }
  });
  return out;
}

SubdividedMesh Subdivider::mesh(const double* points) const {
  SubdividedMesh out;
  out.points = subdivide(points);
  out.faces = faces_;
  out.corners_per_face = corners_per_face();
  out.face_origin = origin_;
  out.uvs = uvs_;
  out.level = level_;
  out.scheme = control_.scheme;
  return out;
}

SubdividedMesh subdivide(const ControlMesh& mesh, const double* points, int level, std::int64_t max_faces) {
  require_finite_rows(points, mesh.vertex_count, "points");
  return Subdivider(mesh, level, max_faces).mesh(points);
}

}  // namespace deformkit
