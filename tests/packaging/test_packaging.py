"""Packaging rules: the engine stays pure, the manifest satisfies Blender's extension rules."""
import ast
import os
import re
import tomllib

import engine
from scenes import ROOT

BLENDER_MODULES = {"bpy", "bmesh", "mathutils", "gpu", "bl_ui", "bl_operators", "bpy_extras"}


def _py_files(folder):
    for dirpath, _, files in os.walk(os.path.join(ROOT, folder)):
        for f in files:
            if f.endswith(".py"):
                yield os.path.join(dirpath, f)


def test_engine_never_imports_blender():
    offenders = []
    for path in _py_files("engine"):
        tree = ast.parse(open(path, encoding="utf-8").read(), path)
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name.split(".")[0] for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module.split(".")[0]]
            offenders += [f"{path}:{node.lineno} {n}" for n in names if n in BLENDER_MODULES]
    assert offenders == []


def test_engine_imports_are_relative():
    """Inside engine/ the engine is imported relatively (never `import engine...`)."""
    offenders = []
    for path in _py_files("engine"):
        tree = ast.parse(open(path, encoding="utf-8").read(), path)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module and \
                    node.module.split(".")[0] == "engine":
                offenders.append(f"{path}:{node.lineno}")
            if isinstance(node, ast.Import) and any(a.name.split(".")[0] == "engine" for a in node.names):
                offenders.append(f"{path}:{node.lineno}")
    assert offenders == []


def test_no_sys_path_edits():
    offenders = []
    files = list(_py_files("engine")) + list(_py_files("blender_indoor_addon")) + [os.path.join(ROOT, "__init__.py")]
    for path in files:
        text = open(path, encoding="utf-8").read()
        if re.search(r"sys\.path\.(insert|append|extend)", text):
            offenders.append(path)
    assert offenders == []


def test_manifest_follows_extension_rules():
    with open(os.path.join(ROOT, "blender_manifest.toml"), "rb") as f:
        m = tomllib.load(f)
    assert m["schema_version"] == "1.0.0"
    assert re.fullmatch(r"[a-z][a-z0-9_]*", m["id"])
    assert re.fullmatch(r"\d+\.\d+\.\d+", m["version"])
    assert m["version"] == engine.__version__
    assert len(m["tagline"]) <= 64 and not m["tagline"].endswith(".")
    assert m["blender_version_min"] == "4.2.0"
    assert m["type"] == "add-on"
    assert m["license"] == ["SPDX:GPL-3.0-or-later"]
    assert m["permissions"] and all(isinstance(v, str) and v and not v.endswith(".")
                                    for v in m["permissions"].values())
    excl = m["build"]["paths_exclude_pattern"]
    assert "/tests/" in excl and "/.venv/" in excl


def test_pyproject_version_and_script():
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        p = tomllib.load(f)
    assert p["project"]["version"] == engine.__version__
    assert p["project"]["scripts"]["indoor"] == "engine.cli:run"


def test_root_init_is_thin():
    tree = ast.parse(open(os.path.join(ROOT, "__init__.py"), encoding="utf-8").read())
    top_imports = [n for n in tree.body if isinstance(n, (ast.Import, ast.ImportFrom))]
    assert top_imports == []  # nothing imported at import time (bpy least of all)
    names = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
    assert {"register", "unregister"} <= names
