"""Change detection on the ``change_demo`` preset of engine.synthetic (SPEC.md §5).

truth = the old building; the scan (with furniture, 5 mm noise) is of the changed building:
the wall between Rooms 1 and 2 removed, two new walls making a storage room in Room 4
(``cloud.fields["new"]`` = 1 on their points).
"""
import numpy as np
import pytest

from engine import synthetic
from engine.change import NEW, detect_changes, transform_model
from scenes.change import precision_recall, removed_faces, rot_z


@pytest.fixture(scope="module")
def demo():
    return synthetic.preset("change_demo", seed=0, target_points=200_000)


def _check(res, cloud, model):
    truth = cloud.fields["new"] == 1
    assert truth.sum() > 1000
    # new structure = candidate elements spanning floor to ceiling
    prec, rec = precision_recall(res.new_structure(), truth)
    assert prec >= 0.97 and rec >= 0.97, (prec, rec)
    # point level: every new-wall point is new; among non-furniture points, few false alarms
    structural = cloud.fields["label"] != synthetic.LABEL_CLUTTER
    prec, rec = precision_recall((res.point_type == NEW)[structural], truth[structural])
    assert prec >= 0.97 and rec >= 0.97, (prec, rec)
    removed = removed_faces(model)
    assert len(removed) == 2
    assert set(res.redundant) == removed
    assert res.registration.residual < 0.01


def test_change_demo_registered(demo):
    res = detect_changes(demo.truth, demo.cloud)
    _check(res, demo.cloud, demo.truth)
    assert np.abs(res.registration.transform - np.eye(4)).max() < 5e-3


def test_change_demo_misregistered_model(demo):
    wrong = rot_z(5.0, (0.3, 0.0, 0.0))
    moved = transform_model(demo.truth, wrong)
    res = detect_changes(moved, demo.cloud)
    pts = demo.cloud.xyz[::50]
    want = pts @ wrong[:3, :3].T + wrong[:3, 3]
    got = pts @ res.registration.transform[:3, :3].T + res.registration.transform[:3, 3]
    assert np.linalg.norm(got - want, axis=1).max() < 0.01
    _check(res, demo.cloud, moved)


def test_change_demo_mobile_noise_automatic_threshold():
    # σ = 2 cm: r is raised from the registration residual (thesis: 0.10 m for mobile scans)
    scene = synthetic.preset("change_demo", seed=1, noise="mobile", target_points=150_000)
    res = detect_changes(scene.truth, scene.cloud)
    assert 0.07 <= res.distance_threshold <= 0.15
    truth = scene.cloud.fields["new"] == 1
    prec, rec = precision_recall(res.new_structure(), truth)
    assert prec >= 0.95 and rec >= 0.95, (prec, rec)
    assert set(res.redundant) == removed_faces(scene.truth)
