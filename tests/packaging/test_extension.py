"""Packaging as a Blender extension: the zip, its manifest, and installing it like a user.

The install test runs Blender in a child process whose HOME and BLENDER_USER_* folders are
a throwaway directory, so the machine's ~/.config/blender is never touched.
"""
import importlib.util
import json
import os
import subprocess
import sys
import textwrap
import tomllib
import zipfile

import pytest
from scenes import DATA, ROOT



def _extension_script():
    spec = importlib.util.spec_from_file_location("extension_script",
                                                  os.path.join(ROOT, "scripts", "extension.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


ext = _extension_script()


def test_exclude_patterns_follow_gitignore_rules():
    pats = ["__pycache__/", "/tests/", "*.egg-info/", ".gitignore", "/Makefile", "/docs/*.md"]
    assert ext.is_excluded("engine/__pycache__", True, pats)
    assert not ext.is_excluded("engine/__pycache__", False, pats)  # "dir/" matches folders only
    assert ext.is_excluded("tests", True, pats)
    assert not ext.is_excluded("engine/tests", True, pats)  # "/x/" is anchored at the root
    assert ext.is_excluded("indoor.egg-info", True, pats)
    assert ext.is_excluded("engine/.gitignore", False, pats)  # unanchored: any depth
    assert ext.is_excluded("Makefile", False, pats) and not ext.is_excluded("engine/Makefile", False, pats)
    assert ext.is_excluded("docs/a.md", False, pats) and not ext.is_excluded("docs/a.txt", False, pats)


def test_build_without_wheels_packs_the_extension_only(tmp_path):
    path = ext.build(str(tmp_path), with_wheels=False)
    manifest = ext.read_manifest()
    assert os.path.basename(path) == f"{manifest['id']}-{manifest['version']}.zip"
    with zipfile.ZipFile(path) as z:
        names = set(z.namelist())
        packed_manifest = tomllib.loads(z.read("blender_manifest.toml").decode())
    for required in ("__init__.py", "blender_manifest.toml", "LICENSE", "blender_indoor_addon/__init__.py",
                     "blender_indoor_addon/operators/__init__.py", "blender_indoor_addon/bridge/__init__.py",
                     "blender_indoor_addon/bridge/points.py", "engine/background.py",
                     "engine/__init__.py", "engine/io/__init__.py", "engine/pointcloud.py"):
        assert required in names
    for n in names:
        top = n.split("/")[0]
        assert top not in {"tests", "scripts", "bench", ".venv", ".git", ".ci", "out", "dist", "wheels"}, n
        assert "__pycache__" not in n and not n.endswith(".pyc") and ".egg-info" not in n, n
    assert "wheels" not in packed_manifest and "platforms" not in packed_manifest
    assert packed_manifest["id"] == manifest["id"]


def _mini_root(tmp_path, wheel_name):
    root = tmp_path / "src"
    (root / "wheels").mkdir(parents=True)
    (root / "__init__.py").write_text("def register():\n    pass\n\n\ndef unregister():\n    pass\n")
    (root / "blender_manifest.toml").write_text(textwrap.dedent(f"""\
        schema_version = "1.0.0"
        id = "mini"
        version = "1.2.3"
        wheels = [
          "./wheels/{wheel_name}",
        ]

        [build]
        paths_exclude_pattern = ["/notes/"]
        """))
    (root / "notes").mkdir()
    (root / "notes" / "todo.txt").write_text("x")
    return root


def test_build_with_wheels_needs_them_and_bundles_them(tmp_path):
    wheel = "tiny-0.1-py3-none-any.whl"
    root = _mini_root(tmp_path, wheel)
    with pytest.raises(SystemExit, match="make wheels"):
        ext.build(str(tmp_path / "dist"), root=str(root))
    with zipfile.ZipFile(root / "wheels" / wheel, "w") as z:
        z.writestr("tiny/__init__.py", "")
    path = ext.build(str(tmp_path / "dist"), root=str(root))
    with zipfile.ZipFile(path) as z:
        assert sorted(z.namelist()) == ["__init__.py", "blender_manifest.toml", f"wheels/{wheel}"]
        assert z.getinfo(f"wheels/{wheel}").compress_type == zipfile.ZIP_STORED
    path = ext.build(str(tmp_path / "dist2"), root=str(root), with_wheels=False)
    with zipfile.ZipFile(path) as z:
        assert sorted(z.namelist()) == ["__init__.py", "blender_manifest.toml"]
        assert "wheels" not in tomllib.loads(z.read("blender_manifest.toml").decode())


def test_split_platform_zip_holds_only_its_wheels(tmp_path):
    root = _mini_root(tmp_path, "tiny-0.1-py3-none-any.whl")
    manifest = (root / "blender_manifest.toml").read_text()
    win, lin = "fast-1.0-cp311-cp311-win_amd64.whl", "fast-1.0-cp311-cp311-manylinux_2_28_x86_64.whl"
    tiny = '  "./wheels/tiny-0.1-py3-none-any.whl",\n'
    manifest = manifest.replace(tiny, tiny + f'  "./wheels/{win}",\n  "./wheels/{lin}",\n')
    manifest = manifest.replace("wheels = [", 'platforms = ["linux-x64", "windows-x64"]\nwheels = [')
    (root / "blender_manifest.toml").write_text(manifest)
    for w in ("tiny-0.1-py3-none-any.whl", win, lin):
        with zipfile.ZipFile(root / "wheels" / w, "w") as z:
            z.writestr("x.py", "")
    path = ext.build(str(tmp_path / "dist"), root=str(root), platform="windows-x64")
    assert os.path.basename(path) == "mini-1.2.3-windows_x64.zip"
    with zipfile.ZipFile(path) as z:
        assert sorted(z.namelist()) == ["__init__.py", "blender_manifest.toml",
                                        f"wheels/{win}", "wheels/tiny-0.1-py3-none-any.whl"]
        m = tomllib.loads(z.read("blender_manifest.toml").decode())
    assert m["platforms"] == ["windows-x64"]
    assert sorted(m["wheels"]) == [f"./wheels/{win}", "./wheels/tiny-0.1-py3-none-any.whl"]
    assert m["build"]["paths_exclude_pattern"] == ["/notes/"]


def test_manifest_wheels_cover_the_engine_dependencies():
    manifest = ext.read_manifest()
    wheels = manifest.get("wheels", [])
    assert wheels, "the manifest lists the bundled wheels"
    assert "/wheels/" not in manifest["build"]["paths_exclude_pattern"]  # Blender must pack them
    parsed = [ext.parse_wheel_name(w) for w in wheels]
    assert all(w.startswith("./wheels/") for w in wheels)
    names = {p["name"].lower() for p in parsed}
    assert "numpy" not in names  # Blender ships numpy; bundling it breaks Blender
    for platform in manifest["platforms"]:
        have = {p["name"].lower() for p in parsed
                if p["plat"] == "any" or ext._plat_family(p["plat"].split(".")[0]) == platform}
        for need in ("scipy", "open3d", "shapely", "networkx", "ifcopenshell", "trimesh", "laspy", "lazrs",
                     "pye57", "matplotlib"):
            assert need in have, (platform, need)
    dists = {ext.dist_name(p["name"]) for p in parsed}
    assert not dists & ext.NOT_LOADED, dists & ext.NOT_LOADED  # what the engine never loads is left out
    assert not dists & ext.BLENDER_SHIPS
    for p in parsed:  # every wheel fits Blender 4.2-4.5's CPython 3.11
        if p["abi"] == "abi3":  # stable ABI: built for CPython 3.x <= 3.11
            assert p["py"].startswith("cp3") and int(p["py"][3:]) <= 11, p
        elif p["abi"] == "none":
            assert p["py"] in {"py3", "py2.py3", "py311"}, p
        else:
            assert (p["py"], p["abi"]) == ("cp311", "cp311"), p


def test_lock_leaves_out_what_blender_ships_and_what_is_never_loaded(tmp_path):
    """``lock`` keeps the resolved wheels but those of BLENDER_SHIPS and NOT_LOADED (pip stands in)."""
    resolved = ["open3d-0.20.0-cp311-cp311-win_amd64.whl", "dash-4.4.1-py3-none-any.whl",
                "Flask-3.1.3-py3-none-any.whl", "ipython-9.18.1-py3-none-any.whl",
                "numpy-1.26.4-cp311-cp311-win_amd64.whl", "typing_extensions-4.16.0-py3-none-any.whl"]
    fake_pip = tmp_path / "pip.py"
    fake_pip.write_text(textwrap.dedent(f"""\
        import json, sys
        report = sys.argv[sys.argv.index("--report") + 1]
        names = {resolved!r}
        items = [{{"metadata": {{"name": n.split("-")[0]}},
                   "download_info": {{"url": "https://files.example/x/" + n}}}} for n in names]
        json.dump({{"install": items}}, open(report, "w"))
        """))
    entries = ext.lock(["windows-x64"], pip=[sys.executable, str(fake_pip)])
    assert entries == ["./wheels/dash-4.4.1-py3-none-any.whl",
                       "./wheels/open3d-0.20.0-cp311-cp311-win_amd64.whl",
                       "./wheels/typing_extensions-4.16.0-py3-none-any.whl"]


@pytest.mark.slow
def test_engine_runs_with_only_the_manifest_wheels():
    """The whole run-time work of the engine (both methods, IFC, evaluation, changes, LAZ, E57,
    OBJ) with only this platform's listed wheels and Blender's packages: it works, and every
    listed wheel is loaded (``extension.py probe``; needs ``make wheels``)."""
    manifest = ext.read_manifest()
    here = ext._this_platform()
    wheels = [w.lstrip("./") for w in manifest["wheels"] if ext.wheel_platform(w) in (None, here)]
    if not all(os.path.isfile(os.path.join(ROOT, w)) for w in wheels):
        pytest.skip("the manifest's wheels are not downloaded (make wheels)")
    out = ext.probe(os.path.join(DATA, "room_scan1.pcd"))
    assert out["not_loaded"] == []
    assert {"open3d", "ifcopenshell", "scipy", "matplotlib", "pye57", "laspy"} <= set(out["loaded"])


_INSTALL_SCRIPT = r'''
import json, os, sys
import bpy

zip_path, scan, report_path = sys.argv[-3:]
out = {"repo_dir": bpy.utils.user_resource("EXTENSIONS", path="user_default")}


def main():
    res = bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                                   enable_on_install=True)
    out["install"] = sorted(res)
    import importlib
    mod = importlib.import_module("bl_ext.user_default.indoor_reconstruction")
    out["module_file"] = mod.__file__
    out["enabled"] = "bl_ext.user_default.indoor_reconstruction" in bpy.context.preferences.addons
    out["has_operator"] = "import_scan" in dir(bpy.ops.indoor)
    bpy.ops.wm.read_homefile(app_template="", use_factory_startup=False)
    out["import"] = sorted(bpy.ops.indoor.import_scan(filepath=scan))
    obj = bpy.context.scene.collection.children["Scan"].objects[0]
    out["vertices"] = len(obj.data.vertices)
    bpy.ops.preferences.addon_disable(module="bl_ext.user_default.indoor_reconstruction")
    out["operator_after_disable"] = "import_scan" in dir(bpy.ops.indoor)
    repo_index = [r.module for r in bpy.context.preferences.extensions.repos].index("user_default")
    out["uninstall"] = sorted(bpy.ops.extensions.package_uninstall(repo_index=repo_index,
                                                                   pkg_id="indoor_reconstruction"))
    out["left_after_uninstall"] = os.path.exists(os.path.join(out["repo_dir"], "indoor_reconstruction"))


try:
    main()
except BaseException as e:
    out["error"] = repr(e)
finally:
    with open(report_path, "w") as f:
        json.dump(out, f)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)  # a failure may leave classes registered; the bpy module would hang at exit

'''


def _blender_command(script, args):
    import bpy

    if bpy.app.binary_path:  # a real Blender: run it in background with our script
        return [bpy.app.binary_path, "-b", "--factory-startup", "--python-exit-code", "1",
                "--python", script, "--", *args]
    return [sys.executable, script, *args]  # the bpy module: a fresh Python


@pytest.mark.blender
def test_install_zip_like_a_user_in_a_throwaway_home(tmp_path):
    pytest.importorskip("bpy")
    zip_path = ext.build(str(tmp_path / "dist"), with_wheels=False)
    home = tmp_path / "home"
    home.mkdir()
    env = dict(os.environ)
    env.update({
        "HOME": str(home),
        "XDG_CONFIG_HOME": str(home / ".config"),
        "BLENDER_USER_RESOURCES": str(home / "blender"),
        "BLENDER_USER_CONFIG": str(home / "blender" / "config"),
        "BLENDER_USER_SCRIPTS": str(home / "blender" / "scripts"),
        "BLENDER_USER_EXTENSIONS": str(home / "blender" / "extensions"),
        "BLENDER_USER_DATAFILES": str(home / "blender" / "datafiles"),
    })
    real_config = os.path.join(os.path.expanduser("~"), ".config", "blender")
    existed = os.path.exists(real_config)
    script = tmp_path / "install_check.py"
    script.write_text(_INSTALL_SCRIPT)
    report = tmp_path / "report.json"
    scan = os.path.join(DATA, "room_scan1.pcd")
    proc = subprocess.run(_blender_command(str(script), [zip_path, scan, str(report)]), env=env,
                          cwd=str(tmp_path), stdin=subprocess.DEVNULL, capture_output=True, text=True,
                          timeout=240)
    assert report.exists(), proc.stdout[-3000:] + proc.stderr[-3000:]
    out = json.loads(report.read_text())
    assert "error" not in out, out
    assert out["repo_dir"].startswith(str(home))
    assert out["install"] == ["FINISHED"]
    assert out["module_file"].startswith(str(home))  # imported from the installed copy
    assert out["enabled"] and out["has_operator"]
    assert out["import"] == ["FINISHED"] and out["vertices"] == 112586
    assert out["operator_after_disable"] is False
    assert out["uninstall"] == ["FINISHED"] and out["left_after_uninstall"] is False
    assert os.path.exists(real_config) == existed  # the real user config was not created
