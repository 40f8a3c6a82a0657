"""A first run compiles its numba kernels on every core it has (issue 16).

numba compiles a kernel the first time it is called, one after another, on one core,
and with it every jitted helper the kernel calls: a fresh install spends 6-7 s of an
RVO or PSO run there. The kernels a method's run compiles and the helpers each calls,
with their argument types and compile times, are recorded once in ``_precompile.json``
(``python -m crowdmotion._precompile --record``, rerun when a kernel's arguments or
helpers change; tests/test_precompile.py says when). When a run starts and numba's
cache lacks some of them, :func:`start` schedules them on the cores: helpers are
compiled as stages of their own, side by side, and a kernel only once the helpers it
needs are in the cache, from which its compile loads them (:func:`schedule`: the
longest chain of compile time first). Forked children compile their lists into the
cache while this process compiles its own, waiting where a helper comes from another
process (a marker file per finished kernel); then the run loads every kernel from the
cache.

Only where ``os.fork`` exists (Linux, macOS), with more than one core, and while this
process runs no other Python thread (a lock held by another thread would stay locked in
a child); a child still compiling after ``CHILD_TIMEOUT_S`` is stopped, and a wait for
a helper ends then too. ``CROWDMOTION_PRECOMPILE=0`` turns it off. A kernel whose
recorded types no longer match is simply compiled again when called, as without this
module.
"""

from __future__ import annotations

import atexit
import importlib
import json
import os
import re
import shutil
import signal
import sys
import tempfile
import threading
import time
from pathlib import Path

RECORD = Path(__file__).with_name("_precompile.json")
CHILD_TIMEOUT_S = 120.0  # a child compiling longer than this is stopped
SCALARS = {"float64", "float32", "int64", "int32", "uint64", "uint8", "int8", "bool", "intp", "uintp", "none"}
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
    """numba argument types from their ``str()`` (arrays, scalars and None only; no eval)."""
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


def cores() -> int:
    """The cores this process may run on (its CPU affinity where the platform says)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def _marker(name: str) -> str:
    return re.sub(r"[^\w.-]", "_", name)


def schedule(kernels: list[dict], workers: int, first: list[dict] = (), head_start: float = 0.0) -> list[list[dict]]:
    """Kernels into ``workers`` lists to compile side by side, each kernel after the
    helpers it ``needs`` (list scheduling: of the kernels whose helpers are placed, the
    one heading the longest chain of compile time goes to the list where it can start
    first). ``first`` go to the first list beforehand, in their order (what this process
    compiles anyway, while ``head_start`` seconds of other work keep it from the rest).
    Each kernel comes back as a copy with ``wait``: the helpers it needs that another
    list compiles. Empty lists are dropped but the first (this process's, which may have
    nothing to compile when the others take it all).
    """
    first = list(first)
    placed = {f["name"] for f in first}
    items = first + [k for k in kernels if k["name"] not in placed]
    by = {k["name"]: k for k in items}
    needs = {k["name"]: [n for n in k.get("needs", ()) if n in by and n != k["name"]] for k in items}
    users: dict[str, list[str]] = {n: [] for n in by}
    for n, ds in needs.items():
        for d in ds:
            users[d].append(n)
    chain: dict[str, float] = {}

    def chain_of(name: str, seen: frozenset = frozenset()) -> float:  # compile time from here to the end
        if name not in chain:
            later = [chain_of(u, seen | {name}) for u in users[name] if u not in seen]
            chain[name] = by[name]["seconds"] + max(later, default=0.0)
        return chain[name]

    lists: list[list[dict]] = [[] for _ in range(max(1, workers))]
    free = [0.0] * len(lists)
    finish: dict[str, float] = {}
    where: dict[str, int] = {}
    for k in first:
        free[0] += k["seconds"]
        finish[k["name"]], where[k["name"]] = free[0], 0
        lists[0].append(k)
    free[0] += head_start
    pending = [k for k in items if k["name"] not in finish]
    while pending:
        ready = [k for k in pending if all(d in finish for d in needs[k["name"]])] or pending  # (a cycle: any)
        k = max(ready, key=lambda k: chain_of(k["name"]))
        after = max((finish.get(d, 0.0) for d in needs[k["name"]]), default=0.0)
        w = min(range(len(lists)), key=lambda w: (max(free[w], after), w))
        free[w] = max(free[w], after) + k["seconds"]
        finish[k["name"]], where[k["name"]] = free[w], w
        lists[w].append(k)
        pending.remove(k)
    out = [[{**k, "wait": [d for d in needs[k["name"]] if where[d] != w]} for k in lst] for w, lst in enumerate(lists)]
    return [lst for i, lst in enumerate(out) if lst or i == 0]


def _cold(kernel: dict) -> bool:
    """Whether numba's cache has no entry at all for this kernel (its index file)."""
    try:
        disp = _dispatcher(kernel["name"])
        return not Path(disp._cache._cache_file._index_path).is_file()
    except Exception:  # an unknown kernel or numba internals moved: leave it to numba
        return False


def _await(marker: Path, deadline: float) -> None:
    while not marker.exists() and time.monotonic() < deadline:
        time.sleep(0.005)


def _compile_one(kernel: dict) -> None:
    """Compile (or load from the cache) the kernel for each of its recorded signatures."""
    disp = _dispatcher(kernel["name"])
    for sig in kernel["signatures"]:
        disp.compile(parse_signature(sig))


def _compile(kernels: list[dict], marks: Path, deadline: float) -> None:
    """Compile each kernel into the cache, after the helpers it waits for (their markers
    in ``marks``; past ``deadline`` it goes ahead and compiles what it lacks itself), and
    mark it done."""
    for k in kernels:
        for name in k.get("wait", ()):
            _await(marks / _marker(name), deadline)
        try:
            _compile_one(k)
        except Exception:  # stale record: the run compiles it when it calls it
            pass
        finally:
            (marks / _marker(k["name"])).touch()


def _closure(kernels: list[dict], names: set[str]) -> list[dict]:
    """The kernels called ``names`` and every helper they need, helpers first."""
    by = {k["name"]: k for k in kernels}
    out: dict[str, dict] = {}

    def visit(name: str, seen: frozenset = frozenset()) -> None:
        if name in by and name not in out and name not in seen:
            for d in by[name].get("needs", ()):
                visit(d, seen | {name})
            out[name] = by[name]
    for k in kernels:
        if k["name"] in names:
            visit(k["name"])
    return list(out.values())


# begun: (this process's share, children, kernels, marker folder, deadline)
_PENDING: dict[str, tuple[list[dict], list[int], int, Path, float]] = {}


def can_fork() -> bool:
    """Whether a forked child may go on running Python here: ``os.fork`` exists and this
    process runs no other Python thread (a lock another thread holds would stay locked
    in the child)."""
    return hasattr(os, "fork") and threading.active_count() == 1


def _cold_kernels(method: str) -> list[dict]:
    """``method``'s recorded kernels that numba's cache lacks (none without a record)."""
    try:
        record = json.loads(RECORD.read_text())
    except (OSError, ValueError):
        return []
    return [k for k in record.get(method, []) if _cold(k)]


def cold_seconds(method: str) -> float:
    """Seconds of compiling (on one core, as recorded) that ``method``'s kernels missing
    from numba's cache take: 0 when the cache has them all."""
    return sum(k["seconds"] for k in _cold_kernels(method))


def _plan(method: str, background: bool = False, head_start: float = 0.0):
    """The cold kernels of ``method`` scheduled as (this process's list, the children's
    lists, how many), or None where nothing is to be done or compiling cannot be spread.
    ``background``: all of it to children (on the other cores), none to this process."""
    if os.environ.get("CROWDMOTION_PRECOMPILE", "1") == "0" or not can_fork():
        return None
    todo = _cold_kernels(method)
    n_cores = cores()
    if not todo or n_cores < 2:
        return None
    if background:
        return [], [lst for lst in schedule(todo, min(n_cores - 1, len(todo))) if lst], len(todo)
    # what reading and checking a scenario calls (RVO's line-of-sight test, for one) this
    # process compiles anyway, with its helpers: its list starts with those, so no child
    # compiles them too
    first = _closure(todo, {k["name"] for k in todo if k.get("at_load")})
    if len(first) == len(todo):
        return None  # this process compiles it all while checking the scenario
    mine, *theirs = schedule(todo, min(n_cores, len(todo)), first=first, head_start=head_start)
    return mine, theirs, len(todo)


def _fork(lists: list[list[dict]], marks: Path, deadline: float) -> list[int]:
    """A child per list, compiling it into the cache and leaving at once; their pids."""
    children = []
    for share in lists:
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:
            code = 0
            try:
                _compile(share, marks, deadline)
            except BaseException:
                code = 1
            os._exit(code)
        children.append(pid)
    return children


def _wait(children: list[int], deadline: float) -> None:
    """Wait for the children; one still compiling after the deadline is stopped (the run
    then compiles what it lacks as usual)."""
    for pid in children:
        while os.waitpid(pid, os.WNOHANG) == (0, 0):
            if time.monotonic() > deadline:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
                break
            time.sleep(0.02)


def _load_registries() -> None:
    """numba's typing and lowering registries loaded here, before forking, so that every
    child starts with them (about 0.3 s a process otherwise, spent by each child and
    this process alike before its first compile: cold pso_gathering 7.9-10.9 -> 7.6-10.7 s,
    three interleaved pairs)."""
    try:
        from numba.core.registry import cpu_target

        cpu_target.typing_context.refresh()
        cpu_target.target_context.refresh()
    except Exception:  # numba internals moved: the children load them as before
        pass


def _launch(method: str, background: bool = False, head_start: float = 0.0):
    plan = _plan(method, background, head_start)
    if plan is None:
        return None
    mine, theirs, count = plan
    _load_registries()
    marks = Path(tempfile.mkdtemp(prefix="crowdmotion-compiling-"))
    deadline = time.monotonic() + CHILD_TIMEOUT_S
    return mine, _fork(theirs, marks, deadline), count, marks, deadline


def stop_children(pids: list[int], sig: int = signal.SIGKILL) -> None:
    """Send ``sig`` to each child process and reap it (one already gone is skipped)."""
    for pid in pids:
        try:
            os.kill(pid, sig)
            os.waitpid(pid, 0)
        except (OSError, ChildProcessError):
            pass


def _stop_pending() -> None:
    """At exit: children begun for a run that never started (a scenario refused) stop."""
    for _, children, _, marks, _ in _PENDING.values():
        stop_children(children)
        shutil.rmtree(marks, ignore_errors=True)
    _PENDING.clear()


# what `crowdmotion run` does between begin() and start() (imports, reading and checking
# the scenario), in seconds of this process's time that the schedule leaves to children
LOAD_S = 1.0


def begin(method: str, background: bool = False) -> None:
    """Start the children compiling ``method``'s cold kernels now, before this process
    reads and checks the scenario (about a second of imports and set-up that the
    compiling then overlaps); :func:`start` compiles this process's share and waits.
    ``background``: the children take every kernel, for a run that comes later (the
    demo's next method while this one's scenes run)."""
    if method in _PENDING:
        return
    launched = _launch(method, background, head_start=LOAD_S)
    if launched is None:
        return
    if not _PENDING:
        atexit.register(_stop_pending)
    _PENDING[method] = launched


def start(method: str) -> int:
    """Compile ``method``'s recorded kernels missing from the cache on all cores, waiting
    until every share is done; returns how many kernels were compiled (0 when the cache
    already had them, on one core, or where fork is missing). Finishes what
    :func:`begin` started, if it did."""
    launched = _PENDING.pop(method, None) or _launch(method)
    if launched is None:
        return 0
    mine, children, count, marks, deadline = launched
    try:
        _compile(mine, marks, deadline)
        _wait(children, deadline)
    finally:
        shutil.rmtree(marks, ignore_errors=True)
    return count


SCENES = {"rvo": ("rvo_street_O", "rvo_doorway"), "pso": ("pso_gathering", "pso_avoidance", "pso_two_swarms_2d"),
          "formation": ("formation_exchange", "formation_army"), "mdp": ("mdp_robots_2d", "mdp_drones_3d")}


def _fresh_run(*args: str, stdin: str = "") -> object:
    """``python -m crowdmotion._precompile ARGS`` in a fresh process on an empty cache,
    with nothing precompiled; its last line of output, read as JSON."""
    import subprocess

    cache = tempfile.mkdtemp(prefix="crowdmotion-record-")
    try:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache, "CROWDMOTION_PRECOMPILE": "0"}
        done = subprocess.run([sys.executable, "-m", "crowdmotion._precompile", *args], env=env, input=stdin,
                              check=True, capture_output=True, text=True)
    finally:
        shutil.rmtree(cache, ignore_errors=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def record(methods=tuple(SCENES)) -> dict:
    """For each method: the kernels its runs compile, with the helpers they call and
    their argument types (a run of a few small built-in scenes in a fresh process on an
    empty cache), and how long each takes to compile once its helpers are in the cache
    (each compiled in turn, helpers first, in another fresh process)."""
    out = {}
    for method in methods:
        kernels = _fresh_run("--time-one", stdin=json.dumps(_fresh_run("--record-one", method)))
        out[method] = sorted(kernels, key=lambda k: -k["seconds"])
    return out


def _name(dispatcher) -> str:
    return f"{dispatcher.py_func.__module__}:{dispatcher.py_func.__qualname__}"


def _record_one(method: str) -> list[dict]:
    """The kernels runs of ``method``'s scenes compile (in this fresh process): those
    called from Python and the helpers they call, cached on disk, with the helpers each
    needs; ``at_load``: compiled while the scenario was read and checked."""
    from numba.core import event

    from crowdmotion.cli import builtin_scenarios
    from crowdmotion.scenario import load_scenario, run_scenario

    found: dict[str, dict] = {}

    class Listener(event.Listener):
        def on_start(self, ev):
            pass

        def on_end(self, ev):
            name = _name(ev.data["dispatcher"])
            if name.startswith("crowdmotion."):
                k = found.setdefault(name, {"name": name, "signatures": []})
                sig = str(tuple(ev.data["args"]))
                if sig not in k["signatures"]:
                    k["signatures"].append(sig)

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
    names = {k["name"] for k in kernels}
    for k in kernels:
        k["needs"] = sorted(_callees(_dispatcher(k["name"])) & names)
    return kernels


def _callees(dispatcher) -> set[str]:
    """The jitted functions the compiled kernel calls (as typed, not inlined), by name."""
    from numba.core import types

    out = set()
    for cres in dispatcher.overloads.values():
        annotation = getattr(cres, "type_annotation", None)
        for t in getattr(annotation, "typemap", {}).values():
            if isinstance(t, types.Dispatcher):
                out.add(_name(t.dispatcher))
    return out


def _time_one(kernels: list[dict]) -> list[dict]:
    """Compile the kernels one by one, helpers first (in this fresh process), timing each."""
    from numba import njit

    njit(lambda a: a + 1)(1)  # numba's own first-compile set-up, not any kernel's
    order = _closure(kernels, {k["name"] for k in kernels})
    for k in order:
        t0 = time.perf_counter()
        _compile_one(k)
        k["seconds"] = round(time.perf_counter() - t0, 3)
    return order


if __name__ == "__main__":  # pragma: no cover - a developer's tool
    if len(sys.argv) == 3 and sys.argv[1] == "--record-one":
        print(json.dumps(_record_one(sys.argv[2])))
        sys.exit(0)
    if len(sys.argv) == 2 and sys.argv[1] == "--time-one":
        print(json.dumps(_time_one(json.loads(sys.stdin.read()))))
        sys.exit(0)
    if "--record" not in sys.argv:
        sys.exit("usage: python -m crowdmotion._precompile --record")
    data = record()
    tmp = RECORD.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1) + "\n")
    tmp.replace(RECORD)
    for m, ks in data.items():
        print(f"{m}: {len(ks)} kernels, {sum(k['seconds'] for k in ks):.1f} s of compiling")
