"""Errors that name the argument when a call does not match its signature.

pybind11 answers an unknown keyword, a missing argument or a value its converters refuse with
"incompatible function arguments", which never says which argument is wrong. Each public entry
point of the native module is wrapped once at import: a successful call costs one Python frame;
a refused call is diagnosed from the signature pybind11 records in the docstring, and re-raised
naming the argument, what it got and what it accepts (and, for a misspelt keyword, the nearest
valid name). Values the converters accept are checked in C++, which names them there.
"""
import difflib
import functools
import inspect
import numbers
import re

import numpy as np

_REFUSED = re.compile(r"incompatible (function|constructor) arguments")
_INT64 = 2**63


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
    """The parameters of the first `name(...) -> ...` line of a pybind11 docstring."""
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


def _describe(value):
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{type(value).__name__} {text}"


def _type_problem(annotation, value, module):
    """Why `value` does not fit `annotation`, in words, or None when it fits."""
    alternatives = [a.strip() for a in annotation.split("|")]
    if value is None:
        return None if "None" in alternatives or annotation in ("object", "") else "expected a value, not None"
    if "object" in alternatives or not annotation:
        return None
    if any(a.startswith("typing.SupportsFloat") for a in alternatives):
        if isinstance(value, (str, bytes, complex, np.complexfloating)):
            return "expected a real number"
        try:
            float(value)
        except OverflowError:
            return "out of range: too large for a float64"
        except (TypeError, ValueError):
            return "expected a real number"
        return None
    if any(a.startswith("typing.SupportsInt") for a in alternatives):
        if isinstance(value, (float, np.floating)):
            return "expected an integer, not a float"
        if not isinstance(value, numbers.Integral) and not hasattr(value, "__index__"):
            return "expected an integer"
        try:
            as_int = int(value.__index__()) if hasattr(value, "__index__") else int(value)
        except (TypeError, ValueError, OverflowError):
            return "expected an integer"
        if not -_INT64 <= as_int < _INT64:
            return "out of range for a 64-bit integer"
        return None
    if "bool" in alternatives:
        return None if isinstance(value, (bool, np.bool_)) else "expected True or False"
    if "str" in alternatives:
        return None if isinstance(value, str) else "expected a string"
    if annotation.startswith("collections.abc.Sequence["):
        item = annotation[len("collections.abc.Sequence["):-1]
        cls = _resolve(item, module)
        if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)):
            return f"expected a list of {item.rsplit('.', 1)[-1]}"
        for i, v in enumerate(value):
            if cls is not None and not isinstance(v, cls):
                return f"item {i} is {_describe(v)}, not a {item.rsplit('.', 1)[-1]}"
        return None
    cls = _resolve(annotation, module)
    if cls is not None and not isinstance(value, cls):
        return f"expected a {cls.__name__}"
    return None


def _resolve(annotation, module):
    if annotation.startswith(module.__name__ + "."):
        return getattr(module, annotation.rsplit(".", 1)[-1], None)
    return None


def _accepts(annotation):
    if annotation.startswith("collections.abc.Sequence["):
        return "a list of " + annotation[len("collections.abc.Sequence["):-1].rsplit(".", 1)[-1] + " objects"
    if annotation in ("object", ""):
        return "see the docstring"
    words = {"typing.SupportsFloat": "a real number", "typing.SupportsInt": "an integer", "bool": "True or False",
             "str": "a string", "None": "None"}
    alternatives = [a.strip() for a in annotation.split("|") if a.strip() != "typing.SupportsIndex"]
    return " or ".join(words.get(a, a.rsplit(".", 1)[-1]) for a in alternatives)


def diagnose(title, params, args, kwargs, module):
    """The TypeError for a call that pybind11 refused, naming the argument."""
    names = [p.name for p in params]
    positional = [p for p in params if not p.keyword_only]
    accepted = ", ".join(names)
    if len(args) > len(positional):
        tail = "; the others are keyword-only" if len(positional) < len(params) else ""
        return TypeError(f"{title}: takes at most {len(positional)} positional argument"
                         f"{'s' if len(positional) != 1 else ''} ({', '.join(p.name for p in positional)}), "
                         f"got {len(args)}{tail}")
    for key in kwargs:
        if key not in names:
            near = difflib.get_close_matches(key, names, n=1, cutoff=0.5)
            hint = f"; did you mean '{near[0]}'?" if near else ""
            return TypeError(f"{title}: unknown keyword argument '{key}'{hint} (accepts: {accepted})")
    given = dict(zip((p.name for p in positional), args))
    for key, value in kwargs.items():
        if key in given:
            return TypeError(f"{title}: got two values for argument '{key}' (positionally and by keyword)")
        given[key] = value
    for p in params:
        if p.name not in given and not p.has_default:
            return TypeError(f"{title}: missing required argument '{p.name}'")
    for p in params:
        if p.name in given:
            value = given[p.name]
            problem = _type_problem(p.annotation, value, module)
            if problem and problem.startswith("item "):
                return TypeError(f"{p.name}: {problem} (accepts {_accepts(p.annotation)})")
            if problem:
                return TypeError(f"{p.name}: {problem}, got {_describe(value)} (accepts {_accepts(p.annotation)})")
    return None


def _wrap(function, title, doc_name, module, owner=None):
    params = parse_signature(function.__doc__, doc_name)
    if params is None:
        return function
    if owner is not None:
        params = params[1:]  # self

    @functools.wraps(function)
    def checked(*args, **kwargs):
        try:
            return function(*args, **kwargs)
        except MemoryError as exc:
            # What the core allocated without naming it (a path with no named guard): name the call.
            if str(exc) not in ("std::bad_alloc", ""):
                raise
            renamed = MemoryError(f"{title}: not enough memory for its working arrays (the C++ core's "
                                  f"allocation failed)")
        except ValueError as exc:
            # The core says "deformer: ..." for the object whose parameters overflow: name its type.
            message = str(exc)
            deformer = getattr(module, "Deformer", None)
            if not (args and deformer and isinstance(args[0], deformer) and message.startswith("deformer: row ")):
                raise  # "deformer: ..." of a deformer= argument, or another argument's message
            renamed = ValueError(f"{type(args[0]).__name__}: {message[len('deformer: '):]}")
        except TypeError as exc:
            if not _REFUSED.search(str(exc)):
                raise
            if owner is not None and (not args or not isinstance(args[0], owner)):
                got = _describe(args[0]) if args else "nothing"
                raise TypeError(f"{title}: called on {got}, not on a {owner.__name__}") from None
            error = diagnose(title, params, args[1:] if owner is not None else args, kwargs, module)
            if error is None:
                raise
            raise error from None
        raise renamed from None

    return checked


def install(module):
    """Wrap every public function, method and constructor of `module` (once)."""
    if getattr(module, "_arguments_installed", False):
        return
    for name, obj in list(vars(module).items()):
        if name.startswith("_"):
            continue
        if inspect.isclass(obj):
            for attr, member in list(obj.__dict__.items()):
                if attr.startswith("_") and attr != "__init__":
                    continue
                title = f"{name}()" if attr == "__init__" else f"{name}.{attr}()"
                if isinstance(member, staticmethod):
                    setattr(obj, attr, staticmethod(_wrap(member.__func__, title, attr, module)))
                elif type(member).__name__ == "instancemethod":
                    setattr(obj, attr, _wrap(member.__func__, title, attr, module, owner=obj))
        elif type(obj).__name__ == "builtin_function_or_method":
            setattr(module, name, _wrap(obj, f"{name}()", name, module))
    module._arguments_installed = True

