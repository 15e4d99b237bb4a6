#pragma once
// The library as a whole (every family): versions compiled in and the SIMD target chosen at run time.
#include <string>
#include <utility>
#include <vector>

namespace deformkit {
// Versions of the libraries compiled in, the SIMD target in use and the thread count.
std::vector<std::pair<std::string, std::string>> build_info();
}  // namespace deformkit
