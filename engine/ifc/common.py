"""Names and small helpers shared by the IFC writer and reader."""
from __future__ import annotations

import datetime
import json
import logging
import os
import uuid
from typing import Optional

from ..errors import InputError, MissingDependencyError, printable
from ..jsonfields import jsonable

__all__ = [
    "PSET_PROVENANCE", "PSET_SHAPE", "PSET_SUPPORT", "PSET_STOREY", "WRITABLE_SCHEMAS",
    "READABLE_SCHEMAS", "require_ifcopenshell", "dumps", "loads", "safe_text", "global_id",
    "source_date_epoch", "GLOBAL_ID_NAMESPACE", "CONNECTION_TYPES", "SLAB_MATERIALS", "millimetres",
    "connection_type", "WRITER_MODULES", "preload_writer_modules",
]

log = logging.getLogger(__name__)

PSET_PROVENANCE = "Indoor_Provenance"
"""Property set on the IfcProject: method, parameters, seed, timings, frame (transform, offset)."""
PSET_SHAPE = "Indoor_Shape"
"""Property set on each product: the model's shape id, type, flags, attributes and rule log."""
PSET_SUPPORT = "Indoor_Support"
"""Property set on each product: the figures from the data (point-on-face index, coverage, ...)."""
PSET_STOREY = "Indoor_Storey"
"""Property set on each IfcBuildingStorey: index, floor and ceiling heights in the model frame."""

WRITABLE_SCHEMAS = ("IFC4", "IFC4X3")
READABLE_SCHEMAS = ("IFC2X3", "IFC4", "IFC4X3")

CONNECTION_TYPES = ("ATSTART", "ATEND", "ATPATH", "NOTDEFINED")
"""IfcConnectionTypeEnum: where a wall join sits on each wall's path (the model's "joins")."""
SLAB_MATERIALS = {"FLOOR": "Floor slab", "ROOF": "Roof slab", "BASESLAB": "Base slab"}
"""Material (and type) name of a slab's single layer by its PredefinedType."""

GLOBAL_ID_NAMESPACE = uuid.UUID("5f0c3b1e-8d2a-5e47-9a1c-6b7d2e4f8a90")
"""UUID namespace of the GlobalIds :func:`global_id` derives (fixed: changing it changes every id)."""


def require_ifcopenshell(purpose: str):
    """Import ifcopenshell or raise :class:`MissingDependencyError` naming the package."""
    try:
        import ifcopenshell  # noqa: F401
    except ImportError:  # pragma: no cover - the environment ships it
        raise MissingDependencyError("ifcopenshell", purpose) from None
    return ifcopenshell


WRITER_MODULES = ("ifcopenshell", "ifcopenshell.api.context", "ifcopenshell.api.owner",
                  "ifcopenshell.api.project", "ifcopenshell.api.root", "ifcopenshell.api.style",
                  "ifcopenshell.api.unit")
"""The modules the IFC writer imports (0.1-0.15 s in all)."""

_preloading = []


def preload_writer_modules() -> None:
    """Import :data:`WRITER_MODULES` in a background thread, once per process: a convert that
    will write an IFC starts it before it reconstructs, so that the import (mostly loading
    ifcopenshell's library) overlaps the reconstruction's NumPy work, which holds no lock
    Python needs. The writer's own import of them then finds them loaded, or waits for the
    thread to finish them; an import error is left for the writer to report."""
    import sys
    import threading

    if _preloading or all(m in sys.modules for m in WRITER_MODULES):
        return

    def work():
        import importlib

        try:
            for m in WRITER_MODULES:
                importlib.import_module(m)
        except Exception:  # the writer imports them again and reports what is missing
            log.debug("preloading %s failed", WRITER_MODULES, exc_info=True)

    t = threading.Thread(target=work, name="ifc-preload", daemon=True)
    _preloading.append(t)
    t.start()


def dumps(value) -> str:
    """Compact JSON text for property values (numpy arrays and scalars become lists/numbers)."""
    return json.dumps(jsonable(value), separators=(",", ":"))


def loads(text, default=None):
    """Parse JSON text written by :func:`dumps`; ``default`` when it is missing or malformed."""
    if text is None:
        return default
    try:
        return json.loads(text)
    except (TypeError, ValueError):
        return default


def check_path(path: str | os.PathLike) -> str:
    """The path as a string; :class:`InputError` when the file is missing or is a folder."""
    p = os.fspath(path)
    if not os.path.exists(p):
        raise InputError("file not found", p)
    if os.path.isdir(p):
        raise InputError("is a folder, not a file", p)
    return p


def safe_text(text) -> str:
    """``text`` as a string IFC can hold (:func:`engine.errors.printable`): undecodable bytes
    of a file name become backslash escapes; valid text is returned unchanged."""
    return printable(text)


def global_id(seed, model_name: str, key) -> str:
    """The IFC GlobalId (22 characters) of the entity ``key`` of a model.

    A name-based UUID (version 5, namespace :data:`GLOBAL_ID_NAMESPACE`) of the model's seed,
    its name and the entity's key, compressed to IFC's base-64 form. ``key`` is a tuple of
    strings, numbers, None and nested tuples naming the entity by what it is (a shape id, a
    role such as ``"opening"``, the ids a relationship joins), so the same model written twice
    gives the same GlobalIds and elements of two runs can be matched by GlobalId.
    """
    import ifcopenshell.guid

    seed = None if seed is None else int(seed)
    name = json.dumps([seed, str(model_name), key], ensure_ascii=True, separators=(",", ":"))
    return ifcopenshell.guid.compress(uuid.uuid5(GLOBAL_ID_NAMESPACE, name).hex)


def source_date_epoch() -> Optional[int]:
    """The ``SOURCE_DATE_EPOCH`` environment variable (seconds since 1970, the
    reproducible-builds convention) or None when it is not set; a malformed value is
    ignored with a warning."""
    v = os.environ.get("SOURCE_DATE_EPOCH", "").strip()
    if not v:
        return None
    try:
        t = int(v)
    except ValueError:
        t = -1
    if t < 0:
        log.warning("SOURCE_DATE_EPOCH=%r is not a whole number of seconds since 1970: ignored", v)
        return None
    return t


def iso_timestamp(epoch: Optional[int]) -> str:
    """ISO 8601 time stamp of ``epoch`` (UTC) or of now (local time zone) when None."""
    if epoch is None:
        return datetime.datetime.now().astimezone().replace(microsecond=0).isoformat()
    return datetime.datetime.fromtimestamp(epoch, datetime.timezone.utc).isoformat()


def millimetres(length: float, step: float = 0.001) -> int:
    """``length`` (m) rounded to ``step`` (m), in whole millimetres: the size of element types
    (walls of one thickness, doors and windows of one width × height share a type)."""
    step = max(float(step), 1e-6)
    return int(round(round(float(length) / step) * step * 1000.0))


def connection_type(value) -> str:
    """A join end ("ATSTART", "ATEND", "ATPATH") as IfcConnectionTypeEnum; NOTDEFINED otherwise."""
    v = str(value or "").strip().upper()
    return v if v in CONNECTION_TYPES else "NOTDEFINED"
