"""Open3D without its plotly/dash viewer at import (engine.lazy_open3d)."""
import subprocess
import sys

import pytest

pytest.importorskip("open3d")


def _run(code: str) -> list[str]:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    return out.strip().splitlines()


def test_open3d_loads_without_dash_and_its_viewer_still_works():
    # a conversion's normals import open3d; dash and plotly (a web viewer) are not loaded, and a
    # user calling open3d's plotly functions gets the real ones on the first call
    code = ("import sys\nfrom engine.lazy_open3d import open3d\no3d = open3d()\n"
            "print('dash' in sys.modules, 'plotly' in sys.modules)\n"
            "import numpy as np\n"
            "pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.random.default_rng(0).random((50, 3))))\n"
            "fig = o3d.visualization.get_plotly_fig([pc])\n"
            "print(type(fig).__name__, 'dash' in sys.modules, callable(o3d.visualization.draw_plotly))\n"
            "from open3d.visualization.draw_plotly import draw_plotly_server\n"
            "print(draw_plotly_server.__module__)")
    lines = _run(code)
    assert lines[-3] == "False False"
    assert lines[-2] == "Figure True True"
    assert lines[-1] == "open3d.visualization.draw_plotly"


def test_open3d_imported_first_by_the_user_is_returned_as_it_is():
    code = ("import sys, open3d\nfrom engine.lazy_open3d import open3d as get\n"
            "print(get() is open3d, 'dash' in sys.modules)")
    assert _run(code)[-1] == "True True"


def test_the_conversions_normals_do_not_load_dash():
    code = ("import sys\nimport numpy as np\nfrom engine.pointcloud import PointCloud\n"
            "from engine.segmentation.cleaning import estimate_normals\n"
            "xyz = np.random.default_rng(0).random((500, 3)) * [4, 4, 0.01]\n"
            "n = estimate_normals(PointCloud(xyz)).normals\n"
            "print(round(float(np.median(np.abs(n[:, 2]))), 2), 'open3d' in sys.modules, 'dash' in sys.modules)")
    median_nz, loaded, dash = _run(code)[-1].split()
    assert float(median_nz) >= 0.99 and (loaded, dash) == ("True", "False")
