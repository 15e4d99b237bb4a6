#include "deformkit/transfer/deformation_transfer.hpp"

#include "core/parallel.hpp"
#include "transfer/sliver.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace deformkit {

namespace {

using Vec3 = Eigen::Vector3d;

Vec3 point(const std::vector<double>& p, int i) { return Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]); }
Vec3 point(const double* p, int i) { return Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]); }

// Sumner and Popovic 2004, eq. 1-3: the triangle's edges and its fourth vertex's offset
// n / sqrt(|n|), which scales as the edges do.
Eigen::Matrix3d frame(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a, n = e1.cross(e2);
  Eigen::Matrix3d v;
  v << e1, e2, n / std::sqrt(n.norm());
  return v;
}

// For each target triangle, its source partners (CSR: offset has t + 1 entries).
void partners_by_target(const std::vector<int>& pairs, std::size_t target_triangles, std::vector<int>& offset,
                        std::vector<int>& partner) {
  offset.assign(target_triangles + 1, 0);
  for (std::size_t p = 0; p < pairs.size() / 2; ++p) ++offset[std::size_t(pairs[2 * p + 1]) + 1];
  for (std::size_t j = 0; j < target_triangles; ++j) offset[j + 1] += offset[j];
  partner.resize(pairs.size() / 2);
  std::vector<int> next(offset.begin(), offset.end() - 1);
  for (std::size_t p = 0; p < pairs.size() / 2; ++p) partner[std::size_t(next[std::size_t(pairs[2 * p + 1])]++)] = pairs[2 * p];
}

// The target's gradient operator, sqrt(area x partners)-weighted: rows 3j..3j+2 give the gradient
// of a piecewise-linear function on triangle j (hat gradients n x (p_k+2 - p_k+1) / (2 area)).
// tangent[j]: I - n n^T times sqrt(area / partners), which turns the partners' summed gradients
// into the weighted mean's rows.
SparseMatrix weighted_gradient_operator(const std::vector<double>& points, const std::vector<int>& triangles,
                                        const std::vector<int>& partner_offset, std::vector<Eigen::Matrix3d>& tangent) {
  const std::size_t t = triangles.size() / 3;
  tangent.resize(t);
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(9 * t);
  for (std::size_t j = 0; j < t; ++j) {
    const int* v = triangles.data() + 3 * j;
    const Vec3 p[3] = {point(points, v[0]), point(points, v[1]), point(points, v[2])};
    const Vec3 nn = (p[1] - p[0]).cross(p[2] - p[0]);
    const double twice_area = nn.norm();  // positive: require_no_sliver ran
    const double m = std::max(1, partner_offset[j + 1] - partner_offset[j]);
    const Vec3 unit = nn / twice_area;
    const double w = std::sqrt(0.5 * twice_area * m);
    tangent[j] = (w / m) * (Eigen::Matrix3d::Identity() - unit * unit.transpose());
    for (int k = 0; k < 3; ++k) {
      const Vec3 g = w * unit.cross(p[(k + 2) % 3] - p[(k + 1) % 3]) / twice_area;
      for (int c = 0; c < 3; ++c) entries.emplace_back(Eigen::Index(3 * j + c), v[k], g[c]);
    }
  }
  SparseMatrix m(Eigen::Index(3 * t), Eigen::Index(points.size() / 3));
  m.setFromTriplets(entries.begin(), entries.end());
  return m;
}

}  // namespace

DeformationTransfer::DeformationTransfer(const PolygonMesh& source, const std::vector<double>& target_points,
                                         const std::vector<int>& fixed_vertices) {
  const std::size_t n = source.vertex_count();
  if (target_points.size() != source.points().size())
    throw std::invalid_argument("target_points: expected " + std::to_string(n) +
                                " points (the source's; the faces are shared), got " +
                                std::to_string(target_points.size() / 3));
  for (std::size_t i = 0; i < target_points.size(); ++i)
    if (!std::isfinite(target_points[i]))
      throw std::invalid_argument("target_points: row " + std::to_string(i / 3) + " is not finite");
  const PolygonMesh tri = source.triangulate();
  const PolygonMesh target(target_points.data(), n, tri.corners().data(), tri.face_count(), 3);
  TransferPairing pairing;
  pairing.fixed_vertices = fixed_vertices;
  for (std::size_t j = 0; j < tri.face_count(); ++j) pairing.pairs.insert(pairing.pairs.end(), {int(j), int(j)});
  int parts = 0;
  const std::vector<int> part = connected_components(tri, &parts);
  std::vector<char> seen(std::size_t(parts), 0);
  for (std::size_t i = 0; i < n; ++i)
    if (!seen[std::size_t(part[i])]) {
      seen[std::size_t(part[i])] = 1;
      pairing.reference.insert(pairing.reference.end(), {int(i), int(i)});
    }
  build(tri, target, pairing);
}

DeformationTransfer::DeformationTransfer(const PolygonMesh& source, const PolygonMesh& target,
                                         const TransferPairing& pairing) {
  build(source.triangulate(), target.triangulate(), pairing);
}

DeformationTransfer::DeformationTransfer(const PolygonMesh& source, const PolygonMesh& target,
                                         const std::vector<int>& source_markers, const std::vector<int>& target_markers,
                                         const std::vector<int>& fixed_vertices, const CorrespondenceOptions& options) {
  const PolygonMesh s = source.triangulate(), t = target.triangulate();
  require_no_sliver(s, "source_faces");
  require_no_sliver(t, "target_faces");
  fit_ = triangle_correspondence(s, t, source_markers, target_markers, options);
  fitted_ = true;
  TransferPairing pairing;
  pairing.pairs = std::move(fit_.pairs);
  fit_.pairs.clear();
  pairing.fixed_vertices = fixed_vertices;
  for (std::size_t i = 0; i < source_markers.size(); ++i)
    pairing.reference.insert(pairing.reference.end(), {source_markers[i], target_markers[i]});
  build(s, t, pairing);
}

void DeformationTransfer::build(const PolygonMesh& source, const PolygonMesh& target, const TransferPairing& pairing) {
  require_no_sliver(source, "source_faces");
  require_no_sliver(target, "target_faces");
  source_ = source.points();
  target_ = target.points();
  source_triangles_ = source.corners();
  target_triangles_ = target.corners();
  pairs_ = pairing.pairs;
  const std::size_t ns = vertex_count(), nt = target_vertex_count(), ts = triangle_count(), tt = target_triangle_count();
  for (std::size_t p = 0; p < pairs_.size() / 2; ++p)
    if (pairs_[2 * p] < 0 || std::size_t(pairs_[2 * p]) >= ts || pairs_[2 * p + 1] < 0 || std::size_t(pairs_[2 * p + 1]) >= tt)
      throw std::invalid_argument("correspondence: pair " + std::to_string(p) + " is (" + std::to_string(pairs_[2 * p]) + ", " +
                                  std::to_string(pairs_[2 * p + 1]) + "); expected a source triangle in 0.." +
                                  std::to_string(ts - 1) + " and a target triangle in 0.." + std::to_string(tt - 1));
  frame_.resize(ts);
  frame_inverse_.resize(ts);
  for (std::size_t j = 0; j < ts; ++j) {
    const int* v = source_triangles_.data() + 3 * j;
    frame_[j] = frame(point(source_, v[0]), point(source_, v[1]), point(source_, v[2]));
    frame_inverse_[j] = frame_[j].inverse();
  }
  partners_by_target(pairs_, tt, partner_offset_, partner_);
  const SparseMatrix m = weighted_gradient_operator(target_, target_triangles_, partner_offset_, tangent_);

  // Gradients fix a shape up to a translation per connected part: fixed vertices where the part
  // has some, else its first vertex held and the part moved by its reference translation.
  std::vector<char> fixed(nt, 0);
  fixed_vertices_ = pairing.fixed_vertices;
  for (std::size_t f = 0; f < fixed_vertices_.size(); ++f) {
    const int v = fixed_vertices_[f];
    if (v < 0 || std::size_t(v) >= nt)
      throw std::invalid_argument("fixed_vertices: entry " + std::to_string(f) + " is " + std::to_string(v) +
                                  ", outside the target's vertices 0.." + std::to_string(nt - 1));
    if (fixed[std::size_t(v)])
      throw std::invalid_argument("fixed_vertices: vertex " + std::to_string(v) + " is given twice");
    fixed[std::size_t(v)] = 1;
  }
  int parts = 0;
  part_ = connected_components(target, &parts);
  part_fixed_.assign(std::size_t(parts), 0);
  for (int v : fixed_vertices_) part_fixed_[std::size_t(part_[std::size_t(v)])] = 1;
  std::vector<std::vector<int>> by_part(part_fixed_.size());
  const std::vector<int>& reference = pairing.reference;
  for (std::size_t r = 0; r < reference.size() / 2; ++r) {
    const int s = reference[2 * r], g = reference[2 * r + 1];
    if (s < 0 || std::size_t(s) >= ns || g < 0 || std::size_t(g) >= nt)
      throw std::invalid_argument("markers: pair " + std::to_string(r) + " is (" + std::to_string(s) + ", " + std::to_string(g) +
                                  "), outside the source's or the target's vertices");
    by_part[std::size_t(part_[std::size_t(g)])].insert(by_part[std::size_t(part_[std::size_t(g)])].end(), {s, g});
  }
  // A part without reference vertices: the corners of its paired triangles (their centroids).
  std::vector<std::vector<int>> by_pairs(part_fixed_.size());
  for (std::size_t p = 0; p < pairs_.size() / 2; ++p) {
    const int* s = source_triangles_.data() + 3 * pairs_[2 * p];
    const int* g = target_triangles_.data() + 3 * pairs_[2 * p + 1];
    std::vector<int>& list = by_pairs[std::size_t(part_[std::size_t(g[0])])];
    for (int c = 0; c < 3; ++c) list.insert(list.end(), {s[c], g[c]});
  }
  for (std::size_t p = 0; p < by_part.size(); ++p)
    if (by_part[p].empty()) by_part[p] = std::move(by_pairs[p]);
  part_reference_offset_.assign(std::size_t(parts) + 1, 0);
  reference_.clear();
  std::vector<char> seen(std::size_t(parts), 0);
  anchors_.clear();
  for (std::size_t i = 0; i < nt; ++i) {
    const std::size_t p = std::size_t(part_[i]);
    if (seen[p] || part_fixed_[p]) continue;
    seen[p] = 1;
    if (by_part[p].empty()) {
      if (std::find(target_triangles_.begin(), target_triangles_.end(), int(i)) == target_triangles_.end())
        throw std::invalid_argument("markers: target vertex " + std::to_string(i) + " is in no face and has no marker or "
                                    "fixed vertex, so nothing places it: give it a marker or a fixed position, or remove it");
      throw std::invalid_argument("markers: the target's connected part of vertex " + std::to_string(i) +
                                  " has no marker (or triangle pair) and no fixed vertex, so nothing fixes its "
                                  "translation: give a marker or a fixed vertex in it");
    }
    fixed[i] = 1;
    anchors_.push_back(int(i));
  }
  for (std::size_t p = 0; p < std::size_t(parts); ++p) {
    if (!part_fixed_[p]) reference_.insert(reference_.end(), by_part[p].begin(), by_part[p].end());
    part_reference_offset_[p + 1] = int(reference_.size());
  }
  system_ = ConstrainedQuadratic::least_squares(m, UnknownSplit(fixed), SoftConstraints{});
  if (!system_.factorised())
    throw std::invalid_argument("target_points: the target's gradient system could not be factorised (degenerate geometry)");
}

std::vector<int> DeformationTransfer::unmatched_target_triangles() const {
  std::vector<int> out;
  for (std::size_t j = 0; j + 1 < partner_offset_.size(); ++j)
    if (partner_offset_[j + 1] == partner_offset_[j]) out.push_back(int(j));
  return out;
}

// Per pose: the source's gradients S_j = V'_j V_j^-1, the target's wanted gradients of each
// coordinate P_t mean(S_j)^T e_c over its partners (the tangential part: Botsch et al. 2006,
// eq. 6), one least-squares solve.
void DeformationTransfer::transfer(const double* poses, std::size_t k, double* out, const double* fixed_positions) const {
  const std::size_t ns = vertex_count(), nt = target_vertex_count(), nf = fixed_vertices_.size();
  for (std::size_t i = 0; i < 3 * ns * k; ++i)
    if (!std::isfinite(poses[i]))
      throw std::invalid_argument("source_pose: pose " + std::to_string(i / (3 * ns)) + ", row " +
                                  std::to_string((i % (3 * ns)) / 3) + " is not finite");
  if (fixed_positions)
    for (std::size_t i = 0; i < 3 * nf * k; ++i)
      if (!std::isfinite(fixed_positions[i]))
        throw std::invalid_argument("fixed_positions: pose " + std::to_string(i / (3 * nf)) + ", row " +
                                    std::to_string((i % (3 * nf)) / 3) + " is not finite");
  // Four poses (12 columns, the solver's widest block) at a time bound the right-hand side's size.
  for (std::size_t first = 0; first < k; first += 4)
    transfer_block(poses + 3 * ns * first, std::min<std::size_t>(4, k - first), out + 3 * nt * first,
                   fixed_positions ? fixed_positions + 3 * nf * first : nullptr);
}

void DeformationTransfer::transfer_block(const double* poses, std::size_t k, double* out, const double* fixed_positions) const {
  const std::size_t ns = vertex_count(), nt = target_vertex_count(), ts = triangle_count(), tt = target_triangle_count();
  const std::size_t nf = fixed_vertices_.size();
  // (S - I)^T = ((V' - V) V^-1)^T per source triangle and pose: the fit is solved for the target's
  // displacement from its rest, whose gradients are S - I, so that the rest pose (V' = V to the
  // bit) gives zero and lands on the target rest exactly (docs/math/transfer.md, "Target fit"). A
  // triangle the pose collapses has no frame (its fourth vertex is n / sqrt(0)).
  std::vector<Eigen::Matrix3d> change(ts * k);
  parallel_blocks(ts, [&](std::size_t begin, std::size_t end) {
    for (std::size_t j = begin; j < end; ++j) {
      const int* v = source_triangles_.data() + 3 * j;
      for (std::size_t q = 0; q < k; ++q) {
        const double* pose = poses + 3 * ns * q;
        const Eigen::Matrix3d moved = frame(point(pose, v[0]), point(pose, v[1]), point(pose, v[2]));
        change[j * k + q] = ((moved - frame_[j]) * frame_inverse_[j]).transpose();
      }
    }
  });
  for (std::size_t p = 0; p < partner_.size(); ++p)
    for (std::size_t q = 0; q < k; ++q)
      if (!change[std::size_t(partner_[p]) * k + q].allFinite())
        throw std::invalid_argument("source_pose: pose " + std::to_string(q) + " collapses triangle " +
                                    std::to_string(partner_[p]) + " to zero area: it has no deformation gradient");
  // A target triangle without partners keeps its rest shape: no change.
  Eigen::MatrixXd r(Eigen::Index(3 * tt), Eigen::Index(3 * k));
  parallel_blocks(tt, [&](std::size_t begin, std::size_t end) {
    for (std::size_t j = begin; j < end; ++j)
      for (std::size_t q = 0; q < k; ++q) {
        Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
        for (int p = partner_offset_[j]; p < partner_offset_[j + 1]; ++p) sum += change[std::size_t(partner_[std::size_t(p)]) * k + q];
        r.block<3, 3>(Eigen::Index(3 * j), Eigen::Index(3 * q)) = tangent_[j] * sum;
      }
  });
  // The held displacements, in the split's (index) order: fixed vertices to where they are given,
  // anchors none.
  const std::vector<int>& held = system_.split().fixed();
  std::vector<int> slot(nt, -1);
  for (std::size_t f = 0; f < nf; ++f) slot[std::size_t(fixed_vertices_[f])] = int(f);
  auto given = [&](std::size_t q, std::size_t i, std::size_t c) {
    const int f = slot[i];
    return f >= 0 && fixed_positions ? fixed_positions[3 * nf * q + 3 * std::size_t(f) + c] : target_[3 * i + c];
  };
  Eigen::MatrixXd values(Eigen::Index(held.size()), Eigen::Index(3 * k));
  for (std::size_t a = 0; a < held.size(); ++a)
    for (std::size_t q = 0; q < k; ++q)
      for (std::size_t c = 0; c < 3; ++c)
        values(Eigen::Index(a), Eigen::Index(3 * q + c)) = given(q, std::size_t(held[a]), c) - target_[3 * std::size_t(held[a]) + c];
  const Eigen::MatrixXd moved = system_.assemble(system_.solve_free(r, values, Eigen::MatrixXd()), values);
  // Each part without fixed vertices: its reference targets' mean moves as their sources' does.
  const std::size_t parts = part_fixed_.size();
  Eigen::MatrixXd shift = Eigen::MatrixXd::Zero(Eigen::Index(parts), Eigen::Index(3 * k));
  for (std::size_t p = 0; p < parts; ++p) {
    const int begin = part_reference_offset_[p], end = part_reference_offset_[p + 1];
    if (begin == end) continue;
    for (int e = begin; e < end; e += 2) {
      const std::size_t s = std::size_t(reference_[std::size_t(e)]), g = std::size_t(reference_[std::size_t(e) + 1]);
      for (std::size_t q = 0; q < k; ++q)
        for (std::size_t c = 0; c < 3; ++c)
          shift(Eigen::Index(p), Eigen::Index(3 * q + c)) +=
              (poses[3 * ns * q + 3 * s + c] - source_[3 * s + c]) - moved(Eigen::Index(g), Eigen::Index(3 * q + c));
    }
    shift.row(Eigen::Index(p)) /= double(end - begin) / 2.0;
  }
  for (std::size_t q = 0; q < k; ++q)
    for (std::size_t i = 0; i < nt; ++i)
      for (std::size_t c = 0; c < 3; ++c)
        out[3 * nt * q + 3 * i + c] = slot[i] >= 0 ? given(q, i, c)
                                                   : target_[3 * i + c] + (moved(Eigen::Index(i), Eigen::Index(3 * q + c)) +
                                                                           shift(part_[i], Eigen::Index(3 * q + c)));
}

}  // namespace deformkit
