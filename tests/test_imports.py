"""The package's layers: every module imports on its own, low-level modules import nothing
above them, and no module imports, even lazily inside a function, one that imports it
back (an import circle)."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import crowdmotion

SRC = Path(crowdmotion.__file__).parent
# the Blender add-on's sources: shipped inside the package, but they run in Blender (bpy), not here
ADDON = SRC / "blender" / "crowdmotion_blender"
# modules the low-level ones (crowdmotion._*, the methods' _kernels) must never import
ABOVE = ("crowdmotion.cli", "crowdmotion.scenario")


def _modules() -> dict[str, Path]:
    """Every module of the package by dotted name (packages by their own name)."""
    out = {}
    for path in sorted(SRC.rglob("*.py")):
        if ADDON in path.parents:
            continue
        parts = path.relative_to(SRC.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


MODULES = _modules()


def _imports(name: str, path: Path, top_only: bool = False) -> set[str]:
    """The crowdmotion modules ``name`` imports (anywhere in it, or at its top level
    only), from its import statements: ``from crowdmotion import groups`` names
    crowdmotion.groups; the package itself, which any import of a submodule loads first,
    is left out."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in (tree.body if top_only else ast.walk(tree)):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(up + ([node.module] if node.module else []))
            found.add(base)
            found.update(f"{base}.{a.name}" for a in node.names)
    return {m for m in found if m in MODULES and m != "crowdmotion" and m != name}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                out.append(sorted(group))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_each_module_imports_alone_in_a_fresh_interpreter():
    script = """
import importlib, json, sys
failed = {}
for name in json.loads(sys.argv[1]):
    for loaded in [m for m in sys.modules if m == "crowdmotion" or m.startswith("crowdmotion.")]:
        del sys.modules[loaded]  # each module on its own, as a first import would meet it
    try:
        importlib.import_module(name)
    except Exception as exc:
        failed[name] = f"{type(exc).__name__}: {exc}"
print(json.dumps(failed))
"""
    names = [n for n in MODULES if n != "crowdmotion.__main__"]
    done = subprocess.run([sys.executable, "-c", script, json.dumps(names)], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.strip().splitlines()[-1]) == {}


def test_low_level_modules_import_neither_the_command_line_nor_the_scenario_loader():
    low = {n: p for n, p in MODULES.items() if n.rpartition(".")[2].startswith("_") and not p.name.startswith("__")}
    assert "crowdmotion._precompile" in low and "crowdmotion.rvo._kernels" in low
    wrong = {n: sorted(m for m in _imports(n, p) if m.startswith(ABOVE)) for n, p in low.items()}
    assert {n: m for n, m in wrong.items() if m} == {}


def test_no_module_imports_one_that_imports_it_back_even_lazily():
    graph = {n: _imports(n, p) for n, p in MODULES.items() if n != "crowdmotion"}
    assert _cycles(graph) == []


def test_the_import_check_sees_lazy_imports_and_circles():
    # the checks above would pass on a blind reader: this one shows they see what they must
    assert "crowdmotion.scenario" in _imports("crowdmotion.demo", MODULES["crowdmotion.demo"])  # inside a function
    assert "crowdmotion.scenario" not in _imports("crowdmotion.demo", MODULES["crowdmotion.demo"], top_only=True)
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_a_methods_names_show_in_dir_before_their_module_loads():
    # the methods' packages load their public names on first use; dir() (an editor's
    # completion, a user looking round) lists them all the same, and loads nothing
    script = ("import sys, crowdmotion.rvo as r, crowdmotion.mdp as m\n"
              "print('Simulator' in dir(r), 'warm_up' in dir(r), set(m.__all__) <= set(dir(m)),\n"
              "      'crowdmotion.rvo.simulator' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert done.stdout.split() == ["True", "True", "True", "False"], done.stderr
