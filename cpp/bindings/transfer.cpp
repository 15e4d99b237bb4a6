// Python bindings of the transfer family: argument conversion and checking only.
#include "common.hpp"

#include <memory>
#include <string>

namespace deformkit_py {

using namespace pybind11::literals;

namespace {

// The shared faces as one list of polygons, for comparing the source's and the target's.
std::vector<std::vector<int>> polygons(const PolygonMesh& m) {
  std::vector<std::vector<int>> out(m.face_count());
  for (std::size_t f = 0; f < m.face_count(); ++f) out[f].assign(m.face(f), m.face(f) + m.face_size(f));
  return out;
}

PolygonMesh parse_mesh(const py::object& points, const py::object& faces, const std::string& which) {
  const py::array p = points_array(points, (which + "_points").c_str());
  return with_mesh_prefix(which, [&] { return parse_polygon_mesh(p, faces); });
}

}  // namespace

void bind_transfer(py::module_& m) {
  py::class_<DeformationTransfer, std::shared_ptr<DeformationTransfer>>(m, "DeformationTransfer", R"(Deformation transfer (Sumner and Popovic 2004): a source mesh's poses carried onto a target mesh.

source_points (n, 3) and source_faces give the source at rest; target_points (n, 3) the target
at rest, with the source's faces (same connectivity: vertex i of one is vertex i of the other).
Each pose's per-triangle deformation gradients (Sumner's frames, with the fourth vertex) are
fitted on the target in least squares (the gradient form of Botsch et al. 2006), factorised once:
transfer(pose) is one back-substitution, several poses one pass. Each connected part's first
vertex moves by its source partner's displacement (the translation gradients cannot fix), so the
rest pose transfers to the target rest exactly. Unlike meshes (other target_faces, markers,
correspondence) are not supported yet.)")
      .def(py::init([](const py::object& source_points, const py::object& source_faces, const py::object& target_points,
                       const py::object& target_faces, const py::object& markers, const py::object& correspondence) {
             PolygonMesh source = parse_mesh(source_points, source_faces, "source");
             if (!target_faces.is_none()) {
               const PolygonMesh target = parse_mesh(target_points, target_faces, "target");
               if (polygons(target) != polygons(source))
                 throw py::value_error("target_faces: differ from source_faces; transfer between unlike meshes "
                                       "(Sumner's correspondence, with markers) is not built yet: give the source's "
                                       "faces or target_faces=None for meshes of the same connectivity");
             }
             if (!markers.is_none() || !correspondence.is_none())
               throw py::value_error(std::string(markers.is_none() ? "correspondence" : "markers") +
                                     ": only same-connectivity transfer is built yet (vertex i to vertex i); "
                                     "give markers=None and correspondence=None");
             const py::array t = points_array(target_points, "target_points");
             const auto td = as_double(t, "target_points");
             std::vector<double> target(td.data(), td.data() + td.size());
             std::shared_ptr<DeformationTransfer> dt;
             without_gil("the transfer system", [&] { dt = std::make_shared<DeformationTransfer>(source, target); });
             return dt;
           }),
           "source_points"_a, "source_faces"_a, "target_points"_a, "target_faces"_a = py::none(), py::kw_only(),
           "markers"_a = py::none(), "correspondence"_a = py::none())
      .def_property_readonly("anchors", [](const DeformationTransfer& d) {
        std::vector<std::int32_t> a(d.anchors().begin(), d.anchors().end());
        const auto k = py::ssize_t(a.size());
        return owned_array(std::move(a), {k});
      }, "The vertices whose translation is fixed: the first of each connected part.")
      .def("transfer", [](const DeformationTransfer& d, const py::object& pose) {
             require_real(pose, "source_pose");
             if (py::isinstance<py::array>(pose)) {  // as every deformer's points: floats, not silently cast
               const auto kind = py::reinterpret_borrow<py::array>(pose).dtype().kind();
               if (kind != 'f')
                 throw py::type_error("source_pose: expected float32 or float64, got " +
                                      std::string(py::str(py::reinterpret_borrow<py::array>(pose).dtype())) +
                                      " (convert with .astype(np.float64))");
             }
             const auto a = c_array<double>(pose, "source_pose");
             const auto n = py::ssize_t(d.vertex_count());
             const bool one = a.ndim() == 2;
             if (!((one && a.shape(0) == n && a.shape(1) == 3) || (a.ndim() == 3 && a.shape(1) == n && a.shape(2) == 3)))
               throw py::value_error("source_pose: expected shape (" + std::to_string(n) + ", 3) or (k, " +
                                     std::to_string(n) + ", 3), the source's vertices, got " + shape_of(a));
             const std::size_t k = one ? 1 : std::size_t(a.shape(0));
             py::array_t<double> out = one ? new_array<double>({n, 3}, "the transferred pose")
                                           : new_array<double>({py::ssize_t(k), n, 3}, "the transferred poses");
             double* o = out.mutable_data();
             without_gil("the transferred poses", [&] { d.transfer(a.data(), k, o); });
             return out;
           }, "source_pose"_a, "The target's positions for a source pose (n, 3), or for k poses (k, n, 3).");
}

}  // namespace deformkit_py
