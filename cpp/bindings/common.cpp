// Argument conversion shared by the binding files.
#include "common.hpp"

#include <cmath>

namespace deformkit_py {


std::string shape_of(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

bool is_float32(const py::array& a) { return a.dtype().kind() == 'f' && a.itemsize() == 4; }

std::string gigabytes(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g GB", bytes / 1e9);
  return buf;
}

std::string working_size(std::size_t n, double bytes_per_point) {
  return std::to_string(n) + " points, " + gigabytes(double(n) * bytes_per_point);
}

[[noreturn]] void throw_memory_error(const std::string& message) {
  PyErr_SetString(PyExc_MemoryError, message.c_str());
  throw py::error_already_set();
}

template <class T>
static const char* dtype_name() {
  if (std::is_same<T, float>::value) return "float32";
  if (std::is_same<T, double>::value) return "float64";
  return std::is_signed<T>::value ? "int64" : "uint8";
}

template <class T>
py::array_t<T, py::array::c_style> c_array(const py::handle& obj, const char* name) {
  if (py::isinstance<py::array>(obj)) {
    const auto a = py::reinterpret_borrow<py::array>(obj);
    if (holds<T>(a) && (a.flags() & py::array::c_style)) return py::reinterpret_borrow<py::array_t<T, py::array::c_style>>(a);
  }
  static const py::object& asarray = *new py::object(py::module_::import("numpy").attr("array"));
  py::object result;
  try {
    // A copy in native order, aligned and C-contiguous; numpy's own conversion rules.
    result = asarray(obj, py::dtype::of<T>(), py::arg("copy") = true, py::arg("order") = "C");
  } catch (py::error_already_set& e) {
    if (e.matches(PyExc_MemoryError)) {
      double bytes = sizeof(T);
      std::string shape = "";
      if (py::isinstance<py::array>(obj)) {
        const auto a = py::reinterpret_borrow<py::array>(obj);
        bytes *= double(a.size());
        shape = " of shape " + shape_of(a);
      }
      throw_memory_error(std::string(name) + ": not enough memory for a contiguous " + dtype_name<T>() + " copy" +
                         shape + " (" + gigabytes(bytes) + ")");
    }
    if (e.matches(PyExc_TypeError) || e.matches(PyExc_ValueError) || e.matches(PyExc_OverflowError))
      throw py::type_error(std::string(name) + ": expected an array of numbers, got " +
                           std::string(py::str(py::type::of(obj).attr("__name__"))) + " (" + e.what() + ")");
    throw;
  }
  const auto a = py::reinterpret_borrow<py::array>(result);
  if (!holds<T>(a) || !(a.flags() & py::array::c_style))
    throw py::type_error(std::string(name) + ": could not be converted to a native C-contiguous " + dtype_name<T>() +
                         " array");
  return py::reinterpret_borrow<py::array_t<T, py::array::c_style>>(a);
}
template py::array_t<float, py::array::c_style> c_array<float>(const py::handle&, const char*);
template py::array_t<double, py::array::c_style> c_array<double>(const py::handle&, const char*);
template py::array_t<std::int64_t, py::array::c_style> c_array<std::int64_t>(const py::handle&, const char*);

template <class T>
py::array_t<T, py::array::c_style> new_array(const std::vector<py::ssize_t>& shape, const char* what) {
  try {
    return py::array_t<T, py::array::c_style>(shape);
  } catch (py::error_already_set& e) {
    if (!e.matches(PyExc_MemoryError) && !e.matches(PyExc_ValueError)) throw;
    double bytes = sizeof(T);
    std::string dims = "(";
    for (std::size_t i = 0; i < shape.size(); ++i) {
      bytes *= double(shape[i]);
      dims += (i ? ", " : "") + std::to_string(shape[i]);
    }
    throw_memory_error(std::string("not enough memory for ") + what + ", a " + dtype_name<T>() + " array of shape " +
                       dims + ") (" + gigabytes(bytes) + ")");
  }
}
template py::array_t<float, py::array::c_style> new_array<float>(const std::vector<py::ssize_t>&, const char*);
template py::array_t<double, py::array::c_style> new_array<double>(const std::vector<py::ssize_t>&, const char*);

void require_float_dtype(const py::array& a, const char* name) {
  // By kind and size, so that byte-swapped or metadata-carrying float dtypes are accepted too.
  const auto kind = a.dtype().kind();
  if (kind == 'f' && (a.itemsize() == 4 || a.itemsize() == 8)) return;
  throw py::type_error(std::string(name) + ": expected float32 or float64, got " + std::string(py::str(a.dtype())) +
                       (kind == 'c' || kind == 'O' || kind == 'U' || kind == 'S' ? " (real numbers only)"
                                                                                 : " (convert with .astype(np.float64))"));
}

py::array_t<double, py::array::c_style> real_array(const py::handle& obj, const char* name) {
  static const py::object& numpy_generic = *new py::object(py::module_::import("numpy").attr("generic"));
  if (py::isinstance<py::array>(obj)) {
    require_float_dtype(py::reinterpret_borrow<py::array>(obj), name);
    return c_array<double>(obj, name);
  }
  if (py::isinstance(obj, numpy_generic)) {  // a numpy scalar carries its dtype as an array does
    require_float_dtype(py::array::ensure(obj), name);
    return c_array<double>(obj, name);
  }
  // Python numbers: numpy reads them as int64 or float64 (bool, complex, strings and objects
  // are what they are, and refused).
  const py::array a = py::array::ensure(obj);
  if (!a) {
    PyErr_Clear();
    throw py::type_error(std::string(name) + ": expected real numbers (a float32 or float64 array, or a sequence of "
                         "numbers), got " + std::string(py::str(py::type::of(obj).attr("__name__"))));
  }
  const auto kind = a.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u')
    throw py::type_error(std::string(name) + ": expected real numbers (a float32 or float64 array, or a sequence of "
                         "numbers), got " + std::string(py::str(py::type::of(obj).attr("__name__"))) + " of " +
                         std::string(py::str(a.dtype())));
  if (kind == 'f') require_float_dtype(a, name);  // a list of float16 or longdouble scalars
  return c_array<double>(a, name);
}

// An (n, 3) float32/float64 numpy array, C-contiguous (copied only when the layout requires it).
py::array points_array(const py::handle& obj, const char* name) {
  if (!py::isinstance<py::array>(obj))
    throw py::type_error(std::string(name) + ": expected a numpy array of shape (n, 3), got " +
                         std::string(py::str(py::type::of(obj).attr("__name__"))));
  auto a = py::reinterpret_borrow<py::array>(obj);
  require_float_dtype(a, name);
  const bool f32 = a.itemsize() == 4;
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error(std::string(name) + ": expected shape (n, 3), got " + shape_of(a));
  if (a.shape(0) == 0) throw py::value_error(std::string(name) + ": is empty (0 rows)");
  if (f32) return c_array<float>(a, name);
  return c_array<double>(a, name);
}

py::array_t<double, py::array::c_style> as_double(const py::array& a, const char* name) {
  return c_array<double>(a, name);
}

// [lo, hi) of the bytes an array's strides reach.
static std::pair<std::uintptr_t, std::uintptr_t> byte_bounds(const py::array& a) {
  auto lo = reinterpret_cast<std::uintptr_t>(a.data()), hi = lo;
  if (a.size() == 0) return {lo, lo};
  for (py::ssize_t i = 0; i < a.ndim(); ++i) {
    const py::ssize_t reach = (a.shape(i) - 1) * a.strides(i);
    if (reach < 0) lo -= std::uintptr_t(-reach);
    else hi += std::uintptr_t(reach);
  }
  return {lo, hi + std::uintptr_t(a.itemsize())};
}

bool overlaps(const py::array& a, const py::array& b) {
  const auto [a0, a1] = byte_bounds(a);
  const auto [b0, b1] = byte_bounds(b);
  return a0 < b1 && b0 < a1;
}

bool same_memory(const py::array& a, const py::array& b) {
  if (a.data() != b.data() || a.ndim() != b.ndim() || a.itemsize() != b.itemsize()) return false;
  for (py::ssize_t i = 0; i < a.ndim(); ++i)
    if (a.shape(i) != b.shape(i) || a.strides(i) != b.strides(i)) return false;
  return true;
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

int int_arg(std::int64_t v, const char* name, int lo, int hi) {
  if (v < lo || v > hi)
    throw py::value_error(std::string(name) + ": must be " + std::to_string(lo) + ".." + std::to_string(hi) +
                          ", got " + std::to_string(v));
  return static_cast<int>(v);
}

bool bool_arg(const py::handle& v, const char* name) {
  static const py::object& numpy_bool = *new py::object(py::module_::import("numpy").attr("bool_"));
  if (py::isinstance<py::bool_>(v) || py::isinstance(v, numpy_bool)) return PyObject_IsTrue(v.ptr()) == 1;
  throw py::type_error(std::string(name) + ": expected True or False, got " +
                       std::string(py::str(py::type::of(v).attr("__name__"))) + " " + std::string(py::repr(v)));
}

py::ssize_t sequence_length(const py::handle& obj) {
  if (py::isinstance<py::str>(obj) || py::isinstance<py::bytes>(obj) || !PySequence_Check(obj.ptr())) return -1;
  const py::ssize_t n = PySequence_Size(obj.ptr());  // a 0-d array is a "sequence" without a length
  if (n < 0) PyErr_Clear();
  return n;
}

Eigen::MatrixXd parse_matrix(const py::object& obj, const char* name, py::ssize_t rows, py::ssize_t cols,
                             const std::string& expected, bool report_shape) {
  const auto a = real_array(obj, name);
  if (a.ndim() != 2 || a.shape(0) != rows || a.shape(1) != cols)
    throw py::value_error(std::string(name) + ": " + expected + (report_shape ? ", got shape " + shape_of(a) : ""));
  Eigen::MatrixXd m(rows, cols);
  for (py::ssize_t r = 0; r < rows; ++r)
    for (py::ssize_t c = 0; c < cols; ++c) m(r, c) = a.at(r, c);
  return m;
}

Mat4 parse_mat4(const py::object& obj, const char* name, bool report_shape) {
  return parse_matrix(obj, name, 4, 4, "expected a 4x4 matrix", report_shape);
}

Frame parse_frame(const py::object& obj, const char* name) {
  if (obj.is_none()) return Frame{};
  return Frame::from_matrix(parse_mat4(obj, name, true), name);
}

std::pair<double, double> parse_range(const py::object& obj, const char* name) {
  const double inf = std::numeric_limits<double>::infinity();
  if (obj.is_none()) return {-inf, inf};
  std::vector<double> v;
  if (sequence_length(obj) == 2) {
    const auto a = real_array(obj, name);
    if (a.ndim() == 1) v.assign(a.data(), a.data() + 2);
  }
  if (v.size() != 2)
    throw py::value_error(std::string(name) + ": expected (lo, hi), got " + std::string(py::repr(obj)).substr(0, 60));
  if (std::isnan(v[0]) || std::isnan(v[1])) throw py::value_error(std::string(name) + ": contains NaN");
  if (v[0] > v[1]) throw py::value_error(std::string(name) + ": lo must not exceed hi");
  if (v[0] == inf || v[1] == -inf)
    throw py::value_error(std::string(name) + ": expected lo <= hi with lo < +inf and hi > -inf, got (" + std::to_string(v[0]) + ", " +
                          std::to_string(v[1]) + ")");
  return {v[0], v[1]};
}

std::vector<double> parse_vector(const py::object& obj, const char* name) {
  const auto a = real_array(obj, name);
  if (a.ndim() != 1)
    throw py::value_error(std::string(name) + ": expected a 1-D sequence of numbers, got shape " + shape_of(a));
  return std::vector<double>(a.data(), a.data() + a.size());
}

// A linear law offset + rate * clamp(z, limits), or a natural cubic spline through samples.
Profile parse_law(double offset, const std::optional<double>& rate, const py::object& limits,
                  const py::object& profile, const std::string& extend) {
  static const EnumNames<Extend> extends("extend", {{"constant", Extend::Constant}, {"linear", Extend::Linear}});
  const Extend ext = extends.parse(extend);
  if (profile.is_none()) {
    const auto [lo, hi] = parse_range(limits, "limits");
    return Profile::linear(offset, finite_param(rate.value_or(0.785398163397448), "rate"), lo, hi);
  }
  if (rate) throw py::value_error("rate: give either rate or profile, not both");
  if (!limits.is_none()) throw py::value_error("limits: a profile sets its own range; give either limits or profile");
  py::sequence seq;
  if (sequence_length(profile) != 2)
    throw py::value_error("profile: expected a pair (positions, values)");
  seq = profile;
  return Profile::spline(parse_vector(seq[0], "profile positions"), parse_vector(seq[1], "profile values"), ext);
}

void apply_weights(Deformer& d, const py::object& weights) {
  if (!weights.is_none()) d.set_weights(parse_vector(weights, "weights"));
}

template <class T>
py::array output_array(const py::object& out, py::ssize_t rows, const py::handle& source, bool in_place) {
  if (out.is_none()) return new_array<T>({rows, 3}, "the result");
  if (!py::isinstance<py::array>(out)) throw py::type_error("out: expected a numpy array or None");
  auto o = py::reinterpret_borrow<py::array>(out);
  const char* want = std::is_same<T, float>::value ? "float32" : "float64";
  if (o.dtype().kind() != 'f' || o.itemsize() != py::ssize_t(sizeof(T)))
    throw py::type_error(std::string(source.is_none() ? "out: must have dtype " : "out: must have the dtype of points (") +
                         want + (source.is_none() ? "" : ")") + ", got " + std::string(py::str(o.dtype())));
  if (!holds<T>(o))
    throw py::type_error(std::string("out: must be native-order and aligned ") + want + ", got " +
                         std::string(py::str(o.dtype())) + (o.dtype().byteorder() == '>' ? " (byte-swapped)" : " (unaligned)"));
  if (o.ndim() != 2 || o.shape(0) != rows || o.shape(1) != 3)
    throw py::value_error("out: expected shape (" + std::to_string(rows) + ", 3), got " + shape_of(o));
  if (!(o.flags() & py::array::c_style) || !o.writeable())
    throw py::value_error("out: must be a writeable C-contiguous array");
  if (source && py::isinstance<py::array>(source)) {
    const auto src = py::reinterpret_borrow<py::array>(source);
    if (!in_place && same_memory(src, o)) throw py::value_error("out: displacement cannot be written over points");
    if (overlaps(src, o) && !(in_place && same_memory(src, o)))
      throw py::value_error(in_place ? "out: overlaps points without being the same array (pass points itself for in place)"
                                     : "out: overlaps points (this result cannot be written over its input)");
  }
  return o;
}
template py::array output_array<float>(const py::object&, py::ssize_t, const py::handle&, bool);
template py::array output_array<double>(const py::object&, py::ssize_t, const py::handle&, bool);

template <class T>
static py::array deform_typed(const Deformer& d, const py::handle& points, const py::array& pts,
                              const py::object& out, Output what) {
  const auto n = static_cast<std::size_t>(pts.shape(0));
  py::array result = output_array<T>(out, pts.shape(0), points, what == Output::Positions);
  const T* in = static_cast<const T*>(pts.data());
  T* dst = static_cast<T*>(result.mutable_data());
  without_gil("the deformer's working arrays (" + working_size(n, 3.0 * sizeof(T)) + ")", [&] {
    if (what == Output::Positions) d.deform(in, dst, n);
    else d.displacement(in, dst, n);
  });
  return result;
}

py::array deform_or_displace(const Deformer& d, const py::object& points, const py::object& out, Output what) {
  if (!out.is_none() && !py::isinstance<py::array>(out)) throw py::type_error("out: expected a numpy array or None");
  const py::array pts = points_array(points, "points");
  if (is_float32(pts)) return deform_typed<float>(d, points, pts, out, what);
  return deform_typed<double>(d, points, pts, out, what);
}

py::array py_deform(const Deformer& d, const py::object& points, const py::object& out) {
  return deform_or_displace(d, points, out, Output::Positions);
}

py::array py_displacement(const Deformer& d, const py::object& points, const py::object& out) {
  return deform_or_displace(d, points, out, Output::Displacement);
}

// A derivative call's out=: the result's own shape and dtype (float32 exactly when the call would
// return float32), writeable, C-contiguous, native and aligned, sharing no memory with an input.
static py::array derivative_out(const py::object& out, const std::vector<py::ssize_t>& shape, bool single,
                                std::initializer_list<py::array> inputs) {
  if (!py::isinstance<py::array>(out)) throw py::type_error("out: expected a numpy array or None");
  auto o = py::reinterpret_borrow<py::array>(out);
  const char* want = single ? "float32" : "float64";
  const bool dtype_ok = single ? holds<float>(o) : holds<double>(o);
  if (!dtype_ok)
    throw py::type_error(std::string("out: expected a native-order aligned ") + want + " array (the result's dtype), got " +
                         std::string(py::str(o.dtype())) + (o.dtype().byteorder() == '>' ? " (byte-swapped)" : ""));
  std::string expected = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) expected += (i ? ", " : "") + std::to_string(shape[i]);
  expected += shape.size() == 1 ? ",)" : ")";
  if (o.ndim() != py::ssize_t(shape.size()) || !std::equal(shape.begin(), shape.end(), o.shape()))
    throw py::value_error("out: expected shape " + expected + ", got " + shape_of(o));
  if (!(o.flags() & py::array::c_style) || !o.writeable())
    throw py::value_error("out: must be a writeable C-contiguous array");
  for (const py::array& in : inputs)
    if (overlaps(in, o)) throw py::value_error("out: overlaps an input (this result cannot be written over it)");
  return o;
}

// The double result computed into `out` directly, or through a double array when out is float32.
template <class F>
static py::array into_out(const py::object& out, const std::vector<py::ssize_t>& shape, bool single,
                          std::initializer_list<py::array> inputs, const char* what, F&& compute) {
  if (out.is_none()) {
    auto result = new_array<double>(shape, what);
    compute(result.mutable_data());
    return single ? py::array(result.attr("astype")(py::dtype::of<float>())) : py::array(std::move(result));
  }
  py::array o = derivative_out(out, shape, single, inputs);
  if (!single) {
    compute(static_cast<double*>(o.mutable_data()));
    return o;
  }
  auto tmp = new_array<double>(shape, what);
  compute(tmp.mutable_data());
  std::copy(tmp.data(), tmp.data() + tmp.size(), static_cast<float*>(o.mutable_data()));
  return o;
}

py::array py_jacobian(const Deformer& d, const py::object& points, const py::object& out) {
  const py::array pts = points_array(points, "points");
  const auto p = as_double(pts);
  const auto n = static_cast<std::size_t>(pts.shape(0));
  const bool single = is_float32(pts);  // the core checks the float range of a float32 result
  return into_out(out, {pts.shape(0), py::ssize_t(3), py::ssize_t(3)}, single, {pts}, "the Jacobians", [&](double* dst) {
    const double* in = p.data();
    without_gil("the Jacobians' working arrays (" + working_size(n, 72.0) + ")", [&] { d.jacobian(in, dst, n, single); });
  });
}

py::array py_normals(const Deformer& d, const py::object& points, const py::object& normals, const py::object& out) {
  const py::array pts = points_array(points, "points");
  const py::array nrm = points_array(normals, "normals");
  if (nrm.shape(0) != pts.shape(0))
    throw py::value_error("normals: has " + std::to_string(nrm.shape(0)) + " rows but points has " +
                          std::to_string(pts.shape(0)));
  const auto n = static_cast<std::size_t>(pts.shape(0));
  const std::string working = "the Jacobians behind the normals (" + working_size(n, 72.0) + ")";
  if (is_float32(pts) && is_float32(nrm)) {  // a viewport's normals: computed in float where the deformer can
    const auto p = c_array<float>(pts, "points"), q = c_array<float>(nrm, "normals");
    py::array result = out.is_none() ? py::array(new_array<float>({pts.shape(0), py::ssize_t(3)}, "the normals"))
                                     : derivative_out(out, {pts.shape(0), py::ssize_t(3)}, true, {pts, nrm});
    const float *in = p.data(), *nin = q.data();
    float* dst = static_cast<float*>(result.mutable_data());
    without_gil(working, [&] { transform_normals(d, in, nin, dst, n); });
    return result;
  }
  const auto p = as_double(pts), q = as_double(nrm, "normals");
  return into_out(out, {pts.shape(0), py::ssize_t(3)}, is_float32(nrm), {pts, nrm}, "the normals", [&](double* dst) {
    const double *in = p.data(), *nin = q.data();
    without_gil(working, [&] { transform_normals(d, in, nin, dst, n); });
  });
}

py::array py_volume_ratio(const Deformer& d, const py::object& points, const py::object& out) {
  const py::array pts = points_array(points, "points");
  const auto p = as_double(pts);
  const auto n = static_cast<std::size_t>(pts.shape(0));
  const bool single = is_float32(pts);  // the core checks the float range of a float32 result
  return into_out(out, {pts.shape(0)}, single, {pts}, "the volume ratios", [&](double* dst) {
    const double* in = p.data();
    without_gil("the Jacobians behind the volume ratios (" + working_size(n, 72.0) + ")",
                [&] { volume_ratio(d, in, dst, n, single); });
  });
}

py::object weights_of(const Deformer& d) {
  if (d.weights().empty()) return py::none();
  return copied_array(d.weights().data(), {py::ssize_t(d.weights().size())});
}

py::tuple csr_tuple(std::vector<std::int64_t>&& indptr, std::vector<std::int32_t>&& indices,
                    std::vector<double>&& values) {
  const auto rows = py::ssize_t(indptr.size()), columns = py::ssize_t(indices.size()),
             weights = py::ssize_t(values.size());
  return py::make_tuple(owned_array(std::move(indptr), {rows}), owned_array(std::move(indices), {columns}),
                        owned_array(std::move(values), {weights}));
}


// An (m, k) integer array, or a sequence of index sequences (polygons of mixed sizes).
Faces parse_faces(const py::object& faces) {
  std::vector<std::int64_t> corners, offsets{0};
  if (py::isinstance<py::array>(faces)) {
    const py::array a = py::reinterpret_borrow<py::array>(faces);
    if (a.dtype().kind() != 'i' && a.dtype().kind() != 'u')
      throw py::type_error("faces: expected integer vertex indices, got " + std::string(py::str(a.dtype())));
    const auto f = c_array<std::int64_t>(a, "faces");
    if (f.ndim() != 2 || f.shape(0) == 0 || f.shape(1) < 3)
      throw py::value_error("faces: expected shape (m, k) with m >= 1 and k >= 3, got " + shape_of(f));
    corners.assign(f.data(), f.data() + f.size());
    offsets.reserve(std::size_t(f.shape(0)) + 1);
    for (py::ssize_t i = 1; i <= f.shape(0); ++i) offsets.push_back(i * f.shape(1));
    return {std::move(corners), std::move(offsets)};
  }
  if (sequence_length(faces) < 0)
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
  return {std::move(corners), std::move(offsets)};
}

// An (m, k) array of int32 or int64 with m >= 1, k >= 3 (which parse_faces would accept as it is)
// is read in place; other integer arrays and lists go through parse_faces.
template <class Index>
std::optional<py::array_t<Index, py::array::c_style>> uniform_face_array(const py::object& faces) {
  if (!py::isinstance<py::array>(faces)) return std::nullopt;
  const py::array a = py::reinterpret_borrow<py::array>(faces);
  if (a.dtype().kind() != 'i' || a.dtype().itemsize() != sizeof(Index) || a.ndim() != 2 || a.shape(0) == 0 ||
      a.shape(1) < 3 || a.shape(1) > std::numeric_limits<int>::max())
    return std::nullopt;
  return c_array<Index>(a, "faces");
}
template std::optional<py::array_t<std::int32_t, py::array::c_style>> uniform_face_array(const py::object&);

PolygonMesh parse_polygon_mesh(const py::object& points, const py::object& faces) {
  const auto p = as_double(points_array(points, "points"));
  const std::size_t n = std::size_t(p.shape(0));
  if (const auto f = uniform_face_array<std::int32_t>(faces))
    return PolygonMesh(p.data(), n, f->data(), std::size_t(f->shape(0)), int(f->shape(1)));
  if (const auto f = uniform_face_array<std::int64_t>(faces))
    return PolygonMesh(p.data(), n, f->data(), std::size_t(f->shape(0)), int(f->shape(1)));
  const Faces f = parse_faces(faces);
  return PolygonMesh(p.data(), n, f.corners, f.offsets);
}

std::string prefixed_argument(const std::string& message, const std::string& prefix) {
  for (const char* name : {"points", "faces"})
    if (message.rfind(std::string(name) + ":", 0) == 0) return prefix + "_" + message;
  return message;
}

}  // namespace deformkit_py
