#include "deformkit/subdivision/limit_surface.hpp"

#include "deformkit/core/types.hpp"
#include "deformkit/core/validation.hpp"
#include "core/parallel.hpp"
#include "subdivision/osd_refiner.hpp"

#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/ptexIndices.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace deformkit {

using namespace OpenSubdiv;

struct LimitSurface::Osd {
  std::unique_ptr<Refiner> refiner;
  std::unique_ptr<const Far::PatchTable> patches;
  std::unique_ptr<Far::PatchMap> map;
};

namespace {

// Deep enough that semi-sharp creases are exact (a crease of sharpness s needs ceil(s) levels);
// smooth extraordinary vertices get Gregory end caps at this depth.
int isolation_level(const ControlMesh& mesh) {
  int level = 4;
  for (double s : mesh.crease_sharpness)
    if (s < kInfiniteSharpness) level = std::max(level, int(std::ceil(s)));
  for (double s : vertex_sharpness(mesh))
    if (s < kInfiniteSharpness) level = std::max(level, int(std::ceil(s)));
  return std::min(level, 10);
}

// The power of two that brings the largest |value| into [0.5, 1): 0 for all zeros.
int scale_exponent(const double* values, std::size_t n) {
  double largest = 0.0;
  for (std::size_t i = 0; i < n; ++i) largest = std::max(largest, std::abs(values[i]));
  int exponent = 0;
  if (largest > 0) std::frexp(largest, &exponent);
  return exponent;
}

// A sample's u or v as the patch basis takes it: in [0, 1] (check_samples allowed 1e-12 beyond),
// and a subnormal as 0, which OpenSubdiv's Gregory basis would turn into 0/0.
double sample_parameter(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return t < std::numeric_limits<double>::min() ? 0.0 : t;
}

// du x dv normalised, from tangents scaled to unit largest component first so that neither the
// cross product nor its length can overflow or underflow; zero where the tangents are parallel.
void unit_normal(const double* du, const double* dv, double* normal) {
  double a[3], b[3];
  const double sa = std::max({std::abs(du[0]), std::abs(du[1]), std::abs(du[2])});
  const double sb = std::max({std::abs(dv[0]), std::abs(dv[1]), std::abs(dv[2])});
  for (int c = 0; c < 3; ++c) a[c] = sa > 0 ? du[c] / sa : 0.0, b[c] = sb > 0 ? dv[c] / sb : 0.0;
  const double n[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  for (int c = 0; c < 3; ++c) normal[c] = len > 0 ? n[c] / len : 0.0;
}

// Positions and derivatives back in the cage's units (exact: a power of two); refused where the
// true value lies beyond the double range.
void scale_back(LimitSamples& s, int exponent) {
  for (std::vector<double>* field : {&s.position, &s.du, &s.dv, &s.duu, &s.duv, &s.dvv}) {
    for (double& x : *field) x = std::ldexp(x, exponent);
    for (std::size_t i = 0; i < field->size(); ++i)
      if (!std::isfinite((*field)[i]))
        throw std::invalid_argument("points: the limit surface at sample " + std::to_string(i / 3) +
                                    " exceeds the double range (coordinates near 1e308); scale the points down");
  }
}

}  // namespace

LimitSurface::LimitSurface(ControlMesh mesh) : mesh_(std::move(mesh)), osd_(std::make_unique<Osd>()) {
  osd_->refiner = make_refiner(mesh_, false);
  Far::PatchTableFactory::Options options(isolation_level(mesh_));
  options.SetPatchPrecision<double>();
  options.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS);
  options.useInfSharpPatch = true;  // infinitely sharp creases are exact patches, not deep isolation
  // The legacy patch at a smooth corner (edge-only boundary, one face) is a sharp-corner B-spline
  // patch whose corner is a refined point, not the limit; without it the corner is exact.
  options.generateLegacySharpCornerPatches = false;
  osd_->refiner->RefineAdaptive(options.GetRefineAdaptiveOptions());
  osd_->patches.reset(Far::PatchTableFactory::Create(*osd_->refiner, options));
  osd_->map = std::make_unique<Far::PatchMap>(*osd_->patches);
  const Far::PtexIndices ptex(*osd_->refiner);
  ptex_offset_.resize(mesh_.face_count() + 1);
  face_offset_.resize(mesh_.face_count() + 1);
  for (std::size_t f = 0; f < mesh_.face_count(); ++f) {
    ptex_offset_[f] = ptex.GetFaceId(int(f));
    face_offset_[f + 1] = face_offset_[f] + mesh_.face_size(f);
  }
  ptex_offset_.back() = ptex.GetNumFaces();
}

LimitSurface::~LimitSurface() = default;

PatchPoints LimitSurface::patch_points(const double* points) const {
  require_finite_rows(points, mesh_.vertex_count(), "points");
  const Refiner& refiner = *osd_->refiner;
  const int refined = refiner.GetNumVerticesTotal(), local = osd_->patches->GetNumLocalPoints();
  PatchPoints out;
  out.exponent = scale_exponent(points, 3 * mesh_.vertex_count());
  const double down = std::ldexp(1.0, -out.exponent);
  std::vector<Point3> buffer(std::size_t(refined) + local);
  for (std::size_t i = 0; i < mesh_.vertex_count(); ++i)
    buffer[i] = {points[3 * i] * down, points[3 * i + 1] * down, points[3 * i + 2] * down};
  const Far::PrimvarRefinerReal<double> primvar(refiner);
  Point3* src = buffer.data();
  for (int l = 1; l < refiner.GetNumLevels(); ++l) {
    Point3* dst = src + refiner.GetLevel(l - 1).GetNumVertices();
    primvar.Interpolate(l, src, dst);
    src = dst;
  }
  if (local > 0)
    osd_->patches->GetLocalPointStencilTable<double>()->UpdateValues(buffer.data(), buffer.data() + refined);
  out.values.resize(3 * buffer.size());
  for (std::size_t i = 0; i < buffer.size(); ++i) {
    out.values[3 * i] = buffer[i].x;
    out.values[3 * i + 1] = buffer[i].y;
    out.values[3 * i + 2] = buffer[i].z;
  }
  return out;
}

void LimitSurface::check_samples(const int* ptex, const double* uv, std::size_t n) const {
  const bool triangles = mesh_.scheme == SubdivisionScheme::Loop;
  const double tol = 1e-12;
  for (std::size_t i = 0; i < n; ++i) {
    if (ptex[i] < 0 || ptex[i] >= ptex_count())
      throw std::invalid_argument("ptex: sample " + std::to_string(i) + " has ptex face " + std::to_string(ptex[i]) +
                                  ", outside 0.." + std::to_string(ptex_count() - 1));
    const double u = uv[2 * i], v = uv[2 * i + 1];
    const bool inside = u >= -tol && v >= -tol && (triangles ? u + v <= 1 + tol : u <= 1 + tol && v <= 1 + tol);
    if (!inside)  // NaN fails every comparison
      throw std::invalid_argument("uv: sample " + std::to_string(i) + " (" + std::to_string(u) + ", " +
                                  std::to_string(v) + ") is outside the " +
                                  (triangles ? "triangle u, v >= 0, u + v <= 1" : "unit square [0, 1]^2"));
  }
}

LimitSamples LimitSurface::evaluate(const PatchPoints& patch_points, const int* ptex, const double* uv, std::size_t n,
                                    int derivatives) const {
  const std::vector<double>& cvs = patch_points.values;
  check_samples(ptex, uv, n);
  LimitSamples out;
  out.position.resize(3 * n);
  if (derivatives >= 1) out.du.resize(3 * n), out.dv.resize(3 * n), out.normal.resize(3 * n);
  if (derivatives >= 2) out.duu.resize(3 * n), out.duv.resize(3 * n), out.dvv.resize(3 * n);
  // Visit the samples face by face (a counting sort): a patch's points then stay in cache, which
  // makes randomly ordered samples about 2.5x faster.
  std::vector<std::size_t> order(n), start(std::size_t(ptex_count()) + 1, 0);
  for (std::size_t i = 0; i < n; ++i) ++start[ptex[i] + 1];
  for (std::size_t p = 1; p < start.size(); ++p) start[p] += start[p - 1];
  for (std::size_t i = 0; i < n; ++i) order[start[ptex[i]]++] = i;
  std::atomic<bool> missing{false};
  const Far::PatchTable& table = *osd_->patches;
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    double w[6][20];  // weights of P, Du, Dv, Duu, Duv, Dvv; 20 = the most points a patch has
    for (std::size_t o = begin; o < end; ++o) {
      const std::size_t i = order[o];
      if (o + 16 < end) {  // samples arrive in face order, so their own rows are scattered: fetch ahead
        const std::size_t ahead = order[o + 16];
        __builtin_prefetch(uv + 2 * ahead);
        __builtin_prefetch(out.position.data() + 3 * ahead, 1);
        if (derivatives >= 1) {
          __builtin_prefetch(out.du.data() + 3 * ahead, 1);
          __builtin_prefetch(out.dv.data() + 3 * ahead, 1);
          __builtin_prefetch(out.normal.data() + 3 * ahead, 1);
        }
      }
      const double u = sample_parameter(uv[2 * i]), v = sample_parameter(uv[2 * i + 1]);
      const Far::PatchTable::PatchHandle* h = osd_->map->FindPatch(ptex[i], u, v);
      if (!h) {
        missing = true;
        continue;
      }
      table.EvaluateBasis(*h, u, v, w[0], derivatives >= 1 ? w[1] : nullptr, derivatives >= 1 ? w[2] : nullptr,
                          derivatives >= 2 ? w[3] : nullptr, derivatives >= 2 ? w[4] : nullptr,
                          derivatives >= 2 ? w[5] : nullptr);
      // OpenSubdiv 3.5 scales derivatives by 2^depth, counting the split of an n-gon into its
      // sub-quads as a level, but a sub-quad is a whole ptex face: undo that factor there.
      const Far::PatchParam param = table.GetPatchParam(*h);
      if (param.NonQuadRoot()) {
        for (int d = 1; d < 6; ++d)
          for (int k = 0; k < 20; ++k) w[d][k] *= d < 3 ? 0.5 : 0.25;
      }
      // A rotated Loop sub-triangle runs u and v backwards: OpenSubdiv negates the first
      // derivatives, right, and the second ones too, wrong (d2/du2 of f(-u) keeps its sign).
      if (mesh_.scheme == SubdivisionScheme::Loop && param.IsTriangleRotated()) {
        for (int d = 3; d < 6; ++d)
          for (int k = 0; k < 20; ++k) w[d][k] = -w[d][k];
      }
      const Far::ConstIndexArray points = table.GetPatchVertices(*h);
      double acc[6][3] = {};
      const int kinds = derivatives >= 2 ? 6 : derivatives >= 1 ? 3 : 1;
      for (int k = 0; k < points.size(); ++k) {
        const double* p = &cvs[3 * std::size_t(points[k])];
        for (int d = 0; d < kinds; ++d)
          for (int c = 0; c < 3; ++c) acc[d][c] += w[d][k] * p[c];
      }
      std::vector<double>* targets[6] = {&out.position, &out.du, &out.dv, &out.duu, &out.duv, &out.dvv};
      for (int d = 0; d < kinds; ++d) std::copy(acc[d], acc[d] + 3, targets[d]->data() + 3 * i);
      if (derivatives >= 1) unit_normal(acc[1], acc[2], out.normal.data() + 3 * i);
    }
  });
  if (missing) throw std::invalid_argument("ptex: a sample lies in a face without limit surface");
  scale_back(out, patch_points.exponent);
  return out;
}

PtexPoint LimitSurface::corner_point(int face, int corner) const {
  const int size = mesh_.face_size(face), first = ptex_offset_[face];
  if (mesh_.scheme == SubdivisionScheme::Loop) {
    static const double tri[3][2] = {{0, 0}, {1, 0}, {0, 1}};
    return {first, tri[corner][0], tri[corner][1]};
  }
  if (size != 4) return {first + corner, 0.0, 0.0};
  static const double quad[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  return {first, quad[corner][0], quad[corner][1]};
}

PtexPoint LimitSurface::edge_point(int face, int edge, double t) const {
  const int size = mesh_.face_size(face), first = ptex_offset_[face];
  if (mesh_.scheme == SubdivisionScheme::Loop) {
    switch (edge) {
      case 0: return {first, t, 0.0};
      case 1: return {first, 1.0 - t, t};
      default: return {first, 0.0, 1.0 - t};
    }
  }
  if (size == 4) {
    switch (edge) {
      case 0: return {first, t, 0.0};
      case 1: return {first, 1.0, t};
      case 2: return {first, 1.0 - t, 1.0};
      default: return {first, 0.0, 1.0 - t};
    }
  }
  // The first half lies in the sub-quad of the edge's start, the second in that of its end.
  if (t < 0.5) return {first + edge, 2.0 * t, 0.0};
  return {first + (edge + 1) % size, 0.0, 2.0 * (1.0 - t)};
}

PtexPoint LimitSurface::interior_point(int face, int sub) const {
  const int first = ptex_offset_[face];
  if (mesh_.scheme == SubdivisionScheme::Loop) return {first, 1.0 / 3.0, 1.0 / 3.0};
  return {first + (mesh_.face_size(face) == 4 ? 0 : sub), 0.5, 0.5};
}

std::vector<double> LimitSurface::limit_points(const double* points) const {
  std::vector<int> ptex(mesh_.vertex_count());
  std::vector<double> uv(2 * mesh_.vertex_count());
  for (std::size_t f = 0; f < mesh_.face_count(); ++f)
    for (int k = 0; k < mesh_.face_size(f); ++k) {
      const int v = mesh_.corners()[face_offset_[f] + k];
      const PtexPoint p = corner_point(int(f), k);
      ptex[v] = p.ptex;
      uv[2 * v] = p.u;
      uv[2 * v + 1] = p.v;
    }
  return evaluate(patch_points(points), ptex.data(), uv.data(), mesh_.vertex_count(), 0).position;
}

}  // namespace deformkit
