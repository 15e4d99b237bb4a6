#pragma once
// A Barr operator placed in object space by a frame and an axis permutation.
#include "deformkit/barr/barr.hpp"
#include "deformkit/core/deformer.hpp"
#include "deformkit/core/frame.hpp"

namespace deformkit {

class BarrDeformer : public Deformer {
 public:
  BarrDeformer(BarrOp op, Placement placement);
  const BarrOp& op() const { return op_; }
  const Placement& placement() const { return placement_; }
  bool is_identity() const override;
  std::string overflow_parameters() const override { return parameters_; }
  // w (F(x) - x) through the SIMD lanes in one pass (weights: null or one per row); false when the
  // lanes cannot take this map or some row was not finite (Deformer::displacement then decides).
  bool lane_displacement(const float* in, float* out, std::size_t n, const double* weights) const;
  bool lane_displacement(const double* in, double* out, std::size_t n, const double* weights) const;

 protected:
  const char* parameters_ = "angle or factor, origin";  // a SimpleDeform's map; each Barr deformer its own
  bool deform_impl(const float* in, float* out, std::size_t n) const override;
  bool deform_impl(const double* in, double* out, std::size_t n) const override;
  bool displacement_impl(const float* in, float* out, std::size_t n, const double* weights) const override;
  bool displacement_impl(const double* in, double* out, std::size_t n, const double* weights) const override;
  bool jacobian_impl(const double* in, double* jac, std::size_t n) const override;
  bool normals_impl(const double* points, const double* normals, double* out, std::size_t n) const override;
  bool normals_impl(const float* points, const float* normals, float* out, std::size_t n) const override;
  bool volume_ratio_impl(const double* points, double* out, std::size_t n) const override;

 private:
  template <class T> bool deform_any(const T* in, T* out, std::size_t n) const;
  template <class T> bool normals_any(const T* points, const T* normals, T* out, std::size_t n) const;
  bool simd_eligible(bool single) const;
  BarrOp op_;
  Placement placement_;
};

// Barr's deformers, any axis, any frame. `axis` is the deform axis for twist, taper and
// stretch (it becomes canonical z), and the kept axis for bend (canonical x); the other two
// axes follow cyclically, so the placement keeps handedness.
class Twist : public BarrDeformer {  // theta = f(z)
 public:
  Twist(const Profile& theta, int axis, const Frame& frame);
};
class Taper : public BarrDeformer {  // r = f(z)
 public:
  Taper(const Profile& radius, int axis, const Frame& frame);
};
class Stretch : public BarrDeformer {  // Blender: s = 1 + k (z^2 - 1)
 public:
  Stretch(double factor, double lo, double hi, int axis, const Frame& frame);
};
class Bend : public BarrDeformer {  // Barr: theta = k (y^ - y0) on [y_min, y_max]
 public:
  Bend(double curvature, double center, double lo, double hi, int axis, const Frame& frame);
};

}  // namespace deformkit
