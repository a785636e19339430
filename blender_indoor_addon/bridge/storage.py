"""Model storage: the reconstructed model and its edit history, kept as text blocks in the .blend.

The text :data:`MODEL_TEXT` holds the current model (``BuildingModel.to_dict`` as JSON); the
text :data:`HISTORY_TEXT` holds a JSON list of the models that edits replaced (newest last),
so "Revert last edit" works after the file is saved and reopened. Both are written indented
with ``Text.from_string``: Blender's text blocks cost the square of a line's length to fill,
so one long line of a 4 MB model took minutes; short lines take linear time.
"""
from __future__ import annotations

import json

import bpy

from ...engine.model import BuildingModel

__all__ = ["MODEL_TEXT", "HISTORY_TEXT", "HISTORY_DEPTH", "write_model_text", "stored_model", "push_history",
           "history_length", "previous_model", "drop_previous"]

MODEL_TEXT = "Indoor Model.json"
"""Text datablock that keeps the model (``BuildingModel.to_json``) inside the .blend."""
HISTORY_TEXT = "Indoor Model history.json"
"""Text datablock with the models replaced by edits (a JSON list of model JSON strings)."""
HISTORY_DEPTH = 20
"""How many previous models :func:`push_history` keeps."""


def _text(name: str):
    return bpy.data.texts.get(name) or bpy.data.texts.new(name)


def _write(name: str, data) -> None:
    """Fill the text ``name`` with ``data`` as indented JSON (short lines: linear time)."""
    _text(name).from_string(json.dumps(data, indent=1))


def write_model_text(model_json: str) -> None:
    """Store ``model_json`` (a model's JSON) as the current model (:data:`MODEL_TEXT`)."""
    _write(MODEL_TEXT, json.loads(model_json))


def stored_model():
    """The model kept in the .blend (:data:`MODEL_TEXT`): a :class:`~engine.model.BuildingModel`, or None."""
    text = bpy.data.texts.get(MODEL_TEXT)
    if text is None or not text.as_string().strip():
        return None
    return BuildingModel.from_json(text.as_string())


def _history() -> list:
    """The replaced models as dicts (older files kept them as JSON strings)."""
    text = bpy.data.texts.get(HISTORY_TEXT)
    if text is None or not text.as_string().strip():
        return []
    return [json.loads(m) if isinstance(m, str) else m for m in json.loads(text.as_string())]


def _write_history(items: list) -> None:
    _write(HISTORY_TEXT, items[-HISTORY_DEPTH:])


def push_history(model_json: str) -> int:
    """Keep a model's JSON (before an edit) in the .blend; returns the history length."""
    items = _history()
    items.append(json.loads(model_json))
    _write_history(items)
    return min(len(items), HISTORY_DEPTH)


def history_length() -> int:
    """Number of previous models :func:`previous_model` can go back to."""
    return len(_history())


def previous_model() -> BuildingModel | None:
    """The model before the last edit (the newest of the history), or None when there is none."""
    items = _history()
    return BuildingModel.from_dict(items[-1]) if items else None


def drop_previous() -> None:
    """Drop the newest model of the history (after it was restored)."""
    _write_history(_history()[:-1])
