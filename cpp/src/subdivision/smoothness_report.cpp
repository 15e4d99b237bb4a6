#include "deformkit/subdivision/smoothness_report.hpp"

#include "deformkit/numerics/best_rotation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace deformkit {

namespace {

using Vec = std::array<double, 3>;

Vec at(const std::vector<double>& a, std::size_t i) { return {a[3 * i], a[3 * i + 1], a[3 * i + 2]}; }
Vec cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
// Scaled by the largest component first: no overflow of the squares at 1e200, no underflow at 1e-200.
double norm(const Vec& a) {
  const double m = std::max({std::abs(a[0]), std::abs(a[1]), std::abs(a[2])});
  if (!(m > 0) || !std::isfinite(m)) return m;
  const Vec b{a[0] / m, a[1] / m, a[2] / m};
  return m * std::sqrt(dot(b, b));
}
Vec unit(const Vec& a) {
  const double n = norm(a);
  return n > 0 ? Vec{a[0] / n, a[1] / n, a[2] / n} : Vec{0, 0, 0};
}
// Robust near 0 and pi, where acos of a rounded dot product is not (docs/math/subdivision.md, "Angles between normals").
double angle(const Vec& a, const Vec& b) { return std::atan2(norm(cross(a, b)), dot(a, b)); }

double bounding_diagonal(const double* p, std::size_t n) {
  Vec lo{p[0], p[1], p[2]}, hi = lo;
  for (std::size_t i = 1; i < n; ++i)
    for (int c = 0; c < 3; ++c) lo[c] = std::min(lo[c], p[3 * i + c]), hi[c] = std::max(hi[c], p[3 * i + c]);
  return norm({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
}

std::vector<double> unit_scaled(const double* p, std::size_t n) {
  double largest = 0.0;
  for (std::size_t i = 0; i < 3 * n; ++i) largest = std::max(largest, std::abs(p[i]));
  int exponent = 0;
  if (largest > 0) std::frexp(largest, &exponent);
  std::vector<double> out(p, p + 3 * n);
  for (double& x : out) x = std::ldexp(x, -exponent);
  return out;
}

// Newell's normal of each control face: the orientation a limit normal is expected to share.
std::vector<double> face_normals(const ControlMesh& mesh, const double* p) {
  std::vector<double> out(3 * mesh.face_count());
  std::size_t offset = 0;
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const int k = mesh.face_size(f);
    for (int i = 0; i < k; ++i) {
      const double* a = p + 3 * mesh.corners()[offset + i];
      const double* b = p + 3 * mesh.corners()[offset + (i + 1) % k];
      out[3 * f] += (a[1] - b[1]) * (a[2] + b[2]);
      out[3 * f + 1] += (a[2] - b[2]) * (a[0] + b[0]);
      out[3 * f + 2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    offset += k;
  }
  return out;
}

// Positions and tangents of the checked surface at the samples: S, or F(S) with J Du, J Dv.
LimitSamples checked_surface(const LimitSurface& surface, const PatchPoints& cvs, const std::vector<int>& ptex,
                             const std::vector<double>& uv, const Deformer* deformer,
                             std::vector<double>* det = nullptr) {
  LimitSamples s = surface.evaluate(cvs, ptex.data(), uv.data(), ptex.size(), 1);
  if (!deformer) return s;
  const std::size_t n = ptex.size();
  std::vector<double> jac(9 * n), moved(3 * n);
  deformer->jacobian(s.position.data(), jac.data(), n);
  deformer->deform(s.position.data(), moved.data(), n);
  for (std::size_t i = 0; i < 9 * n; ++i)
    if (!std::isfinite(jac[i]) || (i < 3 * n && !std::isfinite(moved[i])))
      throw std::invalid_argument("deformer: maps limit-surface sample " + std::to_string(i < 3 * n ? i / 3 : i / 9) +
                                  " to a non-finite point or Jacobian (the points are out of its range)");
  s.position = std::move(moved);
  if (det) det->resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double* j = &jac[9 * i];
    if (det)
      (*det)[i] = j[0] * (j[4] * j[8] - j[5] * j[7]) - j[1] * (j[3] * j[8] - j[5] * j[6]) +
                  j[2] * (j[3] * j[7] - j[4] * j[6]);
    for (std::vector<double>* t : {&s.du, &s.dv}) {
      const Vec d = at(*t, i);
      for (int r = 0; r < 3; ++r) (*t)[3 * i + r] = j[3 * r] * d[0] + j[3 * r + 1] * d[1] + j[3 * r + 2] * d[2];
    }
    const Vec nrm = unit(cross(unit(at(s.du, i)), unit(at(s.dv, i))));
    std::copy(nrm.begin(), nrm.end(), s.normal.begin() + 3 * i);
  }
  return s;
}

// The largest second difference of the unit normal along the grid lines of every ptex face,
// on a (g+1)^2 grid, as an angle: |n(a) - 2 n(b) + n(c)| is O(h^2) where the normal field is
// smooth and about the jump angle where a crease passes between the three samples.
std::vector<double> normal_kinks(const LimitSurface& surface, const PatchPoints& cvs, const Deformer* deformer,
                                 int g) {
  const bool triangles = surface.mesh().scheme == SubdivisionScheme::Loop;
  const int per = (g + 1) * (g + 1), faces = surface.ptex_count();
  const int batch = std::max(1, (1 << 20) / per);  // ptex faces per batch: bounded memory
  auto inside = [&](int i, int j) { return i >= 0 && j >= 0 && i <= g && j <= g && (!triangles || i + j <= g); };
  std::vector<double> worst(faces, 0.0);
  std::vector<int> ptex;
  std::vector<double> uv;
  for (int p0 = 0; p0 < faces; p0 += batch) {
    const int p1 = std::min(faces, p0 + batch);
    ptex.clear();
    uv.clear();
    for (int p = p0; p < p1; ++p)
      for (int j = 0; j <= g; ++j)
        for (int i = 0; i <= g; ++i) {
          const bool in = inside(i, j);  // outside a triangle: a dummy at its corner, skipped below
          ptex.push_back(p);
          uv.insert(uv.end(), {in ? double(i) / g : 0.0, in ? double(j) / g : 0.0});
        }
    const LimitSamples s = checked_surface(surface, cvs, ptex, uv, deformer);
    for (int p = p0; p < p1; ++p) {
      const std::size_t base = std::size_t(p - p0) * per;
      auto normal = [&](int i, int j) { return at(s.normal, base + std::size_t(j) * (g + 1) + i); };
      for (int j = 0; j <= g; ++j)
        for (int i = 0; i <= g; ++i)
          for (const auto& [di, dj] : {std::pair{1, 0}, std::pair{0, 1}}) {
            if (!inside(i - di, j - dj) || !inside(i, j) || !inside(i + di, j + dj)) continue;
            const Vec a = normal(i - di, j - dj), b = normal(i, j), c = normal(i + di, j + dj);
            if (norm(a) == 0 || norm(b) == 0 || norm(c) == 0) continue;  // singular: no normal
            const double d = norm({a[0] - 2 * b[0] + c[0], a[1] - 2 * b[1] + c[1], a[2] - 2 * b[2] + c[2]});
            worst[p] = std::max(worst[p], 2.0 * std::asin(std::min(1.0, 0.5 * d)));
          }
    }
  }
  return worst;
}

// Per control face, the rotation that best carries its neighbourhood (the vertices of every face
// sharing a vertex with it) from the reference to the points (Kabsch): a sample's reference
// normal, so rotated, is what its normal should agree with in sign. Rigid motions, twists and
// bends turn normals by any angle without folding anything; a fold reverses them locally.
std::vector<Mat3> face_rotations(const ControlMesh& mesh, const double* reference, const double* points) {
  std::vector<int> start(mesh.face_count() + 1, 0);
  for (std::size_t f = 0; f < mesh.face_count(); ++f) start[f + 1] = start[f] + mesh.face_size(f);
  std::vector<std::vector<int>> faces_of(mesh.vertex_count());
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    for (int c = start[f]; c < start[f + 1]; ++c) faces_of[mesh.corners()[c]].push_back(int(f));
  std::vector<Mat3> out(mesh.face_count());
  std::vector<int> ring;
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    ring.clear();
    for (int c = start[f]; c < start[f + 1]; ++c)
      for (int g : faces_of[mesh.corners()[c]])
        ring.insert(ring.end(), mesh.corners().begin() + start[g], mesh.corners().begin() + start[g + 1]);
    std::sort(ring.begin(), ring.end());
    ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
    Vec3 pc = Vec3::Zero(), qc = Vec3::Zero();
    for (int v : ring) pc += Vec3(reference + 3 * v), qc += Vec3(points + 3 * v);
    pc /= double(ring.size());
    qc /= double(ring.size());
    Mat3 cov = Mat3::Zero();
    for (int v : ring) cov += (Vec3(reference + 3 * v) - pc) * (Vec3(points + 3 * v) - qc).transpose();
    out[f] = best_rotation(cov);  // maximises tr(R cov): R (p - pc) ~ q - qc
  }
  return out;
}

std::vector<int> largest_first(const std::vector<double>& values, int count) {
  std::vector<int> order(values.size());
  std::iota(order.begin(), order.end(), 0);
  const std::size_t keep = std::min<std::size_t>(order.size(), std::size_t(count));
  std::partial_sort(order.begin(), order.begin() + keep, order.end(), [&](int x, int y) {
    return values[x] > values[y] || (values[x] == values[y] && x < y);
  });
  order.resize(keep);
  return order;
}

}  // namespace

SmoothnessReport smoothness_report(const LimitSurface& surface, const double* points, const SmoothnessOptions& o) {
  const int samples_per_edge = o.samples_per_edge;
  if (samples_per_edge < 1 || samples_per_edge > 1000)
    throw std::invalid_argument("samples_per_edge: must be 1..1000, got " + std::to_string(samples_per_edge));
  if (o.worst < 0) throw std::invalid_argument("worst: must be >= 0, got " + std::to_string(o.worst));
  if (o.deformer && (o.crease_grid < 1 || o.crease_grid > 64))
    throw std::invalid_argument("crease_grid: must be 1..64, got " + std::to_string(o.crease_grid));
  if (o.deformer && !o.deformer->weights().empty())
    throw std::invalid_argument("deformer: has per-point weights, which do not apply to limit-surface samples");
  const ControlMesh& mesh = surface.mesh();
  require_finite_rows(points, mesh.vertex_count(), "points");
  if (o.reference) require_finite_rows(o.reference, mesh.vertex_count(), "reference");
  // Every figure but a deformer's is scale-invariant: work on the points scaled by a power of two
  // (exact) to unit size, so that no product overflows at 1e200 or underflows at 1e-200.
  const std::vector<double> scaled = o.deformer ? std::vector<double>() : unit_scaled(points, mesh.vertex_count());
  const std::vector<double> scaled_reference =
      o.reference && !o.deformer ? unit_scaled(o.reference, mesh.vertex_count()) : std::vector<double>();
  if (!o.deformer) points = scaled.data();
  const double* reference = o.reference && !o.deformer ? scaled_reference.data() : o.reference;
  const double diagonal = bounding_diagonal(points, mesh.vertex_count());
  if (!(diagonal > 0)) throw std::invalid_argument("points: all points coincide; the surface has no extent");
  if (!std::isfinite(diagonal))
    throw std::invalid_argument("points: the bounding box is wider than the double range (coordinates near 1e308)");

  const EdgeTopology topo = edge_topology(mesh);
  const PatchPoints cvs = surface.patch_points(points);
  const PatchPoints reference_cvs = reference ? surface.patch_points(reference) : PatchPoints();
  const std::vector<double> face_normal = face_normals(mesh, points);
  const std::vector<Mat3> rotation =
      reference && !o.deformer ? face_rotations(mesh, reference, points) : std::vector<Mat3>();
  SmoothnessReport r;
  std::vector<char> face_flipped(mesh.face_count(), 0);

  // One batch of samples: the checked surface there, and which samples are singular or flipped.
  std::vector<int> ptex, owner;  // owner: the base face each sample lies in
  std::vector<double> uv;
  auto add = [&](const PtexPoint& p, int face) {
    ptex.push_back(p.ptex);
    uv.insert(uv.end(), {p.u, p.v});
    owner.push_back(face);
  };
  std::vector<char> singular;
  auto run_batch = [&]() {
    const std::size_t n = ptex.size();
    std::vector<double> det;  // with a deformer: det J, negative where the map turns the surface over
    LimitSamples ls = checked_surface(surface, cvs, ptex, uv, o.deformer, &det);
    std::vector<double> expected;  // the normal each sample should agree with in sign
    if (!rotation.empty()) {
      expected = surface.evaluate(reference_cvs, ptex.data(), uv.data(), n, 1).normal;
      for (std::size_t i = 0; i < n; ++i) {
        const Vec3 turned = rotation[owner[i]] * Vec3(&expected[3 * i]);
        std::copy(turned.data(), turned.data() + 3, &expected[3 * i]);
      }
    }
    singular.assign(n, 0);
    for (std::size_t i = 0; i < n; ++i) {
      const double regularity = norm(cross(unit(at(ls.du, i)), unit(at(ls.dv, i))));
      r.min_regularity = std::min(r.min_regularity, regularity);
      const bool flipped = o.deformer         ? det[i] < 0
                           : expected.empty() ? dot(at(ls.normal, i), at(face_normal, owner[i])) < 0
                                              : dot(at(ls.normal, i), at(expected, i)) < 0;
      if (regularity <= 1e-12) {
        singular[i] = 1;
        ++r.degenerate_samples;
      } else if (flipped) {
        ++r.flipped_samples;
        face_flipped[owner[i]] = 1;
      }
    }
    r.sample_count += long(n);
    return ls;
  };
  auto clear = [&]() { ptex.clear(), uv.clear(), owner.clear(); };

  // Edges in batches of about 2^20 samples, which bounds the memory on large meshes.
  const std::size_t edge_count = topo.edges.size() / 2;
  const std::size_t batch = std::max<std::size_t>(1, (std::size_t(1) << 20) / (2 * samples_per_edge));
  std::vector<int> interior;  // the interior edges of the current batch
  for (std::size_t e0 = 0; e0 < edge_count; e0 += batch) {
    clear();
    interior.clear();
    for (std::size_t e = e0; e < std::min(edge_count, e0 + batch); ++e) {
      const int first = topo.face_offsets[e];
      if (topo.face_offsets[e + 1] - first != 2) {
        ++r.boundary_edges;
        continue;
      }
      const int f = topo.face_of[first], g = topo.face_of[first + 1];
      for (int k = 0; k < samples_per_edge; ++k) {
        const double t = (k + 0.5) / samples_per_edge;
        // Consistent winding: g runs along the shared edge the other way.
        add(surface.edge_point(f, topo.local_of[first], t), f);
        add(surface.edge_point(g, topo.local_of[first + 1], 1.0 - t), g);
      }
      interior.push_back(int(e));
    }
    const LimitSamples ls = run_batch();
    for (std::size_t j = 0; j < interior.size(); ++j) {
      r.edges.insert(r.edges.end(), {topo.edges[2 * interior[j]], topo.edges[2 * interior[j] + 1]});
      double gap = 0.0, turn = 0.0;
      for (int k = 0; k < samples_per_edge; ++k) {
        const std::size_t a = 2 * (j * samples_per_edge + k), b = a + 1;
        const Vec pa = at(ls.position, a), pb = at(ls.position, b);
        gap = std::max(gap, norm({pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2]}) / diagonal);
        if (!singular[a] && !singular[b]) turn = std::max(turn, angle(at(ls.normal, a), at(ls.normal, b)));
      }
      r.edge_gap.push_back(gap);
      r.edge_angle.push_back(turn);
      r.max_angle = std::max(r.max_angle, turn);
      r.max_gap = std::max(r.max_gap, gap);
    }
  }
  // Face interiors (one sample per face, per sub-quad of n-gons): flips and degeneracies only.
  for (std::size_t f0 = 0; f0 < mesh.face_count(); f0 += std::size_t(1) << 20) {
    clear();
    for (std::size_t f = f0; f < std::min(mesh.face_count(), f0 + (std::size_t(1) << 20)); ++f) {
      const bool split = mesh.scheme == SubdivisionScheme::CatmullClark && mesh.face_size(f) != 4;
      for (int sub = 0; sub < (split ? mesh.face_size(f) : 1); ++sub) add(surface.interior_point(int(f), sub), int(f));
    }
    run_batch();
  }
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    if (face_flipped[f]) r.flipped_faces.push_back(int(f));
  r.worst_edges = largest_first(r.edge_angle, o.worst);

  if (o.deformer) {
    const std::vector<double> kinks = normal_kinks(surface, cvs, o.deformer, o.crease_grid);
    r.face_crease.assign(mesh.face_count(), 0.0);
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
      for (int p = surface.ptex_offset()[f]; p < surface.ptex_offset()[f + 1]; ++p)
        r.face_crease[f] = std::max(r.face_crease[f], kinks[p]);
    r.max_crease = *std::max_element(r.face_crease.begin(), r.face_crease.end());
    r.worst_faces = largest_first(r.face_crease, o.worst);
  }
  return r;
}

}  // namespace deformkit
