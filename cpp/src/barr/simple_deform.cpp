#include "deformkit/barr/simple_deform.hpp"

#include "barr/extent_kernel.hpp"
#include "core/parallel.hpp"
#include "core/weight_blend.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>

namespace deformkit {

int simple_deform_limit_axis(const SimpleDeformSettings& s) {
  if (s.mode != SimpleDeformMode::Bend) return s.deform_axis;
  return s.deform_axis == 2 ? 0 : 2;  // bend: X/Y measure along Z, Z along X
}

SimpleDeform::SimpleDeform(SimpleDeformSettings settings) : settings_(std::move(settings)) {
  const auto& s = settings_;
  if (static_cast<int>(s.mode) < 0 || static_cast<int>(s.mode) > 3)
    throw std::invalid_argument("mode: expected TWIST, BEND, TAPER or STRETCH");
  if (!std::isfinite(s.factor)) throw std::invalid_argument("angle/factor: must be finite");
  if (s.deform_axis < 0 || s.deform_axis > 2)
    throw std::invalid_argument("deform_axis: expected X, Y or Z");
  if (!(s.limit_lo >= 0.0 && s.limit_lo <= 1.0 && s.limit_hi >= 0.0 && s.limit_hi <= 1.0))
    throw std::invalid_argument("limits: both must lie in [0, 1] (fractions of the bounding extent)");
  if (s.limit_lo > s.limit_hi) throw std::invalid_argument("limits: lower limit exceeds upper limit");
}

// Blender's canonical axes: the remap (x,y,z) -> (y,z,x) / (z,x,y) brings the deform axis to z;
// bend keeps its own table (docs/blender/simple_deform.md, "Axis tables"), improper for deform axis X.
static Mat3 blender_permutation(const SimpleDeformSettings& s) {
  if (s.mode != SimpleDeformMode::Bend) return axis_to_z(s.deform_axis);
  if (s.deform_axis != 0) return axis_to_x(s.deform_axis);
  Mat3 p = Mat3::Zero();
  p(0, 0) = p(1, 2) = p(2, 1) = 1.0;
  return p;
}

template <class T>
std::shared_ptr<BarrDeformer> SimpleDeform::resolve(const T* points, std::size_t n) const {
  const auto& s = settings_;
  const int axis = simple_deform_limit_axis(s);
  const double row[3] = {s.origin.inverse_linear(axis, 0), s.origin.inverse_linear(axis, 1),
                         s.origin.inverse_linear(axis, 2)};
  const double shift = s.origin.inverse_linear.row(axis).dot(s.origin.translation);
  double lower = std::numeric_limits<double>::infinity(), upper = -lower;
  bool finite = true;
  std::mutex merge;
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    const Extent e = coordinate_extent(row, shift, points + 3 * begin, end - begin);
    std::lock_guard<std::mutex> lock(merge);
    lower = std::min(lower, e.lo);
    upper = std::max(upper, e.hi);
    finite = finite && e.finite;
  });
  if (!finite) require_finite_rows(points, n, "points");
  if (!std::isfinite(upper - lower))
    throw std::invalid_argument("points: their extent along the limit axis overflows a double");
  // MOD_simpledeform: the amount is spread over the limited extent.
  const double l0 = lower + (upper - lower) * s.limit_lo, l1 = lower + (upper - lower) * s.limit_hi;
  const double k = s.factor / std::max<double>(FLT_EPSILON, l1 - l0);
  BarrOp op;
  switch (s.mode) {
    case SimpleDeformMode::Twist:
      op.kind = BarrKind::Twist;
      op.profile = Profile::linear(0.0, k, l0, l1);
      break;
    case SimpleDeformMode::Taper:
      op.kind = BarrKind::Taper;
      op.profile = Profile::linear(1.0, k, l0, l1);
      break;
    case SimpleDeformMode::Stretch:
      op.kind = BarrKind::Stretch;
      break;
    case SimpleDeformMode::Bend:
      if (std::abs(k) < 1e-6) return nullptr;  // Blender's BEND_EPS
      op.kind = BarrKind::Bend;
      break;
  }
  op.k = k;
  op.lo = l0;
  op.hi = l1;
  const Mat3 perm = blender_permutation(s);
  if (s.mode != SimpleDeformMode::Bend) {
    for (int c = 0; c < 3; ++c) {
      int object_axis = 0;
      perm.row(c).maxCoeff(&object_axis);
      op.locked[c] = s.lock[object_axis] && object_axis != s.deform_axis;
    }
  }
  return std::make_shared<BarrDeformer>(op, Placement(s.origin, perm));
}
template std::shared_ptr<BarrDeformer> SimpleDeform::resolve<float>(const float*, std::size_t) const;
template std::shared_ptr<BarrDeformer> SimpleDeform::resolve<double>(const double*, std::size_t) const;

template <class T>
std::shared_ptr<BarrDeformer> SimpleDeform::bind(const T* points, std::size_t n) const {
  require_weight_count(weights(), n, "points", "rows");  // as deform(points) would report
  std::shared_ptr<BarrDeformer> map = resolve(points, n);
  if (!map) {
    BarrOp unchanged;
    unchanged.kind = BarrKind::Bend;  // curvature 0: the identity
    map = std::make_shared<BarrDeformer>(unchanged, Placement(settings_.origin, blender_permutation(settings_)));
  }
  if (!weights().empty()) map->set_weights(weights());
  return map;
}
template std::shared_ptr<BarrDeformer> SimpleDeform::bind<float>(const float*, std::size_t) const;
template std::shared_ptr<BarrDeformer> SimpleDeform::bind<double>(const double*, std::size_t) const;

template <class T>
bool SimpleDeform::deform_any(const T* in, T* out, std::size_t n) const {
  const auto barr = resolve(in, n);
  if (!barr) {
    if (in != out) std::copy(in, in + 3 * n, out);
    return true;
  }
  barr->deform(in, out, n);
  return true;
}

bool SimpleDeform::deform_impl(const float* in, float* out, std::size_t n) const { return deform_any(in, out, n); }
bool SimpleDeform::deform_impl(const double* in, double* out, std::size_t n) const { return deform_any(in, out, n); }

// Through the resolved operator's lanes (resolve names a row that is not finite); a map the lanes
// cannot take, or a result that is not finite, goes to the generic path, which names the error.
bool SimpleDeform::displacement_impl(const float* in, float* out, std::size_t n, const double* w) const {
  const auto barr = resolve(in, n);
  return barr && barr->lane_displacement(in, out, n, w);
}
bool SimpleDeform::displacement_impl(const double* in, double* out, std::size_t n, const double* w) const {
  const auto barr = resolve(in, n);
  return barr && barr->lane_displacement(in, out, n, w);
}

bool SimpleDeform::jacobian_impl(const double* in, double* jac, std::size_t n) const {
  const auto barr = resolve(in, n);
  if (barr) {
    barr->jacobian(in, jac, n);  // checked there: it returns only with finite rows and entries
    return true;
  }
  identity_jacobians(jac, n);
  return false;
}

// Rows that are not finite are left to the generic path, which names the argument in its order.
template <class T>
bool SimpleDeform::normals_any(const T* points, const T* normals, T* out, std::size_t n) const {
  if (!all_finite(points, n, 3) || !all_finite(normals, n, 3)) return false;
  transform_normals(*bind(points, n), points, normals, out, n);
  return true;
}

bool SimpleDeform::normals_impl(const double* points, const double* normals, double* out, std::size_t n) const {
  return normals_any(points, normals, out, n);
}
bool SimpleDeform::normals_impl(const float* points, const float* normals, float* out, std::size_t n) const {
  return normals_any(points, normals, out, n);
}

bool SimpleDeform::volume_ratio_impl(const double* points, double* out, std::size_t n) const {
  if (!all_finite(points, n, 3)) return false;
  volume_ratio(*bind(points, n), points, out, n);
  return true;
}

}  // namespace deformkit
