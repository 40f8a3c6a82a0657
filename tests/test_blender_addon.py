"""`crowdmotion blender-addon` writes the add-on Blender installs: the right files, an
add-on that runs on Blender's own modules alone, and refusals of a bad folder."""

from __future__ import annotations

import ast
import sys
import tomllib
import zipfile

import pytest

from crowdmotion.blender import ADDON, SOURCE
from crowdmotion.cli import main

FILES = {f"{ADDON}/{name}" for name in ("__init__.py", "crowd.py", "footlock.py", "walker.py", "blender_manifest.toml")}
# what Blender's Python has: its own modules, numpy, the standard library
ALLOWED = {"bpy", "bpy_extras", "mathutils", "addon_utils", "numpy", "pxr"}


def test_blender_addon_writes_an_installable_zip_of_the_addon(tmp_path, capsys):
    assert main(["blender-addon", "-o", str(tmp_path)]) == 0
    dest = tmp_path / f"{ADDON}.zip"
    assert str(dest) in capsys.readouterr().out
    with zipfile.ZipFile(dest) as zf:
        assert set(zf.namelist()) == FILES  # one top folder: Blender's add-on installer takes it as a package
        init = zf.read(f"{ADDON}/__init__.py").decode()
        manifest = tomllib.loads(zf.read(f"{ADDON}/blender_manifest.toml").decode())
    tree = ast.parse(init)
    bl_info = next(n for n in tree.body if isinstance(n, ast.Assign) and n.targets[0].id == "bl_info")
    info = ast.literal_eval(bl_info.value)
    assert info["blender"] >= (4, 2, 0) and info["category"] == "Import-Export"
    assert {"register", "unregister"} <= {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
    assert manifest["id"] == ADDON and manifest["type"] == "add-on" and manifest["schema_version"] == "1.0.0"


def test_the_current_folder_by_default(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["blender-addon"]) == 0
    assert (tmp_path / f"{ADDON}.zip").is_file()


def test_the_addon_imports_only_what_blender_has():
    stdlib = set(sys.stdlib_module_names)
    for path in SOURCE.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                assert top in ALLOWED or top in stdlib, (path.name, name)  # never crowdmotion, scipy, pyarrow


@pytest.mark.parametrize("where", ["missing", "file"])
def test_a_folder_that_is_not_one_is_refused_and_nothing_written(tmp_path, capsys, where):
    target = tmp_path / "no" / "such"
    if where == "file":
        target = tmp_path / "a.txt"
        target.write_text("x")
    assert main(["blender-addon", "-o", str(target)]) == 2
    err = capsys.readouterr().err
    assert str(target) in err and "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert not list(tmp_path.rglob("*.zip"))
