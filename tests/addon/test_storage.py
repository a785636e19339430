"""The model kept in the .blend: short lines (Blender fills a text block in the square of a
line's length), the same model back, the edit history in the old format too."""
import importlib
import json

import pytest

bpy = pytest.importorskip("bpy")

import blender_util as bu  # noqa: E402

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def model(synthetic_model):
    return synthetic_model("generic", "syn_house", 0, "tls", 100_000)


@pytest.fixture(scope="module")
def bridge(addon):
    return importlib.import_module(addon.__name__ + ".bridge")


def test_model_text_has_short_lines_and_round_trips(bridge, model):
    bu.fresh_scene()
    text = model.to_json()
    assert len(text) > 50_000  # a real model: one line of this length is what was slow
    bridge.write_model_text(text)
    lines = bpy.data.texts[bridge.MODEL_TEXT].as_string().splitlines()
    assert len(lines) > 1000 and max(len(ln) for ln in lines) < 200
    back = bridge.stored_model()
    assert back.to_dict() == model.to_dict()


def test_history_round_trips_and_reads_the_old_format(bridge, model):
    bu.fresh_scene()
    for t in list(bpy.data.texts):
        bpy.data.texts.remove(t)
    assert bridge.push_history(model.to_json()) == 1
    assert bridge.previous_model().to_dict() == model.to_dict()
    bridge.drop_previous()
    assert bridge.history_length() == 0
    # a .blend written before: a JSON list of model JSON strings
    old = bpy.data.texts.get(bridge.HISTORY_TEXT) or bpy.data.texts.new(bridge.HISTORY_TEXT)
    old.from_string(json.dumps([model.to_json()]))
    assert bridge.history_length() == 1
    assert bridge.previous_model().to_dict() == model.to_dict()
