#include "cage/harmonic_grid.hpp"

#include "cage/exact_geometry.hpp"
#include "core/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace deformkit::harmonic {

namespace {

// Blender's limits: a cut closer than this to its cell counts at this distance, and a point this
// close to a polygon's corner or edge takes that corner's or edge's weights.
constexpr double kMinCutLength = 1e-6;
constexpr double kOnBorder = 1e-5;

Vec3 point_of(const std::vector<double>& p, int i) { return Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]); }

// Blender's quad test: the 0-2 diagonal leaves corners 1 and 3 on the same side (it lies outside).
bool quad_splits_on_1_3(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).cross(c - a).dot((d - a).cross(c - a)) > 0.0;
}

// tan(angle / 2) of the angle at x between a and b: (|a - x| |b - x| - (a - x).(b - x)) / |cross|.
double half_tangent(const Vec3& x, const Vec3& a, const Vec3& b) {
  const Vec3 da = a - x, db = b - x;
  const double area = da.cross(db).norm();
  if (area == 0.0) return 0.0;
  return (da.norm() * db.norm() - da.dot(db)) / area;
}

double segment_distance2(const Vec3& x, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((x - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - x).squaredNorm();
}

}  // namespace

// The sign of component `axis` of (b - a) x (c - a), as cage_exact::turn_along decides it: from
// the doubles when the determinant exceeds the bound on its rounding error (Shewchuk 1997,
// "Adaptive precision floating-point arithmetic and fast robust geometric predicates", orient2d's
// first stage, bound ccwerrboundA), else exactly. Most calls end at the first stage.
int turn_along(const Vec3& a, const Vec3& b, const Vec3& c, int axis) {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  const double left = (b[u] - a[u]) * (c[v] - a[v]), right = (b[v] - a[v]) * (c[u] - a[u]);
  const double det = left - right, magnitude = std::abs(left) + std::abs(right);
  constexpr double eps = 0x1p-53;  // half an ulp of 1
  constexpr double bound = (3.0 + 16.0 * eps) * eps;
  // Far from underflow the bound holds; below it (or for non-finite input) decide exactly.
  if (magnitude > 0x1p-900 && magnitude < 0x1p900) {
    const double error = bound * magnitude;
    if (det > error) return 1;
    if (-det > error) return -1;
  }
  return cage_exact::turn_along(a, b, c, axis);
}

namespace {

std::vector<std::array<std::array<float, 3>, 3>> float_triangles(const std::vector<Vec3>& point,
                                                                 const std::vector<std::array<int, 3>>& triangle) {
  std::vector<std::array<std::array<float, 3>, 3>> out;
  for (const auto& t : triangle) {
    std::array<std::array<float, 3>, 3> corners;
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) corners[std::size_t(k)][std::size_t(a)] = float(point[std::size_t(t[std::size_t(k)])][a]);
    out.push_back(corners);
  }
  return out;
}

}  // namespace

RayCage::RayCage(const CageMesh& cage, int bvh_arity) : polygons_(&cage.polygons()), bvh_({}, 2) {
  const std::vector<double>& p = cage.rest_points();
  for (std::size_t i = 0; i < p.size() / 3; ++i) point_.push_back(point_of(p, int(i)));
  const PolygonMesh& poly = cage.polygons();
  const double orient = cage.flipped() ? -1.0 : 1.0;
  std::vector<std::vector<std::array<int, 3>>> split(poly.face_count());
  for (std::size_t t = 0; t < cage.triangles().size(); ++t)
    split[std::size_t(cage.triangle_face()[t])].push_back(cage.triangles()[t]);
  for (std::size_t f = 0; f < poly.face_count(); ++f) {
    const int* c = poly.face(f);
    const int k = poly.face_size(f);
    Vec3 n = Vec3::Zero();
    for (int i = 1; i + 1 < k; ++i) n += (point_[c[i]] - point_[c[0]]).cross(point_[c[i + 1]] - point_[c[0]]);
    normal_.push_back(orient * n);
    auto add = [&](int a, int b, int d) {
      triangle_.push_back({a, b, d});
      triangle_face_.push_back(int(f));
    };
    if (k == 3) {
      add(c[0], c[1], c[2]);
    } else if (k == 4) {
      if (quad_splits_on_1_3(point_[c[0]], point_[c[1]], point_[c[2]], point_[c[3]])) {
        add(c[0], c[1], c[3]);
        add(c[1], c[2], c[3]);
      } else {
        add(c[0], c[1], c[2]);
        add(c[0], c[2], c[3]);
      }
    } else {
      for (const auto& t : split[f]) add(t[0], t[1], t[2]);
    }
  }
  for (const auto& t : triangle_) {
    const Vec3& p0 = point_[std::size_t(t[0])];
    const Vec3& p1 = point_[std::size_t(t[1])];
    const Vec3& p2 = point_[std::size_t(t[2])];
    triangle_normal_.push_back((p1 - p0).cross(p2 - p0));
    std::array<signed char, 3> turn;
    for (int axis = 0; axis < 3; ++axis) turn[std::size_t(axis)] = static_cast<signed char>(turn_along(p0, p1, p2, axis));
    turn_.push_back(turn);
  }
  bvh_ = BlenderBvh(float_triangles(point_, triangle_), bvh_arity);
  // Per axis, the triangles' projections bucketed on a res x res grid over the cage's projection.
  const int res = std::max(1, int(std::sqrt(double(triangle_.size()))));
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    Buckets& b = buckets_[axis];
    b.res = res;
    double hi[2] = {-INFINITY, -INFINITY};
    b.lo[0] = b.lo[1] = INFINITY;
    for (const Vec3& q : point_) {
      b.lo[0] = std::min(b.lo[0], q[u]);
      b.lo[1] = std::min(b.lo[1], q[v]);
      hi[0] = std::max(hi[0], q[u]);
      hi[1] = std::max(hi[1], q[v]);
    }
    for (int a = 0; a < 2; ++a) b.step[a] = hi[a] > b.lo[a] ? (hi[a] - b.lo[a]) / res : 1.0;
    auto range = [&](const std::array<int, 3>& t, int a, int comp, int& r0, int& r1) {
      double lo = INFINITY, up = -INFINITY;
      for (int i : t) {
        lo = std::min(lo, point_[i][comp]);
        up = std::max(up, point_[i][comp]);
      }
      r0 = std::clamp(int(std::floor((lo - b.lo[a]) / b.step[a])), 0, res - 1);
      r1 = std::clamp(int(std::floor((up - b.lo[a]) / b.step[a])), 0, res - 1);
    };
    b.start.assign(std::size_t(res) * res + 1, 0);
    for (int pass = 0; pass < 2; ++pass) {
      std::vector<int> fill;
      if (pass == 1) {
        for (std::size_t i = 1; i < b.start.size(); ++i) b.start[i] += b.start[i - 1];
        b.items.resize(std::size_t(b.start.back()));
        fill.assign(b.start.begin(), b.start.end() - 1);
      }
      for (std::size_t t = 0; t < triangle_.size(); ++t) {
        int i0, i1, j0, j1;
        range(triangle_[t], 0, u, i0, i1);
        range(triangle_[t], 1, v, j0, j1);
        for (int j = j0; j <= j1; ++j)
          for (int i = i0; i <= i1; ++i) {
            const std::size_t cell = std::size_t(j) * res + i;
            if (pass == 0) ++b.start[cell + 1];
            else b.items[std::size_t(fill[cell]++)] = int(t);
          }
      }
    }
  }
}

void RayCage::line_hits(int axis, double pu, double pv, std::vector<Hit>& out) const {
  out.clear();
  const Buckets& b = buckets_[axis];
  const double fi = (pu - b.lo[0]) / b.step[0], fj = (pv - b.lo[1]) / b.step[1];
  if (!(fi >= 0.0 && fj >= 0.0 && fi <= b.res && fj <= b.res)) return;
  const int i = std::min(b.res - 1, int(fi)), j = std::min(b.res - 1, int(fj));
  const std::size_t cell = std::size_t(j) * b.res + i;
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  Vec3 x = Vec3::Zero();
  x[u] = pu;
  x[v] = pv;
  for (int k = b.start[cell]; k < b.start[cell + 1]; ++k) {
    const int t = b.items[std::size_t(k)];
    double t_hit = 0.0;
    if (meets(t, axis, pu, pv, t_hit)) out.push_back({t_hit, t});
  }
  std::sort(out.begin(), out.end(), [](const Hit& a, const Hit& b) {
    return a.t < b.t || (a.t == b.t && a.triangle < b.triangle);
  });
}

bool RayCage::meets(int triangle, int axis, double pu, double pv, double& t) const {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  const std::array<int, 3>& corner = triangle_[std::size_t(triangle)];
  const Vec3& p0 = point_[std::size_t(corner[0])];
  const Vec3& p1 = point_[std::size_t(corner[1])];
  const Vec3& p2 = point_[std::size_t(corner[2])];
  // Outside the projection's bounding box: no hit, nothing to decide.
  if (pu < std::min({p0[u], p1[u], p2[u]}) || pu > std::max({p0[u], p1[u], p2[u]}) ||
      pv < std::min({p0[v], p1[v], p2[v]}) || pv > std::max({p0[v], p1[v], p2[v]}))
    return false;
  const int whole = turn_[std::size_t(triangle)][std::size_t(axis)];
  if (whole == 0) return false;  // edge-on to the line (Blender's watertight test misses it too)
  Vec3 x = Vec3::Zero();
  x[u] = pu;
  x[v] = pv;
  if (turn_along(x, p0, p1, axis) * whole < 0 || turn_along(x, p1, p2, axis) * whole < 0 ||
      turn_along(x, p2, p0, axis) * whole < 0)
    return false;
  const Vec3& n = triangle_normal_[std::size_t(triangle)];
  t = p0[axis] - (n[u] * (pu - p0[u]) + n[v] * (pv - p0[v])) / n[axis];
  return true;
}

int RayCage::blender_hit(const Vec3& origin, int axis, int sign, double length, double* t) const {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  const float o[3] = {float(origin[0]), float(origin[1]), float(origin[2])};
  const int found = bvh_.first_hit(o, axis, sign, float(length), [&](int tri, double& dist) {
    double at = 0.0;
    if (!meets(tri, axis, origin[u], origin[v], at)) return false;
    dist = (at - origin[axis]) * sign;
    return true;
  });
  if (found >= 0 && t) meets(found, axis, origin[u], origin[v], *t);
  return found;
}

void RayCage::polygon_weights(int face, const Vec3& x, double* w) const {
  const int* c = polygons_->face(std::size_t(face));
  const int n = polygons_->face_size(std::size_t(face));
  const double eps2 = kOnBorder * kOnBorder;
  std::fill(w, w + n, 0.0);
  // The first corner (in order) within reach, else the first edge: Blender's order of tests.
  for (int i = 0; i < n; ++i) {
    const Vec3& a = point_[c[i]];
    const Vec3& b = point_[c[(i + 1) % n]];
    if ((x - a).squaredNorm() < eps2) {
      w[i] = 1.0;
      return;
    }
    if (segment_distance2(x, a, b) < eps2) {
      const double la = (x - a).norm(), lb = (x - b).norm();
      w[i] = lb / (la + lb);
      w[(i + 1) % n] = la / (la + lb);
      return;
    }
  }
  // Mean value weights (Floater 2003): (tan(alpha_{i-1} / 2) + tan(alpha_i / 2)) / |x - p_i|.
  double total = 0.0;
  for (int i = 0; i < n; ++i) {
    const Vec3& prev = point_[c[(i + n - 1) % n]];
    const Vec3& cur = point_[c[i]];
    const Vec3& next = point_[c[(i + 1) % n]];
    w[i] = (half_tangent(x, prev, cur) + half_tangent(x, cur, next)) / (x - cur).norm();
    total += w[i];
  }
  if (total != 0.0)
    for (int i = 0; i < n; ++i) w[i] /= total;
}

std::int64_t HarmonicGrid::neighbour(std::int64_t c, int d) const {
  const std::int64_t s = size;
  const std::int64_t coord[3] = {c % s, (c / s) % s, c / (s * s)};
  const int axis = d / 2;
  const std::int64_t step = d % 2 ? 1 : -1;
  const std::int64_t to = coord[axis] + step;
  if (to < 0 || to >= s) return -1;
  const std::int64_t stride = axis == 0 ? 1 : axis == 1 ? s : s * s;
  return c + step * stride;
}

const Cut& HarmonicGrid::cut_of(std::int64_t c, int d) const {
  const auto it = std::lower_bound(cut_key.begin(), cut_key.end(), c * 6 + d);
  return cuts[std::size_t(it - cut_key.begin())];
}

HarmonicGrid build_grid(const RayCage& cage, const std::vector<double>& cage_points, int precision) {
  HarmonicGrid g;
  g.size = (1 << precision) + 2;
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (std::size_t i = 0; i < cage_points.size(); ++i) {
    lo[i % 3] = std::min(lo[i % 3], cage_points[i]);
    hi[i % 3] = std::max(hi[i % 3], cage_points[i]);
  }
  // Blender's box: made cubic about its centre, padded by 2.1 cells of the unpadded grid.
  const double side = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  double padded = 0.0;
  for (int a = 0; a < 3; ++a) {
    const double centre = 0.5 * (lo[a] + hi[a]);
    double mn = centre - 0.5 * side, mx = centre + 0.5 * side;
    const double inner = (mx - mn) / (g.size - 4);
    mn -= 2.1 * inner;
    mx += 2.1 * inner;
    g.min[a] = mn;
    if (a == 0) {
      padded = mx - mn;
      g.width = padded / g.size;
    }
  }
  g.ray_length = padded + 1.0;

  const std::int64_t cells = g.cells();
  g.cut.assign(std::size_t(cells), 0);
  g.exterior.assign(std::size_t(cells), 0);
  struct Record {
    std::int64_t key;
    double length;
    int face;
    Vec3 at;
  };
  const int s = g.size;
  const int threads = parallel_threads();
  std::vector<std::vector<Record>> found(static_cast<std::size_t>(threads) * 3);
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    const std::int64_t stride[3] = {1, s, std::int64_t(s) * s};
    parallel_tasks(threads, [&](int task) {
      std::vector<RayCage::Hit> hits;
      std::vector<Record>& out = found[std::size_t(axis * threads + task)];
      for (int line = task; line < s * s; line += threads) {
        const int j = line % s, k = line / s;
        const double pu = g.centre(u, j), pv = g.centre(v, k);
        cage.line_hits(axis, pu, pv, hits);
        if (hits.empty()) continue;
        std::int64_t base = 0;
        base += std::int64_t(j) * stride[u] + std::int64_t(k) * stride[v];
        std::size_t h = 0;
        for (int i = 0; i + 1 < s; ++i) {
          const double c0 = g.centre(axis, i), c1 = g.centre(axis, i + 1);
          while (h < hits.size() && hits[h].t < c0) ++h;
          if (h == hits.size()) break;
          if (hits[h].t > c1) continue;
          std::size_t last = h;
          while (last + 1 < hits.size() && hits[last + 1].t <= c1) ++last;
          const std::int64_t a = base + std::int64_t(i) * stride[axis], b = a + stride[axis];
          // Several hits in the segment: the one Blender's traversal keeps, from either end.
          RayCage::Hit up = hits[h], down = hits[last];
          if (last > h) {
            Vec3 from;
            from[u] = pu;
            from[v] = pv;
            from[axis] = c0;
            double t = 0.0;
            int tri = cage.blender_hit(from, axis, 1, g.width, &t);
            if (tri >= 0) up = {t, tri};
            from[axis] = c1;
            tri = cage.blender_hit(from, axis, -1, g.width, &t);
            if (tri >= 0) down = {t, tri};
          }
          auto at = [&](double t) {
            Vec3 x;
            x[axis] = t;
            x[u] = pu;
            x[v] = pv;
            return x;
          };
          out.push_back({a * 6 + 2 * axis + 1, std::max(up.t - c0, kMinCutLength), cage.face_of(up.triangle), at(up.t)});
          out.push_back({b * 6 + 2 * axis, std::max(c1 - down.t, kMinCutLength), cage.face_of(down.triangle), at(down.t)});
          g.cut[std::size_t(a)] |= std::uint8_t(1u << (2 * axis + 1));
          g.cut[std::size_t(b)] |= std::uint8_t(1u << (2 * axis));
        }
      }
    });
  }
  std::vector<Record> all;
  for (auto& f : found) all.insert(all.end(), f.begin(), f.end());
  found.clear();
  std::sort(all.begin(), all.end(), [](const Record& a, const Record& b) { return a.key < b.key; });
  g.cut_key.resize(all.size());
  g.cuts.resize(all.size());
  std::int64_t offset = 0;
  for (std::size_t r = 0; r < all.size(); ++r) {
    g.cut_key[r] = all[r].key;
    g.cuts[r] = {all[r].length, all[r].face, offset};
    offset += cage.polygons().face_size(std::size_t(all[r].face));
  }
  g.cut_weights.resize(std::size_t(offset));
  parallel_tasks(threads, [&](int task) {
    for (std::size_t r = std::size_t(task); r < all.size(); r += std::size_t(threads))
      cage.polygon_weights(all[r].face, all[r].at, g.cut_weights.data() + g.cuts[r].weights);
  });

  // Flood fill from the corner cell, outside by the padding: a neighbour becomes exterior unless
  // it has cuts of its own and the segment toward it is cut.
  std::vector<std::int64_t> stack{0};
  g.exterior[0] = 1;
  while (!stack.empty()) {
    const std::int64_t a = stack.back();
    stack.pop_back();
    for (int d = 0; d < 6; ++d) {
      const std::int64_t b = g.neighbour(a, d);
      if (b < 0 || g.exterior[std::size_t(b)]) continue;
      if (g.cut[std::size_t(b)] && (g.cut[std::size_t(a)] >> d & 1u)) continue;
      g.exterior[std::size_t(b)] = 1;
      stack.push_back(b);
    }
  }
  return g;
}

bool inside_cage(const RayCage& cage, const HarmonicGrid& grid, const Vec3& p, std::vector<RayCage::Hit>& /*scratch*/) {
  for (int axis = 0; axis < 3; ++axis)
    for (int sign = 1; sign >= -1; sign -= 2) {
      const int tri = cage.blender_hit(p, axis, sign, grid.ray_length, nullptr);
      // Blender: inside when the kept hit's polygon faces along the ray (seen from inside).
      if (tri >= 0 && sign * cage.normal(cage.face_of(tri), axis) > 0.0) return true;
    }
  return false;
}

numerics::GridStencil grid_stencil(const HarmonicGrid& g) {
  numerics::GridStencil st;
  st.cells = {g.size, g.size, g.size};
  const std::int64_t cells = g.cells();
  st.unknown.assign(std::size_t(cells), -1);
  int count = 0;
  for (std::int64_t c = 0; c < cells; ++c)
    if (!g.exterior[std::size_t(c)]) st.unknown[std::size_t(c)] = count++;
  st.diagonal.assign(std::size_t(count), 0.0);
  st.coupling.assign(std::size_t(count), {0, 0, 0, 0, 0, 0});
  const double uncut = 1.0 / g.width;
  for (std::int64_t c = 0; c < cells; ++c) {
    const int u = st.unknown[std::size_t(c)];
    if (u < 0) continue;
    double total = 0.0;
    for (int d = 0; d < 6; ++d) {
      const std::int64_t nb = g.neighbour(c, d);
      if (nb < 0) continue;
      if (g.cut[std::size_t(c)] >> d & 1u) {
        total += 1.0 / g.cut_of(c, d).length;
      } else {
        total += uncut;
        if (st.unknown[std::size_t(nb)] >= 0) st.coupling[std::size_t(u)][std::size_t(d)] = uncut;
      }
    }
    st.diagonal[std::size_t(u)] = total;
  }
  return st;
}

std::vector<BoundaryTerm> boundary_terms(const HarmonicGrid& g, const numerics::GridStencil& st) {
  std::vector<BoundaryTerm> terms;
  for (std::size_t r = 0; r < g.cut_key.size(); ++r) {
    const std::int64_t c = g.cut_key[r] / 6;
    const int u = st.unknown[std::size_t(c)];
    if (u < 0) continue;
    terms.push_back({u, 1.0 / g.cuts[r].length, g.cuts[r].face, g.cuts[r].weights});
  }
  return terms;
}

namespace {

// The cuts' boundary values at a cut exterior cell, averaged with weights 1/length.
void add_semibound(const RayCage& cage, const HarmonicGrid& g, std::int64_t cell, double scale, SparseValues& out) {
  double total = 0.0;
  for (int d = 0; d < 6; ++d)
    if (g.cut[std::size_t(cell)] >> d & 1u) total += 1.0 / g.cut_of(cell, d).length;
  for (int d = 0; d < 6; ++d) {
    if (!(g.cut[std::size_t(cell)] >> d & 1u)) continue;
    const Cut& cut = g.cut_of(cell, d);
    const int* corner = cage.polygons().face(std::size_t(cut.face));
    const int k = cage.polygons().face_size(std::size_t(cut.face));
    for (int i = 0; i < k; ++i)
      out.push_back({corner[i], scale * (1.0 / cut.length) / total * g.cut_weights[std::size_t(cut.weights + i)]});
  }
}

}  // namespace

SparseValues exterior_values(const RayCage& cage, const HarmonicGrid& g, std::int64_t cell) {
  SparseValues raw;
  if (!g.exterior[std::size_t(cell)]) return raw;
  if (g.semibound(cell)) {
    add_semibound(cage, g, cell, 1.0, raw);
  } else {
    int count = 0;
    for (int d = 0; d < 6; ++d) {
      const std::int64_t nb = g.neighbour(cell, d);
      if (nb >= 0 && g.semibound(nb)) ++count;
    }
    for (int d = 0; d < 6; ++d) {
      const std::int64_t nb = g.neighbour(cell, d);
      if (nb >= 0 && g.semibound(nb)) add_semibound(cage, g, nb, 1.0 / count, raw);
    }
  }
  std::sort(raw.begin(), raw.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  SparseValues merged;
  for (const auto& e : raw) {
    if (!merged.empty() && merged.back().first == e.first) merged.back().second += e.second;
    else merged.push_back(e);
  }
  return merged;
}

}  // namespace deformkit::harmonic
