"""Every error the command prints is one message in the user's terms: a generated corpus of
broken scenario files (each field of a small scenario of every method given values of the
wrong kind or size) and of damaged run folders, run through the command in this process.
Stderr never holds a traceback, a numpy repr or a temporary file's name, and the exit
status is 2, the user's error."""

from __future__ import annotations

import json
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from crowdmotion.cli import main
from tests.test_scenario import FORMATION, GOOD, PSO, RVO

USER_ERROR = 2
BASES = {"mdp": GOOD, "rvo": RVO, "pso": PSO, "formation": FORMATION}


def _leaves(data, path=()):
    """(dotted path, value) of every value in the scenario's data."""
    if isinstance(data, dict):
        for k, v in data.items():
            yield from _leaves(v, (*path, k))
    elif isinstance(data, list) and data and isinstance(data[0], (dict, list)):
        for i, v in enumerate(data):
            yield from _leaves(v, (*path, i))
    else:
        yield path, data


def _bad_values(value):
    """Values of the wrong kind or size for a field holding ``value``."""
    if isinstance(value, bool):
        return ['"no"', "1"]
    if isinstance(value, (int, float)):
        return ["true", '"x"', "-1", "nan", "1e300", "1e-300"]
    if isinstance(value, str):
        return ["1", '""', '"?"']
    if isinstance(value, list):
        return ["[]", "[nan, 1]", "[1e300, 1e300]", '"x"']
    return ["1"]


def _toml(data) -> str:
    """A scenario's data written back as TOML (inline tables), values kept as given."""
    def value(v):
        if isinstance(v, str) and v.startswith("\0"):
            return v[1:]  # a raw TOML value put in by the corpus
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, float):
            return repr(v) if np.isfinite(v) else ("nan" if np.isnan(v) else ("inf" if v > 0 else "-inf"))
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
        return str(v)
    return "\n".join(f"{k} = {value(v)}" for k, v in data.items()) + "\n"


def _mutated(text: str, path: tuple, raw: str) -> str:
    data = tomllib.loads(text)
    node = data
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = "\0" + raw
    return _toml(data)


def _corpus():
    cases = []
    for method, text in BASES.items():
        for path, v in _leaves(tomllib.loads(text)):
            for raw in _bad_values(v):
                cases.append(pytest.param(_mutated(text, path, raw),
                                          id=f"{method}:{'.'.join(map(str, path))}={raw}"))
    return cases


CRAFTED = {  # the cases a careful new user met, each once a traceback
    "deep nesting": "a = " + "[" * 3000 + "]" * 3000,
    "radius 1e-300": GOOD.replace("count = 4", "count = 4\nradius = 1e-300"),
    "heading north": FORMATION.replace("count = 9", 'count = 9\nattributes = { heading_deg = "north" }'),
    "1e12 m scene": GOOD.replace("bounds = [[0, 0], [10, 10]]", "bounds = [[0, 0], [1e12, 1e12]]"),
    "1e12 m rvo scene": RVO.replace("bounds = [[0, 0], [30, 10]]", "bounds = [[0, 0], [1e12, 1e12]]\n"
                                    'obstacles = [{ shape = "circle", center = [15, 5], radius = 1 }]')
    .replace("max_steps = 50", "max_steps = 50\nfield_cell = 0.5\nguidance = \"field\""),
    "1e12 m formation scene": FORMATION.replace("bounds = [[0, -10], [40, 10]]", "bounds = [[0, -10], [1e12, 1e12]]"),
    "1e12 m template": FORMATION.replace("spacing = 1.2", "spacing = 1e12"),
    "empty moving path": GOOD.replace('radius = 1 }', 'radius = 1, path = { times = [], positions = [] } }'),
    "path of two times, one position": GOOD.replace(
        'radius = 1 }', 'radius = 1, path = { times = [0, 1], positions = [[5, 5]] } }'),
    "unsorted path": GOOD.replace('radius = 1 }',
                                  'radius = 1, path = { times = [2, 1], positions = [[5, 5], [6, 6]] } }'),
    "not toml": "name = ",
    "not utf-8": b"\xff\xfe name".decode("latin-1"),
    "empty file": "",
    "no groups": 'method = "rvo"\n[scene]\nbounds = [[0, 0], [1, 1]]\n',
    "time_step 1e6": RVO.replace("max_steps = 50", "max_steps = 50\ntime_step = 1e6"),
    "formats []": GOOD + "[output]\nformats = []\n",
}


def _check(capsys, argv, allow_ok: bool = False) -> str:
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    err = capsys.readouterr().err
    for bad in ("Traceback", "np.", ".tmp"):
        assert bad not in err, err
    if allow_ok and code == 0:
        return err
    assert code == USER_ERROR, (code, err)
    assert err.startswith("crowdmotion") or err.startswith("usage:"), err
    return err


@pytest.mark.parametrize("text", _corpus())
def test_a_broken_scenario_field_is_refused_in_one_message(tmp_path, capsys, text):
    path = tmp_path / "s.toml"
    path.write_text(text)
    _check(capsys, ["validate", str(path)], allow_ok=True)


@pytest.mark.parametrize("name", list(CRAFTED))
def test_a_broken_scenario_a_user_met_is_refused_in_one_message(tmp_path, capsys, name):
    path = tmp_path / "s.toml"
    path.write_bytes(CRAFTED[name].encode("latin-1") if name == "not utf-8" else CRAFTED[name].encode())
    err = _check(capsys, ["validate", str(path)])
    assert str(path) in err, err


# ---- damaged run folders ----------------------------------------------------------------

@pytest.fixture(scope="module")
def run_folder(tmp_path_factory):
    """A small finished run (trajectories.parquet, trajectories.csv, summary.json)."""
    root = tmp_path_factory.mktemp("run")
    path = root / "s.toml"
    path.write_text(GOOD + '[output]\nformats = ["parquet", "csv"]\n')
    out = root / "out"
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "none"]) == 0
    return out


def _rewrite_parquet(folder: Path, change) -> None:
    import pyarrow.parquet as pq

    table = pq.read_table(folder / "trajectories.parquet")
    meta = json.loads(table.schema.metadata[b"crowdmotion"])
    table, meta = change(table, meta)
    table = table.replace_schema_metadata({b"crowdmotion": meta if isinstance(meta, bytes) else json.dumps(meta)})
    pq.write_table(table, folder / "trajectories.parquet")


def _column(table, name, values):
    import pyarrow as pa

    return table.set_column(table.column_names.index(name), name, pa.array(values))


def _nan_x(table, meta):
    x = table["x"].to_numpy().copy()
    x[3] = np.nan
    return _column(table, "x", x), meta


def _no_bounds(table, meta):
    del meta["scene"]["bounds"]
    return table, meta


DAMAGES = {
    "no trajectories": lambda f: [(f / n).unlink() for n in ("trajectories.parquet", "trajectories.csv")],
    "empty parquet": lambda f: (f / "trajectories.parquet").write_bytes(b""),
    "garbage parquet": lambda f: (f / "trajectories.parquet").write_bytes(b"PAR1 not really"),
    "truncated parquet": lambda f: (f / "trajectories.parquet").write_bytes(
        (f / "trajectories.parquet").read_bytes()[:300]),
    "metadata not json": lambda f: _rewrite_parquet(f, lambda t, m: (t, b"{not json")),
    "metadata a list": lambda f: _rewrite_parquet(f, lambda t, m: (t, b"[1, 2]")),
    "scene without bounds": lambda f: _rewrite_parquet(f, _no_bounds),
    "scene not a table": lambda f: _rewrite_parquet(f, lambda t, m: (t, {**m, "scene": "garbage"})),
    "obstacle garbage": lambda f: _rewrite_parquet(f, lambda t, m: (t, {**m, "scene": {**m["scene"],
                                                                                        "obstacles": [{"x": 1}]}})),
    "dt zero": lambda f: _rewrite_parquet(f, lambda t, m: (t.drop_columns(["time"]), {**m, "dt": 0})),
    "nan position": lambda f: _rewrite_parquet(f, _nan_x),
    "no rows": lambda f: _rewrite_parquet(f, lambda t, m: (t.slice(0, 0), m)),
    "missing column": lambda f: _rewrite_parquet(f, lambda t, m: (t.drop_columns(["x"]), m)),
    "negative radius": lambda f: _rewrite_parquet(f, lambda t, m: (_column(t, "radius", -t["radius"].to_numpy()), m)),
}
def _csv_nan(path: Path) -> None:
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    row = lines[3].split(",")
    row[[h.strip("\"") for h in header].index("x")] = "nan"
    lines[3] = ",".join(row)
    path.write_text("\n".join(lines) + "\n")


CSV_DAMAGES = {
    "csv garbage": lambda f: (f / "trajectories.csv").write_text("frame,agent\n1,2,3,4\n\x00"),
    "csv empty": lambda f: (f / "trajectories.csv").write_text(""),
    "csv sidecar broken": lambda f: (f / "trajectories.csv.meta.json").write_text("{"),
    "csv nan": lambda f: _csv_nan(f / "trajectories.csv"),
}
SUMMARY_DAMAGES = {
    "summary not json": lambda f: (f / "summary.json").write_text("{"),
    "summary empty": lambda f: (f / "summary.json").write_text(""),
    "summary a list": lambda f: (f / "summary.json").write_text("[1]"),
    "summary arrival not a table": lambda f: (f / "summary.json").write_text('{"time_to_goal_by_group_s": 3}'),
}
COMMANDS = {
    "export csv": ["export", "RUN", "--to", "csv", "-o", "OUT/t.csv"],
    "export sqlite": ["export", "RUN", "--to", "sqlite", "-o", "OUT/t.sqlite"],
    "export usd": ["export", "RUN", "--to", "usda", "-o", "OUT/t.usda"],
    "report": ["report", "RUN"],
    "render": ["render", "RUN", "--to", "gif", "--max-frames", "2", "-q"],
    "view": ["view", "RUN", "-o", "OUT/v.html"],
}


def _damaged(run_folder, tmp_path, damage, only_csv: bool = False) -> Path:
    folder = tmp_path / "run"
    shutil.copytree(run_folder, folder)
    if only_csv:
        (folder / "trajectories.parquet").unlink()
    damage(folder)
    return folder


def _argv(command, folder, tmp_path):
    (tmp_path / "o").mkdir(exist_ok=True)
    return [str(folder) if a == "RUN" else a.replace("OUT", str(tmp_path / "o")) for a in COMMANDS[command]]


@pytest.mark.parametrize("command", list(COMMANDS))
@pytest.mark.parametrize("damage", list(DAMAGES))
def test_a_damaged_run_folder_is_refused_naming_the_file(run_folder, tmp_path, capsys, damage, command):
    folder = _damaged(run_folder, tmp_path, DAMAGES[damage])
    err = _check(capsys, _argv(command, folder, tmp_path))
    assert str(folder) in err, err


@pytest.mark.parametrize("command", list(COMMANDS))
@pytest.mark.parametrize("damage", list(CSV_DAMAGES))
def test_a_damaged_csv_run_is_refused_naming_the_file(run_folder, tmp_path, capsys, damage, command):
    folder = _damaged(run_folder, tmp_path, CSV_DAMAGES[damage], only_csv=True)
    err = _check(capsys, _argv(command, folder, tmp_path))
    assert str(folder) in err, err


@pytest.mark.parametrize("damage", list(SUMMARY_DAMAGES))
def test_a_damaged_summary_is_refused_by_report_naming_it(run_folder, tmp_path, capsys, damage):
    folder = _damaged(run_folder, tmp_path, SUMMARY_DAMAGES[damage])
    err = _check(capsys, ["report", str(folder)])
    assert str(folder / "summary.json") in err, err


def test_export_to_sqlite_into_a_csv_name_is_refused_not_written_as_csv(run_folder, tmp_path, capsys):
    err = _check(capsys, ["export", str(run_folder), "--to", "sqlite", "-o", str(tmp_path / "t.csv")])
    assert "--to sqlite" in err and "t.csv" in err
    assert not (tmp_path / "t.csv").exists()


def test_export_into_a_missing_folder_names_no_temporary_file(run_folder, tmp_path, capsys):
    err = _check(capsys, ["export", str(run_folder), "--to", "csv", "-o", str(tmp_path / "no" / "t.csv")])
    assert "does not exist" in err


def test_debug_shows_the_traceback(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD.replace("count = 4", "count = 0"))
    with pytest.raises(ValueError, match="groups.0.count"):
        main(["--debug", "validate", str(path)])


def test_a_full_disk_while_exporting_names_the_file_not_its_temporary_twin(run_folder, tmp_path, capsys, monkeypatch):
    import errno

    from crowdmotion.io import csv as csv_io

    def full(traj, path):  # the disk fills while the temporary file is written
        from crowdmotion.io.atomic import atomic_path

        with atomic_path(path) as tmp:
            raise OSError(errno.ENOSPC, "No space left on device", str(tmp))

    monkeypatch.setattr(csv_io, "write", full)
    dest = tmp_path / "t.csv"
    err = _check(capsys, ["export", str(run_folder), "--to", "csv", "-o", str(dest)])
    assert f"cannot write {dest}: No space left on device" in err and ".tmp" not in err, err


@pytest.mark.parametrize("argv", [
    ["run", "no_such_scene"],
    ["validate", "RUNDIR"],
    ["run", "SCENE", "--plots", "pathz"],
    ["sweep", "SCENE", "--set", "novalue"],
    ["sweep", "SCENE", "--set", "mdp.tau=0.5", "--set", "mdp.tau=1"],
    ["sweep", "SCENE", "--set", "mdp.nope=1", "-o", "OUT"],
    ["export", "RUNDIR", "--to", "usd", "-o", "OUT/t.csv"],
    ["export", "RUNDIR", "--to", "usda", "-o", "OUT/t.usda", "--prototype-up", "W"],
    ["export", "RUNDIR", "--to", "usda", "-o", "OUT/t.usda", "--prototype-up", "Y", "--prototype-forward=-Y"],
    ["export", "RUNDIR", "--to", "csv", "-o", "OUT/t.csv", "--prototype-up", "Y"],
    ["blender-addon", "-o", "OUT/no_such_folder"],
    ["blender-addon", "-o", "SCENE"],
    ["report", "OUT/nothing"],
    ["view", "SCENE"],
    ["demo", "--only", "no_such_scene"],
    ["verify", "--case", "no_such_case", "-o", "OUT"],
])
def test_a_mistyped_command_line_is_refused_in_one_message(run_folder, tmp_path, capsys, argv):
    scene = tmp_path / "s.toml"
    scene.write_text(GOOD)
    subs = {"SCENE": str(scene), "RUNDIR": str(run_folder)}
    argv = [subs.get(a, a.replace("OUT", str(tmp_path / "o"))) for a in argv]
    _check(capsys, argv)
