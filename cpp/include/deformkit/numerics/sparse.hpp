#pragma once
// The sparse matrix type the numerics and the mesh operators share.
#include <Eigen/SparseCore>

namespace deformkit {

using SparseMatrix = Eigen::SparseMatrix<double>;

}  // namespace deformkit
