#pragma once
// Composition F = F_n o ... o F_1, with the chain rule J = J_n(F_n-1(...)) ... J_1(x).
#include "deformkit/core/deformer.hpp"

namespace deformkit {

// Members that are stacks without weights are spliced in (a Stack of Stacks is one Stack);
// weighted stacks keep their own members, nested at most kMaxStackDepth deep.
constexpr int kMaxStackDepth = 64;

class Stack : public Deformer {
 public:
  explicit Stack(std::vector<DeformerPtr> deformers);
  const std::vector<DeformerPtr>& deformers() const { return deformers_; }
  // Weighted stacks nested inside this one (0 when no member is a stack).
  int depth() const { return depth_; }
  bool is_identity() const override;
  double point_magnitude(double limit) const override;  // the least of its members'

 protected:
  bool deform_impl(const float* in, float* out, std::size_t n) const override;
  bool deform_impl(const double* in, double* out, std::size_t n) const override;
  bool jacobian_impl(const double* in, double* jac, std::size_t n) const override;

 private:
  template <class T> bool deform_any(const T* in, T* out, std::size_t n) const;
  std::vector<DeformerPtr> deformers_;
  int depth_ = 0;
};

}  // namespace deformkit
