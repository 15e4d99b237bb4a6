#include "deformkit/lattice/extended_ffd.hpp"

#include <algorithm>
#include <cstring>
#include <cmath>
#include <stdexcept>
#include <string>

namespace deformkit {

namespace {

LatticeAxes bezier_axes(std::array<int, 3> counts) {
  for (int c : counts)
    if (c < 4 || (c - 1) % 3 != 0)
      throw std::invalid_argument("rest_control_points: an extended FFD grid needs 3k+1 >= 4 points per axis, got " +
                                  std::to_string(counts[0]) + " x " + std::to_string(counts[1]) + " x " +
                                  std::to_string(counts[2]));
  if (double(counts[0]) * counts[1] * counts[2] > double(kMaxControlPoints))
    throw std::invalid_argument("rest_control_points: more control points than the limit of " +
                                std::to_string(kMaxControlPoints));
  return {AxisBasis::make(BasisKind::BezierBlocks, counts[0], "rest_control_points"),
          AxisBasis::make(BasisKind::BezierBlocks, counts[1], "rest_control_points"),
          AxisBasis::make(BasisKind::BezierBlocks, counts[2], "rest_control_points")};
}

const std::vector<double>& finite_grid(const std::vector<double>& rest) {
  for (double v : rest)
    if (!std::isfinite(v)) throw std::invalid_argument("rest_control_points: contains a non-finite value");
  return rest;
}

}  // namespace

ExtendedFFD::ExtendedFFD(std::array<int, 3> counts, std::vector<double> rest, double strength,
                         NewtonSettings newton)
    : ControlLattice(bezier_axes(counts), finite_grid(rest), Outside::Unchanged, strength), newton_(newton) {
  if (!(newton.tolerance > 0.0) || !std::isfinite(newton.tolerance))
    throw std::invalid_argument("tolerance: must be a positive number");
  if (newton.max_iterations < 1 || newton.max_iterations > 1000)
    throw std::invalid_argument("max_iterations: must be 1..1000");
  Eigen::AlignedBox3d all;
  for (std::size_t i = 0; i < control_count(); ++i) all.extend(Vec3(rest[3 * i], rest[3 * i + 1], rest[3 * i + 2]));
  size_ = all.diagonal().norm();
  if (!(size_ > 0.0)) throw std::invalid_argument("rest_control_points: all control points coincide");
  merge_coincident_control_points(1e-9 * size_);
  for (int a = 0; a < 3; ++a) blocks_[a] = (counts[a] - 1) / 3;
  for (int bi = 0; bi < blocks_[0]; ++bi)
    for (int bj = 0; bj < blocks_[1]; ++bj)
      for (int bk = 0; bk < blocks_[2]; ++bk) {
        Eigen::AlignedBox3d box;
        for (int i = 0; i < 4; ++i)
          for (int j = 0; j < 4; ++j)
            for (int k = 0; k < 4; ++k) {
              const std::size_t f = (std::size_t(3 * bi + i) * counts[1] + 3 * bj + j) * counts[2] + 3 * bk + k;
              box.extend(Vec3(rest[3 * f], rest[3 * f + 1], rest[3 * f + 2]));
            }
        const double pad = 1e-9 * size_;
        box.min().array() -= pad;
        box.max().array() += pad;
        bounds_.push_back(box);
      }
  require_one_to_one();
  const double salt[2] = {newton.tolerance, double(newton.max_iterations)};
  std::memcpy(&layout_salt_, &salt[0], sizeof layout_salt_);
  layout_salt_ ^= static_cast<std::uint64_t>(newton.max_iterations) * 0x9E3779B97F4A7C15ull;
}

// Newton can only place points where each block maps one to one: det(dX/ds) must keep one sign
// and not vanish inside every block (on a face it may: a cylinder's axis, a prism's apex edge).
void ExtendedFFD::require_one_to_one() const {
  constexpr double kSamples[3] = {0.15, 0.5, 0.85};
  int sign = 0;
  for (int b = 0; b < int(bounds_.size()); ++b) {
    for (double s : kSamples)
      for (double t : kSamples)
        for (double u : kSamples) {
          Mat3 d;
          block_point(b, Vec3(s, t, u), &d);
          // det of the unit columns, |det| / (|d_s| |d_t| |d_u|) (Hadamard's bound is 1): how far the
          // three directions are from a plane, whatever the block's size or aspect ratio.
          double det = 0.0;
          const Vec3 n0 = d.col(0).stableNormalized(), n1 = d.col(1).stableNormalized(), n2 = d.col(2).stableNormalized();
          if (n0.allFinite() && n1.allFinite() && n2.allFinite() && n0.squaredNorm() > 0.5 && n1.squaredNorm() > 0.5 &&
              n2.squaredNorm() > 0.5)
            det = n0.dot(n1.cross(n2));
          const int here = det > 1e-9 ? 1 : det < -1e-9 ? -1 : 0;
          if (here == 0 || (sign != 0 && here != sign)) {
            const int bk = b % blocks_[2], bj = (b / blocks_[2]) % blocks_[1], bi = b / (blocks_[1] * blocks_[2]);
            throw std::invalid_argument("rest_control_points: block (" + std::to_string(bi) + ", " + std::to_string(bj) +
                                        ", " + std::to_string(bk) + ") is " + (here == 0 ? "flat" : "folded") +
                                        " (det dX/ds " + (here == 0 ? "vanishes" : "changes sign") +
                                        " inside it); an extended FFD needs blocks that map one to one");
          }
          sign = here;
        }
  }
}

Vec3 ExtendedFFD::block_point(int block, const Vec3& local, Mat3* derivative) const {
  const int bk = block % blocks_[2], bj = (block / blocks_[2]) % blocks_[1], bi = block / (blocks_[1] * blocks_[2]);
  double w[3][4], dw[3][4];
  for (int a = 0; a < 3; ++a) bernstein_basis(3, local[a], w[a], dw[a]);
  const auto res = resolution();
  const auto& rest = rest_control_points();
  Vec3 x = Vec3::Zero();
  Mat3 d = Mat3::Zero();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) {
        const std::size_t f = (std::size_t(3 * bi + i) * res[1] + 3 * bj + j) * res[2] + 3 * bk + k;
        const Vec3 p(rest[3 * f], rest[3 * f + 1], rest[3 * f + 2]);
        x += w[0][i] * w[1][j] * w[2][k] * p;
        d.col(0) += dw[0][i] * w[1][j] * w[2][k] * p;
        d.col(1) += w[0][i] * dw[1][j] * w[2][k] * p;
        d.col(2) += w[0][i] * w[1][j] * dw[2][k] * p;
      }
  if (derivative) *derivative = d;
  return x;
}

// Solve J step = f; near-singular J (a wedge block on a cylinder's axis) takes the minimum-norm step.
static Vec3 newton_step(const Mat3& j, const Vec3& f) {
  const double scale = j.cwiseAbs().maxCoeff();
  if (std::abs(j.determinant()) > 1e-12 * scale * scale * scale) return j.partialPivLu().solve(f);
  return j.completeOrthogonalDecomposition().solve(f);
}

ExtendedFFD::Placement ExtendedFFD::invert_block(int block, const Vec3& x, Vec3& local) const {
  constexpr double kAccept = 1e-7;  // a point on a shared face may land a rounding error outside
  const double goal = newton_.tolerance * size_;
  bool ended_inside = false;
  for (int start = 0; start < 9; ++start) {
    Vec3 s = start == 0 ? Vec3(0.5, 0.5, 0.5)
                        : Vec3(start & 1 ? 0.75 : 0.25, start & 2 ? 0.75 : 0.25, start & 4 ? 0.75 : 0.25);
    Mat3 j;
    Vec3 f = block_point(block, s, &j) - x;
    double err = f.norm();
    for (int it = 0; it < newton_.max_iterations && err > goal; ++it) {
      const Vec3 step = newton_step(j, f);
      // Damped: halve the step until the residual decreases (docs/math/lattice.md, "Extended FFD").
      double lambda = 1.0;
      bool improved = false;
      for (int h = 0; h < 30 && !improved; ++h, lambda *= 0.5) {
        const Vec3 trial = (s - lambda * step).cwiseMax(-0.5).cwiseMin(1.5);
        Mat3 jt;
        const Vec3 ft = block_point(block, trial, &jt) - x;
        if (ft.norm() < err) {
          s = trial, f = ft, j = jt, err = ft.norm();
          improved = true;
        }
      }
      if (!improved) break;
    }
    if (err <= goal) {
      if ((s.array() >= -kAccept).all() && (s.array() <= 1.0 + kAccept).all()) {
        local = s.cwiseMax(0.0).cwiseMin(1.0);
        return Placement::Inside;
      }
      return Placement::Outside;
    }
    if ((s.array() >= -0.05).all() && (s.array() <= 1.05).all()) ended_inside = true;
  }
  // Stuck well outside the block: the point is outside it; stuck inside: Newton failed.
  return ended_inside ? Placement::Failed : Placement::Outside;
}

PointStatus ExtendedFFD::locate(const Vec3& x, Vec3& parameters) const {
  parameters = Vec3::Constant(-1.0);
  bool failed = false;
  for (int b = 0; b < int(bounds_.size()); ++b) {
    if (!bounds_[b].contains(x)) continue;  // outside the control points' hull box: outside the block
    Vec3 local;
    const Placement p = invert_block(b, x, local);
    if (p == Placement::Inside) {
      const int bk = b % blocks_[2], bj = (b / blocks_[2]) % blocks_[1], bi = b / (blocks_[1] * blocks_[2]);
      parameters = Vec3((bi + local[0]) / blocks_[0], (bj + local[1]) / blocks_[1], (bk + local[2]) / blocks_[2]);
      return PointStatus::Inside;
    }
    failed = failed || p == Placement::Failed;
  }
  return failed ? PointStatus::NotPlaced : PointStatus::Outside;
}

Mat3 ExtendedFFD::parameter_jacobian(const Vec3& parameters) const {
  Mat3 d;
  rest_map(parameters, &d);
  // On a degenerate wedge (the cylinder's axis) d is singular; the pseudo-inverse stays finite.
  return d.completeOrthogonalDecomposition().pseudoInverse();
}

// Generated lattices stay where their determinants (products of three lengths) are representable.
constexpr double kMaxLatticeExtent = 1e100, kMinLatticeExtent = 1e-100;

std::vector<double> ExtendedFFD::prism_grid(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& height,
                                            std::array<int, 3> blocks) {
  if (!a.allFinite() || !b.allFinite() || !c.allFinite()) throw std::invalid_argument("triangle: corners must be finite");
  if (!height.allFinite()) throw std::invalid_argument("height: must be finite");
  // Beyond this scale the rest lattice's determinants (cubes of lengths) overflow or underflow.
  const double extent = std::max({a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff(), c.cwiseAbs().maxCoeff()});
  if (extent > kMaxLatticeExtent) throw std::invalid_argument("triangle: corners must lie within 1e100 of the origin");
  if (height.cwiseAbs().maxCoeff() > kMaxLatticeExtent) throw std::invalid_argument("height: must be at most 1e100 long");
  // Unit directions (stableNormalized: no squares that underflow at 1e-100 or overflow at 1e100).
  const Vec3 ab = (b - a).stableNormalized(), ac = (c - a).stableNormalized();
  const Vec3 normal = ab.cross(ac);
  if ((b - a).cwiseAbs().maxCoeff() < kMinLatticeExtent || (c - a).cwiseAbs().maxCoeff() < kMinLatticeExtent ||
      !(normal.stableNorm() > 1e-12))
    throw std::invalid_argument("triangle: corners are collinear or coincide; a prism needs a triangle with area");
  if (height.cwiseAbs().maxCoeff() < kMinLatticeExtent ||
      !(std::abs(normal.stableNormalized().dot(height.stableNormalized())) > 1e-12))
    throw std::invalid_argument("height: must be a vector out of the triangle's plane (got one in it, or zero)");
  for (int n : blocks)
    if (n < 1 || n > 256) throw std::invalid_argument("blocks: a prism needs 1..256 blocks per axis");
  const int ns = 3 * blocks[0] + 1, nt = 3 * blocks[1] + 1, nu = 3 * blocks[2] + 1;
  if (double(ns) * nt * nu > double(kMaxControlPoints))
    throw std::invalid_argument("blocks: more control points than the limit of " + std::to_string(kMaxControlPoints));
  // X = A + (1 - t) s (B - A) + t (C - A) + u H: bilinear in (s, t), so its Bezier control points
  // are its values at i/3 steps; at t = 1 every s lands on the edge through C (merged points).
  std::vector<double> grid;
  grid.reserve(3 * std::size_t(ns) * nt * nu);
  for (int i = 0; i < ns; ++i)
    for (int j = 0; j < nt; ++j)
      for (int k = 0; k < nu; ++k) {
        const double s = double(i) / (ns - 1), t = double(j) / (nt - 1), u = double(k) / (nu - 1);
        const Vec3 p = a + (1.0 - t) * s * (b - a) + t * (c - a) + u * height;
        grid.insert(grid.end(), {p[0], p[1], p[2]});
      }
  return grid;
}

std::vector<double> ExtendedFFD::cylinder_grid(double radius, double height, std::array<int, 3> blocks,
                                               const Vec3& center, int axis) {
  if (!(radius >= kMinLatticeExtent && radius <= kMaxLatticeExtent))
    throw std::invalid_argument("radius: must be in 1e-100..1e100, got " + std::to_string(radius));
  if (!(height >= kMinLatticeExtent && height <= kMaxLatticeExtent))
    throw std::invalid_argument("height: must be in 1e-100..1e100, got " + std::to_string(height));
  if (!center.allFinite()) throw std::invalid_argument("center: is not finite");
  if (blocks[0] < 1 || blocks[2] < 1 || blocks[1] < 3 || blocks[0] > 64 || blocks[1] > 256 || blocks[2] > 256)
    throw std::invalid_argument("blocks: a cylinder needs 1..64 radial, 3..256 angular and 1..256 axial blocks");
  const int nr = 3 * blocks[0] + 1, na = 3 * blocks[1] + 1, nh = 3 * blocks[2] + 1;
  if (double(nr) * na * nh > double(kMaxControlPoints))
    throw std::invalid_argument("blocks: more control points than the limit of " + std::to_string(kMaxControlPoints));
  const double step = 2.0 * M_PI / blocks[1];
  const double kappa = 4.0 / 3.0 * std::tan(step / 4.0);  // cubic Bezier arc handle length
  std::vector<double> grid;
  grid.reserve(3 * std::size_t(nr) * na * nh);
  for (int i = 0; i < nr; ++i)
    for (int j = 0; j < na; ++j)
      for (int k = 0; k < nh; ++k) {
        const double r = radius * i / (nr - 1);
        const int b = j / 3, q = j % 3;
        const double a0 = step * b, a1 = step * (b + 1);
        double x, y;
        if (q == 0) x = std::cos(a0), y = std::sin(a0);
        else if (q == 1) x = std::cos(a0) - kappa * std::sin(a0), y = std::sin(a0) + kappa * std::cos(a0);
        else x = std::cos(a1) + kappa * std::sin(a1), y = std::sin(a1) - kappa * std::cos(a1);
        const Vec3 local(r * x, r * y, height * (double(k) / (nh - 1) - 0.5));
        // Cyclic so that the cylinder's axis lands on `axis` with a right-handed frame.
        const Vec3 p = center + Vec3(local[(2 - axis) % 3], local[(3 - axis) % 3], local[(4 - axis) % 3]);
        grid.insert(grid.end(), {p[0], p[1], p[2]});
      }
  return grid;
}

}  // namespace deformkit
