"""Reading parsed JSON with checks, and writing Python values as JSON.

The readers take a value and ``where`` (its place in the document, e.g.
``"shapes[3].geometry.vertices"``) and return it typed, or raise :class:`Malformed` whose
message says where and what is wrong. :func:`parse_json` turns text into values with a
:class:`~engine.errors.FormatError` naming the file and the line; :func:`jsonable` turns
numpy arrays and scalars, enums and dataclasses into JSON-ready values.
"""
from __future__ import annotations

import enum
import json
from dataclasses import asdict
from typing import Any, Mapping

import numpy as np

from .errors import FormatError

__all__ = ["Malformed", "REQUIRED", "json_kind", "as_object", "member", "as_text", "as_integer", "as_flag",
           "as_number", "as_array", "as_numbers", "parse_json", "error_text", "jsonable"]


class Malformed(ValueError):
    """A field of a JSON document has the wrong type or value; the message says where."""


REQUIRED = object()
"""Default of :func:`member`: the key must be there."""


def json_kind(v) -> str:
    """The JSON name of the type of ``v`` (for messages)."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, (int, float)):
        return "a number"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, (list, tuple)):
        return "an array"
    if isinstance(v, Mapping):
        return "an object"
    return type(v).__name__


def as_object(v, where: str) -> Mapping:
    """``v`` when it is a JSON object."""
    if not isinstance(v, Mapping):
        raise Malformed(f"{where} must be an object, not {json_kind(v)}")
    return v


def member(d: Mapping, key: str, where: str, default=REQUIRED):
    """``d[key]``; ``default`` when it is missing (Malformed when there is no default)."""
    if key in d:
        return d[key]
    if default is REQUIRED:
        raise Malformed(f"{where} has no {key!r}")
    return default


def as_text(v, where: str, optional: bool = False):
    """``v`` when it is a string (or None, when ``optional``)."""
    if v is None and optional:
        return None
    if not isinstance(v, str):
        raise Malformed(f"{where} must be a string, not {json_kind(v)}")
    return v


def as_integer(v, where: str) -> int:
    """``v`` as an int when it is a whole number."""
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        if isinstance(v, float) and v.is_integer():
            return int(v)
        raise Malformed(f"{where} must be a whole number, not {json_kind(v)}")
    return int(v)


def as_flag(v, where: str) -> bool:
    """``v`` as a bool when it is true/false (or 0/1)."""
    if isinstance(v, bool) or (isinstance(v, int) and v in (0, 1)):
        return bool(v)
    raise Malformed(f"{where} must be true or false, not {json_kind(v)}")


def as_number(v, where: str, finite: bool = True) -> float:
    """``v`` as a float when it is a number (finite, unless ``finite`` is False)."""
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise Malformed(f"{where} must be a number, not {json_kind(v)}")
    x = float(v)
    if finite and not np.isfinite(x):
        raise Malformed(f"{where} must be finite, not {x}")
    return x


def as_array(v, where: str) -> list:
    """``v`` as a list when it is a JSON array."""
    if not isinstance(v, (list, tuple)):
        raise Malformed(f"{where} must be an array, not {json_kind(v)}")
    return list(v)


def as_numbers(v, where: str, shape: tuple) -> np.ndarray:
    """float64 array of ``shape`` (-1 for any length) from nested arrays of finite numbers."""
    if not isinstance(v, (list, tuple, np.ndarray)):
        raise Malformed(f"{where} must be an array, not {json_kind(v)}")
    try:
        a = np.asarray(v)
    except ValueError:  # ragged
        raise Malformed(f"{where} must be an array of shape {_shape_text(shape)} (rows differ in length)") \
            from None
    if a.size == 0 and -1 in shape:
        return np.zeros([0 if n == -1 else n for n in shape], dtype=np.float64)
    if a.dtype.kind not in "iuf":
        raise Malformed(f"{where} must hold numbers only")
    if a.ndim != len(shape) or any(n != -1 and n != m for n, m in zip(shape, a.shape)):
        raise Malformed(f"{where} must be an array of shape {_shape_text(shape)}, "
                         f"not {_shape_text(a.shape)}")
    a = a.astype(np.float64)
    if not np.isfinite(a).all():
        raise Malformed(f"{where} holds non-finite numbers")
    return a


def _shape_text(shape) -> str:
    return "(" + ", ".join("n" if n == -1 else str(n) for n in shape) + ")"


def parse_json(text: str, path) -> Any:
    """``json.loads(text)``; FormatError naming ``path`` (and the line) when it is not JSON."""
    if not text.strip():
        raise FormatError("the file is empty" if path is not None else "empty JSON text", path)
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        where = f"line {e.lineno} column {e.colno}"
        if e.pos >= len(text.rstrip()) or e.msg.startswith("Unterminated string"):
            raise FormatError(f"truncated JSON: the text ends inside a value ({e.msg} at {where})", path) \
                from None
        raise FormatError(f"not readable as JSON: {e.msg} at {where}", path) from None
    except RecursionError:
        raise FormatError("not readable as JSON: nested too deeply", path) from None


def error_text(e: BaseException) -> str:
    """The message of a parsing error (a KeyError's is the bare key)."""
    if isinstance(e, KeyError):
        return f"missing key {e.args[0]!r}" if e.args else "missing key"
    return str(e) or e.__class__.__name__


def jsonable(x):
    """``x`` with numpy arrays and scalars, enums and dataclasses (recursively) made JSON-ready."""
    if isinstance(x, Mapping):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, enum.Enum):
        return x.value
    if hasattr(x, "__dataclass_fields__"):
        return jsonable(asdict(x))
    return x
