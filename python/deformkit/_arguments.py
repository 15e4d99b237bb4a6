"""Errors that name the argument when a call does not match its signature.

pybind11 answers an unknown keyword, a missing argument or a value its converters refuse with
"incompatible function arguments", which never says which argument is wrong. The bindings declare
every function, method and constructor they define -- each parameter's name, kind, default and
what its C++ type accepts, read from the C++ types, not from docstrings -- as `_core._signatures`
(cpp/bindings/declared.hpp). Each declared entry point is wrapped once at import: a successful
call costs one Python frame; a refused call is explained from the declared signature
(`inspect.Signature.bind` decides whether the arguments fit it) and re-raised naming the
argument, what it got and what it accepts (for a misspelt keyword, the nearest valid name).
Values the converters accept are checked in C++, which names them there; the C++ core's own
messages are worded in C++ too (declared.hpp's call guard).
"""
import difflib
import functools
import inspect
import numbers
import re

import numpy as np

_KINDS = {"positional": inspect.Parameter.POSITIONAL_OR_KEYWORD, "keyword_only": inspect.Parameter.KEYWORD_ONLY,
          "positional_only": inspect.Parameter.POSITIONAL_ONLY}


def _accepts(accepts):
    """What a parameter accepts, in words."""
    kind = accepts["kind"]
    words = {"real": "a real number", "integer": "an integer", "bool": "True or False", "str": "a string",
             "object": "see the docstring"}.get(kind) or accepts["class"].__name__
    return words + " or None" if accepts["none"] and kind != "object" else words


def _describe(value):
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{type(value).__name__} {text}"


def _array_problem(value):
    """A scalar parameter given an array of one or more dimensions: NumPy turns a 1-element one into
    a number with a DeprecationWarning (an error in later NumPy), so it is refused here, by name."""
    if isinstance(value, np.ndarray) and value.ndim > 0:
        return f"expected a single number, not an array of shape {value.shape} (for one element: a[0] or a.item())"
    return None


def _integer_problem(value, accepts):
    if isinstance(value, (float, np.floating)):
        return "expected an integer, not a float"
    if not isinstance(value, numbers.Integral) and not hasattr(value, "__index__"):
        return "expected an integer"
    try:
        as_int = int(value.__index__()) if hasattr(value, "__index__") else int(value)
    except (TypeError, ValueError, OverflowError):
        return "expected an integer"
    if not accepts["min"] <= as_int <= accepts["max"]:
        bits = accepts["max"].bit_length() + (accepts["min"] < 0)
        return f"out of range for a {bits}-bit integer"
    return None


def _real_problem(value):
    if isinstance(value, (str, bytes, complex, np.complexfloating)):
        return "expected a real number"
    try:
        float(value)
    except OverflowError:
        return "out of range: too large for a float64"
    except (TypeError, ValueError):
        return "expected a real number"
    return None


def _type_problem(accepts, value):
    """Why `value` does not fit a parameter that accepts `accepts`, in words, or None when it fits."""
    kind = accepts["kind"]
    if value is None:
        return None if accepts["none"] else "expected a value, not None"
    if kind == "object":
        return None
    if kind == "real":
        return _array_problem(value) or _real_problem(value)
    if kind == "integer":
        return _array_problem(value) or _integer_problem(value, accepts)
    if kind == "bool":
        return None if isinstance(value, (bool, np.bool_)) else "expected True or False"
    if kind == "str":
        return None if isinstance(value, (str, bytes, bytearray)) else "expected a string"  # pybind11 decodes bytes
    cls = accepts["class"]
    return None if isinstance(value, cls) else f"expected a {cls.__name__}"


class Declared:
    """One entry point's declared signature, and the explanation of a call pybind11 refused."""

    def __init__(self, title, declaration, owner=None):
        self.title, self.owner = title, owner
        self.accepts = {p["name"]: p["accepts"] for p in declaration["parameters"]}
        self.signature = inspect.Signature([
            inspect.Parameter(p["name"], _KINDS[p["kind"]], default=p.get("default", inspect.Parameter.empty),
                              annotation=_accepts(p["accepts"]))
            for p in declaration["parameters"]])
        self.method = declaration["method"]

    def shown_signature(self):
        """The signature Python shows (help, inspect.signature): with self for a method."""
        if not self.method:
            return self.signature
        self_ = inspect.Parameter("self", inspect.Parameter.POSITIONAL_ONLY)
        return self.signature.replace(parameters=[self_, *self.signature.parameters.values()])

    def explain(self, args, kwargs):
        """The TypeError for a refused call, naming the argument; None when the declared signature
        finds nothing wrong (then the refusal came from C++, which named it)."""
        if self.method:
            if self.owner is not None and (not args or not isinstance(args[0], self.owner)):
                got = _describe(args[0]) if args else "nothing"
                return TypeError(f"{self.title}: called on {got}, not on a {self.owner.__name__}")
            args = args[1:]
        try:
            bound = self.signature.bind(*args, **kwargs)
        except TypeError as exc:
            return self._arity_error(args, kwargs) or TypeError(f"{self.title}: {exc}")
        for name, value in bound.arguments.items():
            problem = _type_problem(self.accepts[name], value)
            if problem:
                return TypeError(f"{name}: {problem}, got {_describe(value)} (accepts {_accepts(self.accepts[name])})")
        return None

    def _arity_error(self, args, kwargs):
        """Why `args` and `kwargs` do not bind to the signature, in words."""
        params = list(self.signature.parameters.values())
        names = [p.name for p in params]
        positional = [p for p in params if p.kind != inspect.Parameter.KEYWORD_ONLY]
        if len(args) > len(positional):
            tail = "; the others are keyword-only" if len(positional) < len(params) else ""
            return TypeError(f"{self.title}: takes at most {len(positional)} positional argument"
                             f"{'s' if len(positional) != 1 else ''} ({', '.join(p.name for p in positional)}), "
                             f"got {len(args)}{tail}")
        for key in kwargs:
            if key not in names:
                near = difflib.get_close_matches(key, names, n=1, cutoff=0.5)
                hint = f"; did you mean '{near[0]}'?" if near else ""
                return TypeError(f"{self.title}: unknown keyword argument '{key}'{hint} (accepts: {', '.join(names)})")
        given = {p.name for p in positional[:len(args)]}
        for key in kwargs:
            if key in given:
                return TypeError(f"{self.title}: got two values for argument '{key}' (positionally and by keyword)")
        for p in params:
            if p.name not in given and p.name not in kwargs and p.default is inspect.Parameter.empty:
                return TypeError(f"{self.title}: missing required argument '{p.name}'")
        return None


def _wrap(function, declared):
    # The scalar parameters (real, integer): pybind11 would take an array of one element for them
    # (through NumPy's deprecated conversion), so an array there is refused before the call.
    params = list(declared.signature.parameters.values())
    scalars = [(i + declared.method, p.name) for i, p in enumerate(params)
               if declared.accepts[p.name]["kind"] in ("real", "integer")]

    @functools.wraps(function)
    def checked(*args, **kwargs):
        for at, name in scalars:
            value = args[at] if at < len(args) else kwargs.get(name)
            if isinstance(value, np.ndarray) and value.ndim > 0:
                raise TypeError(f"{name}: {_array_problem(value)}, got {_describe(value)} "
                                f"(accepts {_accepts(declared.accepts[name])})")
        try:
            return function(*args, **kwargs)
        except TypeError:
            error = declared.explain(args, kwargs)
            if error is None:
                raise
            raise error from None

    checked.__signature__ = declared.shown_signature()
    checked._declared = declared
    return checked


def install(module):
    """Wrap every entry point the bindings declare (once). A declared name the module does not have
    is an ImportError: the declarations and the module are built together."""
    if getattr(module, "_arguments_installed", False):
        return
    for key, declaration in module._signatures.items():
        scope, _, attr = key.rpartition(".")
        if not scope:
            setattr(module, attr, _wrap(getattr(module, attr), Declared(f"{attr}()", declaration)))
            continue
        owner = getattr(module, scope)
        member = vars(owner).get(attr)
        if member is None:
            raise ImportError(f"deformkit: {key} is declared but {scope} has no {attr}")
        title = f"{scope}()" if attr == "__init__" else f"{scope}.{attr}()"
        if isinstance(member, staticmethod):
            setattr(owner, attr, staticmethod(_wrap(member.__func__, Declared(title, declaration))))
        else:
            function = getattr(member, "__func__", member)  # pybind11 wraps methods in instancemethod
            setattr(owner, attr, _wrap(function, Declared(title, declaration, owner)))
    module._arguments_installed = True


class Parameter:
    def __init__(self, name, annotation, has_default, keyword_only):
        self.name, self.annotation, self.has_default, self.keyword_only = name, annotation, has_default, keyword_only


def _split_top_level(text):
    """Split at commas outside brackets and quotes."""
    parts, depth, quote, start = [], 0, None, 0
    for i, ch in enumerate(text):
        if quote:
            quote = None if ch == quote and text[i - 1] != "\\" else quote
        elif ch in "'\"":
            quote = ch
        elif ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(text[start:i].strip())
            start = i + 1
    tail = text[start:].strip()
    return parts + [tail] if tail else parts


def parse_signature(doc, name):
    """The parameters pybind11 prints on the first `name(...) -> ...` line of a docstring.

    Not used to explain calls (the declared signatures are): the tests read pybind11's own account
    of each signature with it, to walk the API independently of the declarations."""
    match = re.search(r"^(?:\d+\. )?" + re.escape(name) + r"\((.*)\) ->", doc or "", re.M)
    if not match:
        return None
    params, keyword_only = [], False
    for part in _split_top_level(match.group(1)):
        if part == "*":
            keyword_only = True
            continue
        head, _, default = part.partition(" = ")
        pname, _, annotation = head.partition(": ")
        params.append(Parameter(pname.strip(), annotation.strip(), bool(default), keyword_only))
    return params
