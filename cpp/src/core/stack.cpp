#include "deformkit/core/stack.hpp"

#include "core/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace deformkit {

namespace {

// A member's error, with the member named: "deformers[2]: ..." ("deformers[2].deformers[0]: ..."
// through a weighted stack inside), so that an overflow is never blamed on the caller's points.
std::invalid_argument member_error(std::size_t index, const std::invalid_argument& e) {
  const std::string msg = e.what(), name = "deformers[" + std::to_string(index) + "]";
  if (const auto* overflow = dynamic_cast<const NonFiniteResult*>(&e)) {
    // Kept as an overflow report (its row), so that an in-place caller can still blame its point.
    const std::string renamed = msg.rfind("deformer: ", 0) == 0 ? name + ": " + msg.substr(10) : name + "." + msg;
    throw NonFiniteResult(renamed, overflow->row, overflow->quantity);
  }
  if (msg.rfind("deformer: ", 0) == 0) return std::invalid_argument(name + ": " + msg.substr(10));
  if (msg.rfind("deformers[", 0) == 0) return std::invalid_argument(name + "." + msg);
  if (msg.rfind("points: ", 0) == 0) return std::invalid_argument(name + ": the points it receives: " + msg.substr(8));
  return std::invalid_argument(name + ": " + msg);
}

}  // namespace

Stack::Stack(std::vector<DeformerPtr> deformers) {
  for (std::size_t i = 0; i < deformers.size(); ++i) {
    if (!deformers[i]) throw std::invalid_argument("deformers: entry " + std::to_string(i) + " is None, not a deformer");
    // A stack without weights is its members in order: spliced, so nesting never deepens the
    // recursion of deform, jacobian or destruction.
    const auto* inner = dynamic_cast<const Stack*>(deformers[i].get());
    if (inner && inner->weights().empty()) {
      deformers_.insert(deformers_.end(), inner->deformers_.begin(), inner->deformers_.end());
      depth_ = std::max(depth_, inner->depth_);
      continue;
    }
    deformers_.push_back(deformers[i]);
    if (inner) depth_ = std::max(depth_, inner->depth_ + 1);
  }
  if (depth_ > kMaxStackDepth)
    throw std::invalid_argument("deformers: weighted stacks nest " + std::to_string(depth_) + " deep, more than " +
                                std::to_string(kMaxStackDepth) + " (flatten them, or combine their weights)");
}

double Stack::point_magnitude(double limit) const {
  double range = Deformer::point_magnitude(limit);
  for (const auto& d : deformers_) range = std::min(range, d->point_magnitude(limit));
  return range;
}

bool Stack::is_identity() const {
  for (const auto& d : deformers_)
    if (!d->is_identity()) return false;
  return true;
}

template <class T>
bool Stack::deform_any(const T* in, T* out, std::size_t n) const {
  if (deformers_.empty()) {
    if (in != out) std::copy(in, in + 3 * n, out);
    require_finite_rows(in, n, "points");
    return true;
  }
  try {
    deformers_.front()->deform(in, out, n);
  } catch (const NonFiniteResult& e) {
    if (in != out) blame_points_beyond_range(e.row, e.quantity, in + 3 * e.row, point_magnitude(double(std::numeric_limits<T>::max())));
    throw member_error(0, e);
  } catch (const std::invalid_argument& e) {
    // Bad points are the caller's; anything else (an in-place call has checked its input before
    // writing) is the member's.
    if (!all_finite(in, n, 3) || std::string(e.what()).rfind("points: ", 0) == 0) throw;
    throw member_error(0, e);
  }
  for (std::size_t i = 1; i < deformers_.size(); ++i) {
    try {
      deformers_[i]->deform_verified(out, out, n);
    } catch (const NonFiniteResult& e) {
      // The caller's point, when it is out of range, is to blame whatever earlier members made of it.
      if (in != out) blame_points_beyond_range(e.row, e.quantity, in + 3 * e.row, point_magnitude(double(std::numeric_limits<T>::max())));
      throw member_error(i, e);
    } catch (const std::invalid_argument& e) {
      throw member_error(i, e);
    }
  }
  return true;
}

bool Stack::deform_impl(const float* in, float* out, std::size_t n) const { return deform_any(in, out, n); }
bool Stack::deform_impl(const double* in, double* out, std::size_t n) const { return deform_any(in, out, n); }

bool Stack::jacobian_impl(const double* in, double* jac, std::size_t n) const {
  identity_jacobians(jac, n);
  std::vector<double> points(in, in + 3 * n), stage(9 * n);
  for (std::size_t s = 0; s < deformers_.size(); ++s) {
    try {
      // Chain rule: J <- J_s(F_s-1(...(x))) * J.
      deformers_[s]->jacobian(points.data(), stage.data(), n);
      parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) {
          const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> js(&stage[9 * i]);
          Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> total(&jac[9 * i]);
          total = (js * total).eval();
        }
      });
      if (s + 1 < deformers_.size()) deformers_[s]->deform_verified(points.data(), points.data(), n);
    } catch (const std::invalid_argument& e) {
      if (s == 0 && (!all_finite(in, n, 3) || std::string(e.what()).rfind("points: ", 0) == 0)) throw;
      throw member_error(s, e);
    }
  }
  return false;
}

}  // namespace deformkit
