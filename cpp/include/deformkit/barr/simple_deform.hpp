#pragma once
// Blender's Simple Deform modifier (MOD_simpledeform), reproduced: the amount is spread over
// the limited extent of the input measured in the origin frame, k = amount / (L1 - L0).
#include "deformkit/barr/barr_deformer.hpp"

namespace deformkit {

enum class SimpleDeformMode : int { Twist = 0, Bend = 1, Taper = 2, Stretch = 3 };

struct SimpleDeformSettings {
  SimpleDeformMode mode = SimpleDeformMode::Twist;
  double factor = 0.785398163397448;  // Blender's DNA default, 45 degrees
  int deform_axis = 0;                // X
  Frame origin;                       // origin frame in the object's local space
  double limit_lo = 0.0, limit_hi = 1.0;
  std::array<bool, 3> lock{false, false, false};
};

// Which object axis the limits and the bounding pass measure.
int simple_deform_limit_axis(const SimpleDeformSettings& s);

class SimpleDeform : public Deformer {
 public:
  explicit SimpleDeform(SimpleDeformSettings settings);
  const SimpleDeformSettings& settings() const { return settings_; }
  // Every mode with a zero angle or factor leaves points where they are (MOD_simpledeform).
  bool is_identity() const override { return settings_.factor == 0.0; }
  std::string overflow_parameters() const override { return "angle or factor, origin, limits"; }
  // The Barr operator Blender would apply to these points (bounds measured from them);
  // nullptr when Blender leaves them unchanged (bend with |k| < 1e-6).
  template <class T>
  std::shared_ptr<BarrDeformer> resolve(const T* points, std::size_t n) const;
  // The fixed spatial map that deform(points) applies: the Barr operator with the extent measured
  // on these points, carrying this deformer's weights (which must count them). Unlike deform(),
  // it measures nothing when called, so splitting points into chunks never changes a result
  // (docs/blender/simple_deform.md, "Binding the extent"); where Blender leaves the points
  // unchanged (bend with |k| < 1e-6) it is an identity bend. Throws std::invalid_argument naming
  // `points` (a row not finite, an extent that overflows) or `weights` (a count other than n).
  template <class T>
  std::shared_ptr<BarrDeformer> bind(const T* points, std::size_t n) const;

 protected:
  bool deform_impl(const float* in, float* out, std::size_t n) const override;
  bool deform_impl(const double* in, double* out, std::size_t n) const override;
  bool displacement_impl(const float* in, float* out, std::size_t n, const double* weights) const override;
  bool displacement_impl(const double* in, double* out, std::size_t n, const double* weights) const override;
  bool jacobian_impl(const double* in, double* jac, std::size_t n) const override;
  // Through the bound Barr operator's SIMD lanes (bind: the extent measured on these points).
  bool normals_impl(const double* points, const double* normals, double* out, std::size_t n) const override;
  bool normals_impl(const float* points, const float* normals, float* out, std::size_t n) const override;
  bool volume_ratio_impl(const double* points, double* out, std::size_t n) const override;

 private:
  template <class T> bool deform_any(const T* in, T* out, std::size_t n) const;
  template <class T> bool normals_any(const T* points, const T* normals, T* out, std::size_t n) const;
  SimpleDeformSettings settings_;
};

}  // namespace deformkit
