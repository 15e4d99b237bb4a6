#include "deformkit/barr/barr_deformer.hpp"

#include "barr/barr_kernels.hpp"
#include "core/parallel.hpp"
#include "core/scale_free.hpp"

#include <algorithm>
#include <atomic>
#include <limits>
#include <cmath>
#include <stdexcept>
#include <string>

namespace deformkit {

// The displacement g(c) - c rather than g(c): it is exactly zero at rest (angle, curvature or
// factor 0, radius 1), so that x + B (g(c) - c) gives back x to the last bit in any frame.
void barr_offset_with_jacobian(const BarrOp& op, const Vec3& c, Vec3& offset, Mat3& jac) {
  jac.setIdentity();
  if (op.kind == BarrKind::Bend) {
    // Barr's bend in the stable half-angle form: S/k = 2 sin(t/2) cos(t/2) / k and
    // (1 - C)/k = 2 sin^2(t/2) / k never cancel, so k -> 0 tends to the identity.
    if (op.is_identity_bend()) {
      offset.setZero();
      return;
    }
    const double y_hat = std::clamp(c.y(), op.lo, op.hi);
    const bool inside = c.y() >= op.lo && c.y() <= op.hi;
    const double theta = op.k * (y_hat - op.center);
    const double h = std::sin(0.5 * theta), c2 = std::cos(0.5 * theta);
    const double s = 2.0 * h * c2, cs_minus_1 = -2.0 * h * h, cs = 1.0 + cs_minus_1, q = h / op.k;
    const double d = c.y() - y_hat;  // tangent continuation beyond the region
    // y' = y0 + S/k - S z + C d and z' = C z + (1 - C)/k + S d, minus (y, z) = (y_hat + d, z).
    offset = Vec3(0.0, (2.0 * q * c2 - (y_hat - op.center)) - s * c.z() + cs_minus_1 * d,
                  cs_minus_1 * c.z() + 2.0 * q * h + s * d);
    const double a = inside ? 1.0 - op.k * c.z() : 1.0;  // lecture: J = [1 0 0; 0 C(1-k^z) -S; 0 S(1-k^z) C]
    jac(1, 1) = cs * a;
    jac(1, 2) = -s;
    jac(2, 1) = s * a;
    jac(2, 2) = cs;
    return;
  }
  const double ux = op.locked[0] ? 0.0 : 1.0, uy = op.locked[1] ? 0.0 : 1.0;
  const double qx = ux * c.x(), qy = uy * c.y();
  switch (op.kind) {
    case BarrKind::Twist: {  // x' = x cos(t) - y sin(t), y' = x sin(t) + y cos(t), t = f(z)
      double theta, dtheta;
      op.profile.evaluate(c.z(), theta, dtheta);
      // cos(t) - 1 = -2 sin^2(t/2): exactly 0 at t = 0, where cos(t) - 1 may round to -2^-53.
      const double h = std::sin(0.5 * theta), c2 = std::cos(0.5 * theta);
      const double s = 2.0 * h * c2, cs_minus_1 = -2.0 * h * h, cs = 1.0 + cs_minus_1;
      offset = Vec3(qx * cs_minus_1 - qy * s, qx * s + qy * cs_minus_1, 0.0);
      jac(0, 0) = ux * cs + (1.0 - ux);
      jac(0, 1) = -uy * s;
      jac(0, 2) = (-qx * s - qy * cs) * dtheta;
      jac(1, 0) = ux * s;
      jac(1, 1) = uy * cs + (1.0 - uy);
      jac(1, 2) = (qx * cs - qy * s) * dtheta;
      return;
    }
    case BarrKind::Taper: {  // x' = r x, y' = r y, r = f(z)
      double r, dr;
      op.profile.evaluate(c.z(), r, dr);
      offset = Vec3(qx * (r - 1.0), qy * (r - 1.0), 0.0);
      jac(0, 0) = ux * r + (1.0 - ux);
      jac(0, 2) = qx * dr;
      jac(1, 1) = uy * r + (1.0 - uy);
      jac(1, 2) = qy * dr;
      return;
    }
    case BarrKind::Stretch: {  // Blender: s = 1 + k (z^2 - 1), x' = s x, y' = s y, z' = (1 + k) z
      const double z_hat = std::clamp(c.z(), op.lo, op.hi);
      const bool inside = c.z() >= op.lo && c.z() <= op.hi;
      const double s_minus_1 = op.k * (z_hat * z_hat - 1.0), ds = inside ? 2.0 * op.k * z_hat : 0.0;
      offset = Vec3(qx * s_minus_1, qy * s_minus_1, op.k * z_hat);
      jac(0, 0) = ux * (1.0 + s_minus_1) + (1.0 - ux);
      jac(0, 2) = qx * ds;
      jac(1, 1) = uy * (1.0 + s_minus_1) + (1.0 - uy);
      jac(1, 2) = qy * ds;
      jac(2, 2) = inside ? 1.0 + op.k : 1.0;
      return;
    }
    case BarrKind::Bend: break;
  }
}

void barr_apply_with_jacobian(const BarrOp& op, const Vec3& c, Vec3& out, Mat3& jac) {
  Vec3 offset;
  barr_offset_with_jacobian(op, c, offset, jac);
  out = c + offset;
}

Vec3 barr_apply(const BarrOp& op, const Vec3& c) {
  Vec3 out;
  Mat3 jac;
  barr_apply_with_jacobian(op, c, out, jac);
  return out;
}

BarrDeformer::BarrDeformer(BarrOp op, Placement placement) : op_(std::move(op)), placement_(placement) {
  if (!std::isfinite(op_.k) || !std::isfinite(op_.center))
    throw std::invalid_argument("deformer: curvature, factor and center must be finite");
  const double inf = std::numeric_limits<double>::infinity();
  if (std::isnan(op_.lo) || std::isnan(op_.hi) || op_.lo > op_.hi || op_.lo == inf || op_.hi == -inf)
    throw std::invalid_argument("limits: expected lo <= hi with lo < +inf and hi > -inf");
}

bool BarrDeformer::is_identity() const {
  switch (op_.kind) {
    case BarrKind::Twist: return op_.profile.is_constant(0.0);
    case BarrKind::Taper: return op_.profile.is_constant(1.0);
    case BarrKind::Stretch: return op_.k == 0.0;
    case BarrKind::Bend: return op_.is_identity_bend();
  }
  return false;
}

static BarrKernelParams kernel_params(const BarrOp& op, const Placement& pl) {
  BarrKernelParams p{};
  p.kind = static_cast<int>(op.kind);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      p.M[3 * r + c] = pl.to_canonical(r, c);
      p.B[3 * r + c] = pl.to_object(r, c);
    }
    p.m[r] = pl.canonical_offset[r];
    p.unlocked[r] = op.locked[r] ? 0.0 : 1.0;
  }
  p.identity_placement = pl.identity;
  p.offset = op.profile.offset();
  p.slope = op.profile.slope();
  const bool uses_profile = op.kind == BarrKind::Twist || op.kind == BarrKind::Taper;
  p.lo = uses_profile ? op.profile.lo() : op.lo;
  p.hi = uses_profile ? op.profile.hi() : op.hi;
  p.k = op.k;
  p.center = op.center;
  return p;
}

// The float32 kernels compute in float: every coefficient must be representable there.
static bool fits_float(const BarrKernelParams& p) {
  const double values[] = {p.M[0], p.M[1], p.M[2], p.M[3], p.M[4], p.M[5], p.M[6], p.M[7], p.M[8],
                           p.B[0], p.B[1], p.B[2], p.B[3], p.B[4], p.B[5], p.B[6], p.B[7], p.B[8],
                           p.m[0], p.m[1], p.m[2], p.offset, p.slope, p.k, p.center};
  for (double v : values)
    if (!(std::abs(v) <= 1e37)) return false;
  return true;
}

// Linear laws only (a spline profile has no SIMD form), and for float32 coefficients that fit.
bool BarrDeformer::simd_eligible(bool single) const {
  return op_.profile.is_linear() && !op_.is_identity_bend() && (!single || fits_float(kernel_params(op_, placement_)));
}

template <class T>
bool BarrDeformer::deform_any(const T* in, T* out, std::size_t n) const {
  std::atomic<bool> finite{true};
  const BarrKernelParams params = kernel_params(op_, placement_);
  const bool simd = simd_eligible(sizeof(T) == sizeof(float));
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    bool ok = true;
    if (simd) {
      ok = barr_kernel(params, in + 3 * begin, out + 3 * begin, end - begin);
    } else {
      for (std::size_t i = begin; i < end; ++i) {
        const Vec3 p(in[3 * i], in[3 * i + 1], in[3 * i + 2]);
        ok = ok && p.allFinite();
        Vec3 offset;
        Mat3 unused;
        barr_offset_with_jacobian(op_, placement_.canonical(p), offset, unused);
        const Vec3 q = p + placement_.to_object * offset;
        for (int a = 0; a < 3; ++a) out[3 * i + a] = static_cast<T>(q[a]);
        ok = ok && std::isfinite(out[3 * i]) && std::isfinite(out[3 * i + 1]) && std::isfinite(out[3 * i + 2]);
      }
    }
    if (!ok) finite = false;
  });
  return finite;
}

// The lanes' offset B (g(c) - c) itself: one pass, no subtraction (Blender's offsets attribute).
// Weighted, each chunk is scaled while it is still in cache, as deform() blends: w (F(x) - x).
template <class T>
static bool displacement_lanes(const BarrKernelParams& base, const T* in, T* out, std::size_t n, const double* w) {
  constexpr std::size_t kChunk = 2048;
  BarrKernelParams params = base;
  params.displacement = true;
  std::atomic<bool> finite{true};
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t lo = begin; lo < end; lo += kChunk) {
      const std::size_t hi = std::min(end, lo + kChunk);
      if (!barr_kernel(params, in + 3 * lo, out + 3 * lo, hi - lo)) finite = false;
      if (w)
        for (std::size_t i = lo; i < hi; ++i)
          for (int a = 0; a < 3; ++a) out[3 * i + a] = static_cast<T>(w[i] * out[3 * i + a]);
    }
  });
  return finite;
}

bool BarrDeformer::lane_displacement(const float* in, float* out, std::size_t n, const double* w) const {
  return simd_eligible(true) && displacement_lanes(kernel_params(op_, placement_), in, out, n, w);
}
bool BarrDeformer::lane_displacement(const double* in, double* out, std::size_t n, const double* w) const {
  return simd_eligible(false) && displacement_lanes(kernel_params(op_, placement_), in, out, n, w);
}
bool BarrDeformer::displacement_impl(const float* in, float* out, std::size_t n, const double* w) const {
  return lane_displacement(in, out, n, w);
}
bool BarrDeformer::displacement_impl(const double* in, double* out, std::size_t n, const double* w) const {
  return lane_displacement(in, out, n, w);
}

bool BarrDeformer::deform_impl(const float* in, float* out, std::size_t n) const { return deform_any(in, out, n); }
bool BarrDeformer::deform_impl(const double* in, double* out, std::size_t n) const { return deform_any(in, out, n); }

// One point's Jacobian through the scalar formulas: I + B (J_canon - I) M, the identity itself at
// rest, where B M is only close to it.
static void scalar_jacobian(const BarrOp& op, const Placement& placement, const double* in, double* jac) {
  Vec3 offset;
  Mat3 jc;
  barr_offset_with_jacobian(op, placement.canonical(Vec3(in[0], in[1], in[2])), offset, jc);
  const Mat3 j = Mat3::Identity() + placement.to_object * (jc - Mat3::Identity()) * placement.to_canonical;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) jac[3 * r + c] = j(r, c);
}

bool BarrDeformer::jacobian_impl(const double* in, double* jac, std::size_t n) const {
  const BarrKernelParams params = kernel_params(op_, placement_);
  const bool simd = simd_eligible(false);
  std::atomic<bool> verified{simd};
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    // The lanes mark every non-finite input and entry; a block they cannot finish goes through the
    // scalar formulas, whose results the caller checks.
    if (simd && barr_jacobian_kernel(params, nullptr, in + 3 * begin, jac + 9 * begin, end - begin)) return;
    verified = false;
    for (std::size_t i = begin; i < end; ++i) scalar_jacobian(op_, placement_, in + 3 * i, jac + 9 * i);
  });
  return verified;
}

// A row the lanes left to the scalar path: J blended by its weight, as Deformer::jacobian does.
static Mat3 scalar_blended_jacobian(const BarrOp& op, const Placement& placement, const std::vector<double>& w,
                                    const Vec3& p, std::size_t i) {
  double j[9];
  scalar_jacobian(op, placement, p.data(), j);
  Mat3 m;
  for (int e = 0; e < 9; ++e) m(e / 3, e % 3) = j[e];
  return w.empty() ? m : Mat3((1.0 - w[i]) * Mat3::Identity() + w[i] * m);
}

// Rows [0, n) through the lanes, block by block on both cores: lanes(begin, end, flags) is the
// kernel, row(i) the scalar path for a row it flagged, false where the generic path must take
// over (an input not finite: it names the argument).
template <class Lanes, class Row>
static bool lanes_then_flagged_rows(std::size_t n, Lanes&& lanes, Row&& row) {
  std::atomic<bool> ok{true};
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    std::vector<unsigned char> flags(end - begin, 0);
    if (!ok || lanes(begin, end, flags.data())) return;
    for (std::size_t i = begin; i < end && ok; ++i)
      if (flags[i - begin] && !row(i)) ok = false;
  });
  return ok;
}

template <class T>
bool BarrDeformer::normals_any(const T* points, const T* normals, T* out, std::size_t n) const {
  if (!simd_eligible(sizeof(T) == sizeof(float))) return false;
  const BarrKernelParams params = kernel_params(op_, placement_);
  const std::vector<double>& w = weights();
  return lanes_then_flagged_rows(
      n,
      [&](std::size_t begin, std::size_t end, unsigned char* flags) {
        return barr_normals_kernel(params, w.empty() ? nullptr : w.data() + begin, points + 3 * begin,
                                   normals + 3 * begin, out + 3 * begin, flags, end - begin);
      },
      [&](std::size_t i) {
        const Vec3 p(points[3 * i], points[3 * i + 1], points[3 * i + 2]), q(normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]);
        if (!p.allFinite() || !q.allFinite()) return false;
        // A Jacobian that is not finite is jacobian()'s to refuse: normals follow its one rule.
        const Mat3 j = scalar_blended_jacobian(op_, placement_, w, p, i);
        if (!j.allFinite()) return false;
        const Vec3 m = normal_direction(j, q);
        for (int a = 0; a < 3; ++a) out[3 * i + a] = static_cast<T>(m[a]);
        return m.allFinite();
      });
}

bool BarrDeformer::normals_impl(const double* points, const double* normals, double* out, std::size_t n) const {
  return normals_any(points, normals, out, n);
}
bool BarrDeformer::normals_impl(const float* points, const float* normals, float* out, std::size_t n) const {
  return normals_any(points, normals, out, n);
}

bool BarrDeformer::volume_ratio_impl(const double* points, double* out, std::size_t n) const {
  // A twist turns x and y by t(z) and keeps z: det J = cos^2 t + sin^2 t = 1 exactly (Barr 1984),
  // whatever the profile or placement (det B det M = 1), unless an axis is locked or weights blend J.
  if (op_.kind == BarrKind::Twist && !op_.locked[0] && !op_.locked[1] && weights().empty()) {
    if (!all_finite(points, n, 3)) return false;  // the generic path names the row
    parallel_blocks(n, [&](std::size_t begin, std::size_t end) { std::fill(out + begin, out + end, 1.0); });
    return true;
  }
  if (!simd_eligible(false)) return false;
  const BarrKernelParams params = kernel_params(op_, placement_);
  const std::vector<double>& w = weights();
  return lanes_then_flagged_rows(
      n,
      [&](std::size_t begin, std::size_t end, unsigned char* flags) {
        return barr_determinant_kernel(params, w.empty() ? nullptr : w.data() + begin, points + 3 * begin, out + begin,
                                       flags, end - begin);
      },
      [&](std::size_t i) {
        const Vec3 p(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
        if (!p.allFinite()) return false;
        const Mat3 j = scalar_blended_jacobian(op_, placement_, w, p, i);
        if (!j.allFinite()) return false;  // jacobian()'s to refuse, as for normals
        out[i] = scaled_determinant(j);
        return true;
      });
}

static BarrOp twist_op(BarrKind kind, const Profile& profile) {
  BarrOp op;
  op.kind = kind;
  op.profile = profile;
  return op;
}

static BarrOp ranged_op(BarrKind kind, double k, double center, double lo, double hi) {
  BarrOp op;
  op.kind = kind;
  op.k = k;
  op.center = center;
  op.lo = lo;
  op.hi = hi;
  return op;
}

Twist::Twist(const Profile& theta, int axis, const Frame& frame)
    : BarrDeformer(twist_op(BarrKind::Twist, theta), Placement(frame, axis_to_z(axis))) {
  parameters_ = "rate, limits, profile, frame";
}

Taper::Taper(const Profile& radius, int axis, const Frame& frame)
    : BarrDeformer(twist_op(BarrKind::Taper, radius), Placement(frame, axis_to_z(axis))) {
  parameters_ = "rate, limits, profile, frame";
}

Stretch::Stretch(double factor, double lo, double hi, int axis, const Frame& frame)
    : BarrDeformer(ranged_op(BarrKind::Stretch, factor, 0.0, lo, hi), Placement(frame, axis_to_z(axis))) {
  parameters_ = "factor, limits, frame";
}

Bend::Bend(double curvature, double center, double lo, double hi, int axis, const Frame& frame)
    : BarrDeformer(ranged_op(BarrKind::Bend, curvature, center, lo, hi), Placement(frame, axis_to_x(axis))) {
  parameters_ = "curvature, center, region, frame";
}

}  // namespace deformkit
