#pragma once
// What the lattice tests share: a skewed box and control points moved at random.
#include "test_util.hpp"

#include <random>

namespace deformkit::test {

inline LatticeBox skewed_box() {
  Mat3 e;
  e << 1.2, 0.1, 0.0,  //
      0.2, 0.9, 0.3,   //
      -0.1, 0.0, 1.1;
  return LatticeBox::from_edges(Vec3(-0.3, 0.2, 0.1), e);
}

inline void perturb(ControlLattice& lat, unsigned seed, double amount) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, amount);
  auto grid = lat.control_points();
  for (auto& v : grid) v += n(rng);
  lat.set_control_points(grid);
}

}  // namespace deformkit::test
