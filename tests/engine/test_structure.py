"""The code's shape: no import cycle among the engine's modules (imports inside functions
count), no module over 800 lines, one home for each geometric kernel."""
import ast
import os

import networkx as nx
from scenes import ROOT

MAX_LINES = 800


def _modules(package="engine"):
    """{module name: path} of every .py file of a package (``__init__`` as the package)."""
    out = {}
    base = os.path.join(ROOT, package)
    for d, _, files in os.walk(base):
        for f in files:
            if not f.endswith(".py"):
                continue
            rel = os.path.relpath(os.path.join(d, f), ROOT)[:-3].replace(os.sep, ".")
            out[rel[: -len(".__init__")] if rel.endswith(".__init__") else rel] = os.path.join(d, f)
    return out


def _resolve(name, mods):
    """The longest prefix of a dotted name that is a known module."""
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name or None


def import_graph(package="engine") -> nx.DiGraph:
    """Module → imported module, for every import statement anywhere in a module. Importing
    ``a.b.c`` from outside package ``a.b`` also runs ``a.b``'s ``__init__`` (an edge too)."""
    mods = _modules(package)
    g = nx.DiGraph()
    for mod, path in mods.items():
        g.add_node(mod)
        is_pkg = path.endswith("__init__.py")
        here = mod if is_pkg else mod.rpartition(".")[0]
        with open(path, encoding="utf-8") as f:
            tree = ast.parse(f.read())
        for node in ast.walk(tree):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    parts = here.split(".")
                    base = ".".join(parts[: len(parts) - node.level + 1])
                    src = f"{base}.{node.module}" if node.module else base
                else:
                    src = node.module or ""
                targets = [f"{src}.{a.name}" for a in node.names] + [src]
            for t in targets:
                if not t.startswith(package):
                    continue
                target = _resolve(t, mods)
                if target is None or target == mod:
                    continue
                g.add_edge(mod, target)
                # the packages on the way that the importer is not inside of
                parent = target.rpartition(".")[0]
                while parent and not (mod == parent or mod.startswith(parent + ".")):
                    if parent in mods:
                        g.add_edge(mod, parent)
                    parent = parent.rpartition(".")[0]
    return g


def test_no_import_cycle_among_engine_modules():
    g = import_graph()
    cycles = [sorted(c) for c in nx.strongly_connected_components(g) if len(c) > 1]
    assert not cycles, "import cycles: " + "; ".join(" <-> ".join(c) for c in cycles)


def test_the_cycle_check_sees_in_function_imports(tmp_path):
    """The checker itself: a cycle hidden by an import inside a function is found."""
    pkg = tmp_path / "cyc"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from . import b\n")
    (pkg / "b.py").write_text("def f():\n    from .a import x\n")
    global ROOT
    old, ROOT = ROOT, str(tmp_path)
    try:
        g = import_graph("cyc")
    finally:
        ROOT = old
    assert any(len(c) > 1 for c in nx.strongly_connected_components(g))


def test_no_module_over_800_lines():
    long = {}
    for package in ("engine", "blender_indoor_addon"):
        for mod, path in _modules(package).items():
            with open(path, encoding="utf-8") as f:
                n = sum(1 for _ in f)
            if n > MAX_LINES:
                long[mod] = n
    assert not long, long


def test_one_module_each_for_alpha_shapes_and_pca_normals():
    """The kernels live in engine.geometry; no other module defines its own."""
    own = []
    for mod, path in _modules("engine").items():
        if mod.startswith("engine.geometry"):
            continue
        with open(path, encoding="utf-8") as f:
            tree = ast.parse(f.read())
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef):
                body = ast.unparse(node)
                if "eigh(" in body and ("query(" in body or "KDTree" in body):
                    own.append(f"{mod}.{node.name} (kNN PCA)")
                if "Delaunay(" in body:
                    own.append(f"{mod}.{node.name} (alpha shape)")
    assert not own, own
