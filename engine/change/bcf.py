"""BCF topics for the changes a scan shows (docs/method.md §5): one topic per change, the
element's IFC GlobalId as the topic's selected component, and a perspective viewpoint
looking at it, so that a reviewer opens the file in Bonsai (or any BCF viewer) beside the IFC.

Written as BCF 2.1 (``bcf.v2`` of IfcOpenShell's ``bcf-client``), the version most viewers
read (Bonsai reads 2.1 and 3.0).
"""
from __future__ import annotations

import math
import os
import uuid
import zipfile
from typing import Mapping, Optional, Sequence

import numpy as np

from ..errors import FormatError, InputError, MissingDependencyError, OutputError
from ..fileutil import atomic_path

__all__ = ["write_bcf", "read_bcf", "camera_for_box", "BCF_VERSION", "FIELD_OF_VIEW", "DOWN_ANGLE"]

BCF_VERSION = "2.1"
"""The BCF version written."""
FIELD_OF_VIEW = 60.0
"""Vertical field of view of the viewpoints' perspective camera, degrees."""
DOWN_ANGLE = 30.0
"""The camera looks down at the element at this angle below the horizontal, degrees."""
MIN_DISTANCE = 2.0
"""The camera stands at least this far from the element's centre, metres."""
AUTHOR = "indoor changes"
"""The topics' creation author."""


def _bcf():
    try:
        from bcf.v2 import model as mdl
        from bcf.v2.bcfxml import BcfXml
        from bcf.v2.visinfo import VisualizationInfoHandler
    except ImportError:
        raise MissingDependencyError("bcf-client", "writing BCF") from None
    return BcfXml, mdl, VisualizationInfoHandler


def _vector(value, what: str, i: int) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise InputError(f"BCF topic {i}: {what} must be three numbers, not {value!r}") from None
    if not np.all(np.isfinite(v)):
        raise InputError(f"BCF topic {i}: {what} must be finite, not {value!r}")
    return v


def camera_for_box(center, bbox, field_of_view: float = FIELD_OF_VIEW,
                   down: float = DOWN_ANGLE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A perspective camera looking at ``center`` from outside ``bbox``.

    The camera looks down by ``down`` degrees, across the box's thinner horizontal side (at a
    wall's face rather than along it), from the side of lower x / y, at the distance where the
    box's bounding sphere fills the field of view (at least :data:`MIN_DISTANCE`, and outside
    the box). Returns ``(position, direction, up)``, each (3,) float64, direction and up unit.
    """
    c = np.asarray(center, dtype=np.float64).reshape(3)
    lo, hi = (np.asarray(b, dtype=np.float64).reshape(3) for b in bbox)
    lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    size = hi - lo
    radius = 0.5 * float(np.linalg.norm(size))
    distance = max(MIN_DISTANCE, radius / math.sin(math.radians(0.5 * field_of_view)))
    horizontal = np.array([0.0, -1.0, 0.0]) if size[0] >= size[1] else np.array([-1.0, 0.0, 0.0])
    a = math.radians(down)
    back = math.cos(a) * horizontal + np.array([0.0, 0.0, math.sin(a)])  # unit, from the centre to the camera
    position = c + distance * back
    direction = -back
    right = np.cross(direction, np.array([0.0, 0.0, 1.0]))
    up = np.cross(right / np.linalg.norm(right), direction)
    return position, direction, up / np.linalg.norm(up)


def _check_topics(topics) -> list:
    if isinstance(topics, Mapping) or not isinstance(topics, Sequence):
        raise InputError(f"BCF topics must be a list of dicts, not {type(topics).__name__}")
    out = []
    for i, t in enumerate(topics):
        if not isinstance(t, Mapping):
            raise InputError(f"BCF topic {i} must be a dict, not {type(t).__name__}")
        title = str(t.get("title") or "").strip()
        if not title:
            raise InputError(f"BCF topic {i} has no title")
        guid = t.get("guid")
        if guid is not None and (not isinstance(guid, str) or not guid.strip()):
            raise InputError(f"BCF topic {i} ({title}): guid must be an IFC GlobalId string or None, not {guid!r}")
        center = _vector(t.get("center"), "center", i)
        bbox = t.get("bbox")
        if bbox is None:
            lo = hi = center
        else:
            try:
                lo, hi = bbox
            except (TypeError, ValueError):
                raise InputError(f"BCF topic {i} ({title}): bbox must be two corners, not {bbox!r}") from None
            lo, hi = _vector(lo, "bbox corner", i), _vector(hi, "bbox corner", i)
        out.append({"title": title, "description": str(t.get("description") or ""),
                    "status": str(t.get("status") or ""), "guid": guid, "ifc_class": str(t.get("ifc_class") or ""),
                    "center": center, "bbox": (lo, hi)})
    return out


def write_bcf(path, topics, *, project_name: str = "indoor changes") -> str:
    """Write a BCF 2.1 file with one topic per entry of ``topics``; returns ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.bcf`` file (written atomically: nothing is left at ``path`` on failure).
    topics : list of dict
        Each with "title", "description", "status" (the topic's status, e.g. "not
        installed", "new", "incomplete"), "guid" (the element's IFC GlobalId, or None for
        an element not in the model), "ifc_class" (the topic type, e.g. "IfcWall"),
        "center" (x, y, z) and "bbox" ((x0, y0, z0), (x1, y1, z1)), model coordinates, metres.
    project_name : str

    Raises
    ------
    InputError
        A malformed topic.
    OutputError
        ``path`` cannot be written.
    MissingDependencyError
        bcf-client is not installed.
    """
    checked = _check_topics(topics)
    BcfXml, mdl, VisualizationInfoHandler = _bcf()
    path = os.fspath(path)
    bcf = BcfXml.create_new(project_name)
    for t in checked:
        handler = bcf.add_topic(t["title"], t["description"], AUTHOR, topic_type=t["ifc_class"],
                                topic_status=t["status"])
        pos, direction, up = camera_for_box(t["center"], t["bbox"])
        components = None
        if t["guid"]:
            components = mdl.Components(
                selection=mdl.ComponentSelection(component=[mdl.Component(ifc_guid=t["guid"])]),
                visibility=mdl.ComponentVisibility(default_visibility=True))
        camera = mdl.PerspectiveCamera(
            camera_view_point=mdl.Point(x=float(pos[0]), y=float(pos[1]), z=float(pos[2])),
            camera_direction=mdl.Direction(x=float(direction[0]), y=float(direction[1]), z=float(direction[2])),
            camera_up_vector=mdl.Direction(x=float(up[0]), y=float(up[1]), z=float(up[2])),
            field_of_view=FIELD_OF_VIEW)
        info = mdl.VisualizationInfo(guid=str(uuid.uuid4()), components=components, perspective_camera=camera)
        handler.add_visinfo_handler(VisualizationInfoHandler(visualization_info=info))
    try:
        with atomic_path(path, suffix=".bcf") as tmp:
            bcf.save(tmp)
    except OSError as exc:
        raise OutputError(f"cannot write the BCF file: {exc.strerror or exc}", path) from None
    return path


def read_bcf(path) -> list[dict]:
    """The topics of a BCF file (2.1, via bcf-client), in the file's order of topic folders.

    Returns a list of dicts: "title", "description", "status", "ifc_class" (the topic
    type), "guid" (the first selected component's IFC GlobalId of the first viewpoint, or
    None), "guids" (all of them) and "camera" (``{"position", "direction", "up",
    "field_of_view"}`` of the first viewpoint's perspective camera, or None).

    Raises
    ------
    InputError
        ``path`` does not exist.
    FormatError
        It is not a BCF file.
    """
    BcfXml, _, _ = _bcf()
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError("BCF file not found", path)
    if not zipfile.is_zipfile(path):
        raise FormatError("not a BCF file (not a zip archive)", path)
    try:
        bcf = BcfXml.load(path)
        out = []
        for handler in bcf.topics.values():
            topic = handler.topic
            guids: list = []
            camera: Optional[dict] = None
            for vp in handler.viewpoints.values():
                info = vp.visualization_info
                if info.components is not None and info.components.selection is not None:
                    guids += [c.ifc_guid for c in info.components.selection.component if c.ifc_guid]
                cam = info.perspective_camera
                if cam is not None and camera is None:
                    camera = {"position": _xyz(cam.camera_view_point), "direction": _xyz(cam.camera_direction),
                              "up": _xyz(cam.camera_up_vector), "field_of_view": float(cam.field_of_view)}
            out.append({"title": topic.title, "description": topic.description or "",
                        "status": topic.topic_status or "", "ifc_class": topic.topic_type or "",
                        "guid": guids[0] if guids else None, "guids": guids, "camera": camera})
        bcf.close()
    except (KeyError, ValueError, AttributeError, zipfile.BadZipFile) as exc:
        raise FormatError(f"not a readable BCF file ({exc.__class__.__name__}: {exc})", path) from None
    except Exception as exc:  # the XML parser's errors (xsdata) have no common base we can import cheaply
        if exc.__class__.__module__.split(".")[0] in ("xsdata", "lxml", "xml"):
            raise FormatError(f"not a readable BCF file ({exc.__class__.__name__}: {exc})", path) from None
        raise
    return out


def _xyz(p) -> tuple:
    return (float(p.x), float(p.y), float(p.z))
