"""Build the Blender extension zip and fetch the wheels its manifest lists.

    python scripts/extension.py build [--out dist] [--no-wheels] [--split-platforms]
    python scripts/extension.py wheels [--platform linux-x64 ...]    # download the listed wheels
    python scripts/extension.py lock [--platform ...]                # resolve versions -> wheel list
    python scripts/extension.py probe [--scan FILE]                  # which wheels the engine loads

With a Blender binary the same zip comes from
``blender --command extension build --source-dir . --output-dir dist`` (add
``--split-platforms`` for one zip per platform, each with only its wheels) and is checked by
``blender --command extension validate dist/<zip>``.

``build`` packs every file of the repository root except the manifest's
``[build] paths_exclude_pattern`` (gitignore syntax, as Blender reads it), checks the wheels
the manifest lists are present (``make wheels`` first) and writes
``<out>/<id>-<version>.zip``. ``--no-wheels`` writes a zip whose manifest lists no wheels: it
installs into a Blender whose Python already has the packages (the bpy-module environment
of the tests).

``wheels`` downloads exactly the files the manifest lists (name, version and platform tag
read from each wheel's file name) with ``pip download --no-deps --only-binary=:all:`` for
CPython 3.11, Blender 4.2–4.5's Python; nothing is committed (``wheels/`` is git-ignored).

``lock`` resolves the engine's requirements for each platform with
``pip install --dry-run --report`` and prints the ``wheels = [...]`` list for the manifest,
leaving out what Blender itself ships (numpy and friends) and the distributions the engine's
dependencies declare but never load (:data:`NOT_LOADED`: open3d's Jupyter and web-app
extras, for instance).

``probe`` checks that list: it installs this machine's platform's wheels of the manifest
alone into a temporary folder, beside the packages Blender ships (linked from this Python),
runs the engine's whole run-time work there (both methods, IFC out and in, evaluation with
its plot, change detection, LAZ, E57 and OBJ input) with no other site-packages, and prints
the distributions that were loaded and the listed ones that were not; it fails when the work
fails (a wheel the engine needs is missing).
"""
from __future__ import annotations

import argparse
import fnmatch
import json
import os
import re
import subprocess
import sys
import tempfile
import tomllib
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MANIFEST = "blender_manifest.toml"
PYTHON_VERSION = "3.11"
"""Python of Blender 4.2–4.5 (the wheels' ``cp311`` tag)."""
REQUIREMENTS = ["scipy>=1.11", "open3d>=0.18", "shapely>=2.0", "networkx>=3.0", "ifcopenshell>=0.8",
                "trimesh>=4.0", "laspy>=2.5", "lazrs", "pye57>=0.4", "matplotlib>=3.7", "dask[distributed]>=2024.1",
                "bcf-client>=0.8", "numpy>=1.26,<2"]
"""What the engine needs (the ranges of requirements.txt). numpy is constrained to what
Blender 4.2–4.5 ship (1.26) so the resolver picks builds compatible with it; numpy itself is
never bundled."""
BLENDER_SHIPS = {"numpy", "requests", "certifi", "idna", "charset-normalizer", "urllib3", "cython",
                 "zstandard"}
"""Packages Blender's own Python already has; never bundled (bundling numpy breaks Blender)."""
NOT_LOADED = {
    # open3d's optional Jupyter widget and its IPython stack
    "ipywidgets", "jupyterlab-widgets", "widgetsnbextension", "comm", "traitlets", "ipython",
    "ipython-pygments-lexers", "pygments", "jedi", "parso", "prompt-toolkit", "wcwidth", "pexpect",
    "ptyprocess", "stack-data", "executing", "asttokens", "pure-eval", "matplotlib-inline",
    "nbformat", "fastjsonschema", "jsonschema", "jsonschema-specifications", "referencing", "rpds-py",
    "attrs", "jupyter-core", "platformdirs", "nest-asyncio", "retrying",
    # dash's web server (open3d imports dash, which never starts a server here)
    # (click, jinja2, psutil, importlib-metadata and zipp stay: dask.distributed loads them)
    "flask", "blinker", "itsdangerous", "setuptools",
    # open3d's command-line tools, ifcopenshell's and matplotlib's unused extras
    "configargparse", "tzdata", "isodate", "lazy-importer", "contourpy",
}
"""Distributions the engine's dependencies declare but the engine never loads at run time
(``probe``: an import of open3d, ifcopenshell, trimesh, laspy, pye57, matplotlib and a whole
run load none of them, and the run works without them); never bundled. What open3d imports
unconditionally (dash, plotly and what they import) stays."""
PLATFORM_TAGS = {
    "linux-x64": ["manylinux_2_35_x86_64", "manylinux_2_34_x86_64", "manylinux_2_31_x86_64",
                  "manylinux_2_28_x86_64", "manylinux_2_27_x86_64", "manylinux_2_24_x86_64",
                  "manylinux_2_17_x86_64", "manylinux2014_x86_64", "linux_x86_64"],
    "windows-x64": ["win_amd64"],
    "macos-arm64": ["macosx_14_0_arm64", "macosx_13_0_arm64", "macosx_12_0_arm64", "macosx_11_0_arm64",
                    "macosx_11_0_universal2", "macosx_10_9_universal2"],
}
"""pip ``--platform`` tags tried for each Blender platform name."""
ALWAYS_EXCLUDED_SUFFIXES = (".pyc", ".pyo")


# --------------------------------------------------------------------------- manifest
def read_manifest(root: str = ROOT) -> dict:
    with open(os.path.join(root, MANIFEST), "rb") as f:
        return tomllib.load(f)


def manifest_without_wheels(text: str) -> str:
    """The manifest text with its ``wheels = [...]`` and ``platforms`` entries removed."""
    text = re.sub(r"(?ms)^wheels\s*=\s*\[.*?\]\s*\n", "", text)
    return re.sub(r"(?m)^platforms\s*=\s*\[.*?\]\s*\n", "", text)


def manifest_for_platform(text: str, platform: str, wheels: list[str]) -> str:
    """The manifest text for one platform: ``platforms = [platform]`` and only ``wheels``."""
    text = manifest_without_wheels(text)
    block = f'platforms = ["{platform}"]\n'
    if wheels:
        block += "wheels = [\n" + "".join(f'  "./{w}",\n' for w in wheels) + "]\n"
    m = re.search(r"(?m)^\[", text)  # before the first table, where top-level keys belong
    at = m.start() if m else len(text)
    return text[:at] + block + ("\n" if m else "") + text[at:]


def wheel_platform(filename: str) -> str | None:
    """The Blender platform of a wheel (``linux-x64``...), None for pure-Python wheels."""
    plat = parse_wheel_name(filename)["plat"]
    return None if plat == "any" else _plat_family(plat.split(".")[0])


# --------------------------------------------------------------------------- exclusion
def is_excluded(rel_path: str, is_dir: bool, patterns) -> bool:
    """Gitignore-style matching of Blender's ``paths_exclude_pattern``.

    ``rel_path`` is POSIX and relative to the root. A trailing ``/`` matches directories
    only; a leading ``/`` anchors the pattern at the root; a pattern with no other ``/`` is
    matched against the last path component at any depth, otherwise against the whole path.
    """
    name = rel_path.rsplit("/", 1)[-1]
    for pattern in patterns:
        dir_only = pattern.endswith("/")
        p = pattern.rstrip("/")
        if dir_only and not is_dir:
            continue
        if p.startswith("/"):
            if fnmatch.fnmatchcase(rel_path, p[1:]):
                return True
        elif "/" in p:
            if fnmatch.fnmatchcase(rel_path, p) or fnmatch.fnmatchcase(rel_path, "*/" + p):
                return True
        elif fnmatch.fnmatchcase(name, p):
            return True
    return False


def package_files(root: str = ROOT, patterns=None) -> list[str]:
    """Relative POSIX paths of the files the extension zip holds, sorted."""
    if patterns is None:
        patterns = read_manifest(root).get("build", {}).get("paths_exclude_pattern", [])
    out = []
    for dirpath, dirnames, filenames in os.walk(root):
        rel_dir = os.path.relpath(dirpath, root).replace(os.sep, "/")
        rel_dir = "" if rel_dir == "." else rel_dir + "/"
        dirnames[:] = sorted(d for d in dirnames if not is_excluded(rel_dir + d, True, patterns))
        for f in sorted(filenames):
            rel = rel_dir + f
            if f.endswith(ALWAYS_EXCLUDED_SUFFIXES) or is_excluded(rel, False, patterns):
                continue
            out.append(rel)
    return sorted(out)


# --------------------------------------------------------------------------- build
def build(out_dir: str, *, root: str = ROOT, with_wheels: bool = True, name: str | None = None,
          platform: str | None = None) -> str:
    """Write the extension zip and return its path.

    Parameters
    ----------
    out_dir : str
        Folder that receives ``<id>-<version>.zip`` (or ``name``).
    with_wheels : bool
        Bundle the wheels the manifest lists (they must be present: ``make wheels``). When
        False the zip's manifest lists no wheels and no ``wheels/`` folder is packed.
    platform : str, optional
        Build for one platform only (like Blender's ``--split-platforms``): only its wheels
        and the pure-Python ones, ``platforms = [platform]``, named
        ``<id>-<version>-<platform with _>.zip``.
    """
    manifest = read_manifest(root)
    files = package_files(root)
    wheels = [w.lstrip("./") for w in manifest.get("wheels", [])]
    manifest_text = open(os.path.join(root, MANIFEST), encoding="utf-8").read()
    if platform is not None:
        wheels = [w for w in wheels if wheel_platform(w) in (None, platform)]
        manifest_text = manifest_for_platform(manifest_text, platform, wheels if with_wheels else [])
    if with_wheels:
        missing = [w for w in wheels if not os.path.isfile(os.path.join(root, w))]
        if missing:
            raise SystemExit(f"{len(missing)} wheel(s) listed in {MANIFEST} are missing, e.g. {missing[0]}; "
                             "run `make wheels` (or build with --no-wheels)")
        files = sorted(set(f for f in files if not f.startswith("wheels/")) | set(wheels))
    else:
        files = [f for f in files if not f.startswith("wheels/")]
        if platform is None:
            manifest_text = manifest_without_wheels(manifest_text)
    for required in ("__init__.py", MANIFEST):
        if required not in files:
            raise SystemExit(f"{required} would not be packed: check paths_exclude_pattern")
    os.makedirs(out_dir, exist_ok=True)
    suffix = "" if platform is None else "-" + platform.replace("-", "_")
    dest = os.path.join(out_dir, name or f"{manifest['id']}-{manifest['version']}{suffix}.zip")
    fd, tmp = tempfile.mkstemp(prefix=".ext.", suffix=".zip.part", dir=out_dir)
    os.close(fd)
    try:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as z:
            for rel in files:
                if rel == MANIFEST:
                    z.writestr(rel, manifest_text)
                elif rel.endswith(".whl"):
                    z.write(os.path.join(root, rel), rel, compress_type=zipfile.ZIP_STORED)
                else:
                    z.write(os.path.join(root, rel), rel)
        os.replace(tmp, dest)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    return dest


# --------------------------------------------------------------------------- wheels
_WHEEL_RE = re.compile(r"^(?P<name>[^-]+)-(?P<version>[^-]+)(-\d[^-]*)?"
                       r"-(?P<py>[^-]+)-(?P<abi>[^-]+)-(?P<plat>[^-]+)\.whl$")


def parse_wheel_name(filename: str) -> dict:
    """``{name, version, py, abi, plat}`` of a wheel file name (PEP 427)."""
    m = _WHEEL_RE.match(os.path.basename(filename))
    if m is None:
        raise ValueError(f"{filename}: not a wheel file name")
    return m.groupdict()


def download_wheels(root: str = ROOT, platforms=None, pip=None) -> list[str]:
    """Download the manifest's wheels into ``root/wheels`` (skipping those present)."""
    pip = pip or [sys.executable, "-m", "pip"]
    manifest = read_manifest(root)
    done = []
    for rel in manifest.get("wheels", []):
        rel = rel.lstrip("./")
        w = parse_wheel_name(rel)
        if platforms and w["plat"] != "any" and not any(
                w["plat"] in PLATFORM_TAGS.get(p, [p]) or _plat_family(w["plat"]) == p for p in platforms):
            continue
        dest = os.path.join(root, os.path.dirname(rel))
        if os.path.isfile(os.path.join(root, rel)):
            done.append(rel)
            continue
        cmd = [*pip, "download", "--no-deps", "--only-binary=:all:", "--dest", dest,
               "--python-version", PYTHON_VERSION, "--implementation", "cp"]
        for plat in w["plat"].split("."):
            cmd += ["--platform", plat]
        if w["abi"] != "none":
            cmd += ["--abi", w["abi"]]
        cmd.append(f"{w['name']}=={w['version']}")
        subprocess.run(cmd, check=True)
        if not os.path.isfile(os.path.join(root, rel)):
            raise SystemExit(f"pip did not produce {rel}; the manifest entry may be stale (run `lock`)")
        done.append(rel)
    return done


def _plat_family(plat: str) -> str:
    if plat.startswith(("manylinux", "linux")):
        return "linux-x64"
    if plat.startswith("win"):
        return "windows-x64"
    if plat.startswith("macosx") and plat.endswith(("arm64", "universal2")):
        return "macos-arm64"
    return plat


def lock(platforms, pip=None) -> list[str]:
    """Resolve :data:`REQUIREMENTS` for each platform (newest versions that fit).

    Returns the sorted ``./wheels/<file>`` entries for the manifest, without the packages
    in :data:`BLENDER_SHIPS` and :data:`NOT_LOADED`.
    """
    pip = pip or [sys.executable, "-m", "pip"]
    reqs = list(REQUIREMENTS)
    entries = set()
    for platform in platforms:
        with tempfile.TemporaryDirectory() as tmp:
            report = os.path.join(tmp, "report.json")
            cmd = [*pip, "install", "--dry-run", "--ignore-installed", "--quiet", "--report", report,
                   "--index-url", "https://pypi.org/simple", "--no-cache-dir",
                   "--only-binary=:all:", "--python-version", PYTHON_VERSION, "--implementation", "cp",
                   "--target", os.path.join(tmp, "t")]
            for tag in PLATFORM_TAGS[platform]:
                cmd += ["--platform", tag]
            subprocess.run(cmd + reqs, check=True)
            with open(report) as f:
                for item in json.load(f)["install"]:
                    if dist_name(item["metadata"]["name"]) in BLENDER_SHIPS | NOT_LOADED:
                        continue
                    entries.add("./wheels/" + item["download_info"]["url"].rsplit("/", 1)[1])
    return sorted(entries)


def dist_name(name: str) -> str:
    """A distribution name normalised as in PEP 503 (``Typing_Extensions`` → ``typing-extensions``)."""
    return re.sub(r"[-_.]+", "-", name).lower()


def _this_platform() -> str:
    plat = sys.platform
    if plat.startswith("linux"):
        return "linux-x64"
    return "windows-x64" if plat == "win32" else "macos-arm64"


def _link_blender_packages(dest: str) -> list[str]:
    """Link the packages of :data:`BLENDER_SHIPS` installed in this Python into ``dest``."""
    import importlib.metadata as md

    linked = []
    for d in md.distributions():
        if dist_name(d.metadata["Name"]) not in BLENDER_SHIPS:
            continue
        base = str(d.locate_file(""))
        for top in sorted({str(f).split("/")[0] for f in d.files or []}):
            src, dst = os.path.join(base, top), os.path.join(dest, top)
            if top.startswith("..") or top == "bin" or not os.path.exists(src) or os.path.exists(dst):
                continue
            os.symlink(src, dst)
            linked.append(top)
    return linked


def probe(scan: str, root: str = ROOT, pip=None) -> dict:
    """Run the engine's run-time work with only this platform's manifest wheels and Blender's
    packages; returns ``{"loaded": [...], "not_loaded": [...], "steps": {name: seconds}}``.

    Raises
    ------
    SystemExit
        A listed wheel is missing (``make wheels``) or the work fails without the others.
    """
    pip = pip or [sys.executable, "-m", "pip"]
    platform = _this_platform()
    wheels = [w.lstrip("./") for w in read_manifest(root).get("wheels", [])]
    wheels = [w for w in wheels if wheel_platform(w) in (None, platform)]
    missing = [w for w in wheels if not os.path.isfile(os.path.join(root, w))]
    if missing:
        raise SystemExit(f"{len(missing)} wheel(s) are missing, e.g. {missing[0]}: run `make wheels`")
    with tempfile.TemporaryDirectory(prefix="indoor-probe-") as tmp:
        site, ships = os.path.join(tmp, "site"), os.path.join(tmp, "blender")
        os.makedirs(ships)
        subprocess.run([*pip, "install", "--quiet", "--no-deps", "--no-index", "--target", site,
                        *[os.path.join(root, w) for w in wheels]], check=True)
        _link_blender_packages(ships)
        # -S -E: no site-packages, no PYTHONPATH; the child sees the wheels, Blender's packages, the engine
        proc = subprocess.run([sys.executable, "-S", "-E", os.path.abspath(__file__), "_work",
                               json.dumps([site, ships, root]), os.path.abspath(scan)],
                              capture_output=True, text=True, cwd=tmp)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("PROBE ")]
    if proc.returncode != 0 or not lines:
        raise SystemExit(f"the engine's work failed with only the manifest's wheels:\n{proc.stderr[-3000:]}")
    out = json.loads(lines[-1][len("PROBE "):])
    listed = {dist_name(parse_wheel_name(w)["name"]) for w in wheels}
    out["loaded"] = sorted(set(out["loaded"]) & (listed | BLENDER_SHIPS))
    out["not_loaded"] = sorted(listed - set(out["loaded"]))
    return out


_OBJ_BOX = ("v 0 0 0\nv 4 0 0\nv 4 3 0\nv 0 3 0\nv 0 0 2.5\nv 4 0 2.5\nv 4 3 2.5\nv 0 3 2.5\n"
            "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\n"
            "f 4 1 5\nf 4 5 8\n")
"""A 4 x 3 x 2.5 m box as OBJ (a reference model read through trimesh)."""


def _work(paths: list[str], scan: str) -> None:
    """The child of :func:`probe`: every run-time path of the engine, then the loaded distributions."""
    import time

    sys.path[:0] = paths
    from engine.change import detect_changes
    from engine.evaluation import evaluate, load_model, write_evaluation_outputs
    from engine.ifc import write_ifc
    from engine.io import read_point_cloud
    from engine.reconstruct import reconstruct

    tmp = tempfile.mkdtemp(prefix="indoor-probe-work-")
    steps, state = {}, {}

    def step(name, fn):
        t = time.perf_counter()
        fn()
        steps[name] = round(time.perf_counter() - t, 2)

    def laz():
        import laspy

        header = laspy.LasHeader(point_format=3, version="1.2")
        header.scales = [0.001] * 3
        las = laspy.LasData(header)
        xyz = state["cloud"].xyz[:5000]
        las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
        las.write(os.path.join(tmp, "s.laz"))
        assert len(read_point_cloud(os.path.join(tmp, "s.laz"))) == len(xyz)

    def e57():
        import pye57

        xyz = state["cloud"].xyz[:5000]
        f = pye57.E57(os.path.join(tmp, "s.e57"), mode="w")
        f.write_scan_raw({"cartesianX": xyz[:, 0], "cartesianY": xyz[:, 1], "cartesianZ": xyz[:, 2]})
        f.close()
        assert len(read_point_cloud(os.path.join(tmp, "s.e57"))) == len(xyz)

    def obj():
        with open(os.path.join(tmp, "box.obj"), "w") as f:
            f.write(_OBJ_BOX)
        load_model(os.path.join(tmp, "box.obj"))

    ifc = os.path.join(tmp, "model.ifc")
    step("read", lambda: state.update(cloud=read_point_cloud(scan)))
    step("manhattan", lambda: state.update(model=reconstruct(state["cloud"], "manhattan", rng=0)))
    step("generic", lambda: reconstruct(state["cloud"], "generic", rng=0))
    step("auto", lambda: reconstruct(state["cloud"], "auto", rng=0))
    step("write_ifc", lambda: write_ifc(state["model"], ifc))
    step("read_ifc", lambda: state.update(reference=load_model(ifc)))
    step("evaluate", lambda: write_evaluation_outputs(evaluate(state["model"], state["reference"]),
                                                      os.path.join(tmp, "evaluation")))
    step("changes", lambda: detect_changes(state["model"], state["cloud"]))
    step("laz", laz)
    step("e57", e57)
    step("obj", obj)
    import importlib.metadata as md

    tops = md.packages_distributions()
    loaded = {dist_name(d) for m in list(sys.modules) for d in tops.get(m.split(".")[0], [])}
    print("PROBE " + json.dumps({"loaded": sorted(loaded), "steps": steps}))


# --------------------------------------------------------------------------- CLI
def main(argv=None):
    p = argparse.ArgumentParser(prog="extension.py", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("build", help="write the extension zip")
    b.add_argument("--out", default=os.path.join(ROOT, "dist"))
    b.add_argument("--no-wheels", action="store_true", help="a zip without the bundled wheels")
    b.add_argument("--split-platforms", action="store_true",
                   help="one zip per platform of the manifest, each with only its wheels")
    w = sub.add_parser("wheels", help="download the wheels the manifest lists")
    w.add_argument("--platform", action="append", choices=sorted(PLATFORM_TAGS),
                   help="only this platform's wheels (repeatable; default all)")
    lk = sub.add_parser("lock", help="print the manifest's wheels list for this environment's versions")
    lk.add_argument("--platform", action="append", choices=sorted(PLATFORM_TAGS))
    pr = sub.add_parser("probe", help="run the engine with only the manifest's wheels; list what it loads")
    pr.add_argument("--scan", default=os.path.join(ROOT, "tests", "data", "room_scan1.pcd"))
    wk = sub.add_parser("_work")  # the child of probe
    wk.add_argument("paths")
    wk.add_argument("scan")
    args = p.parse_args(argv)
    if args.cmd == "build":
        if args.split_platforms:
            for plat in read_manifest().get("platforms", []):
                print(build(args.out, with_wheels=not args.no_wheels, platform=plat))
        else:
            print(build(args.out, with_wheels=not args.no_wheels))
    elif args.cmd == "probe":
        out = probe(args.scan)
        print(json.dumps(out, indent=1))
    elif args.cmd == "_work":
        _work(json.loads(args.paths), args.scan)
    elif args.cmd == "wheels":
        files = download_wheels(platforms=args.platform)
        print(f"{len(files)} wheel(s) in {os.path.join(ROOT, 'wheels')}")
    else:
        entries = lock(args.platform or sorted(PLATFORM_TAGS))
        print("wheels = [\n" + "".join(f'  "{e}",\n' for e in entries) + "]")
    return 0


if __name__ == "__main__":
    sys.exit(main())
