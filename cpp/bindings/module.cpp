// Python bindings: argument conversion and checking only; the math lives in cpp/src.
#include "deformkit/build_info.hpp"
#include "deformkit/deformkit.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <optional>
#include <string>

namespace py = pybind11;
using namespace py::literals;
using namespace deformkit;

namespace {

std::string shape_of(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

// An (n, 3) float32/float64 array, C-contiguous (copied only when the layout requires it).
py::array points_array(const py::handle& obj, const char* name) {
  if (!py::isinstance<py::array>(obj))
    throw py::type_error(std::string(name) + ": expected a numpy array of shape (n, 3), got " +
                         std::string(py::str(py::type::of(obj).attr("__name__"))));
  auto a = py::reinterpret_borrow<py::array>(obj);
  const auto kind = a.dtype().kind();
  // By kind and size, so that byte-swapped or metadata-carrying float dtypes are accepted too.
  const bool f32 = kind == 'f' && a.itemsize() == 4, f64 = kind == 'f' && a.itemsize() == 8;
  if (!f32 && !f64)
    throw py::type_error(std::string(name) + ": expected float32 or float64, got " +
                         std::string(py::str(a.dtype())) + (kind == 'f' ? "" : " (convert with .astype(np.float64))"));
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error(std::string(name) + ": expected shape (n, 3), got " + shape_of(a));
  if (a.shape(0) == 0) throw py::value_error(std::string(name) + ": is empty (0 rows)");
  if (f32) return py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(a);
  return py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
}

py::array_t<double, py::array::c_style> as_double(const py::array& a) {
  return py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
}

int parse_axis(const py::object& axis, const char* name) {
  if (py::isinstance<py::str>(axis)) {
    const std::string s = axis.cast<std::string>();
    if (s == "x" || s == "X") return 0;
    if (s == "y" || s == "Y") return 1;
    if (s == "z" || s == "Z") return 2;
  } else if (!py::isinstance<py::bool_>(axis) && PyIndex_Check(axis.ptr())) {  // int, numpy integers
    const long long i = PyNumber_AsSsize_t(axis.ptr(), nullptr);  // saturates instead of overflowing
    if (PyErr_Occurred()) PyErr_Clear();
    else if (i >= 0 && i <= 2) return static_cast<int>(i);
  }
  throw py::value_error(std::string(name) + ": expected 'x', 'y', 'z' or 0, 1, 2, got " +
                        std::string(py::repr(axis)));
}

double finite_param(double v, const char* name) {
  if (!std::isfinite(v)) throw py::value_error(std::string(name) + ": must be finite, got " + std::to_string(v));
  return v;
}

// Real numbers only: forcecast would silently drop an imaginary part or call into objects.
void require_real(const py::object& obj, const char* name) {
  const py::array a = py::array::ensure(obj);
  if (a && (a.dtype().kind() == 'c' || a.dtype().kind() == 'O' || a.dtype().kind() == 'U' || a.dtype().kind() == 'S'))
    throw py::type_error(std::string(name) + ": expected real numbers, got " + std::string(py::str(a.dtype())));
}

Frame parse_frame(const py::object& obj, const char* name) {
  if (obj.is_none()) return Frame{};
  require_real(obj, name);
  py::array_t<double, py::array::c_style | py::array::forcecast> a;
  try {
    a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  } catch (const py::error_already_set&) {
  }
  if (!a || a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
    throw py::value_error(std::string(name) + ": expected a 4x4 matrix" + (a ? ", got shape " + shape_of(a) : ""));
  Mat4 m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = a.at(r, c);
  return Frame::from_matrix(m, name);
}

std::pair<double, double> parse_range(const py::object& obj, const char* name) {
  const double inf = std::numeric_limits<double>::infinity();
  if (obj.is_none()) return {-inf, inf};
  std::vector<double> v;
  require_real(obj, name);
  try {
    v = obj.cast<std::vector<double>>();
  } catch (const py::cast_error&) {
  }
  if (v.size() != 2) throw py::value_error(std::string(name) + ": expected (lo, hi)");
  if (std::isnan(v[0]) || std::isnan(v[1])) throw py::value_error(std::string(name) + ": contains NaN");
  if (v[0] > v[1]) throw py::value_error(std::string(name) + ": lo must not exceed hi");
  return {v[0], v[1]};
}

std::vector<double> parse_vector(const py::object& obj, const char* name) {
  require_real(obj, name);
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  if (!a || a.ndim() != 1) throw py::value_error(std::string(name) + ": expected a 1-D sequence of numbers");
  return std::vector<double>(a.data(), a.data() + a.size());
}

// A linear law offset + rate * clamp(z, limits), or a natural cubic spline through samples.
Profile parse_law(double offset, const std::optional<double>& rate, const py::object& limits,
                  const py::object& profile, const std::string& extend) {
  Extend ext;
  if (extend == "constant") ext = Extend::Constant;
  else if (extend == "linear") ext = Extend::Linear;
  else throw py::value_error("extend: expected 'constant' or 'linear', got '" + extend + "'");
  if (profile.is_none()) {
    const auto [lo, hi] = parse_range(limits, "limits");
    return Profile::linear(offset, finite_param(rate.value_or(0.785398163397448), "rate"), lo, hi);
  }
  if (rate) throw py::value_error("rate: give either rate or profile, not both");
  if (!limits.is_none()) throw py::value_error("limits: a profile sets its own range; give either limits or profile");
  py::sequence seq;
  if (!py::isinstance<py::sequence>(profile) || py::len(profile) != 2)
    throw py::value_error("profile: expected a pair (positions, values)");
  seq = profile;
  return Profile::spline(parse_vector(seq[0], "profile positions"), parse_vector(seq[1], "profile values"), ext);
}

void apply_weights(Deformer& d, const py::object& weights) {
  if (!weights.is_none()) d.set_weights(parse_vector(weights, "weights"));
}

enum class Output { Positions, Displacement };

template <class T>
py::array deform_typed(const Deformer& d, const py::array& pts, const py::object& out, Output what) {
  const auto n = static_cast<std::size_t>(pts.shape(0));
  py::array_t<T> result;
  if (out.is_none()) {
    result = py::array_t<T>({pts.shape(0), py::ssize_t(3)});
  } else {
    auto o = py::reinterpret_borrow<py::array>(out);
    if (!py::isinstance<py::array_t<T>>(o) || !o.dtype().is(pts.dtype()))
      throw py::type_error("out: must have the dtype of points (" + std::string(py::str(pts.dtype())) + ")");
    if (o.ndim() != 2 || o.shape(0) != pts.shape(0) || o.shape(1) != 3)
      throw py::value_error("out: expected shape " + shape_of(pts) + ", got " + shape_of(o));
    if (!(o.flags() & py::array::c_style) || !o.writeable())
      throw py::value_error("out: must be a writeable C-contiguous array");
    const auto* a0 = static_cast<const char*>(pts.data());
    const auto* b0 = static_cast<const char*>(o.data());
    if (a0 != b0 && a0 < b0 + o.nbytes() && b0 < a0 + pts.nbytes())
      throw py::value_error("out: overlaps points without being the same array (pass points itself for in place)");
    result = py::reinterpret_borrow<py::array_t<T>>(o);
  }
  const T* in = static_cast<const T*>(pts.data());
  T* dst = result.mutable_data();
  {
    py::gil_scoped_release release;
    if (what == Output::Positions) d.deform(in, dst, n);
    else d.displacement(in, dst, n);
  }
  return std::move(result);
}

py::array deform_or_displace(const Deformer& d, const py::object& points, const py::object& out, Output what) {
  if (!out.is_none() && !py::isinstance<py::array>(out)) throw py::type_error("out: expected a numpy array or None");
  const py::array pts = points_array(points, "points");
  if (pts.dtype().is(py::dtype::of<float>())) return deform_typed<float>(d, pts, out, what);
  return deform_typed<double>(d, pts, out, what);
}

py::array py_deform(const Deformer& d, const py::object& points, const py::object& out) {
  return deform_or_displace(d, points, out, Output::Positions);
}

py::array py_displacement(const Deformer& d, const py::object& points, const py::object& out) {
  return deform_or_displace(d, points, out, Output::Displacement);
}

py::array cast_like(py::array_t<double> result, const py::array& like) {
  if (like.dtype().is(py::dtype::of<float>())) return result.attr("astype")(py::dtype::of<float>());
  return std::move(result);
}

py::array py_jacobian(const Deformer& d, const py::object& points) {
  const py::array pts = points_array(points, "points");
  const auto p = as_double(pts);
  const auto n = static_cast<std::size_t>(pts.shape(0));
  py::array_t<double> jac({pts.shape(0), py::ssize_t(3), py::ssize_t(3)});
  const double* in = p.data();
  double* dst = jac.mutable_data();
  {
    py::gil_scoped_release release;
    d.jacobian(in, dst, n);
  }
  return cast_like(jac, pts);
}

py::array py_normals(const Deformer& d, const py::object& points, const py::object& normals) {
  const py::array pts = points_array(points, "points");
  const py::array nrm = points_array(normals, "normals");
  if (nrm.shape(0) != pts.shape(0))
    throw py::value_error("normals: has " + std::to_string(nrm.shape(0)) + " rows but points has " +
                          std::to_string(pts.shape(0)));
  const auto p = as_double(pts), q = as_double(nrm);
  const auto n = static_cast<std::size_t>(pts.shape(0));
  py::array_t<double> out({pts.shape(0), py::ssize_t(3)});
  const double *in = p.data(), *nin = q.data();
  double* dst = out.mutable_data();
  {
    py::gil_scoped_release release;
    transform_normals(d, in, nin, dst, n);
  }
  return cast_like(out, nrm);
}

py::array py_volume_ratio(const Deformer& d, const py::object& points) {
  const py::array pts = points_array(points, "points");
  const auto p = as_double(pts);
  const auto n = static_cast<std::size_t>(pts.shape(0));
  py::array_t<double> out(pts.shape(0));
  const double* in = p.data();
  double* dst = out.mutable_data();
  {
    py::gil_scoped_release release;
    volume_ratio(d, in, dst, n);
  }
  return cast_like(out, pts);
}

py::object weights_of(const Deformer& d) {
  if (d.weights().empty()) return py::none();
  return py::array_t<double>(d.weights().size(), d.weights().data());
}

SimpleDeformMode parse_mode(const std::string& mode) {
  if (mode == "TWIST") return SimpleDeformMode::Twist;
  if (mode == "BEND") return SimpleDeformMode::Bend;
  if (mode == "TAPER") return SimpleDeformMode::Taper;
  if (mode == "STRETCH") return SimpleDeformMode::Stretch;
  throw py::value_error("mode: expected 'TWIST', 'BEND', 'TAPER' or 'STRETCH', got '" + mode + "'");
}

const char* mode_name(SimpleDeformMode m) {
  switch (m) {
    case SimpleDeformMode::Twist: return "TWIST";
    case SimpleDeformMode::Bend: return "BEND";
    case SimpleDeformMode::Taper: return "TAPER";
    case SimpleDeformMode::Stretch: return "STRETCH";
  }
  return "?";
}

const char* kDeformDoc = R"(Deform points: returns F(x) for each row of `points` ((n, 3) float32 or float64).

The result has the dtype of `points`; the input is never modified. Pass `out=` (same shape and
dtype, C-contiguous; it may be `points` itself) to write in place. With weights w, the result is
x + w (F(x) - x).)";
const char* kDisplacementDoc = R"(Displacement F(x) - x for each row of `points`, as `deform` returns positions.

Same dtype rules and `out=` as `deform`, except that `out` may not be `points` itself.)";
const char* kJacobianDoc = R"(Jacobian J = dF/dx at each point, shape (n, 3, 3), J[i, r, c] = dF_r/dx_c (Barr 1984, eq. for J(X)).)";
const char* kNormalsDoc = R"(Carry unit normals through the map: N' = det(J) J^-T N (the cofactor matrix), renormalised.)";
const char* kVolumeDoc = R"(Local volume ratio det(J) at each point.)";

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "deformkit native core: spatial deformers with exact Jacobians.";

  py::class_<Deformer, std::shared_ptr<Deformer>>(m, "Deformer",
                                                  "Interface shared by every spatial deformer.")
      .def("deform", &py_deform, "points"_a, py::kw_only(), "out"_a = py::none(), kDeformDoc)
      .def("displacement", &py_displacement, "points"_a, py::kw_only(), "out"_a = py::none(), kDisplacementDoc)
      .def("jacobian", &py_jacobian, "points"_a, kJacobianDoc)
      .def("transform_normals", &py_normals, "points"_a, "normals"_a, kNormalsDoc)
      .def("volume_ratio", &py_volume_ratio, "points"_a, kVolumeDoc)
      .def_property_readonly("weights", &weights_of, "Per-point blend weights, or None.");

  py::class_<Twist, Deformer, std::shared_ptr<Twist>>(m, "Twist", R"(Barr's twist about an axis.

x' = x cos(t) - y sin(t), y' = x sin(t) + y cos(t), z' = z with t = f(z) (Barr 1984, twisting).
By default f(z) = rate * clamp(z, limits) (limits None: unbounded); with `profile=(z, theta)` f is
the natural cubic spline through the samples, held constant (extend='constant') or continued
along its end tangents (extend='linear') outside them. `axis` is the twist axis; `frame` (4x4)
places the deformer's coordinates in object space.)")
      .def(py::init([](std::optional<double> rate, const py::object& axis, const py::object& limits,
                       const py::object& profile, const std::string& extend, const py::object& frame,
                       const py::object& weights) {
             auto d = std::make_shared<Twist>(parse_law(0.0, rate, limits, profile, extend), parse_axis(axis, "axis"),
                                              parse_frame(frame, "frame"));
             apply_weights(*d, weights);
             return d;
           }),
           "rate"_a = py::none(), "axis"_a = "z", "limits"_a = py::none(), "profile"_a = py::none(),
           "extend"_a = "constant", "frame"_a = py::none(), "weights"_a = py::none());

  py::class_<Taper, Deformer, std::shared_ptr<Taper>>(m, "Taper", R"(Barr's taper along an axis.

x' = r x, y' = r y, z' = z with r = f(z) (Barr 1984, tapering; det J = r^2). By default
f(z) = 1 + rate * clamp(z, limits); `profile=(z, r)` gives r by a natural cubic spline.)")
      .def(py::init([](std::optional<double> rate, const py::object& axis, const py::object& limits,
                       const py::object& profile, const std::string& extend, const py::object& frame,
                       const py::object& weights) {
             auto d = std::make_shared<Taper>(parse_law(1.0, rate, limits, profile, extend), parse_axis(axis, "axis"),
                                              parse_frame(frame, "frame"));
             apply_weights(*d, weights);
             return d;
           }),
           "rate"_a = py::none(), "axis"_a = "z", "limits"_a = py::none(), "profile"_a = py::none(),
           "extend"_a = "constant", "frame"_a = py::none(), "weights"_a = py::none());

  py::class_<Stretch, Deformer, std::shared_ptr<Stretch>>(m, "Stretch", R"(Blender's stretch along an axis.

With z^ = clamp(z, limits) and s = 1 + k (z^2 - 1): x' = s x, y' = s y, z' = z + k z^
(MOD_simpledeform). Approximately volume preserving near |z| = 1 only.)")
      .def(py::init([](double factor, const py::object& axis, const py::object& limits, const py::object& frame,
                       const py::object& weights) {
             const auto [lo, hi] = parse_range(limits, "limits");
             auto d = std::make_shared<Stretch>(finite_param(factor, "factor"), lo, hi, parse_axis(axis, "axis"),
                                                parse_frame(frame, "frame"));
             apply_weights(*d, weights);
             return d;
           }),
           "factor"_a = 0.785398163397448, "axis"_a = "z", "limits"_a = py::none(), "frame"_a = py::none(),
           "weights"_a = py::none());

  py::class_<Bend, Deformer, std::shared_ptr<Bend>>(m, "Bend", R"(Barr's bend.

In canonical coordinates x is kept and the y axis bends toward +z on a circle of radius 1/k:
t = k (y^ - y0) with y^ = clamp(y, region); y' = -sin(t)(z - 1/k) + y0 + cos(t)(y - y^),
z' = cos(t)(z - 1/k) + 1/k + sin(t)(y - y^) (Barr 1984, bending; outside the region the ends
continue along the tangent). det J = 1 - k z inside the region. Evaluated in a half-angle
form that tends to the identity as k -> 0. `axis` is the kept axis (canonical x); the
length and bend directions follow cyclically (axis='z': length along x, bends toward y).)")
      .def(py::init([](double curvature, double center, const py::object& region, const py::object& axis,
                       const py::object& frame, const py::object& weights) {
             const auto [lo, hi] = parse_range(region, "region");
             auto d = std::make_shared<Bend>(finite_param(curvature, "curvature"), finite_param(center, "center"), lo,
                                             hi, parse_axis(axis, "axis"), parse_frame(frame, "frame"));
             apply_weights(*d, weights);
             return d;
           }),
           "curvature"_a = 0.785398163397448, "center"_a = 0.0, "region"_a = py::none(), "axis"_a = "x",
           "frame"_a = py::none(), "weights"_a = py::none());

  py::class_<SimpleDeform, Deformer, std::shared_ptr<SimpleDeform>>(m, "SimpleDeform",
                                                                     R"(Blender's Simple Deform modifier, reproduced.

Settings as in Blender: mode ('TWIST', 'BEND', 'TAPER', 'STRETCH'), angle (twist, bend) or
factor (taper, stretch) -- one value, as in Blender --, deform_axis, origin (4x4 matrix of the
origin object in this object's local space, i.e. inverse(object.matrix_world) @
origin.matrix_world), limits (fractions of the bounding extent), lock_x/y/z, weights (the vertex
group) and invert_weights. As in Blender, the amount is spread over the limited extent of the
points given: k = amount / (L1 - L0), measured in the origin frame on each call; the Jacobian
is that of the map with these bounds held fixed.)")
      .def(py::init([](const std::string& mode, std::optional<double> angle, std::optional<double> factor,
                       const py::object& deform_axis, const py::object& origin, const py::object& limits,
                       bool lock_x, bool lock_y, bool lock_z, const py::object& weights, bool invert_weights) {
             if (angle && factor) throw py::value_error("angle: give angle or factor (they are one value), not both");
             SimpleDeformSettings s;
             s.mode = parse_mode(mode);
             s.factor = finite_param(angle ? *angle : factor.value_or(0.785398163397448), angle ? "angle" : "factor");
             s.deform_axis = parse_axis(deform_axis, "deform_axis");
             s.origin = parse_frame(origin, "origin");
             const auto [lo, hi] = parse_range(limits, "limits");
             s.limit_lo = lo;
             s.limit_hi = hi;
             s.lock = {lock_x, lock_y, lock_z};
             auto d = std::make_shared<SimpleDeform>(s);
             if (!weights.is_none()) {
               auto w = parse_vector(weights, "weights");
               if (invert_weights)
                 for (double& x : w) x = 1.0 - x;
               d->set_weights(std::move(w));
             } else if (invert_weights) {
               throw py::value_error("invert_weights: needs weights");
             }
             return d;
           }),
           "mode"_a = "TWIST", "angle"_a = py::none(), "factor"_a = py::none(), "deform_axis"_a = "X",
           "origin"_a = py::none(), "limits"_a = py::make_tuple(0.0, 1.0), "lock_x"_a = false, "lock_y"_a = false,
           "lock_z"_a = false, "weights"_a = py::none(), "invert_weights"_a = false)
      .def_property_readonly("mode", [](const SimpleDeform& d) { return mode_name(d.settings().mode); })
      .def_property_readonly("angle", [](const SimpleDeform& d) { return d.settings().factor; })
      .def_property_readonly("factor", [](const SimpleDeform& d) { return d.settings().factor; })
      .def_property_readonly("deform_axis", [](const SimpleDeform& d) { return std::string(1, "XYZ"[d.settings().deform_axis]); })
      .def_property_readonly("limits", [](const SimpleDeform& d) {
        return py::make_tuple(d.settings().limit_lo, d.settings().limit_hi);
      });

  py::class_<Stack, Deformer, std::shared_ptr<Stack>>(m, "Stack", R"(Composition of deformers, applied in order.

F = F_n o ... o F_1, with the chain rule J = J_n(F_n-1(...)) ... J_1(x) for jacobian, normals and
volume ratio. Stacks nest.)")
      .def(py::init([](const std::vector<std::shared_ptr<Deformer>>& deformers, const py::object& weights) {
             std::vector<DeformerPtr> list(deformers.begin(), deformers.end());
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

  m.def("build_info", []() {
    py::dict info;
    for (const auto& [k, v] : build_info()) info[py::str(k)] = v;
    return info;
  }, "Versions compiled in, the SIMD instruction set chosen for this CPU and the thread count.");
}
