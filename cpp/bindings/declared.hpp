#pragma once
// Every function, method and constructor of the module is defined through `Class<...>` (for
// py::class_) or `def(m, ...)`, which
// - record the signature the binding declares -- each parameter's name, kind (positional or
//   keyword-only), default, and what its C++ type takes from Python -- published as
//   `_core._signatures` once the module is built (publish_signatures), for
//   deformkit/_arguments.py to explain a call pybind11 refuses, naming the argument;
// - run the call in one guard that words the core's exceptions for Python (the function's name on
//   an allocation failure, the deformer's type on its own overflow report).
// Read from the C++ types and pybind11's public py::arg / py::kw_only, not from docstrings, so a
// pybind11 upgrade cannot change what is declared; a binding that bypasses them is missed by the
// test that walks the module (tests/core/test_declared_signatures.py).
#include "common.hpp"

#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

namespace deformkit_py {

// What a parameter of C++ type T takes from Python, as a dict _arguments.py reads:
// {"kind": "real" | "integer" | "bool" | "str" | "object" | "class", "none": accepts None,
//  "min"/"max" (integers), "class" (the Python type)}. Built when the module is published, so
// that a class is resolved after every class is registered.
template <class T>
struct accepts_of {
  static py::dict get() {
    using D = std::remove_cv_t<std::remove_reference_t<T>>;
    py::dict d;
    d["none"] = false;
    if constexpr (std::is_same<D, bool>::value) {
      d["kind"] = "bool";
    } else if constexpr (std::is_floating_point<D>::value) {
      d["kind"] = "real";
    } else if constexpr (std::is_integral<D>::value) {
      d["kind"] = "integer";
      d["min"] = py::int_(std::numeric_limits<D>::min());
      d["max"] = py::int_(std::numeric_limits<D>::max());
    } else if constexpr (std::is_same<D, std::string>::value) {
      d["kind"] = "str";
    } else if constexpr (std::is_base_of<py::handle, D>::value) {
      d["kind"] = "object";
      d["none"] = true;
    } else {
      d["kind"] = "class";
      d["class"] = py::type::of<D>();
      d["none"] = std::is_pointer<T>::value;
    }
    return d;
  }
};
template <class T>
struct accepts_of<std::optional<T>> {
  static py::dict get() {
    py::dict d = accepts_of<T>::get();
    d["none"] = true;
    return d;
  }
};
template <class T>
struct accepts_of<std::shared_ptr<T>> : accepts_of<T> {};
template <class T>
struct accepts_of<const std::shared_ptr<T>&> : accepts_of<T> {};
template <class T>
struct accepts_of<const std::optional<T>&> : accepts_of<std::optional<T>> {};
template <class T>
struct accepts_of<T*> {
  static py::dict get() {
    py::dict d = accepts_of<T>::get();
    d["none"] = true;
    return d;
  }
};

template <>
struct accepts_of<py::detail::value_and_holder&> {  // the instance a constructor fills: never declared
  static py::dict get() { return py::dict(); }
};

// One declared parameter; `accepts` is called at publication.
struct DeclaredParameter {
  std::string name;
  bool keyword_only = false, positional_only = false;
  py::object default_value;  // null: required
  py::dict (*accepts)() = nullptr;
};
struct Declaration {
  std::string scope, name;  // scope: the class's Python name, "" for a module function
  bool is_method = false;  // the Python callable takes self first (methods, __init__)
  std::vector<DeclaredParameter> parameters;
};
std::vector<Declaration>& declarations();

// Publishes every declaration as module._signatures: {"Twist.__init__": [parameter dicts], ...}.
void publish_signatures(py::module_& m);

// The parameter types of a callable: lambdas, function pointers, member function pointers.
template <class F>
struct callable_traits : callable_traits<decltype(&F::operator())> {};
template <class R, class... A>
struct callable_traits<R (*)(A...)> {
  using result = R;
  using args = std::tuple<A...>;
};
template <class R, class C, class... A>
struct callable_traits<R (C::*)(A...) const> {
  using result = R;
  using args = std::tuple<A...>;  // a lambda's operator(): the lambda itself is not a parameter
};
template <class R, class C, class... A>
struct callable_traits<R (C::*)(A...)> : callable_traits<R (C::*)(A...) const> {};

// Names, kinds and defaults from the py::arg / py::arg_v / py::kw_only / py::pos_only extras.
struct ExtrasReader {
  std::vector<DeclaredParameter> named;
  bool keyword_only = false;
  void read(const py::arg_v& a) {
    read(static_cast<const py::arg&>(a));
    named.back().default_value = a.value;
  }
  void read(const py::arg& a) {
    DeclaredParameter p;
    p.name = a.name;
    p.keyword_only = keyword_only;
    named.push_back(p);
  }
  void read(const py::kw_only&) { keyword_only = true; }
  void read(const py::pos_only&) {
    for (auto& p : named) p.positional_only = true;
  }
  template <class T>
  void read(const T&) {}  // docstrings, return value policies, ...
};

template <class... A, std::size_t... I>
std::vector<DeclaredParameter> typed_parameters(std::tuple<A...>*, std::index_sequence<I...>, std::size_t skip) {
  std::vector<DeclaredParameter> out;
  py::dict (*accepts[])() = {&accepts_of<A>::get..., nullptr};
  for (std::size_t i = skip; i < sizeof...(A); ++i) {
    DeclaredParameter p;
    p.name = "arg" + std::to_string(i - skip);
    p.accepts = accepts[i];
    out.push_back(p);
  }
  return out;
}

template <class Args, class... Extra>
void declare(const std::string& scope, const char* name, bool is_method, const Extra&... extra) {
  ExtrasReader reader;
  (reader.read(extra), ...);
  Declaration d{scope, name, is_method, {}};
  d.parameters = typed_parameters(static_cast<Args*>(nullptr), std::make_index_sequence<std::tuple_size<Args>::value>(),
                                  is_method ? 1 : 0);
  for (std::size_t i = 0; i < d.parameters.size() && i < reader.named.size(); ++i) {
    auto accepts = d.parameters[i].accepts;
    d.parameters[i] = reader.named[i];
    d.parameters[i].accepts = accepts;
  }
  declarations().push_back(std::move(d));
}

template <class T, class = void>
struct is_shared_ptr : std::false_type {};
template <class T>
struct is_shared_ptr<std::shared_ptr<T>> : std::true_type {};

// `self` as its Python object's type name when it is a deformer, else "": a deformer's overflow
// report says "deformer: row ...", which its caller reads as "Taper: row ...".
template <class T>
std::string self_type_name(const T& self) {
  using D = std::remove_cv_t<std::remove_reference_t<T>>;
  if constexpr (std::is_base_of<Deformer, D>::value) {
    return py::str(py::type::of(py::cast(&self, py::return_value_policy::reference)).attr("__name__"));
  } else if constexpr (is_shared_ptr<D>::value) {
    if constexpr (std::is_base_of<Deformer, typename D::element_type>::value)
      return py::str(py::type::of(py::cast(self)).attr("__name__"));
  }
  return "";
}

// `f` run so that an allocation failure the core did not name is a MemoryError naming `title`,
// and a deformer's own overflow report ("deformer: row ...") names the deformer's type.
[[noreturn]] void throw_unnamed_allocation_failure(const std::string& title);
template <class F, class R, class... A>
auto guarded(std::string title, F f, R (*)(std::tuple<A...>*)) {
  return [title = std::move(title), f = std::move(f)](A... a) -> R {
    try {
      return std::invoke(f, std::forward<A>(a)...);
    } catch (const std::bad_alloc&) {
      throw_unnamed_allocation_failure(title);
    } catch (const std::invalid_argument& e) {
      if constexpr (sizeof...(A) > 0) {
        const std::string message = e.what(), prefix = "deformer: row ";
        if (message.rfind(prefix, 0) == 0) {
          const std::string type = self_type_name(std::get<0>(std::forward_as_tuple(a...)));
          if (!type.empty()) throw py::value_error(type + ": " + message.substr(10));
        }
      }
      throw;
    }
  };
}
template <class F>
auto guarded(std::string title, F f) {
  using T = callable_traits<std::decay_t<F>>;
  return guarded(std::move(title), std::move(f),
                 static_cast<typename T::result (*)(typename T::args*)>(nullptr));
}
template <class R, class C, class... A>
auto guarded(std::string title, R (C::*f)(A...) const) {
  return guarded(std::move(title), std::mem_fn(f), static_cast<R (*)(std::tuple<const C&, A...>*)>(nullptr));
}
template <class R, class C, class... A>
auto guarded(std::string title, R (C::*f)(A...)) {
  return guarded(std::move(title), std::mem_fn(f), static_cast<R (*)(std::tuple<C&, A...>*)>(nullptr));
}

template <class F>
using guarded_args = typename callable_traits<decltype(&decltype(guarded(std::string(), std::declval<F>()))::operator())>::args;

// A module function, declared and guarded.
template <class F, class... Extra>
void def(py::module_& m, const char* name, F&& f, const Extra&... extra) {
  declare<guarded_args<F>>("", name, false, extra...);
  m.def(name, guarded(std::string(name) + "()", std::forward<F>(f)), extra...);
}

// py::class_ whose def / def_static declare and guard what they define (the others forward,
// returning Class& so that a chain keeps going through these).
template <class T, class... Options>
class Class : public py::class_<T, Options...> {
  using Base = py::class_<T, Options...>;

 public:
  using Base::Base;

  template <class F, class... Extra>
  Class& def(const char* name, F&& f, const Extra&... extra) {
    const std::string scope = py::str(this->attr("__name__"));
    declare<guarded_args<F>>(scope, name, true, extra...);
    const std::string title = std::string(name) == "__init__" ? scope + "()" : scope + "." + name + "()";
    Base::def(name, guarded(title, std::forward<F>(f)), extra...);
    return *this;
  }
  template <class... Args, class... Extra>
  Class& def(py::detail::initimpl::factory<Args...>&& init, const Extra&... extra) {
    std::move(init).execute(*this, extra...);  // comes back through def("__init__", ...) above
    return *this;
  }
  template <class F, class... Extra>
  Class& def_static(const char* name, F&& f, const Extra&... extra) {
    const std::string scope = py::str(this->attr("__name__"));
    declare<guarded_args<F>>(scope, name, false, extra...);
    Base::def_static(name, guarded(scope + "." + name + "()", std::forward<F>(f)), extra...);
    return *this;
  }
  template <class... A>
  Class& def_property(A&&... a) {
    Base::def_property(std::forward<A>(a)...);
    return *this;
  }
  template <class... A>
  Class& def_property_readonly(A&&... a) {
    Base::def_property_readonly(std::forward<A>(a)...);
    return *this;
  }
  template <class... A>
  Class& def_readonly(A&&... a) {
    Base::def_readonly(std::forward<A>(a)...);
    return *this;
  }
};

}  // namespace deformkit_py
