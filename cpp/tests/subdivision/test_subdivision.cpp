// The limit surface against OpenSubdiv's own independent evaluators (Far limit stencils, Bfr
// surfaces, uniform refinement's limit masks), and uniform subdivision's counts.
#include "deformkit/subdivision/limit_surface.hpp"
#include "deformkit/subdivision/smoothness_report.hpp"
#include "deformkit/subdivision/subdivide.hpp"
#include "subdivision/osd_refiner.hpp"

#include <gtest/gtest.h>
#include <opensubdiv/bfr/refinerSurfaceFactory.h>
#include <opensubdiv/bfr/surface.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/stencilTableFactory.h>

#include <cmath>
#include <random>

namespace deformkit {
namespace {

using namespace OpenSubdiv;

struct Cage {
  std::vector<double> points;
  std::vector<std::int64_t> corners, offsets{0};
  void face(std::initializer_list<int> f) {
    corners.insert(corners.end(), f.begin(), f.end());
    offsets.push_back(std::int64_t(corners.size()));
  }
};

// A cube of 8 valence-3 vertices, twisted about z: every vertex is extraordinary.
Cage twisted_cube() {
  Cage c;
  for (int i = 0; i < 8; ++i) {
    const double x = (i & 1) ? 1 : -1, y = (i & 2) ? 1 : -1, z = (i & 4) ? 1 : -1, a = 0.4 * z;
    c.points.insert(c.points.end(), {x * std::cos(a) - y * std::sin(a), x * std::sin(a) + y * std::cos(a), z});
  }
  for (auto f : {std::initializer_list<int>{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2},
                 {1, 3, 7, 5}})
    c.face(f);
  return c;
}

// A pentagonal prism: two pentagons (n-gons split into sub-quads) and five quads.
Cage pentagonal_prism() {
  Cage c;
  for (int z = 0; z < 2; ++z)
    for (int i = 0; i < 5; ++i) {
      const double a = 2 * M_PI * i / 5;
      c.points.insert(c.points.end(), {std::cos(a) * (1 + 0.2 * z), std::sin(a), 1.5 * z + 0.1 * i});
    }
  c.face({4, 3, 2, 1, 0});
  c.face({5, 6, 7, 8, 9});
  for (int i = 0; i < 5; ++i) c.face({i, (i + 1) % 5, 5 + (i + 1) % 5, 5 + i});
  return c;
}

// An open 3 x 3 grid of quads, bumped: boundary and corner rules.
Cage open_grid() {
  Cage c;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) c.points.insert(c.points.end(), {double(i), double(j), 0.3 * std::sin(i + 2.0 * j)});
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) c.face({4 * j + i, 4 * j + i + 1, 4 * j + i + 5, 4 * j + i + 4});
  return c;
}

// An octahedron for Loop: six valence-4 (extraordinary for Loop) vertices.
Cage octahedron() {
  Cage c;
  c.points = {1, 0, 0, -1, 0, 0, 0, 1.2, 0, 0, -1, 0, 0, 0, 0.8, 0, 0, -1};
  for (auto f : {std::initializer_list<int>{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5},
                 {3, 1, 5}, {0, 3, 5}})
    c.face(f);
  return c;
}

ControlMesh control(const Cage& c, SubdivisionScheme s) {
  return make_control_mesh(PolygonMesh(c.points.data(), c.points.size() / 3, c.corners, c.offsets), s,
                           BoundaryRule::EdgeAndCorner);
}

struct Samples {
  std::vector<int> ptex;
  std::vector<double> uv;
};

Samples random_samples(const LimitSurface& s, int per_face, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Samples out;
  for (int p = 0; p < s.ptex_count(); ++p)
    for (int k = 0; k < per_face; ++k) {
      double a = u(rng), b = u(rng);
      if (s.mesh().scheme == SubdivisionScheme::Loop && a + b > 1) a = 1 - a, b = 1 - b;
      out.ptex.push_back(p);
      out.uv.insert(out.uv.end(), {a, b});
    }
  return out;
}

double max_diff(const std::vector<double>& a, const std::vector<double>& b) {
  EXPECT_EQ(a.size(), b.size());
  double m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

// Far's LimitStencilTable: stencils over the coarse points, built by its own factory.
void expect_matches_limit_stencils(const Cage& c, SubdivisionScheme scheme) {
  const LimitSurface surface(control(c, scheme));
  const Samples s = random_samples(surface, 7, 3);
  const LimitSamples ours = surface.evaluate(surface.patch_points(c.points.data()), s.ptex.data(), s.uv.data(),
                                             s.ptex.size(), 2);
  std::unique_ptr<Refiner> refiner = make_refiner(control(c, scheme), false);
  Far::PatchTableFactory::Options po(4);
  po.SetPatchPrecision<double>();
  po.useInfSharpPatch = true;
  refiner->RefineAdaptive(po.GetRefineAdaptiveOptions());
  std::unique_ptr<const Far::PatchTable> table(Far::PatchTableFactory::Create(*refiner, po));
  Far::LimitStencilTableFactoryReal<double>::LocationArrayVec locations;
  std::vector<std::vector<double>> us(surface.ptex_count()), vs(surface.ptex_count());
  for (std::size_t i = 0; i < s.ptex.size(); ++i) {
    us[s.ptex[i]].push_back(s.uv[2 * i]);
    vs[s.ptex[i]].push_back(s.uv[2 * i + 1]);
  }
  for (int p = 0; p < surface.ptex_count(); ++p) {
    Far::LimitStencilTableFactoryReal<double>::LocationArray a;
    a.ptexIdx = p;
    a.numLocations = int(us[p].size());
    a.s = us[p].data();
    a.t = vs[p].data();
    locations.push_back(a);
  }
  Far::LimitStencilTableFactoryReal<double>::Options o;
  o.generate1stDerivatives = true;
  o.generate2ndDerivatives = true;
  std::unique_ptr<const Far::LimitStencilTableReal<double>> stencils(
      Far::LimitStencilTableFactoryReal<double>::Create(*refiner, locations, nullptr, table.get(), o));
  ASSERT_TRUE(stencils);
  const std::size_t n = s.ptex.size();
  std::vector<Point3> coarse(c.points.size() / 3), P(n), Du(n), Dv(n), Duu(n), Duv(n), Dvv(n);
  for (std::size_t i = 0; i < coarse.size(); ++i) coarse[i] = {c.points[3 * i], c.points[3 * i + 1], c.points[3 * i + 2]};
  stencils->UpdateValues(coarse.data(), P.data());
  stencils->UpdateDerivs(coarse.data(), Du.data(), Dv.data());
  stencils->Update2ndDerivs(coarse.data(), Duu.data(), Duv.data(), Dvv.data());
  auto flat = [](const std::vector<Point3>& v) {
    std::vector<double> f;
    for (const Point3& p : v) f.insert(f.end(), {p.x, p.y, p.z});
    return f;
  };
  EXPECT_LT(max_diff(ours.position, flat(P)), 1e-12);
  // Far's stencils share the patch basis' derivative scale, which counts an n-gon's split into
  // sub-quads as a level (2x, 4x): compare in the ptex face's own scale, checked against finite
  // differences below.
  std::vector<double> first(n, 1.0);
  for (std::size_t i = 0; i < n; ++i) {
    const int f = int(std::upper_bound(surface.ptex_offset().begin(), surface.ptex_offset().end(), s.ptex[i]) -
                      surface.ptex_offset().begin()) - 1;
    if (scheme == SubdivisionScheme::CatmullClark && surface.mesh().face_size(f) != 4) first[i] = 0.5;
  }
  auto scaled = [&](std::vector<Point3> v, int order) {
    for (std::size_t i = 0; i < n; ++i) {
      const double k = order == 1 ? first[i] : first[i] * first[i];
      v[i] = {v[i].x * k, v[i].y * k, v[i].z * k};
    }
    return flat(v);
  };
  EXPECT_LT(max_diff(ours.du, scaled(Du, 1)), 1e-11);
  EXPECT_LT(max_diff(ours.dv, scaled(Dv, 1)), 1e-11);
  if (scheme == SubdivisionScheme::CatmullClark) {  // Loop: Far's second derivatives have the sign slip
    EXPECT_LT(max_diff(ours.duu, scaled(Duu, 2)), 1e-9);
    EXPECT_LT(max_diff(ours.duv, scaled(Duv, 2)), 1e-9);
    EXPECT_LT(max_diff(ours.dvv, scaled(Dvv, 2)), 1e-9);
  }
}

TEST(LimitSurface, MatchesFarLimitStencilsOnQuadsNgonsAndTriangles) {
  expect_matches_limit_stencils(twisted_cube(), SubdivisionScheme::CatmullClark);
  expect_matches_limit_stencils(pentagonal_prism(), SubdivisionScheme::CatmullClark);
  expect_matches_limit_stencils(open_grid(), SubdivisionScheme::CatmullClark);
  expect_matches_limit_stencils(octahedron(), SubdivisionScheme::Loop);
}

// Bfr evaluates each base face's limit surface by its own code path (not the PatchTable).
void expect_matches_bfr(const Cage& c, SubdivisionScheme scheme, double tolerance) {
  const LimitSurface surface(control(c, scheme));
  std::unique_ptr<Refiner> refiner = make_refiner(control(c, scheme), false);
  Bfr::RefinerSurfaceFactory<> factory(*refiner, Bfr::RefinerSurfaceFactory<>::Options().SetApproxLevelSmooth(4));
  const PatchPoints cvs = surface.patch_points(c.points.data());
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  int checked = 0;
  for (std::size_t f = 0; f < surface.mesh().face_count(); ++f) {
    Bfr::Surface<double> bfr;
    ASSERT_TRUE(factory.InitVertexSurface(int(f), &bfr));
    std::vector<double> pp(3 * std::size_t(bfr.GetNumPatchPoints()));
    bfr.PreparePatchPoints(c.points.data(), 3, pp.data(), 3);
    const Bfr::Parameterization param = bfr.GetParameterization();
    const int subs = surface.ptex_offset()[f + 1] - surface.ptex_offset()[f];
    for (int sub = 0; sub < subs; ++sub)
      for (int k = 0; k < 5; ++k) {
        double st[2] = {u01(rng), u01(rng)};
        if (scheme == SubdivisionScheme::Loop && st[0] + st[1] > 1) st[0] = 1 - st[0], st[1] = 1 - st[1];
        double uv[2] = {st[0], st[1]}, scale = 1.0;
        if (param.HasSubFaces()) {
          param.ConvertNormalizedSubFaceToCoord(sub, st, uv);
          const double o[2] = {0, 0}, e[2] = {1, 0};
          double a[2], b[2];
          param.ConvertNormalizedSubFaceToCoord(sub, o, a);
          param.ConvertNormalizedSubFaceToCoord(sub, e, b);
          scale = std::hypot(b[0] - a[0], b[1] - a[1]);
        }
        double P[3], Du[3], Dv[3];
        bfr.Evaluate(uv, pp.data(), 3, P, Du, Dv);
        const int ptex = surface.ptex_offset()[f] + sub;
        const LimitSamples ours = surface.evaluate(cvs, &ptex, st, 1, 1);
        for (int d = 0; d < 3; ++d) {
          EXPECT_NEAR(ours.position[d], P[d], tolerance) << "face " << f << " sub " << sub;
          EXPECT_NEAR(ours.du[d], scale * Du[d], 10 * tolerance) << "face " << f << " sub " << sub;
          EXPECT_NEAR(ours.dv[d], scale * Dv[d], 10 * tolerance) << "face " << f << " sub " << sub;
        }
        ++checked;
      }
  }
  EXPECT_GT(checked, 0);
}

TEST(LimitSurface, MatchesBfrSurfaces) {
  expect_matches_bfr(open_grid(), SubdivisionScheme::CatmullClark, 1e-12);
  expect_matches_bfr(twisted_cube(), SubdivisionScheme::CatmullClark, 1e-12);
  expect_matches_bfr(pentagonal_prism(), SubdivisionScheme::CatmullClark, 1e-12);
  expect_matches_bfr(octahedron(), SubdivisionScheme::Loop, 1e-12);
}

// Uniform refinement to level L followed by OpenSubdiv's limit masks gives exact limit points at
// the dyadic parameters of the refined vertices; the surface must pass through them. Each refined
// corner's parameters come from a linearly interpolated face-varying channel holding every base
// quad's own corner parameters.
void expect_passes_through_refined_limit_points(const Cage& c, int level,
                                                BoundaryRule boundary = BoundaryRule::EdgeAndCorner) {
  ControlMesh mesh = make_control_mesh(PolygonMesh(c.points.data(), c.points.size() / 3, c.corners, c.offsets),
                                       SubdivisionScheme::CatmullClark, boundary);
  std::vector<double> corner_uv;
  for (std::size_t f = 0; f < mesh.face_count(); ++f) corner_uv.insert(corner_uv.end(), {0, 0, 1, 0, 1, 1, 0, 1});
  set_uvs(mesh, corner_uv.data(), corner_uv.size() / 2, UvSmooth::None);
  const LimitSurface surface(mesh);
  std::unique_ptr<Refiner> refiner = make_refiner(mesh, true);
  Far::TopologyRefiner::UniformOptions uniform(level);
  uniform.fullTopologyInLastLevel = true;  // the limit masks need the last level's full topology
  refiner->RefineUniform(uniform);
  struct Uv {
    double u, v;
    void Clear(void* = nullptr) { u = v = 0; }
    void AddWithWeight(const Uv& o, double w) { u += w * o.u, v += w * o.v; }
  };
  std::vector<Point3> buffer(refiner->GetNumVerticesTotal());
  std::vector<Uv> params(refiner->GetNumFVarValuesTotal(0));
  for (std::size_t i = 0; i < c.points.size() / 3; ++i) buffer[i] = {c.points[3 * i], c.points[3 * i + 1], c.points[3 * i + 2]};
  for (std::size_t i = 0; i < mesh.uvs.size() / 2; ++i) params[i] = {mesh.uvs[2 * i], mesh.uvs[2 * i + 1]};
  Far::PrimvarRefinerReal<double> primvar(*refiner);
  Point3* src = buffer.data();
  Uv* psrc = params.data();
  for (int l = 1; l <= level; ++l) {
    Point3* dst = src + refiner->GetLevel(l - 1).GetNumVertices();
    Uv* pdst = psrc + refiner->GetLevel(l - 1).GetNumFVarValues(0);
    primvar.Interpolate(l, src, dst);
    primvar.InterpolateFaceVarying(l, psrc, pdst, 0);
    src = dst;
    psrc = pdst;
  }
  const Far::TopologyLevel& last = refiner->GetLevel(level);
  std::vector<Point3> limit(last.GetNumVertices());
  primvar.Limit(src, limit);
  const PatchPoints cvs = surface.patch_points(c.points.data());
  double worst = 0;
  int checked = 0;
  for (int f = 0; f < last.GetNumFaces(); ++f) {
    int base = f;
    for (int l = level; l >= 1; --l) base = refiner->GetLevel(l).GetFaceParentFace(base);
    const Far::ConstIndexArray fv = last.GetFaceVertices(f), fp = last.GetFaceFVarValues(f, 0);
    for (int k = 0; k < fv.size(); ++k) {
      const int ptex = surface.ptex_offset()[base];
      const double uv[2] = {psrc[fp[k]].u, psrc[fp[k]].v};
      const LimitSamples s = surface.evaluate(cvs, &ptex, uv, 1, 0);
      const Point3& p = limit[fv[k]];
      worst = std::max({worst, std::abs(s.position[0] - p.x), std::abs(s.position[1] - p.y),
                        std::abs(s.position[2] - p.z)});
      ++checked;
    }
  }
  EXPECT_EQ(checked, 4 * last.GetNumFaces());
  EXPECT_LT(worst, 1e-12);
}

TEST(LimitSurface, PassesThroughLimitPointsOfRefinedVertices) {
  expect_passes_through_refined_limit_points(open_grid(), 2);
  expect_passes_through_refined_limit_points(twisted_cube(), 3);
}

// Smooth corners (edge-only boundary) are exact only without OpenSubdiv's legacy sharp-corner
// patches, which put a refined point there.
TEST(LimitSurface, PassesThroughLimitPointsAtSmoothCorners) {
  expect_passes_through_refined_limit_points(open_grid(), 2, BoundaryRule::EdgeOnly);
  expect_passes_through_refined_limit_points(open_grid(), 3, BoundaryRule::EdgeOnly);
}

TEST(Subdivide, CountsFollowTheSchemes) {
  const Cage prism = pentagonal_prism();  // V 10, E 15, F 7, 30 corners
  const ControlMesh cc = control(prism, SubdivisionScheme::CatmullClark);
  for (int level = 1; level <= 3; ++level) {
    const SubdividedMesh out = subdivide(cc, prism.points.data(), level, kDefaultMaxFaces);
    const std::size_t faces = out.face_origin.size();
    EXPECT_EQ(std::int64_t(faces), subdivided_face_count(cc, level));
    EXPECT_EQ(faces, std::size_t(30) << (2 * (level - 1)));
    // A closed surface of genus 0 keeps Euler characteristic 2: V - E + F with E = 2F for quads.
    EXPECT_EQ(std::int64_t(out.points.size() / 3) - 2 * std::int64_t(faces) + std::int64_t(faces), 2);
  }
  const Cage octa = octahedron();
  const SubdividedMesh loop = subdivide(control(octa, SubdivisionScheme::Loop), octa.points.data(), 2, kDefaultMaxFaces);
  EXPECT_EQ(loop.face_origin.size(), 8u * 16u);
  EXPECT_EQ(loop.points.size() / 3, 6u + 12u + 48u);  // V1 = V + E, V2 = V1 + E1 (E1 = 2E + 3F)
}

TEST(Subdivide, RefusesLevelsAndSizesOutOfRange) {
  const Cage c = twisted_cube();
  const ControlMesh m = control(c, SubdivisionScheme::CatmullClark);
  EXPECT_THROW(subdivide(m, c.points.data(), 0, kDefaultMaxFaces), std::invalid_argument);
  EXPECT_THROW(subdivide(m, c.points.data(), kMaxSubdivisionLevel + 1, kDefaultMaxFaces), std::invalid_argument);
  EXPECT_THROW(subdivide(m, c.points.data(), 3, 95), std::invalid_argument);  // 24 * 16 = 384 faces
  EXPECT_NO_THROW(subdivide(m, c.points.data(), 3, 384));
}

SmoothnessOptions options(int samples_per_edge) {
  SmoothnessOptions o;
  o.samples_per_edge = samples_per_edge;
  o.worst = 3;
  return o;
}

TEST(SmoothnessReport, TwistedCubeIsG1AndASharpEdgeIsNot) {
  const Cage c = twisted_cube();
  const LimitSurface smooth(control(c, SubdivisionScheme::CatmullClark));
  const SmoothnessReport r = smoothness_report(smooth, c.points.data(), options(16));
  EXPECT_EQ(r.edge_angle.size(), 12u);
  EXPECT_LT(r.max_angle, 1e-12);
  EXPECT_LT(r.max_gap, 1e-14);
  EXPECT_EQ(r.flipped_samples, 0);
  EXPECT_EQ(r.degenerate_samples, 0);
  ControlMesh creased = control(c, SubdivisionScheme::CatmullClark);
  set_creases(creased, {0, 1}, {kInfiniteSharpness});
  const LimitSurface sharp(std::move(creased));
  const SmoothnessReport s = smoothness_report(sharp, c.points.data(), options(16));
  EXPECT_GT(s.max_angle, 0.5);
  ASSERT_FALSE(s.worst_edges.empty());
  EXPECT_EQ(s.edges[2 * s.worst_edges[0]], 0);
  EXPECT_EQ(s.edges[2 * s.worst_edges[0] + 1], 1);
  EXPECT_LT(s.max_gap, 1e-14);
}

}  // namespace
}  // namespace deformkit
namespace deformkit {
namespace {
TEST(LimitSurface, DerivativesMatchFiniteDifferences) {
  for (const auto& [c, scheme] : {std::pair{pentagonal_prism(), SubdivisionScheme::CatmullClark},
                                  std::pair{twisted_cube(), SubdivisionScheme::CatmullClark},
                                  std::pair{octahedron(), SubdivisionScheme::Loop}}) {
    const LimitSurface surface(control(c, scheme));
    const PatchPoints cvs = surface.patch_points(c.points.data());
    const Samples s = random_samples(surface, 4, 5);
    const double h = 1e-6;
    for (std::size_t i = 0; i < s.ptex.size(); ++i) {
      const double u = std::clamp(s.uv[2 * i], 0.1, 0.8), v = std::clamp(s.uv[2 * i + 1], 0.1, 0.8) * (scheme == SubdivisionScheme::Loop ? 0.2 : 1);
      const int p = s.ptex[i];
      const double at[2] = {u, v}, up[2] = {u + h, v}, um[2] = {u - h, v}, vp[2] = {u, v + h}, vm[2] = {u, v - h};
      const LimitSamples a = surface.evaluate(cvs, &p, at, 1, 2);
      const auto pos = [&](const double* q) { return surface.evaluate(cvs, &p, q, 1, 1); };
      const LimitSamples pu = pos(up), mu = pos(um), pv = pos(vp), mv = pos(vm);
      for (int d = 0; d < 3; ++d) {
        EXPECT_NEAR(a.du[d], (pu.position[d] - mu.position[d]) / (2 * h), 1e-6) << "scheme " << int(scheme) << " ptex " << p;
        EXPECT_NEAR(a.dv[d], (pv.position[d] - mv.position[d]) / (2 * h), 1e-6) << "scheme " << int(scheme) << " ptex " << p;
        EXPECT_NEAR(a.duu[d], (pu.du[d] - mu.du[d]) / (2 * h), 1e-5) << "scheme " << int(scheme) << " ptex " << p;
        EXPECT_NEAR(a.duv[d], (pv.du[d] - mv.du[d]) / (2 * h), 1e-5) << "scheme " << int(scheme) << " ptex " << p;
        EXPECT_NEAR(a.dvv[d], (pv.dv[d] - mv.dv[d]) / (2 * h), 1e-5) << "scheme " << int(scheme) << " ptex " << p;
      }
    }
  }
}
}  // namespace
}  // namespace deformkit
