"""A first run compiles its numba kernels on every core it has (issue 16).

numba compiles a kernel the first time it is called, one after another, on one core: a
fresh install spends 6-7 s of an RVO or PSO run there. The kernels a method's run
compiles, with their argument types and how long each took, are recorded once in
``_precompile.json`` (``python -m crowdmotion._precompile --record``, rerun when a
kernel's arguments change; tests/test_precompile.py says when). When a run starts and
numba's cache lacks some of them, :func:`start` shares them out by compile time among
the cores: forked children compile their share into the cache while this process
compiles its own, then waits for them, and the run loads every kernel from the cache.

Only where ``os.fork`` exists (Linux, macOS), with more than one core, and while this
process runs no other Python thread (a lock held by another thread would stay locked in
a child); a child still compiling after ``CHILD_TIMEOUT_S`` is stopped.
``CROWDMOTION_PRECOMPILE=0`` turns it off. A kernel whose recorded types no longer match
is simply compiled again when called, as without this module.
"""

from __future__ import annotations

import atexit
import importlib
import json
import os
import re
import signal
import sys
import threading
import time
from pathlib import Path

RECORD = Path(__file__).with_name("_precompile.json")
CHILD_TIMEOUT_S = 120.0  # a child compiling longer than this is stopped
SCALARS = {"float64", "float32", "int64", "int32", "uint64", "uint8", "int8", "bool", "intp", "uintp"}
_ARRAY = re.compile(r"Array\((\w+), (\d+), '([CFA])', (True|False), aligned=True\)")
_TOKEN = re.compile(r"Array\([^)]*\)|\w+")


def _dispatcher(name: str):
    """The numba dispatcher called ``module:qualname`` (a ``@threaded`` twin by its name)."""
    module, qual = name.split(":")
    mod = importlib.import_module(module)
    obj = getattr(mod, qual, None)
    if obj is None and qual.endswith("_serial"):
        obj = getattr(getattr(mod, qual[: -len("_serial")]), "serial")
    return getattr(obj, "serial", obj) if qual.endswith("_serial") else obj


def parse_signature(text: str) -> tuple:
    """numba argument types from their ``str()`` (arrays and scalars only; no eval)."""
    from numba.core import types

    out = []
    for tok in _TOKEN.findall(text):
        m = _ARRAY.fullmatch(tok)
        if m:
            dtype, ndim, layout, readonly = m.groups()
            out.append(types.Array(getattr(types, "boolean" if dtype == "bool" else dtype), int(ndim), layout,
                                   readonly=readonly == "True"))
        elif tok in SCALARS:
            out.append(getattr(types, "boolean" if tok == "bool" else tok))
        else:
            raise ValueError(f"unsupported argument type {tok!r} in {text!r}")
    return tuple(out)


def _cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def share_out(kernels: list[dict], parts: int, first: list[dict] = ()) -> list[list[dict]]:
    """Kernels into ``parts`` lists of about equal compile time (longest first, each to
    the least loaded list); ``first`` are given to the first list beforehand (kernels
    this process compiles anyway). Empty lists are dropped, but the first is kept when
    ``first`` is given."""
    bins: list[list[dict]] = [list(first)] + [[] for _ in range(max(1, parts) - 1)]
    load = [sum(k["seconds"] for k in first)] + [0.0] * (len(bins) - 1)
    for k in sorted(kernels, key=lambda k: -k["seconds"]):
        i = load.index(min(load))
        bins[i].append(k)
        load[i] += k["seconds"]
    return [b for i, b in enumerate(bins) if b or (i == 0 and first)]


def _cold(kernel: dict) -> bool:
    """Whether numba's cache has no entry at all for this kernel (its index file)."""
    try:
        disp = _dispatcher(kernel["name"])
        return not Path(disp._cache._cache_file._index_path).is_file()
    except Exception:  # an unknown kernel or numba internals moved: leave it to numba
        return False


def _compile(kernels: list[dict]) -> None:
    for k in kernels:
        try:
            disp = _dispatcher(k["name"])
            for sig in k["signatures"]:
                disp.compile(parse_signature(sig))
        except Exception:  # stale record: the run compiles it when it calls it
            continue


_PENDING: dict[str, tuple[list[dict], list[int], int]] = {}  # begun: (this share, children, kernels)


def _plan(method: str, background: bool = False):
    """The cold kernels of ``method`` shared out as (this process's share, the children's
    shares, how many), or None where nothing is to be done or compiling cannot be spread.
    ``background``: all of it to children (on the other cores), none to this process."""
    if os.environ.get("CROWDMOTION_PRECOMPILE", "1") == "0" or not hasattr(os, "fork"):
        return None
    if threading.active_count() > 1:  # a lock another thread holds would stay locked in a child
        return None
    try:
        record = json.loads(RECORD.read_text())
    except (OSError, ValueError):
        return None
    todo = [k for k in record.get(method, []) if _cold(k)]
    cores = _cores()
    if not todo or cores < 2:
        return None
    if background:
        return [], share_out(todo, min(cores - 1, len(todo))), len(todo)
    # what reading and checking a scenario calls (RVO's line-of-sight test, for one) this
    # process compiles anyway: its share starts with those, so no child compiles them too
    at_load = [k for k in todo if k.get("at_load")]
    rest = [k for k in todo if not k.get("at_load")]
    if not rest:
        return None
    mine, *theirs = share_out(rest, min(cores, len(rest) + bool(at_load)), first=at_load)
    return mine, theirs, len(todo)


def _fork(shares: list[list[dict]]) -> list[int]:
    """A child per share, compiling it into the cache and leaving at once; their pids."""
    children = []
    for share in shares:
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:
            code = 0
            try:
                _compile(share)
            except BaseException:
                code = 1
            os._exit(code)
        children.append(pid)
    return children


def _wait(children: list[int]) -> None:
    """Wait for the children; one still compiling after ``CHILD_TIMEOUT_S`` is stopped
    (the run then compiles what it lacks as usual)."""
    deadline = time.monotonic() + CHILD_TIMEOUT_S
    for pid in children:
        while os.waitpid(pid, os.WNOHANG) == (0, 0):
            if time.monotonic() > deadline:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
                break
            time.sleep(0.02)


def _stop_pending() -> None:
    """At exit: children begun for a run that never started (a scenario refused) stop."""
    for _, children, _ in _PENDING.values():
        for pid in children:
            try:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
            except (OSError, ChildProcessError):
                pass
    _PENDING.clear()


def begin(method: str, background: bool = False) -> None:
    """Start the children compiling ``method``'s cold kernels now, before this process
    reads and checks the scenario (about a second of imports and set-up that the
    compiling then overlaps); :func:`start` compiles this process's share and waits.
    ``background``: the children take every kernel, for a run that comes later (the
    demo's next method while this one's scenes run)."""
    if method in _PENDING:
        return
    plan = _plan(method, background)
    if plan is None:
        return
    mine, theirs, count = plan
    if not _PENDING:
        atexit.register(_stop_pending)
    _PENDING[method] = (mine, _fork(theirs), count)


def start(method: str) -> int:
    """Compile ``method``'s recorded kernels missing from the cache on all cores, waiting
    until every share is done; returns how many kernels were compiled (0 when the cache
    already had them, on one core, or where fork is missing). Finishes what
    :func:`begin` started, if it did."""
    if method in _PENDING:
        mine, children, count = _PENDING.pop(method)
    else:
        plan = _plan(method)
        if plan is None:
            return 0
        mine, theirs, count = plan
        children = _fork(theirs)
    _compile(mine)
    _wait(children)
    return count


SCENES = {"rvo": ("rvo_street_O", "rvo_doorway"), "pso": ("pso_gathering", "pso_avoidance", "pso_two_swarms_2d"),
          "formation": ("formation_exchange", "formation_army"), "mdp": ("mdp_robots_2d", "mdp_drones_3d")}


def record(methods=tuple(SCENES)) -> dict:
    """For each method, run a few small built-in scenes in a fresh process on an empty
    cache and note every kernel called from Python (not nested in another): its argument
    types and compile time."""
    import subprocess
    import tempfile

    out = {}
    for method in methods:
        env = {**os.environ, "NUMBA_CACHE_DIR": tempfile.mkdtemp(prefix="crowdmotion-record-"),
               "CROWDMOTION_PRECOMPILE": "0"}
        done = subprocess.run([sys.executable, "-m", "crowdmotion._precompile", "--record-one", method], env=env,
                              check=True, capture_output=True, text=True)
        out[method] = json.loads(done.stdout.strip().splitlines()[-1])
    return out


def _record_one(method: str) -> list[dict]:
    """The kernels runs of ``method``'s scenes compile (in this fresh process)."""
    from numba.core import event

    from crowdmotion.cli import builtin_scenarios
    from crowdmotion.scenario import load_scenario, run_scenario

    found: dict[str, dict] = {}

    class Listener(event.Listener):
        def __init__(self):
            self.stack = []

        def on_start(self, ev):
            self.stack.append(time.perf_counter())

        def on_end(self, ev):
            t0 = self.stack.pop()
            if self.stack:
                return  # nested: compiled as part of its caller
            d = ev.data["dispatcher"]
            name = f"{d.py_func.__module__}:{d.py_func.__qualname__}"
            if not name.startswith("crowdmotion."):
                return
            k = found.setdefault(name, {"name": name, "signatures": [], "seconds": 0.0})
            sig = str(tuple(ev.data["args"]))
            if sig not in k["signatures"]:
                k["signatures"].append(sig)
            k["seconds"] = round(k["seconds"] + time.perf_counter() - t0, 3)

    paths = {p.stem: p for p in builtin_scenarios()}
    event.register("numba:compile", Listener())
    for scene in SCENES[method]:
        loaded = set(found)
        sc = load_scenario(paths[scene])
        for name in set(found) - loaded:  # compiled while the scenario was read and checked
            found[name]["at_load"] = True
        run_scenario(sc, progress=False)
    kernels = []
    for k in found.values():
        try:
            for sig in k["signatures"]:
                parse_signature(sig)
            if not hasattr(_dispatcher(k["name"])._cache, "_cache_file"):
                continue  # not cached on disk: nothing another process could compile for it
        except Exception:
            continue  # a type we cannot write down, or not reachable by name
        kernels.append(k)
    return sorted(kernels, key=lambda k: -k["seconds"])


if __name__ == "__main__":  # pragma: no cover - a developer's tool
    if len(sys.argv) == 3 and sys.argv[1] == "--record-one":
        print(json.dumps(_record_one(sys.argv[2])))
        sys.exit(0)
    if "--record" not in sys.argv:
        sys.exit("usage: python -m crowdmotion._precompile --record")
    data = record()
    tmp = RECORD.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1) + "\n")
    tmp.replace(RECORD)
    for m, ks in data.items():
        print(f"{m}: {len(ks)} kernels, {sum(k['seconds'] for k in ks):.1f} s of compiling")
