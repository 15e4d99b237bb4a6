// Python bindings of the cage family: argument conversion and checking only.
#include "common.hpp"
#include "declared.hpp"

#include "deformkit/cage/mesh_deform.hpp"

#include <memory>
#include <optional>
#include <string>

namespace deformkit_py {

using namespace pybind11::literals;

namespace {

// A binding remembers its cage: its weights are that cage's coordinates.
struct PyCageBinding {
  std::shared_ptr<CageBinding> binding;
  std::shared_ptr<const CageDeformer> cage;
};

CageMesh parse_cage(const py::object& points, const py::object& faces) {
  const py::array p = points_array(points, "cage_points");
  return with_mesh_prefix("cage", [&] { return CageMesh(parse_polygon_mesh(p, faces)); });
}

std::vector<double> parse_cage_points(const py::object& obj, const CageDeformer& cage) {
  const auto a = real_array(obj, "cage_points");
  if (a.ndim() != 2 || a.shape(1) != 3 || std::size_t(a.shape(0)) != cage.vertex_count())
    throw py::value_error("cage_points: expected shape (" + std::to_string(cage.vertex_count()) + ", 3), got " +
                          shape_of(a));
  return std::vector<double>(a.data(), a.data() + a.size());
}

py::array points_of(const std::vector<double>& p) {
  return copied_array(p.data(), {py::ssize_t(p.size() / 3), py::ssize_t(3)});
}

const EnumNames<WeightStorage> kPrecisionNames("precision", {{"float64", WeightStorage::Float64},
                                                             {"float32", WeightStorage::Float32}});

PyCageBinding py_bind(const std::shared_ptr<CageDeformer>& cage, const py::object& points,
                      const std::string& precision, const std::optional<double>& sparsify) {
  CageBindOptions options;
  options.storage = kPrecisionNames.parse(precision);
  if (sparsify) {
    const double t = finite_param(*sparsify, "sparsify");
    if (!(t > 0.0)) throw py::value_error("sparsify: expected a positive threshold, got " + std::to_string(t));
    if (options.storage == WeightStorage::Float32)
      throw py::value_error("sparsify: a sparsified binding keeps its weights in the points' dtype (float32 for "
                            "float32 points), so precision does not apply; give precision='float64' (the default) or no sparsify");
    options.storage = WeightStorage::Sparse;
    options.sparsify_threshold = t;
  }
  const py::array pts = points_array(points, "points");
  const auto n = static_cast<std::size_t>(pts.shape(0));
  auto b = std::make_shared<CageBinding>();
  const double bytes = (options.storage == WeightStorage::Float32 ? 4.0 : 8.0) * double(cage->columns()) + 24.0;
  without_gil("the cage binding (" + working_size(n, bytes) + ")", [&] {
    if (is_float32(pts)) *b = cage->bind(static_cast<const float*>(pts.data()), n, options);
    else *b = cage->bind(static_cast<const double*>(pts.data()), n, options);
  });
  return PyCageBinding{b, cage};
}

py::array py_deform_bound(const CageDeformer& cage, const PyCageBinding& pb, const py::object& out) {
  const CageBinding& b = *pb.binding;
  const auto rows = py::ssize_t(b.size());
  py::array result = b.single_precision ? output_array<float>(out, rows, py::none(), false)
                                        : output_array<double>(out, rows, py::none(), false);
  without_gil("the cage's working arrays", [&] {
    if (b.single_precision) cage.deform_bound(b, static_cast<float*>(result.mutable_data()));
    else cage.deform_bound(b, static_cast<double*>(result.mutable_data()));
  });
  return result;
}

py::tuple py_weights(const PyCageBinding& pb) {
  WeightTable w;
  without_gil("the sparse weight matrix (" + working_size(pb.binding->size(), 12.0 * double(pb.binding->columns)) +
                  " at most)",
              [&] { w = pb.cage->weights_table(*pb.binding); });
  return csr_tuple(std::move(w.indptr), std::move(w.indices), std::move(w.values));
}

const char* storage_name(WeightStorage s) {
  return s == WeightStorage::Float64 ? "float64" : s == WeightStorage::Float32 ? "float32" : "sparse";
}

// A Mesh Deform binding remembers its deformer, as a cage binding does.
struct PyMeshDeformBinding {
  std::shared_ptr<MeshDeformBinding> binding;
  std::shared_ptr<const MeshDeform> deformer;
};

// Blender's mesh ray-cast trees: 4 children per branch before 4.4, 2 since.
int bvh_arity_of(const py::object& version) {
  const py::ssize_t n = sequence_length(version);
  std::vector<std::int64_t> parts;
  if (n == 2 || n == 3) {
    try {
      for (const py::handle item : version) {
        if (py::isinstance<py::bool_>(item) || !py::isinstance<py::int_>(item)) throw py::type_error("");
        parts.push_back(item.cast<std::int64_t>());
      }
    } catch (const std::exception&) {
      parts.clear();
    }
  }
  if (parts.size() < 2 || parts[0] < 2)
    throw py::value_error("blender_version: expected (major, minor) integers of a Blender release, e.g. (5, 0) "
                          "or bpy.app.version, got " + py::repr(version).cast<std::string>());
  return parts[0] > 4 || (parts[0] == 4 && parts[1] >= 4) ? 2 : 4;
}

// A dynamic bind's kept inside flags: None, or one True/False per point (a bool array or a
// sequence of bools; integers are refused: 0/1 are too easily a row index array).
std::vector<std::uint8_t> inside_flags(const py::object& inside, std::size_t n) {
  if (inside.is_none()) return {};
  const py::array a = py::array::ensure(inside);
  if (!a || (a.size() > 0 && a.dtype().kind() != 'b'))
    throw py::type_error("inside: expected one True/False flag per point (a bool array), got " +
                         (a ? "dtype " + py::str(a.dtype()).cast<std::string>()
                            : py::str(py::type::of(inside).attr("__name__")).cast<std::string>()));
  if (a.ndim() != 1 || std::size_t(a.shape(0)) != n)
    throw py::value_error("inside: expected one flag per point, shape (" + std::to_string(n) + ",), got shape " +
                          py::str(py::tuple(py::cast(std::vector<py::ssize_t>(a.shape(), a.shape() + a.ndim()))))
                              .cast<std::string>());
  const auto flags = py::array_t<bool, py::array::c_style | py::array::forcecast>::ensure(a);
  std::vector<std::uint8_t> kept(n);
  for (std::size_t i = 0; i < n; ++i) kept[i] = flags.data()[i] ? 1 : 0;
  return kept;
}

// A static bind's saved rows: (indptr, indices, data) as MeshDeformBinding.weights() gives them,
// one-dimensional, indptr of n + 1 entries; the values are checked in C++ (MeshDeform::bind_rows).
WeightTable rows_table(const py::object& rows, std::size_t n) {
  const char* what = "(indptr, indices, data): binding.weights() of a static bind of these points";
  if (!py::isinstance<py::tuple>(rows) && !py::isinstance<py::list>(rows))
    throw py::type_error(std::string("rows: expected ") + what + ", got " +
                         py::str(py::type::of(rows).attr("__name__")).cast<std::string>());
  const py::sequence parts = rows.cast<py::sequence>();
  if (py::len(parts) != 3)
    throw py::value_error(std::string("rows: expected 3 arrays ") + what + ", got " + std::to_string(py::len(parts)));
  auto one_dimensional = [](const char* name, py::ssize_t length) {
    return [name, length](const py::array& a) {
      if (a.ndim() != 1 || (length >= 0 && a.shape(0) != length))
        throw py::value_error(std::string("rows: ") + name + ": expected shape (" +
                              (length >= 0 ? std::to_string(length) : std::string("k")) + ",), got " +
                              py::str(py::tuple(py::cast(std::vector<py::ssize_t>(a.shape(), a.shape() + a.ndim()))))
                                  .cast<std::string>());
    };
  };
  WeightTable t;
  t.indptr = parse_index_array(parts[0], "rows: indptr", "integer row offsets",
                               one_dimensional("indptr", py::ssize_t(n) + 1));
  const std::vector<std::int64_t> indices =
      parse_index_array(parts[1], "rows: indices", "integer cage vertex indices", one_dimensional("indices", -1));
  t.indices.resize(indices.size());
  for (std::size_t k = 0; k < indices.size(); ++k) {
    if (indices[k] < 0 || indices[k] > INT32_MAX)
      throw py::value_error("rows: indices: " + std::to_string(indices[k]) + " is no cage vertex index");
    t.indices[k] = std::int32_t(indices[k]);
  }
  const auto data = real_array(parts[2], "rows: data");
  one_dimensional("data", py::ssize_t(t.indices.size()))(data);
  t.values.assign(data.data(), data.data() + data.size());
  return t;
}

PyMeshDeformBinding py_md_bind(const std::shared_ptr<MeshDeform>& md, const py::object& points,
                               const py::object& inside, const py::object& rows) {
  const py::array pts = points_array(points, "points");
  const auto n = static_cast<std::size_t>(pts.shape(0));
  const std::vector<std::uint8_t> kept = inside_flags(inside, n);
  const std::uint8_t* flags = inside.is_none() ? nullptr : kept.data();
  auto b = std::make_shared<MeshDeformBinding>();
  if (!rows.is_none()) {
    const WeightTable table = rows_table(rows, n);
    without_gil("the Mesh Deform binding from its rows", [&] {
      if (is_float32(pts)) *b = md->bind_rows(static_cast<const float*>(pts.data()), n, flags, table);
      else *b = md->bind_rows(static_cast<const double*>(pts.data()), n, flags, table);
    });
    return PyMeshDeformBinding{b, md};
  }
  const double bytes = 8.0 * double(md->vertex_count()) + 40.0;
  without_gil("the Mesh Deform binding (" + working_size(n, bytes) + ")", [&] {
    if (is_float32(pts)) *b = md->bind(static_cast<const float*>(pts.data()), n, flags);
    else *b = md->bind(static_cast<const double*>(pts.data()), n, flags);
  });
  return PyMeshDeformBinding{b, md};
}

py::array py_md_deform_bound(const MeshDeform& md, const PyMeshDeformBinding& pb, const py::object& out) {
  const MeshDeformBinding& b = *pb.binding;
  const auto rows = py::ssize_t(b.size());
  py::array result = b.single_precision ? output_array<float>(out, rows, py::none(), false)
                                        : output_array<double>(out, rows, py::none(), false);
  without_gil("the Mesh Deform's working arrays", [&] {
    if (b.single_precision) md.deform_bound(b, static_cast<float*>(result.mutable_data()));
    else md.deform_bound(b, static_cast<double*>(result.mutable_data()));
  });
  return result;
}

py::array py_md_displacement_bound(const MeshDeform& md, const PyMeshDeformBinding& pb, const py::object& out) {
  const MeshDeformBinding& b = *pb.binding;
  const auto rows = py::ssize_t(b.size());
  py::array result = b.single_precision ? output_array<float>(out, rows, py::none(), false)
                                        : output_array<double>(out, rows, py::none(), false);
  without_gil("the Mesh Deform's working arrays", [&] {
    if (b.single_precision) md.displacement_bound(b, static_cast<float*>(result.mutable_data()));
    else md.displacement_bound(b, static_cast<double*>(result.mutable_data()));
  });
  return result;
}

}  // namespace

void bind_cage(py::module_& m) {
  Class<PyCageBinding>(m, "CageBinding", R"(Points bound to a cage: their coordinates, computed once.

`cage.deform_bound(binding)` then deforms them with the cage's current points: one matrix
product W c (W the weights, c the control values). `storage` is 'float64', 'float32' or
'sparse'. For a sparsified binding, `dropped_weight_max` is the largest sum of |dropped
weights| of a point and `weight_change_max` the largest change of a point's weights (L1, Green's
face weights scaled by a bound of their control values per unit of cage radius): at any deformed
cage, a bound point moves at most weight_change_max * (the deformed cage's radius about any
centre; GreenCage(stretch=False): at least the rest cage's) away from where the dense weights put
it.)")
      .def("__len__", [](const PyCageBinding& b) { return b.binding->size(); })
      .def_property_readonly("storage", [](const PyCageBinding& b) { return storage_name(b.binding->storage); })
      .def_property_readonly("columns", [](const PyCageBinding& b) { return b.binding->columns; })
      .def_property_readonly("dropped_weight_max", [](const PyCageBinding& b) { return b.binding->dropped_weight_max; })
      .def_property_readonly("weight_change_max", [](const PyCageBinding& b) { return b.binding->weight_change_max; })
      .def_property_readonly("float32_rounding_max",
                             [](const PyCageBinding& b) { return b.binding->float32_rounding_max; },
                             "float32 weights: the largest L1 change rounding made to a point's weights.")
      .def("weights", &py_weights, R"(The weight matrix W as CSR (indptr, indices, data): every stored non-zero weight.

Columns are the cage's control values (MeanValueCage: its vertices); deform_bound = W c (then
blended by the cage's per-point weights, if any).)");

  Class<CageDeformer, Deformer, std::shared_ptr<CageDeformer>>(m, "CageDeformer",
                                                                    "Interface of the cage deformers: F(x) = sum_j w_j(x) c_j.")
      .def_property("cage_points", [](const CageDeformer& c) { return points_of(c.cage_points()); },
                    [](CageDeformer& c, const py::object& p) { c.set_cage_points(parse_cage_points(p, c)); },
                    "The current cage (m, 3); assigning validates and copies. The rest cage is the identity.")
      .def_property_readonly("rest_cage_points", [](const CageDeformer& c) { return points_of(c.rest_cage_points()); })
      .def_property_readonly("triangles", [](const CageDeformer& c) {
        const auto& t = c.cage().triangles();
        std::vector<std::int32_t> flat;
        flat.reserve(3 * t.size());
        for (const auto& tri : t) flat.insert(flat.end(), tri.begin(), tri.end());
        return owned_array(std::move(flat), {py::ssize_t(t.size()), py::ssize_t(3)});
      }, "The cage's outward triangles (t, 3): every polygon split by the documented rule, flipped if inward.")
      .def_property_readonly("triangle_faces", [](const CageDeformer& c) {
        std::vector<std::int32_t> f(c.cage().triangle_face().begin(), c.cage().triangle_face().end());
        const auto t = py::ssize_t(f.size());
        return owned_array(std::move(f), {t});
      }, "For each triangle, the index of the polygon of cage_faces it comes from.")
      .def_property_readonly("flipped", [](const CageDeformer& c) { return c.cage().flipped(); },
                             "True when the cage's faces pointed inward (negative volume) and were flipped.")
      .def_property_readonly("volume", [](const CageDeformer& c) { return c.cage().volume(); },
                             "The rest cage's enclosed volume (positive).")
      .def_property_readonly("columns", &CageDeformer::columns, "The number of coordinates per point.")
      .def("bind", &py_bind, "points"_a, py::kw_only(), "precision"_a = "float64", "sparsify"_a = py::none(),
           R"(Bind points: compute their coordinates once (CageBinding).

precision 'float64' (default) or 'float32' stores the dense weights in that type; sparsify=t
(t > 0) keeps only weights of magnitude >= t, scaled so each point's weights keep their sum
(float64). deform_bound's dtype is that of the points.)")
      .def("deform_bound", &py_deform_bound, "binding"_a, py::kw_only(), "out"_a = py::none(),
           "Deform bound points with the current cage: W c. The dtype is that of the bound points.");

  Class<MeanValueCage, CageDeformer, std::shared_ptr<MeanValueCage>>(m, "MeanValueCage", R"(Mean value coordinates of a closed cage (Ju, Schaefer, Warren 2005).

cage_points (m, 3) and cage_faces (an (f, k) integer array or a list of polygons) give the rest
cage: closed, manifold, consistently oriented, not self-intersecting (an inward-facing cage is
flipped: `flipped`). Polygons are split into triangles by a rule of their geometry (ears of the
shortest diagonal). F(x) = sum_j w_j(x) v'_j with v' the current cage_points; the weights
reproduce linear functions, interpolate on the cage and extend outside it. Computed in the
determinant form of Thiery, Memari, Boubekeur 2018; Jacobians are exact.)")
      .def(py::init([](const py::object& points, const py::object& faces, const py::object& weights) {
             auto c = std::make_shared<MeanValueCage>(parse_cage(points, faces));
             apply_weights(*c, weights);
             return c;
           }),
           "cage_points"_a, "cage_faces"_a, py::kw_only(), "weights"_a = py::none());

  Class<GreenCage, CageDeformer, std::shared_ptr<GreenCage>>(m, "GreenCage", R"(Green coordinates of a closed cage (Lipman, Levin, Cohen-Or 2008).

cage_points and cage_faces as for MeanValueCage. F(x) = sum_i phi_i(x) v'_i + sum_j psi_j(x) s_j n'_j
over the cage's vertices v' and triangles (their unit outward normals n'), with Lipman's stretch
factors s_j from the triangles' edges (stretch=False: s_j = 1). The coordinates reproduce linear
functions; the map reproduces similarities of the cage and is quasi-conformal, so details keep
their shape. Outside the cage the coordinates are extended through the nearest cage triangle
(the paper's exterior extension), so the map is continuous across the cage. Not interpolating:
a point on the cage moves with its face, not exactly onto it. Jacobians are exact.)")
      .def(py::init([](const py::object& points, const py::object& faces, const py::object& stretch,
                       const py::object& weights) {
             auto c = std::make_shared<GreenCage>(parse_cage(points, faces), bool_arg(stretch, "stretch"));
             apply_weights(*c, weights);
             return c;
           }),
           "cage_points"_a, "cage_faces"_a, py::kw_only(), "stretch"_a = true, "weights"_a = py::none())
      .def_property_readonly("stretch", &GreenCage::stretch, "Whether Lipman's stretch factors scale the normals.");

  Class<PyMeshDeformBinding>(m, "MeshDeformBinding", R"(Points bound to a MeshDeform: Blender's bind of them.

`inside` says which points lie inside the rest cage (Blender's ray test); the others are not
deformed. A static bind holds each inside point's harmonic coordinates (weights above 1e-5 kept,
renormalised); a dynamic one only the inside flags (the coordinates are the grid's, read where
the point is).)")
      .def("__len__", [](const PyMeshDeformBinding& b) { return b.binding->size(); })
      .def_property_readonly("dynamic", [](const PyMeshDeformBinding& b) { return b.binding->dynamic; })
      .def_property_readonly("inside", [](const PyMeshDeformBinding& b) {
        const auto& in = b.binding->inside;
        py::array_t<bool> a(py::ssize_t(in.size()));
        auto* d = a.mutable_data();
        for (std::size_t i = 0; i < in.size(); ++i) d[i] = in[i] != 0;
        return a;
      }, "Per point: inside the rest cage (deformed) or not (left where it is).")
      .def("weights", [](const PyMeshDeformBinding& pb) {
        WeightTable w;
        without_gil("the sparse weight matrix", [&] { w = pb.deformer->weights_table(*pb.binding); });
        return csr_tuple(std::move(w.indptr), std::move(w.indices), std::move(w.values));
      }, R"(The harmonic coordinates as CSR (indptr, indices, data) over the cage's vertices: a point's
row sums to 1 (an outside point's is empty). Dynamic: interpolated at the bound points.)");

  Class<MeshDeform, Deformer, std::shared_ptr<MeshDeform>>(m, "MeshDeform", R"(Blender's Mesh Deform modifier: harmonic coordinates on a grid (Joshi et al. 2007).

cage_points and cage_faces as for MeanValueCage. precision p (2 to 10, Blender's default 5) gives
a grid of 2^p + 2 cells a side over the cage's box; dynamic=True is Blender's Dynamic bind (the
grid's coordinates read at each point's current position) instead of the static one (each
point's coordinates, computed once at bind). A point inside the rest cage moves by
sum_a w_a (c_a - c_a at rest): the rest cage is the identity bit for bit; a point outside stays.
Equal to Blender's modifier to its float precision. The grid is solved in bind (static) or here
(dynamic). blender_version (major, minor), default (5, 0): the Blender whose ray casts to follow
(before 4.4 Blender's ray-cast tree had 4 children per branch, since then 2; it decides which hit
Blender keeps on a ray that meets the cage more than once, e.g. which points count as inside).)")
      .def(py::init([](const py::object& points, const py::object& faces, std::int64_t precision,
                       const py::object& dynamic, const py::object& blender_version, const py::object& weights) {
             CageMesh cage = parse_cage(points, faces);
             const int p = int_arg(precision, "precision", MeshDeform::kMinPrecision, MeshDeform::kMaxPrecision);
             const bool dyn = bool_arg(dynamic, "dynamic");
             const int arity = bvh_arity_of(blender_version);
             std::shared_ptr<MeshDeform> md;
             without_gil("the Mesh Deform grid", [&] { md = std::make_shared<MeshDeform>(std::move(cage), p, dyn, arity); });
             apply_weights(*md, weights);
             return md;
           }),
           "cage_points"_a, "cage_faces"_a, py::kw_only(), "precision"_a = 5, "dynamic"_a = false,
           "blender_version"_a = py::make_tuple(5, 0), "weights"_a = py::none())
      .def_property("cage_points", [](const MeshDeform& c) { return points_of(c.cage_points()); },
                    [](MeshDeform& c, const py::object& p) {
                      const auto a = real_array(p, "cage_points");
                      if (a.ndim() != 2 || a.shape(1) != 3 || std::size_t(a.shape(0)) != c.vertex_count())
                        throw py::value_error("cage_points: expected shape (" + std::to_string(c.vertex_count()) +
                                              ", 3), got " + shape_of(a));
                      c.set_cage_points(std::vector<double>(a.data(), a.data() + a.size()));
                    },
                    "The current cage (m, 3); assigning validates and copies. The rest cage is the identity.")
      .def_property_readonly("rest_cage_points", [](const MeshDeform& c) { return points_of(c.rest_cage_points()); })
      .def_property_readonly("precision", &MeshDeform::precision)
      .def_property_readonly("dynamic", &MeshDeform::dynamic)
      .def_property_readonly("unknowns", &MeshDeform::unknown_count, "The grid system's unknowns (cells not outside).")
      .def_property_readonly("grid_size", &MeshDeform::grid_size, "Cells a side: 2^precision + 2.")
      .def_property_readonly("flipped", [](const MeshDeform& c) { return c.cage().flipped(); },
                             "True when the cage's faces pointed inward (negative volume) and were flipped.")
      .def("bind", &py_md_bind, "points"_a, py::kw_only(), "inside"_a = py::none(), "rows"_a = py::none(),
           R"(Bind points as Blender's Bind button does (MeshDeformBinding).

Static: solves the grid for every cage vertex and keeps each inside point's coordinates; or,
with `rows` ((indptr, indices, data): binding.weights() of an earlier static bind of these
points to this cage, e.g. saved with a file), takes those coordinates without the solve (with
`inside`, that bind's inside flags; without, the points with a row are inside). Dynamic: finds
which points are inside (the grid was solved by the constructor); or, with `inside` (one bool per
point, e.g. binding.inside of the points at Bind), takes those flags as Blender's dynamic bind
keeps them from Bind, wherever the points are now.)")
      .def("deform_bound", &py_md_deform_bound, "binding"_a, py::kw_only(), "out"_a = py::none(),
           "Deform bound points with the current cage. The dtype is that of the bound points.")
      .def("displacement_bound", &py_md_displacement_bound, "binding"_a, py::kw_only(), "out"_a = py::none(),
           R"(w (F(x) - x) of the bound points in one pass: the offsets Blender's modifier adds
(w the per-point weights, 1 without); exactly 0 at the rest cage. The dtype is that of the bound points.)");
}

}  // namespace deformkit_py
