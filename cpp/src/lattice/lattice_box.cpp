#include "deformkit/lattice/lattice_box.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace deformkit {

LatticeBox LatticeBox::from_edges(const Vec3& origin, const Mat3& edges, const char* argument) {
  const std::string name(argument);
  if (!origin.allFinite()) throw std::invalid_argument("origin: is not finite");
  if (!edges.allFinite()) throw std::invalid_argument(name + ": is not finite");
  const Vec3 s = edges.col(0), t = edges.col(1), u = edges.col(2);
  const double volume = s.dot(t.cross(u));
  // Scale-free: the volume against the product of edge lengths is the sine-like flatness.
  const double lengths = s.norm() * t.norm() * u.norm();
  if (!std::isfinite(lengths) || !std::isfinite(volume))
    throw std::invalid_argument(name + ": the lattice box is too large (its volume overflows)");
  if (!(lengths > 0.0) || std::abs(volume) <= 1e-12 * lengths)
    throw std::invalid_argument(name + ": the lattice box has zero volume (an edge is zero or the edges are "
                                       "coplanar)");
  LatticeBox box;
  box.origin = origin;
  box.edges = edges;
  const Vec3 tu = t.cross(u), su = s.cross(u), st = s.cross(t);
  box.to_box.row(0) = (tu / tu.dot(s)).transpose();
  box.to_box.row(1) = (su / su.dot(t)).transpose();
  box.to_box.row(2) = (st / st.dot(u)).transpose();
  return box;
}

LatticeBox LatticeBox::from_matrix(const Mat4& m, const char* argument) {
  const std::string name(argument);
  if (!m.allFinite()) throw std::invalid_argument(name + ": is not finite");
  if (m(3, 0) != 0.0 || m(3, 1) != 0.0 || m(3, 2) != 0.0 || m(3, 3) != 1.0)
    throw std::invalid_argument(name + ": the last row must be (0, 0, 0, 1) (an affine transform)");
  const Mat3 a = m.topLeftCorner<3, 3>();
  const Vec3 t = m.topRightCorner<3, 1>();
  return from_edges(t - 0.5 * a * Vec3::Ones(), a, argument);
}

}  // namespace deformkit
