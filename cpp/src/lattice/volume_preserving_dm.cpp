// Volume-preserving direct manipulation: the smallest control-point change that meets the handle
// constraints and keeps a closed mesh's volume (Hirota, Maheshwari and Lin 1999, "Fast
// volume-preserving free form deformation using multi-level optimization"), by SQP on the
// Lagrangian (docs/math/lattice.md, "Volume-preserving direct manipulation").
#include "deformkit/core/polygon_mesh.hpp"
#include "deformkit/core/validation.hpp"
#include "deformkit/lattice/direct_manipulation.hpp"
#include "lattice/handle_solve.hpp"
#include "lattice/mesh_volume_constraint.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace deformkit {

namespace {

std::string edge_name(std::uint64_t e) {
  return "(" + std::to_string(e >> 32) + ", " + std::to_string(e & 0xffffffffu) + ")";
}

// Neumaier's compensated sum: the 1e-12 stopping rule needs the volume to a few ulps of its terms.
struct CompensatedSum {
  double sum = 0.0, carry = 0.0;
  void add(double x) {
    const double t = sum + x;
    carry += std::abs(sum) >= std::abs(x) ? (sum - t) + x : (x - t) + sum;
    sum = t;
  }
  double value() const { return sum + carry; }
};

}  // namespace

void require_closed_oriented(const PolygonMesh& mesh) {
  std::vector<std::uint64_t> directed;
  directed.reserve(mesh.corner_count());
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const int* c = mesh.face(f);
    const int k = mesh.face_size(f);
    for (int i = 0; i < k; ++i)
      directed.push_back(std::uint64_t(std::uint32_t(c[i])) << 32 | std::uint32_t(c[(i + 1) % k]));
  }
  std::sort(directed.begin(), directed.end());
  const std::string prefix = "preserve_volume: mesh_faces: ";
  for (std::size_t i = 0; i < directed.size(); ++i) {
    const std::uint64_t e = directed[i], reverse = (e << 32) | (e >> 32);
    if (i + 1 < directed.size() && directed[i + 1] == e)
      throw std::invalid_argument(prefix + "edge " + edge_name(e) + " is used twice in the same direction: the "
                                  "faces are not consistently oriented or the mesh is not manifold; expected a "
                                  "closed mesh whose every edge is shared by two faces in opposite directions");
    if (!std::binary_search(directed.begin(), directed.end(), reverse))
      throw std::invalid_argument(prefix + "edge " + edge_name(e) + " has no face running it the other way: the "
                                  "mesh is not closed (or not consistently oriented); expected a closed mesh whose "
                                  "every edge is shared by two faces in opposite directions");
  }
}

LatticeMeshVolume::LatticeMeshVolume(const ControlLattice& lattice, const PolygonMesh& mesh)
    : handles_(lattice.handle_count()) {
  const std::size_t n = mesh.vertex_count();
  LatticeBinding binding;
  try {
    binding = lattice.bind(mesh.points().data(), n);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("preserve_volume: mesh_" + std::string(e.what()));
  }
  const WeightTable w = lattice.weights_matrix(binding);
  const auto& control = lattice.control_points();
  const auto& rest = lattice.rest_control_points();
  indptr_.assign(w.indptr.begin(), w.indptr.end());
  handle_.resize(w.indices.size());
  weight_.resize(w.values.size());
  y0_.resize(Eigen::Index(n), 3);
  for (std::size_t v = 0; v < n; ++v) {
    Vec3 y(mesh.points()[3 * v], mesh.points()[3 * v + 1], mesh.points()[3 * v + 2]);
    for (std::int64_t e = w.indptr[v]; e < w.indptr[v + 1]; ++e) {
      const std::size_t g = std::size_t(w.indices[e]);
      handle_[e] = lattice.handle_of()[g];
      weight_[e] = lattice.strength() * w.values[e];
      for (int a = 0; a < 3; ++a) y[a] += weight_[e] * (control[3 * g + a] - rest[3 * g + a]);
    }
    if (!y.allFinite())
      throw std::invalid_argument("preserve_volume: mesh_points: the lattice's current control points move point " +
                                  std::to_string(v) + " beyond the double range");
    y0_.row(Eigen::Index(v)) = y.transpose();
  }
  // The volume of a closed mesh does not depend on the origin: measuring from the centroid keeps
  // the determinants, and their rounding, at the mesh's own size.
  if (n > 0) y0_.rowwise() -= y0_.colwise().mean();
  const PolygonMesh fan = mesh.triangulate();
  triangles_.resize(fan.face_count());
  for (std::size_t t = 0; t < triangles_.size(); ++t)
    triangles_[t] = {fan.face(t)[0], fan.face(t)[1], fan.face(t)[2]};
  for (const auto& t : triangles_)
    unsigned_sum_ += std::abs(y0_.row(t[0]).dot(y0_.row(t[1]).cross(y0_.row(t[2])))) / 6.0;
}

LatticeMeshVolume::Rows LatticeMeshVolume::carried(const Rows& offset, const Eigen::MatrixXd& dp) const {
  Rows y = offset;
  for (Eigen::Index v = 0; v < y.rows(); ++v)
    for (std::int64_t e = indptr_[v]; e < indptr_[v + 1]; ++e) y.row(v) += weight_[e] * dp.row(handle_[e]);
  return y;
}

Eigen::MatrixXd LatticeMeshVolume::pulled_back(const Rows& per_vertex) const {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(handles_, 3);
  for (Eigen::Index v = 0; v < per_vertex.rows(); ++v)
    for (std::int64_t e = indptr_[v]; e < indptr_[v + 1]; ++e) out.row(handle_[e]) += weight_[e] * per_vertex.row(v);
  return out;
}

double LatticeMeshVolume::value(const Eigen::MatrixXd& dp, Eigen::MatrixXd* gradient) const {
  const Rows y = carried(y0_, dp);
  // V = 1/6 sum a . (b x c); dV/da = (b x c) / 6, cyclically
  // (docs/math/lattice.md, "Volume-preserving direct manipulation").
  CompensatedSum volume;
  Rows dy;
  if (gradient) dy = Rows::Zero(y.rows(), 3);
  for (const auto& t : triangles_) {
    const Vec3 a = y.row(t[0]), b = y.row(t[1]), c = y.row(t[2]);
    const Vec3 bc = b.cross(c);
    volume.add(a.dot(bc) / 6.0);
    if (!gradient) continue;
    dy.row(t[0]) += bc / 6.0;
    dy.row(t[1]) += c.cross(a) / 6.0;
    dy.row(t[2]) += a.cross(b) / 6.0;
  }
  if (gradient) *gradient = pulled_back(dy);  // dV/dP_h = sum_v strength w_vh dV/dy_v
  return volume.value();
}

Eigen::MatrixXd LatticeMeshVolume::hessian_times(const Eigen::MatrixXd& dp, const Eigen::MatrixXd& d) const {
  const Rows y = carried(y0_, dp), dy = carried(Rows::Zero(y0_.rows(), 3), d);
  // d(b x c) = db x c + b x dc, cyclically: the gradient's derivative along d.
  Rows out = Rows::Zero(y.rows(), 3);
  for (const auto& t : triangles_) {
    const Vec3 a = y.row(t[0]), b = y.row(t[1]), c = y.row(t[2]);
    const Vec3 da = dy.row(t[0]), db = dy.row(t[1]), dc = dy.row(t[2]);
    out.row(t[0]) += (db.cross(c) + b.cross(dc)) / 6.0;
    out.row(t[1]) += (dc.cross(a) + c.cross(da)) / 6.0;
    out.row(t[2]) += (da.cross(b) + a.cross(db)) / 6.0;
  }
  return pulled_back(out);
}

namespace {

// Conjugate gradients on M v = v + mu Pi H Pi v over the handles' null space (H: the volume's
// Hessian at x): false when M shows a direction of non-positive curvature or does not converge.
bool solve_newton_matrix(const LatticeMeshVolume& volume, const HandleSolve& solve, const Eigen::MatrixXd& x,
                         double mu, const Eigen::MatrixXd& rhs, Eigen::MatrixXd& v) {
  v = Eigen::MatrixXd::Zero(rhs.rows(), 3);
  Eigen::MatrixXd r = rhs, p = rhs;
  double rr = r.squaredNorm();
  const double stop = 1e-20 * rr;
  const int limit = std::min<int>(100, int(3 * rhs.rows()));
  for (int k = 0; k < limit && rr > stop; ++k) {
    const Eigen::MatrixXd mp = p + mu * solve.free_part(volume.hessian_times(x, p));
    const double curvature = p.cwiseProduct(mp).sum();
    if (!(curvature > 1e-12 * p.squaredNorm())) return false;
    const double step = rr / curvature;
    v += step * p;
    r -= step * mp;
    const double next = r.squaredNorm();
    p = r + (next / rr) * p;
    rr = next;
  }
  return rr <= stop;
}

struct LagrangeStep {
  Eigen::MatrixXd step;  // in the handles' null space
  double multiplier = 0.0;
};

// Newton on the Lagrangian's stationarity u + mu Pi G = 0 and g = 0, with M = I + mu_k Pi H Pi the
// Lagrangian's Hessian: step = -M^-1 u - mu M^-1 Pi G, mu chosen so that G . step = -g. Where M is
// not positive definite (or mu_k = 0) the objective's Hessian I stands in for it: the SQP step.
LagrangeStep lagrange_step(const LatticeMeshVolume& volume, const HandleSolve& solve, const Eigen::MatrixXd& x,
                           const Eigen::MatrixXd& u, const Eigen::MatrixXd& free_gradient, double g, double mu_k) {
  Eigen::MatrixXd m_u = u, m_g = free_gradient;
  if (mu_k != 0.0 && !(solve_newton_matrix(volume, solve, x, mu_k, u, m_u) &&
                       solve_newton_matrix(volume, solve, x, mu_k, free_gradient, m_g))) {
    m_u = u;
    m_g = free_gradient;
  }
  LagrangeStep s;
  s.multiplier = (g - free_gradient.cwiseProduct(m_u).sum()) / free_gradient.cwiseProduct(m_g).sum();
  s.step = -s.multiplier * m_g - m_u;
  return s;
}

}  // namespace

DirectManipulationResult direct_manipulation(const ControlLattice& lattice, const double* points,
                                             const double* targets, std::size_t m,
                                             const PolygonMesh& preserve_volume) {
  require_distinct_corners(preserve_volume);
  require_closed_oriented(preserve_volume);
  const HandleSolve solve = solve_handles(lattice, points, targets, m);
  const LatticeMeshVolume volume(lattice, preserve_volume);
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(lattice.handle_count(), 3);
  const double target = volume.value(zero);
  if (!std::isfinite(target) || !std::isfinite(volume.unsigned_sum()))
    throw std::invalid_argument("preserve_volume: mesh_points: the mesh's volume under the current control points "
                                "overflows a double");
  if (!(std::abs(target) > 1e-8 * volume.unsigned_sum())) {
    std::ostringstream msg;
    msg << "preserve_volume: the mesh encloses no volume (" << target << " under the current control points, "
        << "against " << volume.unsigned_sum() << " for its faces' unsigned volumes); expected a closed mesh of "
        << "non-zero volume";
    throw std::invalid_argument(msg.str());
  }
  const double tolerance = 1e-12 * std::abs(target);
  double scale = 0.0;  // the lattice's size: the floor of the stationarity test
  for (double c : lattice.control_points()) scale = std::max(scale, std::abs(c));

  // Newton / SQP on the Lagrangian over x = x_ls + u, u in the handles' null space
  // (docs/math/lattice.md, "Volume-preserving direct manipulation").
  Eigen::MatrixXd x = solve.dp, u = Eigen::MatrixXd::Zero(x.rows(), 3), gradient;
  double rho = 0.0, multiplier = 0.0, v = volume.value(x, &gradient);
  constexpr int kMaxIterations = 100;
  int iterations = 0;
  for (;; ++iterations) {
    const double r = v - target;
    const Eigen::MatrixXd free_gradient = solve.free_part(gradient);
    const double free2 = free_gradient.squaredNorm(), g2 = gradient.squaredNorm();
    if (!(free2 > 1e-18 * g2)) {
      if (std::abs(r) <= tolerance) break;  // nothing the handles leave free changes the volume, nor need it
      std::ostringstream msg;
      msg << "preserve_volume: no volume-preserving change exists near: the handle constraints pin every control "
             "point that could change the mesh's volume (its gradient lies in their span), and the volume would "
             "be " << v << " instead of " << target << "; free some control points (fewer points) or drop "
             "preserve_volume";
      throw std::invalid_argument(msg.str());
    }
    const LagrangeStep newton = lagrange_step(volume, solve, x, u, free_gradient, r, multiplier);
    const Eigen::MatrixXd& step = newton.step;
    const double mu = newton.multiplier;
    const double step_norm = step.norm();
    if (std::abs(r) <= tolerance && step_norm <= 1e-9 * x.norm() + 1e-14 * scale) break;
    if (iterations == kMaxIterations) {
      if (std::abs(r) <= tolerance) break;  // the volume holds; the change is minimal to the last step
      std::ostringstream msg;
      msg << "preserve_volume: no volume-preserving change found near the handle solve after " << kMaxIterations
          << " iterations (relative volume error " << std::abs(r) / std::abs(target)
          << "); the targets may demand too large a change for the volume to be kept";
      throw std::invalid_argument(msg.str());
    }
    // Backtracking on the l1 merit 1/2 |u|^2 + rho |V - V0|, whose slope along step is
    // -step.M step + mu r - rho |r| < 0 once rho >= |mu|; rounding of the terms is allowed for.
    rho = std::max(rho, 1.5 * std::abs(mu));
    const double merit = 0.5 * u.squaredNorm() + rho * std::abs(r);
    const double slope = u.cwiseProduct(step).sum() - rho * std::abs(r);
    double alpha = 1.0, v_trial = 0.0;
    Eigen::MatrixXd trial;
    for (;;) {
      trial = u + alpha * step;
      v_trial = volume.value(x + alpha * step);
      const double noise = 8 * std::numeric_limits<double>::epsilon() *
                           (0.5 * u.squaredNorm() + 0.5 * trial.squaredNorm() + rho * volume.unsigned_sum());
      if (std::isfinite(v_trial) &&
          0.5 * trial.squaredNorm() + rho * std::abs(v_trial - target) <= merit + 1e-4 * alpha * slope + noise)
        break;
      alpha *= 0.5;
      if (alpha < 1e-12)
        throw std::invalid_argument("preserve_volume: no volume-preserving change found near the handle solve (the "
                                    "line search stalled); the targets may demand too large a change for the volume "
                                    "to be kept");
    }
    x += alpha * step;
    u = trial;
    multiplier = mu;
    v = volume.value(x, &gradient);
  }
  DirectManipulationResult result = handle_result(lattice, solve, x);
  result.preserves_volume = true;
  result.volume = v;
  result.volume_target = target;
  result.volume_residual = std::abs(v - target) / std::abs(target);
  result.iterations = iterations;
  return result;
}

}  // namespace deformkit
