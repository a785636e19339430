"""The BCF file of change detection (engine.change.bcf): one topic per change with the element's
GlobalId as the selected component and a perspective viewpoint looking at it, read back with
bcf-client; bad paths and bad topics give typed one-line errors and leave nothing behind."""
import os

import numpy as np
import pytest

from engine.change.bcf import DOWN_ANGLE, FIELD_OF_VIEW, camera_for_box, read_bcf, write_bcf
from engine.errors import FormatError, InputError, OutputError

pytest.importorskip("bcf")

TOPICS = [
    {"title": "Wall Wp2 not installed", "description": "No scan points on either face; seen beyond it.",
     "status": "not installed", "guid": "2O2Fr$t4X7Zf8NOew3FLOH", "ifc_class": "IfcWall",
     "center": (5.0, 4.0, 1.4), "bbox": ((2.0, 3.9, 0.0), (8.0, 4.1, 2.8))},
    {"title": "Wall W7 incomplete", "description": "40 % of its faces covered.", "status": "incomplete",
     "guid": "0hXy3kD5z1RPa2Wq9mLk$1", "ifc_class": "IfcWall",
     "center": (10.0, 2.0, 1.4), "bbox": ((9.9, 0.0, 0.0), (10.1, 4.0, 2.8))},
    {"title": "New wall", "description": "Fitted from the new points, 0.12 m thick.", "status": "new",
     "guid": "3vB1nq8Zz0Xw5Yk7Jm2P$a", "ifc_class": "IfcWall",
     "center": (14.0, 6.0, 1.4), "bbox": ((12.0, 5.94, 0.0), (16.0, 6.06, 2.8))},
]


def _inside(p, bbox):
    lo, hi = np.asarray(bbox[0]), np.asarray(bbox[1])
    return bool(np.all(p >= lo) and np.all(p <= hi))


def test_write_and_read_back(tmp_path):
    path = write_bcf(tmp_path / "changes.bcf", TOPICS, project_name="office")
    assert os.path.isfile(path) and os.listdir(tmp_path) == ["changes.bcf"]  # no temporary left
    back = read_bcf(path)
    assert len(back) == len(TOPICS)  # one topic per change
    by_title = {t["title"]: t for t in back}
    for want in TOPICS:
        got = by_title[want["title"]]
        assert got["guid"] == want["guid"] and got["guids"] == [want["guid"]]
        assert got["status"] == want["status"] and got["ifc_class"] == "IfcWall"
        assert got["description"] == want["description"]
        cam = got["camera"]
        assert cam is not None and cam["field_of_view"] == FIELD_OF_VIEW
        pos, d, up = (np.asarray(cam[k]) for k in ("position", "direction", "up"))
        c = np.asarray(want["center"])
        # looks at the centre: the centre lies on the viewing ray (within 1 mm), in front of the camera
        along = float(np.dot(c - pos, d))
        assert along > 0 and np.linalg.norm(pos + along * d - c) < 1e-3
        assert abs(np.linalg.norm(d) - 1) < 1e-9 and abs(np.dot(d, up)) < 1e-9 and up[2] > 0
        # from outside the box, looking down by DOWN_ANGLE, at least 2 m away
        assert not _inside(pos, want["bbox"]) and along >= 2.0
        assert np.degrees(np.arcsin(-d[2])) == pytest.approx(DOWN_ANGLE, abs=1e-6)
        # the whole box is in the field of view: its corners within the half angle of the axis
        lo, hi = (np.asarray(b) for b in want["bbox"])
        for corner in np.array(np.meshgrid(*zip(lo, hi))).T.reshape(-1, 3):
            v = corner - pos
            angle = np.degrees(np.arccos(np.dot(v, d) / np.linalg.norm(v)))
            assert angle < 0.5 * FIELD_OF_VIEW, (want["title"], corner, angle)


def test_bcf_client_reads_the_file(tmp_path):
    """Directly with bcf-client (what Bonsai uses): version 2.1, the project, topics with a viewpoint."""
    from bcf.v2.bcfxml import BcfXml

    path = write_bcf(tmp_path / "changes.bcf", TOPICS, project_name="office")
    bcf = BcfXml.load(path)
    try:
        assert bcf.version.version_id == "2.1"
        assert bcf.project_info.project.name == "office"
        assert len(bcf.topics) == 3
        for handler in bcf.topics.values():
            assert len(handler.markup.viewpoints) == 1 and len(handler.viewpoints) == 1
            vp = next(iter(handler.viewpoints.values()))
            assert vp.get_selected_guids() in ([t["guid"]] for t in TOPICS)
            assert vp.visualization_info.perspective_camera is not None
    finally:
        bcf.close()


def test_topic_without_guid_has_a_viewpoint_and_no_component(tmp_path):
    topic = dict(TOPICS[2], guid=None)
    back = read_bcf(write_bcf(tmp_path / "one.bcf", [topic]))
    assert len(back) == 1 and back[0]["guid"] is None and back[0]["guids"] == []
    assert back[0]["camera"] is not None


def test_camera_faces_a_wall():
    """A wall along x is looked at across its thickness (from −y), one along y from −x."""
    _, d, _ = camera_for_box((5, 4, 1.4), ((2, 3.9, 0), (8, 4.1, 2.8)))
    assert d[1] > 0.8 and abs(d[0]) < 1e-9
    _, d, _ = camera_for_box((10, 2, 1.4), ((9.9, 0, 0), (10.1, 4, 2.8)))
    assert d[0] > 0.8 and abs(d[1]) < 1e-9


def test_bad_path_is_a_typed_one_line_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(OutputError) as err:
        write_bcf(blocker / "changes.bcf", TOPICS)
    msg = str(err.value)
    assert "\n" not in msg and "changes.bcf" in msg and "BCF" in msg
    assert sorted(os.listdir(tmp_path)) == ["file"]  # nothing half-written


def test_bad_topics_are_typed_errors(tmp_path):
    path = tmp_path / "changes.bcf"
    cases = [
        ({"title": "x"}, "list"),
        ([{"title": "", "center": (0, 0, 0)}], "no title"),
        ([dict(TOPICS[0], center=(0, float("nan"), 0))], "finite"),
        ([dict(TOPICS[0], center=(0, 0))], "three numbers"),
        ([dict(TOPICS[0], guid=12)], "GlobalId"),
        ([dict(TOPICS[0], bbox=(1, 2, 3))], "bbox"),
    ]
    for topics, word in cases:
        with pytest.raises(InputError, match=word) as err:
            write_bcf(path, topics)
        assert "\n" not in str(err.value)
    assert not path.exists()


def test_read_bad_files(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_bcf(tmp_path / "missing.bcf")
    text = tmp_path / "text.bcf"
    text.write_text("hello")
    with pytest.raises(FormatError, match="not a BCF file"):
        read_bcf(text)
