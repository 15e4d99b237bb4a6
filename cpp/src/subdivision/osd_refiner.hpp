#pragma once
// The OpenSubdiv topology refiner for a control mesh (private: OpenSubdiv is not in the public headers).
#include "deformkit/subdivision/control_mesh.hpp"

#include <opensubdiv/far/topologyRefiner.h>

#include <memory>

namespace deformkit {

using Refiner = OpenSubdiv::Far::TopologyRefiner;

// Unrefined; with_uvs adds the UV channel. Boundary faces keep their surface because the
// boundary rule is never OpenSubdiv's default VTX_BOUNDARY_NONE (docs/math/subdivision.md, "Boundary interpolation").
std::unique_ptr<Refiner> make_refiner(const ControlMesh& mesh, bool with_uvs);

struct Point3 {
  double x, y, z;
  void Clear(void* = nullptr) { x = y = z = 0.0; }
  void AddWithWeight(const Point3& p, double w) {
    x += w * p.x;
    y += w * p.y;
    z += w * p.z;
  }
};

}  // namespace deformkit
