#pragma once
// Blender's vertex-group policy, once for deform() and the bound path: the weight count, and the
// per-point blend x' = x + w (F(x) - x) toward the original positions.
#include "deformkit/core/deformer.hpp"

#include "core/parallel.hpp"

#include <cstddef>
#include <vector>

namespace deformkit {

// Throws std::invalid_argument "weights: has N entries but <holder> has M <unit>" when weights are
// set and do not count the n points (holder, unit: "points", "rows" or "the binding", "points").
void require_weight_count(const std::vector<double>& w, std::size_t n, const char* holder, const char* unit);

// out[i] = blend_toward(original[i], out[i], w[i]) for each of the n points.
template <class T>
void blend_toward_originals(const std::vector<double>& w, const T* original, T* out, std::size_t n) {
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      for (int a = 0; a < 3; ++a) out[3 * i + a] = static_cast<T>(blend_toward(original[3 * i + a], out[3 * i + a], w[i]));
  });
}

}  // namespace deformkit
