#pragma once
// The cage deformers' sparse inner product: CSR rows of kept weights times the control values.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace deformkit {

// The control values (columns x 3) as rows of four doubles (x, y, z, 0) on 32-byte boundaries:
// one load, never split across cache lines, per kept weight whatever its column. Not copyable
// (rows() points into the storage), movable.
class PaddedControlRows {
 public:
  PaddedControlRows(const double* control, std::size_t columns);
  PaddedControlRows(const PaddedControlRows&) = delete;
  PaddedControlRows& operator=(const PaddedControlRows&) = delete;
  PaddedControlRows(PaddedControlRows&&) = default;
  PaddedControlRows& operator=(PaddedControlRows&&) = default;
  const double* rows() const { return rows_; }

 private:
  std::vector<double> storage_;
  double* rows_ = nullptr;
};

// out[3 r + a] = sum_k values[k] c4[4 indices[k] + a] over k in [indptr[r], indptr[r + 1]), for
// each of `rows` rows (indptr holds rows + 1 offsets, absolute into indices and values), accumulated
// in double (float32 values widened), with the widest SIMD target of this CPU (Highway's run-time
// dispatch). c4 is PaddedControlRows::rows() and the indices are valid columns of it. The
// summation order depends only on the row and the target, so one row gives the same bits whichever
// call computes it.
void sparse_rows_product(const std::int64_t* indptr, const std::int32_t* indices, const double* values,
                         std::size_t rows, const double* c4, double* out);
void sparse_rows_product(const std::int64_t* indptr, const std::int32_t* indices, const float* values,
                         std::size_t rows, const double* c4, double* out);

}  // namespace deformkit
