// Python bindings of the lattice family: argument conversion and checking only.
#include "common.hpp"
#include "declared.hpp"
#include "deformkit/lattice/jacobian_bounds.hpp"

#include <cmath>
#include <memory>

namespace deformkit_py {

using namespace pybind11::literals;

namespace {

// A binding remembers its lattice: its weights are the lattice's bases at the bound coordinates.
struct PyBinding {
  std::shared_ptr<LatticeBinding> binding;
  std::shared_ptr<const ControlLattice> lattice;
};

struct PyDirect {
  py::array control_points, displacement, residual;
  double max_residual = 0.0;
  int rank = 0;
  // None unless preserve_volume was given.
  py::object volume = py::none(), volume_target = py::none(), volume_residual = py::none();
  int iterations = 0;
};

std::array<int, 3> parse_counts(const py::object& obj, const char* name) {
  auto as_int = [&](const py::handle& h) -> int {
    if (py::isinstance<py::bool_>(h) || !PyIndex_Check(h.ptr()))
      throw py::type_error(std::string(name) + ": expected an int or three ints, got " + std::string(py::repr(obj)));
    const long long v = PyNumber_AsSsize_t(h.ptr(), nullptr);
    if (PyErr_Occurred()) PyErr_Clear();
    return static_cast<int>(std::clamp<long long>(v, -1, 1 << 24));  // out-of-range values still read as out of range
  };
  if (sequence_length(obj) >= 0) {
    const auto seq = py::reinterpret_borrow<py::sequence>(obj);
    if (sequence_length(obj) != 3) throw py::value_error(std::string(name) + ": expected an int or three ints");
    return {as_int(seq[0]), as_int(seq[1]), as_int(seq[2])};
  }
  const int v = as_int(obj);
  return {v, v, v};
}

Vec3 parse_vec3(const py::object& obj, const char* name) {
  const auto v = parse_vector(obj, name);
  if (v.size() != 3) throw py::value_error(std::string(name) + ": expected 3 numbers");
  return Vec3(v[0], v[1], v[2]);
}

LatticeBox parse_box(const py::object& origin, const py::object& edges, const py::object& frame) {
  if (!frame.is_none()) {
    if (!origin.is_none() || !edges.is_none())
      throw py::value_error("frame: give either frame or origin/edges, not both");
    return LatticeBox::from_matrix(parse_mat4(frame, "frame", false), "frame");
  }
  const Vec3 o = origin.is_none() ? Vec3::Zero() : parse_vec3(origin, "origin");
  Mat3 e = Mat3::Identity();
  if (!edges.is_none())  // rows S, T, U are the box's edge columns
    e = parse_matrix(edges, "edges", 3, 3, "expected three edge vectors S, T, U as a 3x3 array (one per row)", false)
            .transpose();
  return LatticeBox::from_edges(o, e, "edges");
}

const EnumNames<Outside> kOutsideNames("outside", {{"clamp", Outside::Clamp},
                                                   {"unchanged", Outside::Unchanged},
                                                   {"extrapolate", Outside::Extrapolate}});

Outside parse_outside(const std::string& s) { return kOutsideNames.parse(s); }

// Blender's interpolation types, lower case and without the KEY_ prefix of its enum.
const EnumNames<BasisKind> kInterpolationNames("interpolation", {{"linear", BasisKind::BlenderLinear},
                                                                 {"cardinal", BasisKind::BlenderCardinal},
                                                                 {"catmull_rom", BasisKind::BlenderCatmullRom},
                                                                 {"bspline", BasisKind::BlenderBSpline}});

BasisKind parse_interpolation_one(const py::handle& h) {
  if (!py::isinstance<py::str>(h))
    throw py::type_error("interpolation: expected a string or three strings, got " + std::string(py::repr(h)));
  std::string s = h.cast<std::string>();
  if (s.rfind("KEY_", 0) == 0) s = s.substr(4);
  for (auto& c : s) c = static_cast<char>(std::tolower(c));
  return kInterpolationNames.parse(s, h.cast<std::string>());
}

std::array<BasisKind, 3> parse_interpolation(const py::object& obj) {
  if (py::isinstance<py::str>(obj)) {
    const BasisKind k = parse_interpolation_one(obj);
    return {k, k, k};
  }
  if (sequence_length(obj) != 3)
    throw py::value_error("interpolation: expected a string or three strings (u, v, w)");
  const auto seq = py::reinterpret_borrow<py::sequence>(obj);
  return {parse_interpolation_one(seq[0]), parse_interpolation_one(seq[1]), parse_interpolation_one(seq[2])};
}

const char* interpolation_name(BasisKind k) { return kInterpolationNames.name(k); }

// A (nu, nv, nw, 3) grid as a flat vector, checked against the lattice's resolution.
std::vector<double> parse_grid(const py::object& obj, std::array<int, 3> res, const char* name) {
  const auto a = real_array(obj, name);
  const std::string want = "(" + std::to_string(res[0]) + ", " + std::to_string(res[1]) + ", " +
                           std::to_string(res[2]) + ", 3)";
  if (a.ndim() != 4 || a.shape(0) != res[0] || a.shape(1) != res[1] || a.shape(2) != res[2] || a.shape(3) != 3)
    throw py::value_error(std::string(name) + ": expected shape " + want + ", got " + shape_of(a));
  return std::vector<double>(a.data(), a.data() + a.size());
}

py::array grid_array(const std::vector<double>& g, std::array<int, 3> res) {
  return copied_array(g.data(), {py::ssize_t(res[0]), py::ssize_t(res[1]), py::ssize_t(res[2]), py::ssize_t(3)});
}

template <class L>
std::shared_ptr<L> finish(std::shared_ptr<L> lat, const py::object& control_points, const py::object& weights) {
  if (!control_points.is_none()) lat->set_control_points(parse_grid(control_points, lat->resolution(), "control_points"));
  apply_weights(*lat, weights);
  return lat;
}

// A generated extended FFD (cylinder, prism) whose rest lattice the core refuses: the caller gave
// the generator's arguments, not rest_control_points, so the error names those.
template <class Make>
std::shared_ptr<ExtendedFFD> generated_effd(const Make& make, const py::array& grid, double strength,
                                            const py::object& weights, double tolerance, std::int64_t max_iterations,
                                            const char* what) {
  try {
    return make(grid, py::none(), strength, weights, tolerance, max_iterations);
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what(), prefix = "rest_control_points: ";
    if (msg.rfind(prefix, 0) != 0) throw;
    throw py::value_error(std::string(what) + " is degenerate at double precision: " + msg.substr(prefix.size()));
  }
}

PyBinding py_bind(const std::shared_ptr<ControlLattice>& lat, const py::object& points) {
  const py::array pts = points_array(points, "points");
  const auto n = static_cast<std::size_t>(pts.shape(0));
  auto b = std::make_shared<LatticeBinding>();
  // The binding keeps coordinates, cells and sorted copies of the points: about 100 bytes a point.
  without_gil("the lattice binding (" + working_size(n, 100.0) + ")", [&] {
    if (is_float32(pts)) *b = lat->bind(static_cast<const float*>(pts.data()), n);
    else *b = lat->bind(static_cast<const double*>(pts.data()), n);
  });
  return PyBinding{b, lat};
}

py::array parameters_array(const LatticeBinding& b) {
  auto a = new_array<double>({py::ssize_t(b.size()), py::ssize_t(3)}, "the lattice coordinates");
  std::copy(b.parameters.begin(), b.parameters.end(), a.mutable_data());
  return std::move(a);
}

py::array py_deform_bound(const ControlLattice& lat, const PyBinding& pb, const py::object& out) {
  const LatticeBinding& b = *pb.binding;
  const auto rows = py::ssize_t(b.size());
  py::array result = b.single_precision ? output_array<float>(out, rows, py::none(), false)
                                        : output_array<double>(out, rows, py::none(), false);
  without_gil("the lattice's working arrays", [&] {
    if (b.single_precision) lat.deform_bound(b, static_cast<float*>(result.mutable_data()));
    else lat.deform_bound(b, static_cast<double*>(result.mutable_data()));
  });
  return result;
}

py::array py_displacement_bound(const ControlLattice& lat, const PyBinding& pb, const py::object& out) {
  const LatticeBinding& b = *pb.binding;
  const auto rows = py::ssize_t(b.size());
  py::array result = b.single_precision ? output_array<float>(out, rows, py::none(), false)
                                        : output_array<double>(out, rows, py::none(), false);
  without_gil("the lattice's working arrays", [&] {
    if (b.single_precision) lat.displacement_bound(b, static_cast<float*>(result.mutable_data()));
    else lat.displacement_bound(b, static_cast<double*>(result.mutable_data()));
  });
  return result;
}

py::tuple py_weights(const PyBinding& pb) {
  WeightTable w;
  without_gil("the sparse weight matrix (" + working_size(pb.binding->size(), 12.0 * 64) + " at most)",
              [&] { w = pb.lattice->weights_matrix(*pb.binding); });
  return csr_tuple(std::move(w.indptr), std::move(w.indices), std::move(w.values));
}

// preserve_volume=(mesh_points, mesh_faces) read as every mesh argument is, its errors named
// "preserve_volume: mesh_points: ..." / "preserve_volume: mesh_faces: ...".
PolygonMesh parse_volume_mesh(const py::object& pair) {
  if (!(py::isinstance<py::tuple>(pair) || py::isinstance<py::list>(pair)) || py::len(pair) != 2)
    throw py::type_error("preserve_volume: expected a pair (mesh_points, mesh_faces) of a closed mesh, got " +
                         std::string(py::str(py::type::of(pair).attr("__name__"))) +
                         (sequence_length(pair) >= 0 ? " of length " + std::to_string(sequence_length(pair)) : ""));
  const auto seq = py::reinterpret_borrow<py::sequence>(pair);
  try {
    return with_mesh_prefix("mesh", [&] { return parse_polygon_mesh(seq[0], seq[1]); });
  } catch (const py::type_error& e) {
    throw py::type_error(std::string("preserve_volume: ") + e.what());
  } catch (const py::value_error& e) {
    throw py::value_error(std::string("preserve_volume: ") + e.what());
  }
}

PyDirect py_direct(const ControlLattice& lat, const py::object& points, const py::object& targets,
                   const py::object& preserve_volume) {
  const auto p = as_double(points_array(points, "points"));
  const auto t = as_double(points_array(targets, "targets"), "targets");
  if (t.shape(0) != p.shape(0))
    throw py::value_error("targets: has " + std::to_string(t.shape(0)) + " rows but points has " +
                          std::to_string(p.shape(0)));
  std::optional<PolygonMesh> mesh;
  if (!preserve_volume.is_none()) mesh = parse_volume_mesh(preserve_volume);
  DirectManipulationResult r;
  without_gil("the dense least-squares system of the direct manipulation", [&] {
    r = mesh ? direct_manipulation(lat, p.data(), t.data(), std::size_t(p.shape(0)), *mesh)
             : direct_manipulation(lat, p.data(), t.data(), std::size_t(p.shape(0)));
  });
  PyDirect d;
  d.control_points = grid_array(r.control_points, lat.resolution());
  d.displacement = grid_array(r.displacement, lat.resolution());
  d.residual = copied_array(r.residual.data(), {py::ssize_t(r.residual.size())});
  for (double x : r.residual) d.max_residual = std::max(d.max_residual, x);  // finite: the core checks
  d.rank = r.rank;
  if (r.preserves_volume) {
    d.volume = py::float_(r.volume);
    d.volume_target = py::float_(r.volume_target);
    d.volume_residual = py::float_(r.volume_residual);
    d.iterations = r.iterations;
  }
  return d;
}

const char* kPlacementDoc = R"(

Placement: `origin` and `edges` (rows S, T, U) give the box X0 + s S + t T + u U, any
parallelepiped; or `frame`, a 4x4 matrix from lattice-local space, where the box is Blender's
rest cube [-1/2, 1/2]^3, into the points' space; neither: the unit cube. `control_points`
(nu, nv, nw, 3) are in the points' space; None is the rest lattice. The map is
F(x) = x + strength * sum w(x) (P - R) with R the rest control points, so the rest lattice is
the identity. `outside`: 'clamp' (default) holds the boundary's displacement outside the box,
so the map stays continuous, as Blender's Lattice modifier does; 'unchanged' leaves outside
points where they are (a jump where boundary control points moved); 'extrapolate' continues
the polynomials, and refuses points whose weights' magnitudes sum past 1e6, too far out for the
sum to be accurate (docs/lattice.md, "Far outside").)";


// ---- Certified volume-ratio bounds, fold certificate, exact volume (issue 34) ----

struct PyVolumeBounds {
  VolumeRatioBounds b;
};

struct PyFoldCertificate {
  FoldCertificate c;
};

py::tuple triple(const std::array<int, 3>& v) { return py::make_tuple(v[0], v[1], v[2]); }
py::tuple triple(const std::array<double, 3>& v) { return py::make_tuple(v[0], v[1], v[2]); }

// The cells the bounds cover: the whole region, or those holding `points` (not empty).
std::vector<CellSpec> bounded_cells(const BoxLattice& lat, const py::object& points, bool& identity) {
  identity = false;
  if (points.is_none()) return region_cells(lat);
  const auto p = as_double(points_array(points, "points"));
  if (p.shape(0) == 0)
    throw py::value_error("points: has no rows; give at least one point, or None for the lattice's whole region");
  return cells_holding(lat, p.data(), std::size_t(p.shape(0)), identity);
}

std::array<int, 3> parse_cell(const BoxLattice& lat, const py::object& cell) {
  const auto c = parse_counts(cell, "cell");
  (void)lat;
  return c;
}

template <class L, class C>
void add_bounds_methods(C&& cls) {
  cls.def("volume_ratio_bounds", [](const L& lat, double tolerance, const py::object& points) {
        bool identity = false;
        const auto cells = bounded_cells(lat, points, identity);
        PyVolumeBounds r;
        without_gil("the Bernstein coefficients of det J", [&] {
          r.b = volume_ratio_bounds(lat, cells, identity, tolerance);
        });
        return r;
      }, py::kw_only(), "tolerance"_a = 1e-3, "points"_a = py::none(),
      R"(Guaranteed bounds (lower, upper) of volume_ratio (det J, 1 at rest) over the lattice's region.

From the Bernstein coefficients of det J cell by cell, refined by de Casteljau subdivision until
lower is within tolerance * scale of the least value found (scale = max(1, max |det J| at the
cells' corners)), likewise upper, or until the work cap (converged False). With `points`, only
the cells holding them (docs/lattice.md, "Certified volume-ratio bounds"). Per-point weights
are not applied. Returns a VolumeRatioBounds, which unpacks as (lower, upper).)")
      .def("fold_free", [](const L& lat, const py::object& points) {
        bool identity = false;
        const auto cells = bounded_cells(lat, points, identity);
        PyFoldCertificate r;
        without_gil("the Bernstein coefficients of det J", [&] { r.c = fold_certificate(lat, cells, identity); });
        return r;
      }, "points"_a = py::none(),
      R"(A FoldCertificate: truthy only when det J > 0 is proven over the region (or the cells holding
`points`); otherwise its `cells` say where det J <= 0 was found or could not be ruled out.)")
      .def("deformed_volume", [](const L& lat) {
        double v = 0.0;
        without_gil("the Bernstein coefficients of det J", [&] { v = deformed_volume(lat); });
        return v;
      }, "The exact volume of the deformed lattice region: the integral of det J (signed where it folds).")
      .def("volume_ratio_coefficients", [](const L& lat, const py::object& cell) {
        const auto c = parse_cell(lat, cell);
        const auto& axes = lat.axes();
        for (int a = 0; a < 3; ++a)
          if (c[a] < 0 || c[a] >= axes[a].pieces())
            throw py::value_error("cell: index " + std::to_string(c[a]) + " along axis " + std::to_string(a) +
                                  " is outside 0.." + std::to_string(axes[a].pieces() - 1));
        CellSpec spec;
        for (const CellSpec& s : region_cells(lat))
          if (s.piece == c) spec = s;
        const TriPoly p = cell_volume_ratio(lat, spec).coefficients;
        return copied_array(p.c.data(), {py::ssize_t(p.degree[0] + 1), py::ssize_t(p.degree[1] + 1),
                                         py::ssize_t(p.degree[2] + 1)});
      }, "cell"_a,
      R"(The Bernstein coefficients of det J over a cell of the region, shape (l+1, m+1, n+1) for degree
(l, m, n) in the cell's local coordinates (each in [0, 1]).)")
      .def("cell_control_indices", [](const L& lat, const py::object& cell) {
        const auto idx = cell_control_indices(lat, parse_cell(lat, cell));
        std::vector<int> flat;
        for (const auto& i : idx) flat.insert(flat.end(), i.begin(), i.end());
        return copied_array(flat.data(), {py::ssize_t(idx.size()), py::ssize_t(3)});
      }, "cell"_a, "The grid indices (i, j, k) of the control points that move the map on a cell, (m, 3).")
      .def_property_readonly("cell_grid", [](const L& lat) {
        const auto& a = lat.axes();
        return py::make_tuple(a[0].pieces(), a[1].pieces(), a[2].pieces());
      }, "Cells of the region per axis (blocks, spans or Blender's cells); cell (i, j, k) covers "
         "local coordinates [0, 1]^3.");
}

void bind_lattice_bounds(py::module_& m) {
  Class<PyVolumeBounds>(m, "VolumeRatioBounds", R"(Bounds of det J: unpacks as (lower, upper).

`converged` is False when the work cap stopped the refinement; `minimum` is the least value of
det J found, at `where` ((cell), (local coordinates); None when it is the identity's 1 outside
the lattice ('unchanged') or no cell was bounded); `cells` how many cells were bounded.)")
      .def_property_readonly("lower", [](const PyVolumeBounds& r) { return r.b.lower; })
      .def_property_readonly("upper", [](const PyVolumeBounds& r) { return r.b.upper; })
      .def_property_readonly("converged", [](const PyVolumeBounds& r) { return r.b.converged; })
      .def_property_readonly("minimum", [](const PyVolumeBounds& r) { return r.b.minimum; })
      .def_property_readonly("where", [](const PyVolumeBounds& r) -> py::object {
        if (!r.b.has_where) return py::none();
        return py::make_tuple(triple(r.b.where.cell), triple(r.b.where.local));
      })
      .def_property_readonly("scale", [](const PyVolumeBounds& r) { return r.b.scale; })
      .def_property_readonly("cells", [](const PyVolumeBounds& r) { return r.b.cells; })
      .def_property_readonly("subdivisions", [](const PyVolumeBounds& r) { return r.b.subdivisions; })
      .def("__len__", [](const PyVolumeBounds&) { return 2; })
      .def("__getitem__", [](const PyVolumeBounds& r, std::int64_t i) {
        if (i < -2 || i > 1) throw py::index_error("VolumeRatioBounds index out of range (it is (lower, upper))");
        return (i == 0 || i == -2) ? r.b.lower : r.b.upper;
      }, "index"_a)
      .def("__iter__", [](const PyVolumeBounds& r) { return py::iter(py::make_tuple(r.b.lower, r.b.upper)); })
      .def("__repr__", [](const PyVolumeBounds& r) {
        return "VolumeRatioBounds(lower=" + std::string(py::repr(py::float_(r.b.lower))) +
               ", upper=" + std::string(py::repr(py::float_(r.b.upper))) +
               ", converged=" + (r.b.converged ? "True" : "False") + ", cells=" + std::to_string(r.b.cells) + ")";
      });

  Class<PyFoldCertificate>(m, "FoldCertificate", R"(Whether a lattice is proven not to fold (det J > 0).

Truthy only when `certified`. `lower` is the least lower bound of det J the decision reached;
`cells` lists (cell, local coordinates, lower bound) for each cell where det J <= 0 was found
(`folded` True at that index: the coordinates are where) or could not be ruled out within the
work cap (the coordinates are where the bound is least).)")
      .def_property_readonly("certified", [](const PyFoldCertificate& r) { return r.c.certified; })
      .def_property_readonly("lower", [](const PyFoldCertificate& r) { return r.c.lower; })
      .def_property_readonly("cells", [](const PyFoldCertificate& r) {
        py::list out;
        for (const FoldCell& f : r.c.cells) out.append(py::make_tuple(triple(f.where.cell), triple(f.where.local), f.lower));
        return out;
      })
      .def_property_readonly("folded", [](const PyFoldCertificate& r) {
        py::list out;
        for (const FoldCell& f : r.c.cells) out.append(f.folded);
        return out;
      })
      .def_property_readonly("cells_checked", [](const PyFoldCertificate& r) { return r.c.cells_checked; })
      .def("__bool__", [](const PyFoldCertificate& r) { return r.c.certified; })
      .def("__repr__", [](const PyFoldCertificate& r) {
        return "FoldCertificate(certified=" + std::string(r.c.certified ? "True" : "False") +
               ", lower=" + std::string(py::repr(py::float_(r.c.lower))) + ", cells=" + std::to_string(r.c.cells.size()) + ")";
      });
  add_bounds_methods<FFD>(Class<FFD, ControlLattice, std::shared_ptr<FFD>>(m.attr("FFD")));
  add_bounds_methods<BezierFFD>(Class<BezierFFD, ControlLattice, std::shared_ptr<BezierFFD>>(m.attr("BezierFFD")));
  add_bounds_methods<BSplineLattice>(
      Class<BSplineLattice, ControlLattice, std::shared_ptr<BSplineLattice>>(m.attr("BSplineLattice")));
  add_bounds_methods<BlenderLattice>(
      Class<BlenderLattice, ControlLattice, std::shared_ptr<BlenderLattice>>(m.attr("BlenderLattice")));
}

}  // namespace

void bind_lattice(py::module_& m) {
  Class<PyBinding>(m, "LatticeBinding", R"(Points bound to a lattice: their lattice coordinates, found once.

`lattice.deform_bound(binding)` then deforms them with the lattice's current control points.)")
      .def("__len__", [](const PyBinding& b) { return b.binding->size(); })
      .def_property_readonly("status", [](const PyBinding& b) {
        return copied_array(b.binding->status.data(), {py::ssize_t(b.binding->size())});
      }, "Per point: 0 inside the lattice, 1 outside (the outside policy applies), 2 not placed (extended "
         "FFD: Newton did not converge; left unchanged).")
      .def_property_readonly("parameters", [](const PyBinding& b) { return parameters_array(*b.binding); },
                             "Normalised lattice coordinates (s, t, u), (n, 3).")
      .def("weights", &py_weights, R"(The sparse weight matrix W as CSR (indptr, indices, data).

Columns are flattened control points (i * nv + j) * nw + k; deform = x + strength * W (P - R)
(then blended by the lattice's per-point weights, if any). Rows of points the lattice leaves
unchanged are empty.)");

  Class<PyDirect>(m, "DirectManipulation", "Result of Lattice.direct_manipulation.")
      .def_readonly("control_points", &PyDirect::control_points, "The new control points (nu, nv, nw, 3).")
      .def_readonly("displacement", &PyDirect::displacement, "New minus old control points.")
      .def_readonly("residual", &PyDirect::residual, "Distance from each deformed point to its target.")
      .def_readonly("max_residual", &PyDirect::max_residual)
      .def_readonly("rank", &PyDirect::rank, "Rank of the constraint matrix.")
      .def_readonly("volume", &PyDirect::volume,
                    "With preserve_volume: the mesh's signed volume under the new control points (else None).")
      .def_readonly("volume_target", &PyDirect::volume_target,
                    "With preserve_volume: its volume under the lattice's current control points (else None).")
      .def_readonly("volume_residual", &PyDirect::volume_residual,
                    "With preserve_volume: |volume - volume_target| / |volume_target|, at most 1e-12 (else None).")
      .def_readonly("iterations", &PyDirect::iterations, "With preserve_volume: the SQP iterations taken (else 0).");

  Class<ControlLattice, Deformer, std::shared_ptr<ControlLattice>>(m, "Lattice", "Interface of the lattice deformers.")
      .def_property("control_points",
                    [](const ControlLattice& l) { return grid_array(l.control_points(), l.resolution()); },
                    [](ControlLattice& l, const py::object& g) {
                      l.set_control_points(parse_grid(g, l.resolution(), "control_points"));
                    }, "Control points (nu, nv, nw, 3) in the points' space; assigning validates and copies.")
      .def_property_readonly("rest_control_points",
                             [](const ControlLattice& l) { return grid_array(l.rest_control_points(), l.resolution()); })
      .def_property_readonly("resolution", [](const ControlLattice& l) {
        const auto r = l.resolution();
        return py::make_tuple(r[0], r[1], r[2]);
      })
      .def_property_readonly("strength", &ControlLattice::strength)
      .def_property_readonly("outside", [](const ControlLattice& l) { return kOutsideNames.name(l.outside()); })
      .def_property_readonly("handle_index", [](const ControlLattice& l) {
        const auto r = l.resolution();
        return copied_array(l.handle_of().data(), {py::ssize_t(r[0]), py::ssize_t(r[1]), py::ssize_t(r[2])});
      }, "For each control point, the handle it belongs to (merged control points share one).")
      .def_property_readonly("handles", &ControlLattice::handle_count)
      .def("bind", &py_bind, "points"_a, "Bind points: find their lattice coordinates once (LatticeBinding).")
      .def("deform_bound", &py_deform_bound, "binding"_a, py::kw_only(), "out"_a = py::none(),
           "Deform bound points with the current control points; equals deform(points). The dtype is that of "
           "the bound points.")
      .def("displacement_bound", &py_displacement_bound, "binding"_a, py::kw_only(), "out"_a = py::none(),
           "w (F(x) - x) of the bound points in one pass (w: the weights, 1 without): what deform_bound gives "
           "minus the bound points, computed without them. The dtype is that of the bound points.")
      .def("lattice_coordinates", [](const std::shared_ptr<ControlLattice>& l, const py::object& points) {
        return parameters_array(*py_bind(l, points).binding);
      }, "points"_a, "Normalised lattice coordinates (s, t, u) of each point (the lecture's cross-product formulas).")
      .def("direct_manipulation", &py_direct, "points"_a, "targets"_a, py::kw_only(),
           "preserve_volume"_a = py::none(),
           R"(Smallest control-point change that moves `points` to `targets` (Hsu, Hughes, Kaufman 1992).

Minimum-norm least squares over the control points (merged ones move together): exact when the
constraints allow it, otherwise the least-squares compromise, whose distances are `residual`.
With per-point weights (one per row of `points`) a point of weight w moves w times as far, as
deform() moves it, and the solve plans for that; a point of weight 0 cannot move. Returns a
DirectManipulation; the lattice is not modified (assign result.control_points).

preserve_volume=(mesh_points, mesh_faces), a closed, consistently oriented mesh (faces: an
(m, k) array or a list of polygons), also keeps the mesh's signed volume under the lattice
(without per-point weights) at its volume under the current control points, to 1e-12 relative:
the smallest change that meets the targets as closely as without it, found by SQP (Hirota et
al. 1999); result.volume, volume_target, volume_residual and iterations report it. A clear error
when the handles pin every control point that could change the volume.)");

  Class<FFD, ControlLattice, std::shared_ptr<FFD>>(m, "FFD", (std::string(R"(Sederberg-Parry free-form deformation.

One trivariate Bernstein polynomial of degree (l, m, n) (1..15 each), (l+1)(m+1)(n+1) control
points (Sederberg and Parry 1986).)") + kPlacementDoc).c_str())
      .def(py::init([](const py::object& degree, const py::object& origin, const py::object& edges,
                       const py::object& frame, const py::object& cps, const std::string& outside, double strength,
                       const py::object& weights) {
             return finish(std::make_shared<FFD>(parse_box(origin, edges, frame), parse_counts(degree, "degree"),
                                                 parse_outside(outside), finite_param(strength, "strength")),
                           cps, weights);
           }),
           "degree"_a = 3, py::kw_only(), "origin"_a = py::none(), "edges"_a = py::none(), "frame"_a = py::none(),
           "control_points"_a = py::none(), "outside"_a = "clamp", "strength"_a = 1.0, "weights"_a = py::none())
      .def_property_readonly("degree", [](const FFD& l) {
        const auto r = l.resolution();
        return py::make_tuple(r[0] - 1, r[1] - 1, r[2] - 1);
      });

  Class<BezierFFD, ControlLattice, std::shared_ptr<BezierFFD>>(m, "BezierFFD", (std::string(R"(Piecewise tricubic Bezier FFD blocks.

blocks (a, b, c) give (3a+1, 3b+1, 3c+1) control points; neighbouring blocks share a face
layer (C0); C1 holds where the three control points across a face are collinear and evenly
spaced. A point's block is floor(s * blocks), its local coordinate the fraction.)") + kPlacementDoc).c_str())
      .def(py::init([](const py::object& blocks, const py::object& origin, const py::object& edges,
                       const py::object& frame, const py::object& cps, const std::string& outside, double strength,
                       const py::object& weights) {
             return finish(std::make_shared<BezierFFD>(parse_box(origin, edges, frame), parse_counts(blocks, "blocks"),
                                                       parse_outside(outside), finite_param(strength, "strength")),
                           cps, weights);
           }),
           "blocks"_a = 1, py::kw_only(), "origin"_a = py::none(), "edges"_a = py::none(), "frame"_a = py::none(),
           "control_points"_a = py::none(), "outside"_a = "clamp", "strength"_a = 1.0, "weights"_a = py::none());

  Class<BSplineLattice, ControlLattice, std::shared_ptr<BSplineLattice>>(m, "BSplineLattice", (std::string(R"(Uniform cubic B-spline FFD (C2 everywhere).

resolution >= 4 control points per axis, evenly spaced over the box at rest; the spline covers
the box's inner part, s in [1/(n-1), (n-2)/(n-1)] per axis, and `outside` applies beyond it.)") +
                                                                                             kPlacementDoc).c_str())
      .def(py::init([](const py::object& resolution, const py::object& origin, const py::object& edges,
                       const py::object& frame, const py::object& cps, const std::string& outside, double strength,
                       const py::object& weights) {
             return finish(std::make_shared<BSplineLattice>(parse_box(origin, edges, frame),
                                                            parse_counts(resolution, "resolution"),
                                                            parse_outside(outside), finite_param(strength, "strength")),
                           cps, weights);
           }),
           "resolution"_a = 4, py::kw_only(), "origin"_a = py::none(), "edges"_a = py::none(), "frame"_a = py::none(),
           "control_points"_a = py::none(), "outside"_a = "clamp", "strength"_a = 1.0, "weights"_a = py::none());

  Class<BlenderLattice, ControlLattice, std::shared_ptr<BlenderLattice>>(m, "BlenderLattice", (std::string(R"(Blender's Lattice modifier, reproduced.

resolution 1..64 per axis (points_u/v/w), interpolation 'linear', 'cardinal', 'catmull_rom' or
'bspline' (or Blender's 'KEY_...' names), one for all axes or (u, v, w). For a Lattice object
`lat` on mesh object `obj`: frame = inverse(obj.matrix_world) @ lat.matrix_world, and the
control points are co_deform mapped by frame. strength and weights (the modifier's vertex
group) as in Blender. Outside the lattice Blender clamps control-point indices, so outside
points take the boundary's displacement ('clamp', the default); 'unchanged' is also offered.)") +
                                                                                             kPlacementDoc).c_str())
      .def(py::init([](const py::object& resolution, const py::object& interpolation, const py::object& origin,
                       const py::object& edges, const py::object& frame, const py::object& cps,
                       const std::string& outside, double strength, const py::object& weights) {
             return finish(std::make_shared<BlenderLattice>(parse_box(origin, edges, frame),
                                                            parse_counts(resolution, "resolution"),
                                                            parse_interpolation(interpolation), parse_outside(outside),
                                                            finite_param(strength, "strength")),
                           cps, weights);
           }),
           "resolution"_a = 2, "interpolation"_a = "bspline", py::kw_only(), "origin"_a = py::none(),
           "edges"_a = py::none(), "frame"_a = py::none(), "control_points"_a = py::none(), "outside"_a = "clamp",
           "strength"_a = 1.0, "weights"_a = py::none())
      .def_property_readonly("interpolation", [](const BlenderLattice& l) {
        return py::make_tuple(interpolation_name(l.axes()[0].kind), interpolation_name(l.axes()[1].kind),
                              interpolation_name(l.axes()[2].kind));
      });

  auto make_effd = [](const py::object& rest, const py::object& cps, double strength, const py::object& weights,
                      double tolerance, std::int64_t max_iterations) {
    const auto a = real_array(rest, "rest_control_points");
    if (a.ndim() != 4 || a.shape(3) != 3)
      throw py::value_error("rest_control_points: expected shape (3a+1, 3b+1, 3c+1, 3), got " + shape_of(a));
    const std::array<int, 3> counts{int(a.shape(0)), int(a.shape(1)), int(a.shape(2))};
    NewtonSettings newton{finite_param(tolerance, "tolerance"), int_arg(max_iterations, "max_iterations", 1, 1000)};
    auto l = std::make_shared<ExtendedFFD>(counts, std::vector<double>(a.data(), a.data() + a.size()),
                                           finite_param(strength, "strength"), newton);
    return finish(l, cps, weights);
  };
  Class<ExtendedFFD, ControlLattice, std::shared_ptr<ExtendedFFD>>(m, "ExtendedFFD", R"(Coquillart's extended FFD.

A grid of tricubic Bezier blocks, rest_control_points (3a+1, 3b+1, 3c+1, 3), of any shape.
Each point is located by a bounding-box (convex hull) test and Newton iteration from
(0.5, 0.5, 0.5) in the blocks that may hold it, restarting from the octant centres; binding
reports status 1 for points outside every block and 2 where Newton did not converge, and both
are left unchanged. Control points that coincide at rest are merged into one handle and must
move together (handle_index).)")
      .def(py::init(make_effd), "rest_control_points"_a, py::kw_only(), "control_points"_a = py::none(),
           "strength"_a = 1.0, "weights"_a = py::none(), "tolerance"_a = 1e-10, "max_iterations"_a = 30)
      .def_static("cylinder", [make_effd](double radius, double height, const py::object& blocks, const py::object& center,
                                          const py::object& axis, double strength, const py::object& weights,
                                          double tolerance, std::int64_t max_iterations) {
        const auto b = parse_counts(blocks, "blocks");
        const Vec3 c = center.is_none() ? Vec3::Zero() : parse_vec3(center, "center");
        const auto grid = ExtendedFFD::cylinder_grid(finite_param(radius, "radius"), finite_param(height, "height"), b, c,
                                                     parse_axis(axis, "axis"));
        const std::array<int, 3> counts{3 * b[0] + 1, 3 * b[1] + 1, 3 * b[2] + 1};
        return generated_effd(make_effd, grid_array(grid, counts), strength, weights, tolerance, max_iterations,
                              "radius, height, center: the cylinder they give");
      }, "radius"_a = 1.0, "height"_a = 1.0, "blocks"_a = py::make_tuple(1, 4, 1), "center"_a = py::none(),
         "axis"_a = "z", "strength"_a = 1.0, "weights"_a = py::none(), "tolerance"_a = 1e-10, "max_iterations"_a = 30,
         R"(A cylindrical lattice: s runs from the axis out to `radius`, t once around (cubic Bezier arcs, blocks[1] >= 3),
u along the axis over `height`, centred at `center`. The seam and the axis are merged handles.)")
      .def_static("prism", [make_effd](const py::object& triangle, const py::object& height, const py::object& blocks,
                                       double strength, const py::object& weights, double tolerance, std::int64_t max_iterations) {
        const Mat3 tri = parse_matrix(triangle, "triangle", 3, 3,
                                      "expected three corners A, B, C as a 3x3 array (one per row)", false);
        const Vec3 a = tri.row(0).transpose(), b = tri.row(1).transpose(), c = tri.row(2).transpose();
        const auto n = parse_counts(blocks, "blocks");
        const auto grid = ExtendedFFD::prism_grid(a, b, c, parse_vec3(height, "height"), n);
        const std::array<int, 3> counts{3 * n[0] + 1, 3 * n[1] + 1, 3 * n[2] + 1};
        return generated_effd(make_effd, grid_array(grid, counts), strength, weights, tolerance, max_iterations,
                              "triangle, height: the prism they give");
      }, "triangle"_a, "height"_a, "blocks"_a = 1, "strength"_a = 1.0, "weights"_a = py::none(), "tolerance"_a = 1e-10,
         "max_iterations"_a = 30,
         R"(A triangular prism: the triangle A, B, C swept along `height`. s runs from A to B, t toward C
(where the control points of each s merge into the edge through C), u along the height.)")
      .def_property_readonly("tolerance", [](const ExtendedFFD& l) { return l.newton().tolerance; })
      .def_property_readonly("max_iterations", [](const ExtendedFFD& l) { return l.newton().max_iterations; });
  bind_lattice_bounds(m);
}

}  // namespace deformkit_py
