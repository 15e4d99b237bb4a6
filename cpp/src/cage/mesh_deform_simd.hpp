#pragma once
// The static Mesh Deform frame's hot loop with the widest SIMD target of this CPU (Highway's
// run-time dispatch). Each row's sum depends only on the row and the target, never on which
// thread or block computes it, nor on the width of the column indices.
#include <cstddef>
#include <cstdint>

namespace deformkit::harmonic {

// For rows r in [begin, end): acc[4 (r - begin) + c] = sum over e in [start[r], start[r + 1]) of
// weight[e] * rows4[4 column[e] + c], c in 0..3 (rows4: per cage vertex (d_x, d_y, d_z, 1)), in
// double, or in float as Blender sums them (float32 bindings). The columns 1, 2 or 4 bytes each
// (MeshDeformBinding's WeightColumns).
void weighted_rows(const std::uint32_t* start, const std::uint8_t* column, const double* weight, std::size_t begin,
                   std::size_t end, const double* rows4, double* acc);
void weighted_rows(const std::uint32_t* start, const std::uint16_t* column, const double* weight, std::size_t begin,
                   std::size_t end, const double* rows4, double* acc);
void weighted_rows(const std::uint32_t* start, const std::uint32_t* column, const double* weight, std::size_t begin,
                   std::size_t end, const double* rows4, double* acc);
void weighted_rows(const std::uint32_t* start, const std::uint8_t* column, const float* weight, std::size_t begin,
                   std::size_t end, const float* rows4, float* acc);
void weighted_rows(const std::uint32_t* start, const std::uint16_t* column, const float* weight, std::size_t begin,
                   std::size_t end, const float* rows4, float* acc);
void weighted_rows(const std::uint32_t* start, const std::uint32_t* column, const float* weight, std::size_t begin,
                   std::size_t end, const float* rows4, float* acc);


// Points [8 first, min(8 last, n)) of a dense float binding (MeshDeformBinding::dense_weight,
// `columns` cage vertices): out = (points ? points : 0) + scale * sum_a w_a rows4[4 a .. 4 a + 2],
// scale per point (null: 1), 3 floats per point. False if a result is not finite.
bool dense_blocks(const float* weight, std::size_t columns, const float* rows4, const double* scale,
                  const float* points, std::size_t first, std::size_t last, std::size_t n, float* out);

}  // namespace deformkit::harmonic
