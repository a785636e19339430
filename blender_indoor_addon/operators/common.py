"""What several operators share: the stored model, and the scene after the model changed."""
from __future__ import annotations

import bpy

from .. import bridge
from .engine_call import engine_call

__all__ = ["show_model_change", "stored_or_report", "has_model"]


def show_model_change(op, context, model) -> None:
    """After the stored model changed: redraw the shown graphs, drop the stale path and its text.

    A failure is reported by ``op`` (the model stays changed; what the redraw made is removed).
    """
    with engine_call(op, context, progress_bar=False):
        bridge.refresh_overlays(model, scene=context.scene)
    settings = getattr(context.scene, "indoor", None)
    if settings is not None:
        settings.path_text = ""


def stored_or_report(op, context):
    """The stored model; None after an ERROR report when there is none or it cannot be read."""
    with engine_call(op, context, progress_bar=False) as call:
        model = bridge.stored_model()
    if call.failed:
        return None
    if model is None:
        op.report({"ERROR"}, "no reconstructed model in this file: run Reconstruct first")
    return model


def scene_settings(op, context):
    """The add-on's scene settings, or None after reporting that they are missing."""
    settings = getattr(context.scene, "indoor", None)
    if settings is None:
        op.report({"ERROR"}, "the Indoor add-on's scene settings are missing")
    return settings


def has_model(context) -> bool:
    """A reconstructed model is stored in the .blend."""
    return bpy.data.texts.get(bridge.MODEL_TEXT) is not None
