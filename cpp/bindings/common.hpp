#pragma once
// Argument conversion shared by the binding files, and the methods every deformer exposes.
#include "deformkit/deformkit.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <initializer_list>
#include <new>
#include <optional>
#include <type_traits>
#include <string>
#include <utility>
#include <vector>

namespace deformkit_py {

namespace py = pybind11;
using namespace deformkit;

std::string shape_of(const py::array& a);

// Arrays cross into C++ checked by value -- dtype kind, item size, byte order, alignment, layout --
// never by dtype identity: a pickled or metadata-carrying float32 dtype is a different object
// with the same meaning.
template <class T>
bool holds(const py::array& a) {
  const char kind = std::is_floating_point<T>::value ? 'f' : std::is_signed<T>::value ? 'i' : 'u';
  const char order = a.dtype().byteorder();
  return a.dtype().kind() == kind && a.itemsize() == py::ssize_t(sizeof(T)) && order != '>' &&
         (a.flags() & py::detail::npy_api::NPY_ARRAY_ALIGNED_);
}
bool is_float32(const py::array& a);

// `obj` as a C-contiguous, aligned, native-order array of T, copied only when needed. Allocation
// failure is a MemoryError naming `name` and the size; anything that is not numbers, an error
// naming `name`.
template <class T>
py::array_t<T, py::array::c_style> c_array(const py::handle& obj, const char* name);

// A new array of T, or a MemoryError naming `what`.
template <class T>
py::array_t<T, py::array::c_style> new_array(const std::vector<py::ssize_t>& shape, const char* what);

[[noreturn]] void throw_memory_error(const std::string& message);

// Runs `work` without the GIL; std::bad_alloc inside it becomes a MemoryError naming `what` (the
// core's working arrays are allocated there, on the user's behalf).
template <class F>
void without_gil(const std::string& what, F&& work) {
  bool out_of_memory = false;
  {
    py::gil_scoped_release release;
    try {
      work();
    } catch (const std::bad_alloc&) {
      out_of_memory = true;
    }
  }
  if (out_of_memory) throw_memory_error("not enough memory for " + what);
}

// "n points (x GB)": the size of a working array of `bytes_per_point` bytes a point, for messages.
std::string working_size(std::size_t n, double bytes_per_point);
std::string gigabytes(double bytes);

// The one dtype rule of every real-valued array that crosses into C++, constructors, setters and
// methods alike: a numpy array (or numpy scalar) must be float32 or float64, by value (either
// byte order); any other dtype -- integers, bool, float16, longdouble, complex, datetime64,
// timedelta64, object, strings -- is a TypeError naming `name`, the dtype it got and what it
// accepts. A plain Python sequence of numbers has no dtype and is read as float64.
void require_float_dtype(const py::array& a, const char* name);
// A real-valued argument of any shape, as a C-contiguous float64 array, through that rule.
py::array_t<double, py::array::c_style> real_array(const py::handle& obj, const char* name);

// An (n, 3) float32/float64 numpy array, C-contiguous (copied only when the layout requires it).
py::array points_array(const py::handle& obj, const char* name);

py::array_t<double, py::array::c_style> as_double(const py::array& a, const char* name = "points");

// True when the memory of a and b intersects (by the bounds their strides reach), and
// same_memory when they are exactly one another's layout.
bool overlaps(const py::array& a, const py::array& b);
bool same_memory(const py::array& a, const py::array& b);

int parse_axis(const py::object& axis, const char* name);

double finite_param(double v, const char* name);

// An integer argument narrowed to int: outside lo..hi it is refused naming `name` (the core's
// own range, repeated here only so that values beyond int's range are reported as given).
int int_arg(std::int64_t v, const char* name, int lo, int hi);

// True or False (Python's or numpy's) only: pybind11's bool would take any object with a truth value.
bool bool_arg(const py::handle& v, const char* name);

// The length of a list, tuple or other sized sequence (not a string, not a 0-d array), else -1.
py::ssize_t sequence_length(const py::handle& obj);

Frame parse_frame(const py::object& obj, const char* name);

std::pair<double, double> parse_range(const py::object& obj, const char* name);

std::vector<double> parse_vector(const py::object& obj, const char* name);

// A linear law offset + rate * clamp(z, limits), or a natural cubic spline through samples.
Profile parse_law(double offset, const std::optional<double>& rate, const py::object& limits,
                  const py::object& profile, const std::string& extend);

void apply_weights(Deformer& d, const py::object& weights);

enum class Output { Positions, Displacement };

// `out` checked (dtype, shape, layout, writeable, no overlap with the caller's `source` unless it
// is that very array and `in_place` allows it), or a new (rows, 3) array.
template <class T>
py::array output_array(const py::object& out, py::ssize_t rows, const py::handle& source, bool in_place);

py::array deform_or_displace(const Deformer& d, const py::object& points, const py::object& out, Output what);

py::array py_deform(const Deformer& d, const py::object& points, const py::object& out);

py::array py_displacement(const Deformer& d, const py::object& points, const py::object& out);

py::array py_jacobian(const Deformer& d, const py::object& points, const py::object& out);

py::array py_normals(const Deformer& d, const py::object& points, const py::object& normals, const py::object& out);

py::array py_volume_ratio(const Deformer& d, const py::object& points, const py::object& out);

py::object weights_of(const Deformer& d);

// One table of the names of an enum's values, for parsing an argument and naming a value back.
// An unknown name is a ValueError "<argument>: expected 'a', 'b' or 'c', got '<given>'", the names
// listed in table order.
template <class E>
class EnumNames {
 public:
  EnumNames(const char* argument, std::initializer_list<std::pair<const char*, E>> names)
      : argument_(argument), names_(names) {}
  E parse(const std::string& name) const { return parse(name, name); }
  // Looks up `name` (the caller's normalised spelling); the error shows `given`, as typed.
  E parse(const std::string& name, const std::string& given) const {
    for (const auto& [n, value] : names_)
      if (name == n) return value;
    throw py::value_error(std::string(argument_) + ": expected " + expected() + ", got '" + given + "'");
  }
  // The first name of `value`, or "?" for a value the table does not list.
  const char* name(E value) const {
    for (const auto& [n, v] : names_)
      if (v == value) return n;
    return "?";
  }
  // 'a', 'b' or 'c'
  std::string expected() const {
    std::string s;
    for (std::size_t i = 0; i < names_.size(); ++i)
      s += std::string(i == 0 ? "" : i + 1 == names_.size() ? " or " : ", ") + "'" + names_[i].first + "'";
    return s;
  }

 private:
  const char* argument_;
  std::vector<std::pair<const char*, E>> names_;
};

// A real (rows x cols) matrix argument. A wrong shape is a ValueError "<name>: <expected>", followed
// by ", got shape (...)" when report_shape is set.
Eigen::MatrixXd parse_matrix(const py::object& obj, const char* name, py::ssize_t rows, py::ssize_t cols,
                             const std::string& expected, bool report_shape);
// A 4x4 matrix ("<name>: expected a 4x4 matrix").
Mat4 parse_mat4(const py::object& obj, const char* name, bool report_shape);

// An integer index array: numpy's conversion of `obj` (an empty sequence of any dtype is
// accepted), its shape checked by check_shape(array) (which throws the caller's message), then
// converted to int64. Anything that is not integers is a TypeError "<name>: expected <what>".
template <class CheckShape>
std::vector<std::int64_t> parse_index_array(const py::object& obj, const char* name, const char* what,
                                            CheckShape&& check_shape) {
  const py::array a = py::array::ensure(obj);
  if (!a || (a.size() > 0 && a.dtype().kind() != 'i' && a.dtype().kind() != 'u'))
    throw py::type_error(std::string(name) + ": expected " + what);
  check_shape(a);
  const auto v = c_array<std::int64_t>(a, name);
  return {v.data(), v.data() + v.size()};
}

// Results handed to Python: a numpy array that takes over the vector's buffer (no copy), or a
// copy of `data` (the C++ object keeps its own).
template <class T>
py::array_t<T> owned_array(std::vector<T>&& v, std::vector<py::ssize_t> shape) {
  auto* heap = new std::vector<T>(std::move(v));
  py::capsule owner(heap, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, heap->data(), owner);
}
template <class T>
py::array_t<T> copied_array(const T* data, std::vector<py::ssize_t> shape) {
  return py::array_t<T>(shape, data);
}
// A CSR matrix as the tuple (indptr int64, indices int32, data float64) that scipy.sparse takes.
py::tuple csr_tuple(std::vector<std::int64_t>&& indptr, std::vector<std::int32_t>&& indices,
                    std::vector<double>&& values);

// Polygons as a flat corner list and offsets (face f is corners[offsets[f] .. offsets[f + 1])).
struct Faces {
  std::vector<std::int64_t> corners, offsets;
};
// An (m, k) integer array, or a sequence of index sequences (polygons of mixed sizes).
Faces parse_faces(const py::object& faces);
// `points` (n, 3) and `faces` (as parse_faces) as one checked PolygonMesh: the one way every
// binding that takes a mesh reads it.
PolygonMesh parse_polygon_mesh(const py::object& points, const py::object& faces);
// The core names a mesh's arrays `points` and `faces`; a binding taking a named mesh (a cage, a
// source, a target) runs its reading in `read` and gets those errors as `<prefix>_points: ...`,
// `<prefix>_faces: ...` (the type kept; std::invalid_argument becomes ValueError).
std::string prefixed_argument(const std::string& message, const std::string& prefix);
template <class F>
auto with_mesh_prefix(const std::string& prefix, F&& read) -> decltype(read()) {
  try {
    return read();
  } catch (const py::type_error& e) {
    throw py::type_error(prefixed_argument(e.what(), prefix));
  } catch (const py::value_error& e) {
    throw py::value_error(prefixed_argument(e.what(), prefix));
  } catch (const std::invalid_argument& e) {
    throw py::value_error(prefixed_argument(e.what(), prefix));
  }
}
// `faces` as an (m, k) C-contiguous array of Index when it is one that parse_faces accepts as it is
// (m >= 1, 3 <= k), without a copy where its layout allows; nullopt for anything else.
template <class Index>
std::optional<py::array_t<Index, py::array::c_style>> uniform_face_array(const py::object& faces);

// One binding file per family: core.cpp (Deformer, Stack, mesh_volume), barr.cpp, lattice.cpp,
// surface.cpp, subdivision.cpp, cage.cpp.
void bind_core(py::module_& m);
void bind_barr(py::module_& m);
void bind_lattice(py::module_& m);
void bind_surface(py::module_& m);
void bind_subdivision(py::module_& m);
void bind_cage(py::module_& m);
void bind_cage_generation(py::module_& m);  // the cage family's generator, beside bind_cage
void bind_rbf(py::module_& m);
void bind_transfer(py::module_& m);

}  // namespace deformkit_py
