// Python bindings: argument conversion and checking only; the math lives in cpp/src. One
// bind_<family> per binding file.
#include "common.hpp"
#include "declared.hpp"
#include "deformkit/build_info.hpp"

using namespace deformkit_py;

PYBIND11_MODULE(_core, m) {
  m.doc() = "deformkit native core: spatial deformers with exact Jacobians.";

  // Core first: every family's classes derive from Deformer.
  bind_core(m);
  bind_barr(m);
  bind_lattice(m);
  bind_surface(m);
  bind_subdivision(m);
  bind_cage(m);
  bind_cage_generation(m);
  bind_rbf(m);
  bind_transfer(m);

  def(m, "build_info", []() {
    py::dict info;
    for (const auto& [k, v] : build_info()) info[py::str(k)] = v;
    return info;
  }, "Versions compiled in, the SIMD instruction set chosen for this CPU and the thread count.");

  publish_signatures(m);  // last: every class is registered by now
}
