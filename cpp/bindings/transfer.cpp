// Python bindings of the transfer family: argument conversion and checking only.
#include "common.hpp"
#include "declared.hpp"

#include <limits>
#include <memory>
#include <optional>
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

// An (m, 2) integer array, or (for markers) a pair of equal-length integer sequences.
std::vector<int> index_pairs(const py::object& obj, const char* name, const char* what) {
  py::object pairs = obj;
  if (std::string(name) == "markers" && (py::isinstance<py::tuple>(obj) || py::isinstance<py::list>(obj)) &&
      py::len(obj) == 2 && !py::isinstance<py::str>(obj)) {
    const py::array a = py::array::ensure(obj[py::int_(0)]), b = py::array::ensure(obj[py::int_(1)]);
    if (a && b && a.ndim() == 1 && b.ndim() == 1) {
      if (a.size() != b.size())
        throw py::value_error(std::string(name) + ": expected as many source vertices as target vertices, got " +
                              std::to_string(a.size()) + " and " + std::to_string(b.size()));
      pairs = py::module_::import("numpy").attr("stack")(py::make_tuple(obj[py::int_(0)], obj[py::int_(1)]), "axis"_a = 1);
    }
  }
  const auto v = parse_index_array(pairs, name, what, [&](const py::array& a) {
    if (a.ndim() != 2 || a.shape(1) != 2)
      throw py::value_error(std::string(name) + ": expected " + what + ", got shape " + shape_of(a));
  });
  std::vector<int> out(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (v[i] < 0 || v[i] > std::numeric_limits<int>::max())
      throw py::value_error(std::string(name) + ": pair " + std::to_string(i / 2) + " has index " + std::to_string(v[i]) +
                            ", expected indices from 0");
    out[i] = int(v[i]);
  }
  return out;
}

std::vector<int> vertex_list(const py::object& obj, const char* name) {
  const auto v = parse_index_array(obj, name, "a sequence of target vertex indices", [&](const py::array& a) {
    if (a.ndim() != 1) throw py::value_error(std::string(name) + ": expected a 1-d sequence of target vertex indices, got shape " + shape_of(a));
  });
  std::vector<int> out(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (v[i] < 0 || v[i] > std::numeric_limits<int>::max())
      throw py::value_error(std::string(name) + ": entry " + std::to_string(i) + " is " + std::to_string(v[i]) +
                            ", expected a target vertex index");
    out[i] = int(v[i]);
  }
  return out;
}

py::array int_rows(const std::vector<int>& v, py::ssize_t width) {
  std::vector<std::int32_t> a(v.begin(), v.end());
  const auto rows = py::ssize_t(a.size()) / width;
  return width == 1 ? owned_array(std::move(a), {rows}) : owned_array(std::move(a), {rows, width});
}

// A float array argument of one of the given shapes, as every deformer's points: floats only.
py::array_t<double, py::array::c_style> float_rows(const py::object& obj, const char* name) {
  return real_array(obj, name);
}

}  // namespace

void bind_transfer(py::module_& m) {
  Class<DeformationTransfer, std::shared_ptr<DeformationTransfer>>(m, "DeformationTransfer", R"(Deformation transfer (Sumner and Popovic 2004): a source mesh's poses carried onto a target mesh.

source_points (n_s, 3) and source_faces give the source at rest, target_points (n_t, 3) and
target_faces the target at rest. Polygons are fanned into triangles from their first corner.

- Same connectivity (target_faces None or equal to source_faces): vertex i of one is vertex i of
  the other, triangle j pairs with triangle j.
- Unlike meshes: markers=(source_vertices, target_vertices) (a tuple or list of two sequences;
  an (m, 2) numpy array is read as m pairs) runs Sumner's
  correspondence phase: the source deformed towards the target under the markers, then triangles
  paired by close centroids and agreeing normals, from both sides. correspondence=pairs (an
  (m, 2) array of (source triangle, target triangle), e.g. an earlier .correspondence) skips it.

Each pose's per-triangle deformation gradients are fitted on the target in least squares (the
gradient form of Botsch et al. 2006), factorised once: transfer(pose) is one back-substitution,
several poses one pass. Translation, which gradients cannot fix: fixed_vertices are given per
pose (their rest positions by default); every other connected part of the target moves with its
markers' centroid (same connectivity: its first vertex; correspondence alone: its paired
triangles' centroids) as the source's partners do.)")
      .def(py::init([](const py::object& source_points, const py::object& source_faces, const py::object& target_points,
                       const py::object& target_faces, const py::object& markers, const py::object& correspondence,
                       const py::object& fixed_vertices) {
             PolygonMesh source = parse_mesh(source_points, source_faces, "source");
             const std::vector<int> fixed = fixed_vertices.is_none() ? std::vector<int>{} : vertex_list(fixed_vertices, "fixed_vertices");
             std::optional<PolygonMesh> target;
             if (!target_faces.is_none()) target = parse_mesh(target_points, target_faces, "target");
             const bool same = !target || polygons(*target) == polygons(source);
             std::shared_ptr<DeformationTransfer> dt;
             if (same && correspondence.is_none()) {
               if (!markers.is_none())
                 throw py::value_error("markers: the meshes share their faces (same connectivity: vertex i is vertex i's "
                                       "partner), so markers are not used; give markers=None, or the target's own faces");
               const py::array t = points_array(target_points, "target_points");
               const auto td = as_double(t, "target_points");
               std::vector<double> tp(td.data(), td.data() + td.size());
               without_gil("the transfer system", [&] { dt = std::make_shared<DeformationTransfer>(source, tp, fixed); });
               return dt;
             }
             if (!target) target = parse_mesh(target_points, source_faces, "target");
             if (!correspondence.is_none()) {
               TransferPairing pairing;
               pairing.pairs = index_pairs(correspondence, "correspondence", "an (m, 2) integer array of (source triangle, target triangle) pairs");
               pairing.fixed_vertices = fixed;
               if (!markers.is_none()) pairing.reference = index_pairs(markers, "markers", "(source_vertices, target_vertices) or an (m, 2) integer array");
               without_gil("the transfer system", [&] { dt = std::make_shared<DeformationTransfer>(source, *target, pairing); });
               return dt;
             }
             if (markers.is_none())
               throw py::value_error("markers: the meshes differ (target_faces is not source_faces), so the transfer needs "
                                     "markers=(source_vertices, target_vertices) for the correspondence, or a "
                                     "correspondence from an earlier transfer");
             const std::vector<int> pairs = index_pairs(markers, "markers", "(source_vertices, target_vertices) or an (m, 2) integer array");
             std::vector<int> s(pairs.size() / 2), t(pairs.size() / 2);
             for (std::size_t i = 0; i < s.size(); ++i) {
               s[i] = pairs[2 * i];
               t[i] = pairs[2 * i + 1];
             }
             without_gil("the correspondence", [&] { dt = std::make_shared<DeformationTransfer>(source, *target, s, t, fixed); });
             return dt;
           }),
           "source_points"_a, "source_faces"_a, "target_points"_a, "target_faces"_a = py::none(), py::kw_only(),
           "markers"_a = py::none(), "correspondence"_a = py::none(), "fixed_vertices"_a = py::none())
      .def_property_readonly("anchors", [](const DeformationTransfer& d) { return int_rows(d.anchors(), 1); },
                             "Target vertices held while solving: the first of each connected part without fixed vertices.")
      .def_property_readonly("fixed_vertices", [](const DeformationTransfer& d) { return int_rows(d.fixed_vertices(), 1); },
                             "The target vertices given per pose.")
      .def_property_readonly("correspondence", [](const DeformationTransfer& d) { return int_rows(d.pairs(), 2); },
                             "(m, 2) int32: the (source triangle, target triangle) pairs; pass back as correspondence=.")
      .def_property_readonly("unmatched_target_triangles", [](const DeformationTransfer& d) { return int_rows(d.unmatched_target_triangles(), 1); },
                             "Target triangles with no source partner: they keep their rest shape.")
      .def_property_readonly("correspondence_distance", [](const DeformationTransfer& d) -> py::object {
        const TriangleCorrespondence* f = d.correspondence_fit();
        if (!f) return py::none();
        return py::make_tuple(f->mean_distance, f->max_distance);
      }, "(mean, max) distance of the fitted source's vertices to the target surface, or None without a correspondence phase.")
      .def_property_readonly("fitted_source", [](const DeformationTransfer& d) -> py::object {
        const TriangleCorrespondence* f = d.correspondence_fit();
        if (!f) return py::none();
        return copied_array(f->fitted_source.data(), {py::ssize_t(f->fitted_source.size() / 3), 3});
      }, "The source after the correspondence deformation (n_s, 3), or None without a correspondence phase.")
      .def_property_readonly("source_triangles", [](const DeformationTransfer& d) { return int_rows(d.source_triangles(), 3); },
                             "(t_s, 3) int32: the source's faces fanned from their first corner, as correspondence numbers them.")
      .def_property_readonly("target_triangles", [](const DeformationTransfer& d) { return int_rows(d.target_triangles(), 3); },
                             "(t_t, 3) int32: the target's triangles, likewise.")
      .def("transfer", [](const DeformationTransfer& d, const py::object& pose, const py::object& fixed_positions) {
             const auto a = float_rows(pose, "source_pose");
             const auto n = py::ssize_t(d.vertex_count()), nt = py::ssize_t(d.target_vertex_count());
             const bool one = a.ndim() == 2;
             if (!((one && a.shape(0) == n && a.shape(1) == 3) || (a.ndim() == 3 && a.shape(1) == n && a.shape(2) == 3)))
               throw py::value_error("source_pose: expected shape (" + std::to_string(n) + ", 3) or (k, " +
                                     std::to_string(n) + ", 3), the source's vertices, got " + shape_of(a));
             const std::size_t k = one ? 1 : std::size_t(a.shape(0));
             std::optional<py::array_t<double, py::array::c_style>> fp;
             if (!fixed_positions.is_none()) {
               fp = float_rows(fixed_positions, "fixed_positions");
               const auto f = py::ssize_t(d.fixed_vertices().size());
               const bool ok = one ? (fp->ndim() == 2 && fp->shape(0) == f && fp->shape(1) == 3)
                                   : (fp->ndim() == 3 && fp->shape(0) == py::ssize_t(k) && fp->shape(1) == f && fp->shape(2) == 3);
               if (!ok)
                 throw py::value_error("fixed_positions: expected shape " +
                                       (one ? "(" + std::to_string(f) + ", 3)" : "(" + std::to_string(k) + ", " + std::to_string(f) + ", 3)") +
                                       ", one row per fixed vertex" + (one ? "" : " for each pose") + ", got shape " + shape_of(*fp));
             }
             py::array_t<double> out = one ? new_array<double>({nt, 3}, "the transferred pose")
                                           : new_array<double>({py::ssize_t(k), nt, 3}, "the transferred poses");
             double* o = out.mutable_data();
             const double* f = fp ? fp->data() : nullptr;
             without_gil("the transferred poses", [&] { d.transfer(a.data(), k, o, f); });
             return out;
           }, "source_pose"_a, "fixed_positions"_a = py::none(),
           "The target's positions (n_t, 3) for a source pose (n_s, 3), or (k, n_t, 3) for k poses (k, n_s, 3).\n"
           "fixed_positions: (f, 3) (or (k, f, 3)) for the fixed vertices; None keeps them at rest.");
}

}  // namespace deformkit_py
