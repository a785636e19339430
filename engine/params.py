"""Every reconstruction parameter in one tree, and its TOML file.

``Params`` nests the stages' frozen dataclasses: ``preprocess`` (working cloud, normals,
alignment, storeys, clusters, planes), ``choice`` (``--method auto``), ``manhattan`` (the
shape grammar) and ``generic`` (cells, coverage, rjMCMC search). Each default is written
once, in its dataclass; the CLI (``--params FILE``, ``--set stage.key=value``, ``indoor
params``), the batch script and the Blender add-on all read and write this tree.

Values are SI (metres, m², radians); ``auto`` (TOML string) stands for a value chosen from
the data (``None`` in Python).
"""
from __future__ import annotations

import dataclasses
import functools
import math
import os
import tomllib
import typing
from dataclasses import dataclass, field
from typing import Any, NamedTuple

from .elements.params import ElementsParams
from .errors import InputError
from .fileutil import atomic_write_text
from .grammar.params import GenericParams, ManhattanParams
from .pipeline import ChoiceParams
from .quantities import unit_of
from .segmentation.params import PreprocessParams

__all__ = ["Params", "ParamRow", "load_params", "save_params", "params_from_dict", "with_settings",
           "params_table", "params_to_toml", "parse_value"]


@dataclass(frozen=True)
class Params:
    """All parameters of a reconstruction, by stage."""

    preprocess: PreprocessParams = field(default_factory=PreprocessParams)
    choice: ChoiceParams = field(default_factory=ChoiceParams)
    manhattan: ManhattanParams = field(default_factory=ManhattanParams)
    generic: GenericParams = field(default_factory=GenericParams)
    elements: ElementsParams = field(default_factory=ElementsParams)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def coerce(cls, params) -> "Params":
        """``params`` as a Params: None → defaults; a ManhattanParams, GenericParams or
        PreprocessParams replaces that stage of the defaults."""
        if params is None:
            return cls()
        if isinstance(params, cls):
            return params
        for name, f in _fields(cls).items():
            if isinstance(params, type(getattr(cls(), name))):
                return dataclasses.replace(cls(), **{name: params})
        raise InputError(f"parameters must be a Params, not {type(params).__name__}")


class ParamRow(NamedTuple):
    """One parameter: dotted key, value, unit and the first line of its doc."""

    key: str
    value: Any
    unit: str
    doc: str


def _fields(cls) -> dict:
    return {f.name: f for f in dataclasses.fields(cls)}


@functools.lru_cache(maxsize=None)
def _hints(cls) -> dict:
    return typing.get_type_hints(cls, include_extras=True)


@functools.lru_cache(maxsize=None)  # parsed once per class: the add-on's panels ask 10 times
def _docs(cls) -> dict:
    """Attribute docstrings of a dataclass (the string literal under each field)."""
    import ast
    import inspect
    import textwrap

    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    except (OSError, TypeError, SyntaxError):
        return {}
    body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
    out = {}
    for a, b in zip(body, body[1:]):
        if isinstance(a, ast.AnnAssign) and isinstance(a.target, ast.Name) and isinstance(b, ast.Expr) \
                and isinstance(getattr(b, "value", None), ast.Constant) and isinstance(b.value.value, str):
            out[a.target.id] = " ".join(b.value.value.split())
    return out


def _first_sentence(text: str) -> str:
    cut = text.find(". ")
    return text if cut < 0 else text[:cut + 1]


def params_table(params: Params = Params()) -> list[ParamRow]:
    """Every leaf parameter of ``params`` in tree order."""
    rows: list[ParamRow] = []

    def walk(obj, prefix):
        cls = type(obj)
        hints, docs = _hints(cls), _docs(cls)
        for name in _fields(cls):
            value = getattr(obj, name)
            key = f"{prefix}{name}"
            if dataclasses.is_dataclass(value):
                walk(value, key + ".")
            else:
                rows.append(ParamRow(key, value, unit_of(hints.get(name)), _first_sentence(docs.get(name, ""))))

    walk(params, "")
    return rows


def _format(value) -> str:
    """A TOML literal."""
    if value is None:
        return '"auto"'
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        return repr(value) if math.isfinite(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_format(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def params_to_toml(params: Params = Params()) -> str:
    """The TOML text of ``params``: one table per stage, each value with its unit and doc."""
    lines = ["# indoor reconstruction parameters (SI units: m, m², rad; \"auto\": from the data)"]
    table = None
    for row in params_table(params):
        head, _, leaf = row.key.rpartition(".")
        if head != table:
            lines += ["", f"[{head}]"]
            table = head
        unit = f"rad = {math.degrees(row.value):.1f}°" if row.unit == "rad" and isinstance(row.value, float) \
            else row.unit
        note = ", ".join(x for x in (unit, row.doc) if x)
        lines.append(f"{leaf} = {_format(row.value)}" + (f"  # {note}" if note else ""))
    return "\n".join(lines) + "\n"


def parse_value(text: str):
    """A ``--set`` value: TOML syntax (``0.7``, ``true``, ``[1, 2]``), else the bare word."""
    text = text.strip()
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def _convert(value, current, key: str, optional: bool):
    """``value`` as the type of the field ``key`` (whose value is ``current``)."""
    if value is None or (isinstance(value, str) and value.lower() == "auto"):
        if optional:
            return None
        raise InputError(f"{key} has no automatic value; give a number")
    if isinstance(current, bool):
        if isinstance(value, bool):
            return value
        raise InputError(f"{key} must be true or false, not {value!r}")
    if isinstance(current, int):
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        if isinstance(value, float) and value.is_integer():
            return int(value)
        raise InputError(f"{key} must be a whole number, not {value!r}")
    if isinstance(current, float) or current is None:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
        raise InputError(f"{key} must be a number{' or auto' if optional else ''}, not {value!r}")
    if isinstance(current, tuple):
        if isinstance(value, list):
            return tuple(value)
        raise InputError(f"{key} must be a list, not {value!r}")
    if isinstance(current, str):
        return str(value)
    raise InputError(f"{key} cannot be set")


def _apply(obj, changes: dict, prefix: str, source: str):
    cls = type(obj)
    fields = _fields(cls)
    hints = _hints(cls)
    kw = {}
    for name, value in changes.items():
        key = f"{prefix}{name}"
        if name not in fields:
            known = ", ".join(sorted(fields))
            raise InputError(f"unknown parameter {key!r} (known under {prefix or 'the top level'}: {known})",
                             source or None)
        current = getattr(obj, name)
        if dataclasses.is_dataclass(current):
            if not isinstance(value, dict):
                raise InputError(f"{key} is a table of parameters, not a value", source or None)
            kw[name] = _apply(current, value, key + ".", source)
        elif isinstance(value, dict):
            raise InputError(f"{key} is a value, not a table", source or None)
        else:
            try:
                optional = type(None) in typing.get_args(typing.get_args(hints[name])[0]
                                                         if hasattr(hints[name], "__metadata__") else hints[name])
                kw[name] = _convert(value, current, key, optional)
            except InputError as e:
                raise InputError(e.problem, source or None) from None
    try:
        return dataclasses.replace(obj, **kw)
    except (ValueError, TypeError) as e:
        raise InputError(f"bad parameters under {prefix.rstrip('.') or 'the top level'}: {e}",
                         source or None) from None


def params_from_dict(data: dict, base: Params = Params(), source: str = "") -> Params:
    """``base`` with the nested ``data`` applied (unknown keys and wrong types: InputError)."""
    if not isinstance(data, dict):
        raise InputError("parameters must be a table", source or None)
    return _apply(base, data, "", source)


def load_params(path, base: Params = Params()) -> Params:
    """Read a TOML parameter file (the keys it has replace those of ``base``).

    Raises
    ------
    InputError
        The file cannot be read, is not TOML, or names an unknown parameter or a wrong type.
    """
    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except OSError as e:
        raise InputError(f"cannot read the parameter file: {e.strerror or e}", path) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise InputError(f"not a TOML parameter file: {e}", path) from None
    return params_from_dict(data, base, path)


def save_params(params: Params, path) -> None:
    """Write ``params`` as TOML (atomically)."""
    atomic_write_text(os.fspath(path), params_to_toml(params))


def with_settings(params: Params, settings) -> Params:
    """``params`` with ``["stage.key=value", ...]`` applied (``--set``)."""
    for item in settings or ():
        key, eq, text = str(item).partition("=")
        key = key.strip()
        if not eq or not key:
            raise InputError(f"--set needs stage.key=value, not {item!r}")
        parts = key.split(".")
        obj = params
        for i, part in enumerate(parts):
            if not dataclasses.is_dataclass(obj) or part not in _fields(type(obj)):
                raise InputError(f"unknown parameter {'.'.join(parts[:i + 1])!r} in --set {item!r}")
            obj = getattr(obj, part)
        if dataclasses.is_dataclass(obj):
            raise InputError(f"{key} is a table of parameters; set one of its keys")
        nested: dict = {parts[-1]: parse_value(text)}
        for part in reversed(parts[:-1]):
            nested = {part: nested}
        params = params_from_dict(nested, params)
    return params
