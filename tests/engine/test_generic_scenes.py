"""The hand-written non-Manhattan scenes of ``scenes.generic``: rooms and sampled points."""
import numpy as np
import shapely

from scenes.generic import hexagon_rooms, sample_rooms


def test_scene_geometry():
    rooms = hexagon_rooms()
    assert len(rooms) == 7
    cloud = sample_rooms(rooms, density=20.0, seed=1)
    lab = cloud.fields["label"]
    assert set(np.unique(lab)) == {0, 1, 2}
    # wall points lie on room outlines, within the noise
    w = cloud.xyz[lab == 0][:200]
    d = [min(r.exterior.distance(shapely.Point(p[:2])) for r in rooms) for p in w]
    assert max(d) < 0.03
