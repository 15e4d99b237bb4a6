// Argument conversion shared by the binding files.
#include "common.hpp"

#include <cmath>

namespace deformkit_py {


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

py::array output_array(const py::object& out, py::ssize_t rows, const py::dtype& dtype, const py::array* source) {
  if (out.is_none()) return py::array(dtype, std::vector<py::ssize_t>{rows, 3});
  if (!py::isinstance<py::array>(out)) throw py::type_error("out: expected a numpy array or None");
  auto o = py::reinterpret_borrow<py::array>(out);
  if (!o.dtype().is(dtype)) throw py::type_error("out: must have dtype " + std::string(py::str(dtype)));
  if (o.ndim() != 2 || o.shape(0) != rows || o.shape(1) != 3)
    throw py::value_error("out: expected shape (" + std::to_string(rows) + ", 3), got " + shape_of(o));
  if (!(o.flags() & py::array::c_style) || !o.writeable())
    throw py::value_error("out: must be a writeable C-contiguous array");
  if (source) {
    const auto* a0 = static_cast<const char*>(source->data());
    const auto* b0 = static_cast<const char*>(o.data());
    if (a0 != b0 && a0 < b0 + o.nbytes() && b0 < a0 + source->nbytes())
      throw py::value_error("out: overlaps points without being the same array (pass points itself for in place)");
  }
  return o;
}

template <class T>
static py::array deform_typed(const Deformer& d, const py::array& pts, const py::object& out, Output what) {
  const auto n = static_cast<std::size_t>(pts.shape(0));
  if (!out.is_none() && py::isinstance<py::array>(out) && !py::reinterpret_borrow<py::array>(out).dtype().is(pts.dtype()))
    throw py::type_error("out: must have the dtype of points (" + std::string(py::str(pts.dtype())) + ")");
  py::array result = output_array(out, pts.shape(0), pts.dtype(), &pts);
  const T* in = static_cast<const T*>(pts.data());
  T* dst = static_cast<T*>(result.mutable_data());
  {
    py::gil_scoped_release release;
    if (what == Output::Positions) d.deform(in, dst, n);
    else d.displacement(in, dst, n);
  }
  return result;
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
  const bool single = pts.dtype().is(py::dtype::of<float>());  // as cast_like: the core checks the float range
  {
    py::gil_scoped_release release;
    d.jacobian(in, dst, n, single);
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
  const bool single = pts.dtype().is(py::dtype::of<float>());  // as cast_like: the core checks the float range
  {
    py::gil_scoped_release release;
    volume_ratio(d, in, dst, n, single);
  }
  return cast_like(out, pts);
}

py::object weights_of(const Deformer& d) {
  if (d.weights().empty()) return py::none();
  return py::array_t<double>(d.weights().size(), d.weights().data());
}


// An (m, k) integer array, or a sequence of index sequences (polygons of mixed sizes).
Faces parse_faces(const py::object& faces) {
  std::vector<std::int64_t> corners, offsets{0};
  if (py::isinstance<py::array>(faces)) {
    const py::array a = py::reinterpret_borrow<py::array>(faces);
    if (a.dtype().kind() != 'i' && a.dtype().kind() != 'u')
      throw py::type_error("faces: expected integer vertex indices, got " + std::string(py::str(a.dtype())));
    const auto f = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(a);
    if (f.ndim() != 2 || f.shape(0) == 0 || f.shape(1) < 3)
      throw py::value_error("faces: expected shape (m, k) with m >= 1 and k >= 3, got " + shape_of(f));
    corners.assign(f.data(), f.data() + f.size());
    for (py::ssize_t i = 1; i <= f.shape(0); ++i) offsets.push_back(i * f.shape(1));
    return {corners, offsets};
  }
  if (!py::isinstance<py::sequence>(faces) || py::isinstance<py::str>(faces))
    throw py::type_error("faces: expected an (m, k) integer array or a list of index lists");
  for (const py::handle& face : py::reinterpret_borrow<py::sequence>(faces)) {
    std::vector<std::int64_t> idx;
    try {
      idx = face.cast<std::vector<std::int64_t>>();
    } catch (const py::cast_error&) {
      throw py::type_error("faces: every face must be a sequence of integer vertex indices");
    }
    corners.insert(corners.end(), idx.begin(), idx.end());
    offsets.push_back(std::int64_t(corners.size()));
  }
  if (offsets.size() < 2) throw py::value_error("faces: no faces");
  return {corners, offsets};
}

}  // namespace deformkit_py
