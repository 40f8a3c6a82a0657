"""The first run's kernels compiled on every core (crowdmotion._precompile, issue 16)."""

import json
import os
import subprocess
import sys

import pytest

from crowdmotion import _precompile as pc
from crowdmotion import precompile_record

RECORD = json.loads(pc.RECORD.read_text())
# for the scripts below: ``compiled`` lists what numba compiles once ``L()`` is registered
LISTENER = """from numba.core import event
compiled = []
class L(event.Listener):
    def on_start(self, ev): pass
    def on_end(self, ev):
        d = ev.data["dispatcher"]; compiled.append(d.py_func.__module__ + ":" + d.py_func.__qualname__)
"""


def _in_fresh_process(script: str, cache) -> dict:
    """Run ``script`` in a new Python with numba's cache at ``cache`` and precompiling
    on; the JSON its last line prints."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "CROWDMOTION_PRECOMPILE": "1"}
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _names(lists):
    return [[k["name"] for k in lst] for lst in lists]


def test_a_free_core_takes_the_longest_chain_first():
    # k needs h1 and h2 (2 s each) and takes 3 s itself; x stands alone (4 s): the
    # helpers head 5 s chains, so they go before x, and k last
    kernels = [{"name": "k", "seconds": 3.0, "needs": ["h1", "h2"]}, {"name": "h1", "seconds": 2.0},
               {"name": "h2", "seconds": 2.0}, {"name": "x", "seconds": 4.0}]
    assert [k["name"] for k in pc.ranked(kernels)] == ["h1", "h2", "x", "k"]


def _share(kernels, marks, workers=2, claimed=()):
    """Run ``_work`` on ``workers`` threads over one marker folder, with a compile that
    sleeps a tenth of each kernel's seconds; (name, worker, start, end) per compile."""
    import threading
    import time

    log = []

    def compile_as(worker):
        def compile_one(k):
            t0 = time.monotonic()
            time.sleep(k["seconds"] / 10)
            log.append((k["name"], worker, t0, time.monotonic()))
        return compile_one

    for name in claimed:
        pc._claim(marks, name)
    threads = [threading.Thread(target=pc._work, args=(kernels, marks, time.monotonic() + 60, compile_as(w)))
               for w in range(workers)]
    for t in threads:
        t.start()
    return threads, log


def test_cores_share_the_kernels_each_after_its_helpers(tmp_path):
    kernels = [{"name": "k", "seconds": 3.0, "needs": ["h1", "h2"]}, {"name": "h1", "seconds": 2.0},
               {"name": "h2", "seconds": 2.0}, {"name": "x", "seconds": 4.0}]
    threads, log = _share(kernels, tmp_path)
    for t in threads:
        t.join()
    assert sorted(n for n, *_ in log) == ["h1", "h2", "k", "x"]  # each compiled once
    at = {n: (w, t0, t1) for n, w, t0, t1 in log}
    assert at["k"][1] >= max(at["h1"][2], at["h2"][2])  # after both helpers were finished
    assert at["h1"][0] != at["h2"][0]  # the helpers side by side
    assert {w for w, *_ in at.values()} == {0, 1}


def test_a_cycle_of_helpers_still_compiles_everything(tmp_path):
    loop = [{"name": "a", "seconds": 0.1, "needs": ["b"]}, {"name": "b", "seconds": 0.1, "needs": ["a"]}]
    threads, log = _share(loop, tmp_path)
    for t in threads:
        t.join(timeout=10)
    assert sorted(n for n, *_ in log) == ["a", "b"]


def test_kernels_compiled_while_checking_stay_with_this_process(tmp_path):
    # RVO's check compiles the line-of-sight test: this process claims it before the
    # children start, so none compiles it too, and what calls it waits for it
    import time

    kernels = [{"name": "check", "seconds": 1.0, "at_load": True}, {"name": "k", "seconds": 1.0, "needs": ["check"]},
               {"name": "x", "seconds": 1.0}]
    assert pc._closure(kernels, {"check"}) == kernels[:1]
    threads, log = _share(kernels, tmp_path, claimed=["check"])
    deadline = time.monotonic() + 10
    while not log and time.monotonic() < deadline:  # x, which needs nothing, goes ahead
        time.sleep(0.01)
    time.sleep(0.1)
    assert [n for n, *_ in log] == ["x"]  # k waits while check is being compiled here
    (tmp_path / pc._marker("check")).touch()  # this process has finished it
    for t in threads:
        t.join()
    assert sorted(n for n, *_ in log) == ["k", "x"]


def test_signatures_parse_without_eval():
    from numba.core import types

    sig = pc.parse_signature("(Array(float64, 2, 'F', False, aligned=True), bool, uint64, Array(bool, 1, 'C', True, "
                             "aligned=True), none)")
    assert sig == (types.Array(types.float64, 2, "F"), types.boolean, types.uint64,
                   types.Array(types.boolean, 1, "C", readonly=True), types.none)
    with pytest.raises(ValueError, match="unsupported argument type"):
        pc.parse_signature("(__import__, float64)")


# each compiles its method's kernels into an empty cache (20-70 s): rvo, whose kernels
# change most, runs by default, the others with -m slow
@pytest.mark.parametrize("method", [m if m == "rvo" else pytest.param(m, marks=pytest.mark.slow)
                                    for m in sorted(RECORD)])
def test_the_record_matches_what_a_run_compiles(method):
    # a kernel whose argument types changed, or a helper added or gone, would be
    # precompiled for nothing: rerun python -m crowdmotion.precompile_record --record
    # (whether a kernel compiles while the scenario is read, ``at_load``, is not compared:
    # on a busy machine a threaded kernel's serial twin may compile first in the run instead)
    def summary(kernels):
        return {k["name"]: (sorted(k["signatures"]), sorted(k.get("needs", ()))) for k in kernels}

    assert summary(precompile_record._fresh_run("--record-one", method)) == summary(RECORD[method])


@pytest.mark.slow  # compiles MDP's kernels into an empty cache (about 25 s)
@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_a_cold_start_fills_the_cache_so_the_run_compiles_nothing(tmp_path):
    script = """
import json, os
from crowdmotion import _precompile as pc
done = pc.start("mdp")
""" + LISTENER + """event.register("numba:compile", L())
from crowdmotion.cli import builtin_scenarios
from crowdmotion.scenario import load_scenario, run_scenario
run_scenario(load_scenario([p for p in builtin_scenarios() if p.stem == "mdp_robots_2d"][0]), progress=False)
print(json.dumps({"done": done, "compiled": compiled, "again": pc.start("mdp"),
                  "in_cache": [pc._in_cache(k) for k in json.loads(pc.RECORD.read_text())["mdp"]]}))
"""
    result = _in_fresh_process(script, tmp_path)
    if pc.cores() < 2:
        assert result["done"] == 0
        return
    names = {k["name"] for k in RECORD["mdp"]}
    assert result["done"] >= len(names) - 1  # _prefetch's probe compiles as its module loads
    assert not names & set(result["compiled"]), result["compiled"]  # loaded from the cache, not compiled
    assert result["again"] == 0  # a warm cache: nothing to do
    assert all(result["in_cache"])  # every recorded signature of every kernel


@pytest.mark.slow  # compiles MDP's kernels into an empty cache, as the cold start does by default
@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_compiling_begun_early_is_finished_by_the_run(tmp_path):
    # `crowdmotion run` begins compiling before it reads the scenario; the run's start()
    # compiles the rest and waits, so the run itself compiles nothing
    script = """
import json
from crowdmotion import _precompile as pc
pc.begin("mdp")
children = [pid for v in pc._PENDING.values() for pid in v[2]]
""" + LISTENER + """from crowdmotion.cli import builtin_scenarios
from crowdmotion.scenario import load_scenario, run_scenario
sc = load_scenario([p for p in builtin_scenarios() if p.stem == "mdp_robots_2d"][0])
done = pc.start("mdp")  # what `crowdmotion run` calls first: this process's share, then the wait
event.register("numba:compile", L())
run_scenario(sc, progress=False)
print(json.dumps({"children": children, "compiled": compiled, "pending": list(pc._PENDING), "done": done}))
"""
    result = _in_fresh_process(script, tmp_path)
    if pc.cores() < 2:
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
print(json.dumps({{"code": code, "children": [p for v in pc._PENDING.values() for p in v[2]]}}))
"""
    result = _in_fresh_process(script, tmp_path / "cache")
    assert result["code"] == 2  # refused, with the scenario's error
    for pid in result["children"]:  # stopped at exit, not left compiling
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


def test_what_the_check_compiled_is_used_once_it_is_in_the_cache(tmp_path, monkeypatch):
    # this process marks its claimed kernels only after the scenario is checked; a child
    # needing one of them goes ahead as soon as numba's cache holds all its signatures
    kernels = [{"name": "check", "seconds": 1.0, "at_load": True, "signatures": []},
               {"name": "k", "seconds": 1.0, "needs": ["check"]}]
    in_cache = {"check": False}
    monkeypatch.setattr(pc, "_in_cache", lambda k: in_cache.get(k["name"], False))
    threads, log = _share(kernels, tmp_path, workers=1, claimed=["check"])
    import time

    time.sleep(0.2)
    assert log == []  # not yet in the cache: k waits
    in_cache["check"] = True
    for t in threads:
        t.join(timeout=10)
    assert [n for n, *_ in log] == ["k"] and not (tmp_path / pc._marker("check")).exists()


def test_what_the_check_compiles_comes_with_its_helpers():
    kernels = [{"name": "check", "seconds": 1.0, "at_load": True, "needs": ["h"]}, {"name": "h", "seconds": 1.0},
               {"name": "k", "seconds": 2.0, "needs": ["h"]}]
    assert [k["name"] for k in pc._closure(kernels, {"check"})] == ["h", "check"]


@pytest.mark.slow  # compiles PSO's kernels into an empty cache (about 30 s)
@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_helpers_are_compiled_once_and_loaded_by_their_callers(tmp_path):
    # PSO's avoid-and-commit calls six helpers that compile on the cores first: whichever
    # process compiles a caller loads them from the cache instead of compiling them again
    log = tmp_path / "compiled.txt"
    script = f"""
import json, os
from crowdmotion import _precompile as pc
from numba.core import event
class L(event.Listener):  # every process, children included, notes what it compiles
    def on_start(self, ev): pass
    def on_end(self, ev):
        d = ev.data["dispatcher"]
        with open({str(log)!r}, "a") as f:
            f.write(f"{{os.getpid()}} {{d.py_func.__module__}}:{{d.py_func.__qualname__}}\\n")
event.register("numba:compile", L())
done = pc.start("pso")
print(json.dumps({{"done": done, "cold": [k["name"] for k in json.loads(pc.RECORD.read_text())["pso"] if pc._cold(k)]}}))
"""
    result = _in_fresh_process(script, tmp_path / "cache")
    if pc.cores() < 2:
        assert result["done"] == 0
        return
    assert result["done"] == len(RECORD["pso"]) and result["cold"] == []  # every kernel in the cache
    ours = {k["name"] for k in RECORD["pso"]}
    compiled = [line.split() for line in log.read_text().splitlines()]
    names = sorted(n for _, n in compiled if n in ours)
    assert names == sorted(ours)  # each once, in one process or another
    assert len({pid for pid, _ in compiled}) >= 2  # shared between processes


@pytest.mark.slow  # compiles MDP's kernels into an empty cache (about 30 s)
def test_a_first_run_says_it_is_compiling_and_a_later_one_does_not(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    said = []
    for _ in range(2):
        done = subprocess.run([sys.executable, "-m", "crowdmotion", "run", "mdp_robots_2d", "--plots", "none",
                               "-o", str(tmp_path / "out"), "--overwrite"], capture_output=True, text=True, env=env,
                              timeout=300)
        assert done.returncode == 0, done.stderr
        said.append("a first mdp run here: compiling its kernels" in done.stderr)
    assert said == [True, False]


def test_quiet_runs_do_not_say_it(tmp_path):
    script = """
from crowdmotion import _precompile as pc
from crowdmotion.cli import _begin_compiling, scenario_path
print(pc.cold_seconds("pso") > 0)
_begin_compiling(scenario_path("pso_gathering"), quiet=True)
"""
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "CROWDMOTION_PRECOMPILE": "0"})
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "True"
    assert "compiling" not in done.stderr


def test_a_library_run_forks_no_compiling_children_unless_asked(monkeypatch):
    import crowdmotion
    from crowdmotion.builtin import builtin_scenarios
    from crowdmotion.scenario import load_scenario, run_scenario

    forks = []  # a cold cache on four cores, where `crowdmotion run` would fork
    monkeypatch.setattr(pc, "can_fork", lambda: True)
    monkeypatch.setattr(pc, "cores", lambda: 4)
    monkeypatch.setattr(pc, "_cold_kernels", lambda method: [{"name": "k", "seconds": 1.0, "signatures": []}])
    monkeypatch.setattr(pc, "_fork", lambda n, *args: forks.append(n) or [])
    monkeypatch.setattr(pc, "_work", lambda *args, **kw: None)
    sc = load_scenario(next(p for p in builtin_scenarios() if p.stem == "mdp_robots_2d"))
    run_scenario(sc, progress=False)
    crowdmotion.run(sc, progress=False)
    assert forks == []
    run_scenario(sc, progress=False, precompile=True)  # what the command line asks for
    assert forks == [1]


def test_a_sigterm_as_soon_as_a_child_is_forked_ends_the_child_not_runs_the_parents_handler():
    # a run's handler raises on SIGTERM; a child forked for pictures or compiling that got
    # the signal before installing its own handlers ran that handler and unwound into the
    # run's code (a test suite hung on it): the child must simply end
    import os
    import signal
    import time

    from crowdmotion._precompile import fork

    def raising(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, raising)
    try:
        pid = fork()
        if pid == 0:
            try:
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(1.0)
            finally:
                os._exit(7)  # reached only if the parent's handler ran here
        _, status = os.waitpid(pid, 0)
    finally:
        signal.signal(signal.SIGTERM, old)
    assert os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGTERM, status


@pytest.mark.slow  # warm_up() compiles every RVO kernel into an empty cache (about 2 minutes)
def test_a_warmed_up_live_simulator_compiles_nothing_in_its_steps(tmp_path):
    # a game calls rvo.warm_up() before its first frame: the steps then compile nothing,
    # however the crowd meets its obstacles, a door that opens and a player driven through
    # someone standing in its way
    script = """
import json
import numpy as np
import crowdmotion as cm
from crowdmotion import rvo
ready = rvo.warm_up()
""" + LISTENER + """event.register("numba:compile", L())
scene = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([9, 0], [11, 4]), cm.Box([9, 6], [11, 10])])
sim = rvo.Simulator(scene, time_step=1 / 30, remove_on_arrival=False)
ys = np.linspace(1, 9, 5)
sim.add_agents(np.c_[np.full(5, 2.0), ys], np.c_[np.full(5, 18.0), ys])
player = sim.add_agents([[16, 5]], [[16, 5]], radius=0.3)
sim.add_agents([[14, 5]], [[14, 5]])  # standing in the player's way: it steps aside (escape)
sim.drive(player, [-1.0, 0.0])
door = sim.add_obstacle(cm.Box([9.5, 4], [10.5, 6]))
for k in range(120):
    sim.step()
    if k == 30:
        sim.remove_obstacle(door)
# a crowd of 300 (stepped on the threaded kernels from 250 agents on where there are two
# threads; every core counted free, though the warm-up's compiles just kept them busy)
from crowdmotion import _threads
_threads._free_cores = None
crowd = rvo.Simulator(scene, time_step=1 / 30)
grid = np.stack(np.meshgrid(np.linspace(0.5, 8.5, 18), np.linspace(0.5, 9.5, 17)), -1).reshape(-1, 2)[:300]
crowd.add_agents(grid, [19, 5], radius=0.2)
for k in range(5):
    crowd.step()
print(json.dumps({"ready": ready, "compiled": compiled}))
"""
    result = _in_fresh_process(script, tmp_path)
    assert result["ready"] >= len(RECORD["rvo"])
    assert result["compiled"] == [], result["compiled"]
