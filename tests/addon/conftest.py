"""Fixtures of the add-on tests."""
import pytest

import blender_util as bu


@pytest.fixture(scope="module")
def addon():
    """The add-on, registered for one test module."""
    mod = bu.addon_module()
    mod.register()
    yield mod
    # unregister before the process ends: the bpy module hangs at exit with classes registered
    mod.unregister()
