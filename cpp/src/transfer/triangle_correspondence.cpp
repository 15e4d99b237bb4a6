#include "deformkit/transfer/triangle_correspondence.hpp"

#include "core/parallel.hpp"
#include "deformkit/numerics/constrained_quadratic.hpp"
#include "transfer/sliver.hpp"
#include "transfer/triangle_locator.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <tuple>

namespace deformkit {

namespace {

using Vec3 = Eigen::Vector3d;

Vec3 at(const std::vector<double>& p, int i) { return Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]); }

double bounding_diagonal(const std::vector<double>& p) {
  Vec3 lo = Vec3::Constant(HUGE_VAL), hi = -lo;
  for (std::size_t i = 0; i < p.size() / 3; ++i) {
    lo = lo.cwiseMin(at(p, int(i)));
    hi = hi.cwiseMax(at(p, int(i)));
  }
  return (hi - lo).norm();
}

// The coefficients of a triangle's deformation gradient T = V' V^-1 (Sumner and Popovic 2004,
// eq. 4) in its four unknowns v1, v2, v3, v4: column k of T (for each coordinate alike) is
// sum_m coefficient[k][m] x_m.
using GradientCoefficients = std::array<std::array<double, 4>, 3>;

GradientCoefficients gradient_coefficients(const Eigen::Matrix3d& inverse) {
  GradientCoefficients c;
  for (int k = 0; k < 3; ++k) {
    c[k][1] = inverse(0, k);
    c[k][2] = inverse(1, k);
    c[k][3] = inverse(2, k);
    c[k][0] = -(c[k][1] + c[k][2] + c[k][3]);
  }
  return c;
}

// Triangles sharing an edge, each pair once (all pairs around a non-manifold edge).
std::vector<std::pair<int, int>> adjacent_triangles(const std::vector<int>& tri) {
  std::vector<std::tuple<int, int, int>> edges;
  edges.reserve(tri.size());
  for (std::size_t j = 0; j < tri.size() / 3; ++j)
    for (int k = 0; k < 3; ++k) {
      const int a = tri[3 * j + k], b = tri[3 * j + (k + 1) % 3];
      edges.emplace_back(std::min(a, b), std::max(a, b), int(j));
    }
  std::sort(edges.begin(), edges.end());
  std::vector<std::pair<int, int>> out;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t e = i;
    while (e < edges.size() && std::get<0>(edges[e]) == std::get<0>(edges[i]) && std::get<1>(edges[e]) == std::get<1>(edges[i])) ++e;
    for (std::size_t p = i; p < e; ++p)
      for (std::size_t q = p + 1; q < e; ++q)
        if (std::get<2>(edges[p]) != std::get<2>(edges[q])) out.emplace_back(std::get<2>(edges[p]), std::get<2>(edges[q]));
    i = e;
  }
  return out;
}

double mean_edge_length(const std::vector<double>& p, const std::vector<int>& tri) {
  double sum = 0;
  for (std::size_t j = 0; j < tri.size(); ++j) sum += (at(p, tri[j]) - at(p, tri[j - j % 3 + (j + 1) % 3])).norm();
  return tri.empty() ? 0.0 : sum / double(tri.size());
}

std::vector<Vec3> vertex_normals(const std::vector<double>& p, const std::vector<int>& tri) {
  std::vector<Vec3> n(p.size() / 3, Vec3::Zero());
  for (std::size_t j = 0; j < tri.size() / 3; ++j) {
    const int* v = tri.data() + 3 * j;
    const Vec3 f = (at(p, v[1]) - at(p, v[0])).cross(at(p, v[2]) - at(p, v[0]));  // area-weighted
    for (int k = 0; k < 3; ++k) n[std::size_t(v[k])] += f;
  }
  for (Vec3& x : n)
    if (x.norm() > 0) x.normalize();
  return n;
}

void check_markers(const PolygonMesh& source, const PolygonMesh& target, const std::vector<int>& s,
                   const std::vector<int>& t) {
  if (s.size() != t.size())
    throw std::invalid_argument("markers: expected as many source vertices as target vertices, got " +
                                std::to_string(s.size()) + " and " + std::to_string(t.size()));
  auto check_side = [](const std::vector<int>& m, std::size_t n, const char* side) {
    std::vector<int> first(n, -1);
    for (std::size_t i = 0; i < m.size(); ++i) {
      if (m[i] < 0 || std::size_t(m[i]) >= n)
        throw std::invalid_argument(std::string("markers: pair ") + std::to_string(i) + "'s " + side + " vertex " +
                                    std::to_string(m[i]) + " is outside 0.." + std::to_string(n - 1));
      if (first[std::size_t(m[i])] >= 0)
        throw std::invalid_argument(std::string("markers: pairs ") + std::to_string(first[std::size_t(m[i])]) + " and " +
                                    std::to_string(i) + " give the same " + side + " vertex " + std::to_string(m[i]) +
                                    "; each vertex may be a marker once");
      first[std::size_t(m[i])] = int(i);
    }
  };
  check_side(s, source.vertex_count(), "source");
  check_side(t, target.vertex_count(), "target");
  int parts = 0;
  const std::vector<int> part = connected_components(source, &parts);
  std::vector<char> marked(std::size_t(parts), 0);
  for (int v : s) marked[std::size_t(part[std::size_t(v)])] = 1;
  for (std::size_t v = 0; v < part.size(); ++v)
    if (!marked[std::size_t(part[v])])
      throw std::invalid_argument("markers: the source's connected part of vertex " + std::to_string(v) +
                                  " has no marker; the correspondence needs at least one in every part (" +
                                  std::to_string(parts) + " parts, " + std::to_string(s.size()) + " markers given)");
}

}  // namespace

TriangleCorrespondence triangle_correspondence(const PolygonMesh& source, const PolygonMesh& target,
                                               const std::vector<int>& source_markers,
                                               const std::vector<int>& target_markers,
                                               const CorrespondenceOptions& options) {
  if (!source.all_triangles() || !target.all_triangles())
    throw std::invalid_argument(std::string(source.all_triangles() ? "target_faces" : "source_faces") +
                                ": the correspondence takes triangles (fan the polygons first)");
  check_markers(source, target, source_markers, target_markers);
  require_no_sliver(source, "source_faces");
  const std::vector<double>& rest = source.points();
  const std::vector<int>& tri = source.corners();
  const std::size_t n = source.vertex_count(), t = tri.size() / 3, unknowns = n + t;

  std::vector<GradientCoefficients> coefficient(t);
  for (std::size_t j = 0; j < t; ++j) {
    const int* v = tri.data() + 3 * j;
    const Vec3 e1 = at(rest, v[1]) - at(rest, v[0]), e2 = at(rest, v[2]) - at(rest, v[0]), c = e1.cross(e2);
    Eigen::Matrix3d frame;
    frame << e1, e2, c / std::sqrt(c.norm());  // the fourth vertex (eq. 1)
    coefficient[j] = gradient_coefficients(frame.inverse());
  }
  auto unknown = [&](std::size_t j, int m) { return m < 3 ? tri[3 * j + std::size_t(m)] : int(n + j); };

  // E_S sums ||T_i - T_j||^2 over ordered neighbour pairs (eq. 11): each unordered pair twice.
  const std::vector<std::pair<int, int>> neighbours = adjacent_triangles(tri);
  const double ws = std::sqrt(2.0 * options.smoothness_weight), wi = std::sqrt(options.identity_weight);
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(24 * neighbours.size() + 12 * t);
  Eigen::Index row = 0;
  for (const auto& [i, j] : neighbours)
    for (int k = 0; k < 3; ++k, ++row)
      for (int m = 0; m < 4; ++m) {
        entries.emplace_back(row, unknown(std::size_t(i), m), ws * coefficient[std::size_t(i)][k][m]);
        entries.emplace_back(row, unknown(std::size_t(j), m), -ws * coefficient[std::size_t(j)][k][m]);
      }
  const Eigen::Index identity_rows = row;
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(identity_rows + Eigen::Index(3 * t), 3);
  for (std::size_t j = 0; j < t; ++j)
    for (int k = 0; k < 3; ++k, ++row) {
      for (int m = 0; m < 4; ++m) entries.emplace_back(row, unknown(j, m), wi * coefficient[j][k][m]);
      r(row, k) = wi;  // column k of T towards column k of I, in coordinate k
    }
  SparseMatrix mat(row, Eigen::Index(unknowns));
  mat.setFromTriplets(entries.begin(), entries.end());

  std::vector<char> fixed(unknowns, 0);
  for (int v : source_markers) fixed[std::size_t(v)] = 1;
  const UnknownSplit split(fixed);
  Eigen::MatrixXd marker_values(Eigen::Index(source_markers.size()), 3);
  {
    // split.fixed() is in index order; the values follow it.
    std::vector<int> order(source_markers.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = int(i);
    std::sort(order.begin(), order.end(), [&](int a, int b) { return source_markers[std::size_t(a)] < source_markers[std::size_t(b)]; });
    for (std::size_t i = 0; i < order.size(); ++i)
      marker_values.row(Eigen::Index(i)) = at(target.points(), target_markers[std::size_t(order[i])]).transpose();
  }

  const TriangleLocator target_triangles(target.points(), target.corners());
  const double diagonal = bounding_diagonal(target.points());
  std::vector<double> current = rest;
  auto closest_points = [&](std::vector<TriangleHit>& hits) {
    const std::vector<Vec3> normal = vertex_normals(current, tri);
    hits.assign(n, TriangleHit{});
    parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) hits[i] = target_triangles.closest_valid_point(at(current, int(i)), normal[i]);
    });
  };
  std::vector<TriangleHit> hits;
  std::vector<double> steps(1, 0.0);
  steps.insert(steps.end(), options.closest_weights.begin(), options.closest_weights.end());
  for (const double wc : steps) {
    SoftConstraints soft;
    Eigen::MatrixXd soft_targets;
    if (wc > 0) {
      closest_points(hits);
      for (std::size_t i = 0; i < n; ++i)
        if (!fixed[i] && hits[i].triangle >= 0) {
          soft.unknowns.push_back(int(i));
          soft.weights.push_back(wc / (diagonal * diagonal));
        }
      soft_targets.resize(Eigen::Index(soft.unknowns.size()), 3);
      for (std::size_t s = 0; s < soft.unknowns.size(); ++s)
        soft_targets.row(Eigen::Index(s)) = hits[std::size_t(soft.unknowns[s])].point.transpose();
    }
    const ConstrainedQuadratic system = ConstrainedQuadratic::least_squares(mat, split, soft);
    if (!system.factorised())
      throw std::invalid_argument("source_faces: the correspondence system could not be factorised (degenerate source)");
    const Eigen::MatrixXd all = system.assemble(system.solve_free(r, marker_values, soft_targets), marker_values);
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) current[3 * i + std::size_t(c)] = all(Eigen::Index(i), c);
  }

  TriangleCorrespondence out;
  closest_points(hits);
  double sum = 0;
  for (const TriangleHit& h : hits) {
    sum += h.distance;
    out.max_distance = std::max(out.max_distance, h.distance);
  }
  out.mean_distance = n ? sum / double(n) : 0.0;

  // Compatible pairs from both sides (section 5.3).
  const TriangleLocator source_triangles(current, tri);
  // Centroids of a coarse mesh are a triangle's size apart: the threshold is never below that.
  const double reach = std::max(options.max_centroid_distance * diagonal,
                                2.0 * std::max(mean_edge_length(current, tri), mean_edge_length(target.points(), target.corners())));
  const std::size_t tt = target_triangles.size();
  std::vector<int> to_target(t), to_source(tt);
  parallel_blocks(t, [&](std::size_t begin, std::size_t end) {
    for (std::size_t j = begin; j < end; ++j)
      to_target[j] = target_triangles.nearest_compatible_centroid(source_triangles.centroid(int(j)), source_triangles.normal(int(j)), reach);
  });
  parallel_blocks(tt, [&](std::size_t begin, std::size_t end) {
    for (std::size_t j = begin; j < end; ++j)
      to_source[j] = source_triangles.nearest_compatible_centroid(target_triangles.centroid(int(j)), target_triangles.normal(int(j)), reach);
  });
  std::vector<std::pair<int, int>> pairs;
  pairs.reserve(t + tt);
  for (std::size_t j = 0; j < t; ++j)
    if (to_target[j] >= 0) pairs.emplace_back(int(j), to_target[j]);
  for (std::size_t j = 0; j < tt; ++j)
    if (to_source[j] >= 0) pairs.emplace_back(to_source[j], int(j));
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  std::vector<char> source_hit(t, 0), target_hit(tt, 0);
  for (const auto& [s, g] : pairs) {
    out.pairs.push_back(s);
    out.pairs.push_back(g);
    source_hit[std::size_t(s)] = target_hit[std::size_t(g)] = 1;
  }
  for (std::size_t j = 0; j < tt; ++j)
    if (!target_hit[j]) out.unmatched_target.push_back(int(j));
  for (std::size_t j = 0; j < t; ++j)
    if (!source_hit[j]) out.unmatched_source.push_back(int(j));
  out.fitted_source = std::move(current);
  return out;
}

}  // namespace deformkit
