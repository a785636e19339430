"""Open3D imported without its plotly/dash viewer.

``import open3d`` imports ``open3d.visualization.draw_plotly``, which imports plotly and dash
(a web server): 0.3 s of open3d's 0.7 s import on the 2-core machine, paid by every
conversion and never used by this package. :func:`open3d` imports Open3D with a stand-in for
that one module; its three functions (``get_plotly_fig``, ``draw_plotly``,
``draw_plotly_server``) import the real module on their first call, so a user who calls them
(``open3d.visualization.draw_plotly(...)``) gets what Open3D gives. When Open3D is already
imported (by the user, or in Blender by another add-on) it is returned as it is.
"""
from __future__ import annotations

import importlib
import sys
import types

from .errors import MissingDependencyError

__all__ = ["open3d"]

_VIEWER = "open3d.visualization.draw_plotly"
_VIEWER_FUNCTIONS = ("get_plotly_fig", "draw_plotly", "draw_plotly_server")


def _real_viewer():
    """Import the real plotly viewer in place of the stand-in, and put its functions back on
    ``open3d.visualization`` (the import sets the package's attribute to the module)."""
    if getattr(sys.modules.get(_VIEWER), "_indoor_stand_in", False):
        del sys.modules[_VIEWER]
    real = importlib.import_module(_VIEWER)
    package = sys.modules["open3d.visualization"]
    for name in _VIEWER_FUNCTIONS:
        setattr(package, name, getattr(real, name))
    return real


def _stand_in() -> types.ModuleType:
    mod = types.ModuleType(_VIEWER, "Stand-in: the real module is imported on first use.")
    mod._indoor_stand_in = True

    def forward(name):
        def call(*args, **kwargs):
            return getattr(_real_viewer(), name)(*args, **kwargs)
        call.__name__ = call.__qualname__ = name
        return call

    for name in _VIEWER_FUNCTIONS:
        setattr(mod, name, forward(name))
    return mod


def open3d(purpose: str = "this step"):
    """The ``open3d`` module (see the module's docstring).

    Raises
    ------
    MissingDependencyError
        Open3D is not installed (``purpose`` names what needed it).
    """
    mod = sys.modules.get("open3d")
    if mod is not None:
        return mod
    placed = _VIEWER not in sys.modules
    if placed:
        sys.modules[_VIEWER] = _stand_in()
    try:
        import open3d as o3d
    except ImportError as e:
        raise MissingDependencyError("open3d", purpose) from e
    finally:
        if placed and "open3d" not in sys.modules:  # the import failed: leave nothing behind
            sys.modules.pop(_VIEWER, None)
    return o3d
