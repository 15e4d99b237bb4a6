#include "deformkit/subdivision/subdivide.hpp"

#include "deformkit/core/types.hpp"
#include "deformkit/core/validation.hpp"
#include "core/parallel.hpp"
#include "subdivision/osd_refiner.hpp"

#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/ptexIndices.h>

#include <algorithm>
#include <array>

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

// A face's corners in the ptex parameters of the chart they lie in.
struct ChartFace {
  int ptex = -1;  // -1: a Catmull-Clark n-gon of the control mesh, split into charts at level 1
  std::array<std::array<double, 2>, 4> corners{};  // fixed: no allocation per refined face
  int count = 0;
  void add(std::array<double, 2> p) { corners[std::size_t(count++)] = p; }
};

// The control faces' charts: a quad's corners at (0,0), (1,0), (1,1), (0,1), a Loop triangle's
// at (0,0), (1,0), (0,1) (the convention of LimitSurface::corner_point).
std::vector<ChartFace> control_charts(const ControlMesh& mesh, const std::vector<int>& ptex_offset) {
  static const std::array<double, 2> quad[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}}, tri[3] = {{0, 0}, {1, 0}, {0, 1}};
  std::vector<ChartFace> out(mesh.face_count());
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    if (mesh.scheme == SubdivisionScheme::Loop) out[f] = {ptex_offset[f], {tri[0], tri[1], tri[2]}, 3};
    else if (mesh.face_size(f) == 4) out[f] = {ptex_offset[f], {quad[0], quad[1], quad[2], quad[3]}, 4};
  }
  return out;
}

// What a child vertex is the child of, within its parent face: corner `index`, edge `index`
// (corner index -> index + 1) or the face itself.
struct Role {
  enum Kind { Corner, Edge, Centre } kind;
  int index;
};

Role role_in_parent(const Far::TopologyLevel& parent, int face, int vertex) {
  const Far::ConstIndexArray pv = parent.GetFaceVertices(face), pe = parent.GetFaceEdges(face);
  for (int j = 0; j < pv.size(); ++j) {
    if (vertex == parent.GetVertexChildVertex(pv[j])) return {Role::Corner, j};
    if (vertex == parent.GetEdgeChildVertex(pe[j])) return {Role::Edge, j};
  }
  return {Role::Centre, 0};
}

// In the parent's chart: a corner's parameters, an edge's midpoint, the centre.
std::array<double, 2> in_chart(const ChartFace& chart, Role r) {
  const std::size_t k = std::size_t(chart.count);
  const auto& a = chart.corners[r.index];
  if (r.kind == Role::Corner) return a;
  if (r.kind == Role::Edge) {
    const auto& b = chart.corners[(r.index + 1) % k];
    return {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])};
  }
  std::array<double, 2> c{0, 0};
  for (std::size_t i = 0; i < k; ++i) c[0] += chart.corners[i][0] / double(k), c[1] += chart.corners[i][1] / double(k);
  return c;
}

// In the sub-quad of an n-gon's corner j: that corner (0,0), the midpoint of edge j (1,0), the
// centre (1,1), the midpoint of edge j - 1 (0,1).
std::array<double, 2> in_sub_quad(Role r, int j) {
  if (r.kind == Role::Corner) return {0, 0};
  if (r.kind == Role::Centre) return {1, 1};
  return r.index == j ? std::array<double, 2>{1, 0} : std::array<double, 2>{0, 1};
}

// The charts of one level's child faces, from their parents' charts.
std::vector<ChartFace> child_charts(const Far::TopologyLevel& parent, const Far::TopologyLevel& child,
                                    const std::vector<ChartFace>& charts, const std::vector<int>& ptex_offset) {
  std::vector<ChartFace> out(std::size_t(child.GetNumFaces()));
  std::vector<Role> roles;
  for (int pf = 0; pf < parent.GetNumFaces(); ++pf) {
    const ChartFace& chart = charts[pf];
    for (const int cf : parent.GetFaceChildFaces(pf)) {
      if (!Far::IndexIsValid(cf)) continue;
      const Far::ConstIndexArray cv = child.GetFaceVertices(cf);
      roles.clear();
      for (const int v : cv) roles.push_back(role_in_parent(parent, pf, v));
      ChartFace& made = out[cf];
      if (chart.ptex >= 0) {
        made.ptex = chart.ptex;
        for (const Role& r : roles) made.add(in_chart(chart, r));
        continue;
      }
      const int j = std::find_if(roles.begin(), roles.end(), [](const Role& r) { return r.kind == Role::Corner; })->index;
      made.ptex = ptex_offset[pf] + j;
      for (const Role& r : roles) made.add(in_sub_quad(r, j));
    }
  }
  return out;
}

}  // namespace

struct Subdivider::Osd {
  std::unique_ptr<Refiner> refiner;
};

std::vector<PtexPoint> Subdivider::vertex_parameters() const {
  const Refiner& refiner = *osd_->refiner;
  const Far::PtexIndices ptex(refiner);
  std::vector<int> offset(control_.face_count());
  for (std::size_t f = 0; f < control_.face_count(); ++f) offset[f] = ptex.GetFaceId(int(f));
  std::vector<ChartFace> charts = control_charts(control_, offset);
  for (int l = 1; l <= level_; ++l) charts = child_charts(refiner.GetLevel(l - 1), refiner.GetLevel(l), charts, offset);
  const Far::TopologyLevel& last = refiner.GetLevel(level_);
  std::vector<PtexPoint> out(std::size_t(last.GetNumVertices()), PtexPoint{-1, 0.0, 0.0});
  for (int f = 0; f < last.GetNumFaces(); ++f) {
    const Far::ConstIndexArray fv = last.GetFaceVertices(f);
    for (int c = 0; c < fv.size(); ++c)
      if (out[fv[c]].ptex < 0) out[fv[c]] = {charts[f].ptex, charts[f].corners[c][0], charts[f].corners[c][1]};
  }
  return out;
}

std::int64_t subdivided_face_count(const ControlMesh& mesh, int level) {
  std::int64_t faces = mesh.scheme == SubdivisionScheme::Loop ? std::int64_t(mesh.face_count())
                                                              : std::int64_t(mesh.corners().size());
  for (int l = mesh.scheme == SubdivisionScheme::Loop ? 0 : 1; l < level; ++l) {
    if (faces > (std::int64_t(1) << 56)) return faces;  // far past any cap; avoid overflow
    faces *= 4;
  }
  return faces;
}

Subdivider::Subdivider(const ControlMesh& mesh, int level, std::int64_t max_faces, bool limit_surface)
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
  if (limit_surface) {
    ControlMesh shape = mesh;
    shape.uvs.clear(), shape.uv_indices.clear();  // the limit is of the positions only
    limit_ = std::make_unique<LimitSurface>(std::move(shape));
    for (const PtexPoint& p : vertex_parameters()) {
      limit_ptex_.push_back(p.ptex);
      limit_uv_.insert(limit_uv_.end(), {p.u, p.v});
    }
  }
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
  require_finite_rows(points, control_.vertex_count(), "points");
  if (limit_)
    return limit_->evaluate(limit_->patch_points(points), limit_ptex_.data(), limit_uv_.data(), limit_ptex_.size(), 0)
        .position;
  const Refiner& refiner = *osd_->refiner;
  // Every level's points in one buffer, coarse first (docs/math/subdivision.md, "Refinement buffer").
  std::vector<Point3> buffer(refiner.GetNumVerticesTotal());
  for (std::size_t i = 0; i < control_.vertex_count(); ++i) buffer[i] = {points[3 * i], points[3 * i + 1], points[3 * i + 2]};
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

SubdividedMesh subdivide(const ControlMesh& mesh, const double* points, int level, std::int64_t max_faces,
                         bool limit_surface) {
  require_finite_rows(points, mesh.vertex_count(), "points");
  return Subdivider(mesh, level, max_faces, limit_surface).mesh(points);
}

}  // namespace deformkit
