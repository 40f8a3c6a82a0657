"""The first run's kernels compiled on every core (crowdmotion._precompile, issue 16)."""

import json
import os
import subprocess
import sys

import pytest

from crowdmotion import _precompile as pc
from crowdmotion.cli import builtin_scenarios
from crowdmotion.scenario import load_scenario, run_scenario

RECORD = json.loads(pc.RECORD.read_text())


def test_shares_are_balanced_by_compile_time():
    kernels = [{"name": n, "seconds": s} for n, s in (("a", 5.0), ("b", 3.0), ("c", 2.0), ("d", 1.0), ("e", 1.0))]
    shares = pc.share_out(kernels, 2)
    loads = sorted(sum(k["seconds"] for k in s) for s in shares)
    assert loads == [6.0, 6.0]  # a+e against b+c+d
    assert len(pc.share_out(kernels[:1], 4)) == 1  # no empty shares


def test_signatures_parse_without_eval():
    from numba.core import types

    sig = pc.parse_signature("(Array(float64, 2, 'F', False, aligned=True), bool, uint64, Array(bool, 1, 'C', True, "
                             "aligned=True))")
    assert sig == (types.Array(types.float64, 2, "F"), types.boolean, types.uint64,
                   types.Array(types.boolean, 1, "C", readonly=True))
    with pytest.raises(ValueError, match="unsupported argument type"):
        pc.parse_signature("(__import__, float64)")


@pytest.mark.parametrize("method", sorted(RECORD))
def test_the_record_matches_what_a_run_compiles(method):
    # a kernel whose argument types changed would be precompiled for nothing: rerun
    # python -m crowdmotion._precompile --record
    paths = {p.stem: p for p in builtin_scenarios()}
    for scene in pc.SCENES[method]:
        run_scenario(load_scenario(paths[scene]), progress=False)
    for k in RECORD[method]:
        disp = pc._dispatcher(k["name"])
        used = {str(tuple(s)) for s in disp.signatures}
        for sig in k["signatures"]:
            assert sig in used, f"{k['name']}: recorded types not used any more; rerun the record"
            assert pc.parse_signature(sig) in [tuple(s) for s in disp.signatures]


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_a_cold_start_fills_the_cache_so_the_run_compiles_nothing(tmp_path):
    script = """
import json, os
from numba.core import event
from crowdmotion import _precompile as pc
done = pc.start("mdp")
compiled = []
class L(event.Listener):
    def on_start(self, ev): pass
    def on_end(self, ev):
        d = ev.data["dispatcher"]; compiled.append(d.py_func.__module__ + ":" + d.py_func.__qualname__)
event.register("numba:compile", L())
from crowdmotion.cli import builtin_scenarios
from crowdmotion.scenario import load_scenario, run_scenario
run_scenario(load_scenario([p for p in builtin_scenarios() if p.stem == "mdp_robots_2d"][0]), progress=False)
print(json.dumps({"done": done, "compiled": compiled, "again": pc.start("mdp")}))
"""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "CROWDMOTION_PRECOMPILE": "1"}
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    if cores < 2:
        assert result["done"] == 0
        return
    names = {k["name"] for k in RECORD["mdp"]}
    assert result["done"] >= len(names) - 1  # _prefetch's probe compiles as its module loads
    assert not names & set(result["compiled"]), result["compiled"]  # loaded from the cache, not compiled
    assert result["again"] == 0  # a warm cache: nothing to do


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_compiling_begun_early_is_finished_by_the_run(tmp_path):
    # `crowdmotion run` begins compiling before it reads the scenario; the run's start()
    # compiles the rest and waits, so the run itself compiles nothing
    script = """
import json
from numba.core import event
from crowdmotion import _precompile as pc
pc.begin("mdp")
children = [pid for _, pids, _ in pc._PENDING.values() for pid in pids]
compiled = []
class L(event.Listener):
    def on_start(self, ev): pass
    def on_end(self, ev):
        d = ev.data["dispatcher"]; compiled.append(d.py_func.__module__ + ":" + d.py_func.__qualname__)
from crowdmotion.cli import builtin_scenarios
from crowdmotion.scenario import load_scenario, run_scenario
sc = load_scenario([p for p in builtin_scenarios() if p.stem == "mdp_robots_2d"][0])
done = pc.start("mdp")  # what run_scenario calls first: this process's share, then the wait
event.register("numba:compile", L())
run_scenario(sc, progress=False)
print(json.dumps({"children": children, "compiled": compiled, "pending": list(pc._PENDING), "done": done}))
"""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "CROWDMOTION_PRECOMPILE": "1"}
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    if cores < 2:
        assert result["children"] == []
        return
    assert result["children"] and result["pending"] == [] and result["done"] >= 1
    names = {k["name"] for k in RECORD["mdp"]}
    assert not names & set(result["compiled"]), result["compiled"]


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_children_begun_for_a_refused_scenario_stop_with_the_command(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('method = "rvo"\nname = "bad"\n[scene]\nlower = [0, 0]\nupper = [-1, 5]\n')
    script = f"""
import json, sys
from crowdmotion import _precompile as pc
from crowdmotion.cli import main
code = main(["run", {str(bad)!r}, "-q", "-o", {str(tmp_path / "out")!r}])
print(json.dumps({{"code": code, "children": [p for _, pids, _ in pc._PENDING.values() for p in pids]}}))
"""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "CROWDMOTION_PRECOMPILE": "1"}
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    assert result["code"] == 2  # refused, with the scenario's error
    for pid in result["children"]:  # stopped at exit, not left compiling
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


def test_kernels_compiled_while_checking_stay_with_this_process():
    # RVO's check compiles the line-of-sight test: a child compiling it too would only
    # take a core from the rest
    at_load = [{"name": "check", "seconds": 1.0, "at_load": True}]
    rest = [{"name": n, "seconds": s} for n, s in (("a", 4.0), ("b", 2.0), ("c", 1.0))]
    mine, *theirs = pc.share_out(rest, 2, first=at_load)
    assert mine[0]["name"] == "check" and [k["name"] for k in mine] == ["check", "b", "c"]
    assert [[k["name"] for k in s] for s in theirs] == [["a"]]
    assert pc.share_out([], 2, first=at_load) == [at_load]
