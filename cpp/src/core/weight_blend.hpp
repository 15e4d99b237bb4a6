#pragma once
// Blender's vertex-group policy, once for deform() and the bound path: the weight count, and the
// per-point blend x' = x + w (F(x) - x) toward the original positions.
#include "deformkit/core/deformer.hpp"
#include "deformkit/core/point_binding.hpp"

#include "core/parallel.hpp"

#include <cstddef>
#include <vector>

namespace deformkit {

// Throws std::invalid_argument "weights: has N entries but <holder> has M <unit>" when weights are
// set and do not count the n points (holder, unit: "points", "rows" or "the binding", "points").
void require_weight_count(const std::vector<double>& w, std::size_t n, const char* holder, const char* unit);

// out[p] = blend_toward(x_p, out[p], w[p]) for each of the n points p, the originals x read where
// they are stored (each point is written once, so the blocks may run in parallel).
template <class T>
void blend_toward_stored(const std::vector<double>& w, const StoredPoints<T>& x, T* out, std::size_t n) {
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const std::size_t p = x.order ? x.order[i] : i;
      for (int a = 0; a < 3; ++a)
        out[3 * p + a] = static_cast<T>(blend_toward(x.coord[a][i * x.stride], out[3 * p + a], w[p]));
    }
  });
}

// The same for originals in an (n, 3) array in point order (deform()'s input).
template <class T>
void blend_toward_originals(const std::vector<double>& w, const T* original, T* out, std::size_t n) {
  blend_toward_stored(w, StoredPoints<T>{{original, original + 1, original + 2}, 3, nullptr}, out, n);
}

// out[p] = x_p exactly, for the identity.
template <class T>
void copy_stored(const StoredPoints<T>& x, T* out, std::size_t n) {
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const std::size_t p = x.order ? x.order[i] : i;
      for (int a = 0; a < 3; ++a) out[3 * p + a] = x.coord[a][i * x.stride];
    }
  });
}

}  // namespace deformkit
