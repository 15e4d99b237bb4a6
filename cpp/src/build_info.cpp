#include "deformkit/build_info.hpp"

#include "barr/barr_kernels.hpp"

#include <Eigen/Core>
#include <omp.h>
#include <opensubdiv/version.h>

namespace deformkit {

std::vector<std::pair<std::string, std::string>> build_info() {
  return {
      {"eigen", std::to_string(EIGEN_WORLD_VERSION) + "." + std::to_string(EIGEN_MAJOR_VERSION) + "." +
                    std::to_string(EIGEN_MINOR_VERSION)},
      {"opensubdiv", std::to_string(OPENSUBDIV_VERSION_MAJOR) + "." + std::to_string(OPENSUBDIV_VERSION_MINOR) + "." +
                         std::to_string(OPENSUBDIV_VERSION_PATCH)},
      {"simd_target", simd_target()},
      {"threads", std::to_string(omp_get_max_threads())},
  };
}

}  // namespace deformkit
