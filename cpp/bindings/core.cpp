// Python bindings of the core: the Deformer interface every family shares, Stack, mesh volume.
#include "common.hpp"
#include "declared.hpp"

#include <memory>
#include <string>
#include <vector>

namespace deformkit_py {

using namespace pybind11::literals;

namespace {

const char* kDeformDoc = R"(Deform points: returns F(x) for each row of `points` ((n, 3) float32 or float64).

The result has the dtype of `points`; the input is never modified. Pass `out=` (same shape and
dtype, C-contiguous; it may be `points` itself) to write in place. With weights w, the result is
x + w (F(x) - x).)";
const char* kDisplacementDoc = R"(Displacement F(x) - x for each row of `points`, as `deform` returns positions.

Same dtype rules and `out=` as `deform`, except that `out` may not be `points` itself.)";
const char* kJacobianDoc = R"(Jacobian J = dF/dx at each point, shape (n, 3, 3), J[i, r, c] = dF_r/dx_c (Barr 1984, eq. for J(X)).

float32 for float32 points, else float64. out: an array of that shape and dtype to write into
and return (a viewport's buffer, reused call after call), sharing no memory with points.)";
const char* kNormalsDoc = R"(Carry unit normals through the map: N' = det(J) J^-T N (the cofactor matrix), renormalised.

float32 for float32 normals, else float64. out: an (n, 3) array of that dtype to write into and
return, sharing no memory with points or normals.)";
const char* kVolumeDoc = R"(Local volume ratio det(J) at each point, shape (n,).

float32 for float32 points, else float64. out: an (n,) array of that dtype to write into and
return, sharing no memory with points.)";

// An int32 (m, k) face array is read where it is (a volume is one pass: a copy of the mesh would
// cost as much again); any other faces are read into a PolygonMesh, through the same checks.
double py_mesh_volume(const py::object& points, const py::object& faces) {
  if (const auto f = uniform_face_array<std::int32_t>(faces)) {
    const auto p = as_double(points_array(points, "points"));
    const PolygonMeshView mesh = PolygonMeshView::borrowed(p.data(), std::size_t(p.shape(0)), f->data(),
                                                           std::size_t(f->shape(0)), int(f->shape(1)));
    py::gil_scoped_release release;
    return mesh_volume(mesh);
  }
  const PolygonMesh mesh = parse_polygon_mesh(points, faces);
  py::gil_scoped_release release;
  return mesh_volume(mesh);
}

}  // namespace

void bind_core(py::module_& m) {
  Class<Deformer, std::shared_ptr<Deformer>>(m, "Deformer",
                                                  "Interface shared by every spatial deformer.")
      .def("deform", &py_deform, "points"_a, py::kw_only(), "out"_a = py::none(), kDeformDoc)
      .def("displacement", &py_displacement, "points"_a, py::kw_only(), "out"_a = py::none(), kDisplacementDoc)
      .def("jacobian", &py_jacobian, "points"_a, py::kw_only(), "out"_a = py::none(), kJacobianDoc)
      .def("transform_normals", &py_normals, "points"_a, "normals"_a, py::kw_only(), "out"_a = py::none(), kNormalsDoc)
      .def("volume_ratio", &py_volume_ratio, "points"_a, py::kw_only(), "out"_a = py::none(), kVolumeDoc)
      .def_property_readonly("weights", &weights_of, "Per-point blend weights, or None.");

  Class<Stack, Deformer, std::shared_ptr<Stack>>(m, "Stack", R"(Composition of deformers, applied in order.

F = F_n o ... o F_1, with the chain rule J = J_n(F_n-1(...)) ... J_1(x) for jacobian, normals and
volume ratio. Stacks nest.)")
      .def(py::init([](const py::object& deformers, const py::object& weights) {
             const py::ssize_t count = sequence_length(deformers);
             if (count < 0)
               throw py::type_error("deformers: expected a list of deformers, got " +
                                    std::string(py::str(py::type::of(deformers).attr("__name__"))));
             std::vector<DeformerPtr> list;
             for (py::ssize_t i = 0; i < count; ++i) {
               const py::object item = py::reinterpret_borrow<py::sequence>(deformers)[i];
               if (item.is_none()) throw py::value_error("deformers: entry " + std::to_string(i) + " is None, not a deformer");
               if (!py::isinstance<Deformer>(item))
                 throw py::type_error("deformers: entry " + std::to_string(i) + " is " +
                                      std::string(py::str(py::type::of(item).attr("__name__"))) +
                                      ", not a deformkit deformer (Twist, Bend, FFD, Stack, ...)");
               list.push_back(item.cast<std::shared_ptr<Deformer>>());
             }
             auto d = std::make_shared<Stack>(std::move(list));
             apply_weights(*d, weights);
             return d;
           }),
           "deformers"_a, "weights"_a = py::none())
      .def("__len__", [](const Stack& s) { return s.deformers().size(); })
      .def_property_readonly("deformers", [](const Stack& s) {
        py::list out;
        for (const auto& d : s.deformers()) out.append(std::const_pointer_cast<Deformer>(d));
        return out;
      });

  def(m, "mesh_volume", &py_mesh_volume, "points"_a, "faces"_a,
        R"(Signed volume enclosed by a closed mesh: (1/6) sum a . (b x c) over its triangles (polygons fanned).

faces: (m, k) corner indices or a list of polygons; outward-facing winding gives a positive volume. The deformed volume
of a closed mesh is mesh_volume(deformer.deform(points), faces).)");
}

}  // namespace deformkit_py
