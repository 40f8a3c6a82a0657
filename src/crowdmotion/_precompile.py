"""A first run compiles its numba kernels on every core it has.

numba compiles a kernel the first time it is called, one after another, on one core,
and with it every jitted helper the kernel calls: a fresh install spends 6-7 s of an
RVO or PSO run there. The kernels a method's run compiles and the helpers each calls,
with their argument types and compile times, are recorded once in ``_precompile.json``
(by :mod:`crowdmotion.precompile_record`: ``python -m crowdmotion.precompile_record``,
rerun when a kernel's arguments or helpers change; tests/test_precompile.py says when). When a run starts and numba's
cache lacks some of them, forked children and this process take them from one shared
list (:func:`_work`): each core, when free, claims the next kernel whose helpers are
already in the cache (from which its compile loads them), the one heading the longest
chain of compile time first. Taking work when free rather than in lists planned from
the record keeps every core busy however long a compile takes on the day; then the run
loads every kernel from the cache.

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


def ranked(kernels: list[dict]) -> list[dict]:
    """The kernels in the order a free core takes them: the one heading the longest chain
    of compile time (its own and that of the kernels that call it, through ``needs``)
    first, so that a long kernel's helpers are in the cache before a core is free for it."""
    by = {k["name"]: k for k in kernels}
    users: dict[str, list[str]] = {n: [] for n in by}
    for k in kernels:
        for d in k.get("needs", ()):
            if d in by and d != k["name"]:
                users[d].append(k["name"])
    chain: dict[str, float] = {}

    def chain_of(name: str, seen: frozenset = frozenset()) -> float:  # compile time from here to the end
        if name not in chain:
            later = [chain_of(u, seen | {name}) for u in users[name] if u not in seen]
            chain[name] = by[name]["seconds"] + max(later, default=0.0)
        return chain[name]

    return sorted(kernels, key=lambda k: -chain_of(k["name"]))


def _cold(kernel: dict) -> bool:
    """Whether numba's cache has no entry at all for this kernel (its index file)."""
    try:
        disp = _dispatcher(kernel["name"])
        return not Path(disp._cache._cache_file._index_path).is_file()
    except Exception:  # an unknown kernel or numba internals moved: leave it to numba
        return False


def _in_cache(kernel: dict) -> bool:
    """Whether numba's cache holds the kernel for every one of its recorded signatures."""
    try:
        index = _dispatcher(kernel["name"])._cache._cache_file._load_index()
        return set(kernel["signatures"]) <= {str(tuple(key[0])) for key in index}
    except Exception:  # numba internals moved: not known to be there
        return False


def _compile_one(kernel: dict) -> None:
    """Compile (or load from the cache) the kernel for each of its recorded signatures."""
    disp = _dispatcher(kernel["name"])
    for sig in kernel["signatures"]:
        disp.compile(parse_signature(sig))


# The processes compiling one method's kernels share a folder: ``NAME.claim`` (created
# exclusively, so one process takes a kernel) and ``NAME`` once it is in the cache.
def _claim(marks: Path, name: str) -> bool:
    try:
        os.close(os.open(marks / f"{_marker(name)}.claim", os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:
        return False
    return True


def _claimed(marks: Path, name: str) -> bool:
    return (marks / f"{_marker(name)}.claim").exists()


def _finished(marks: Path, name: str) -> bool:
    return (marks / _marker(name)).exists()


def _finish(marks: Path, kernel: dict, compile_one=None) -> None:
    """Compile the kernel into the cache (a stale record is left to the run, which compiles
    it when it calls it) and mark it finished."""
    try:
        (compile_one or _compile_one)(kernel)
    except Exception:
        pass
    finally:
        (marks / _marker(kernel["name"])).touch()


def _work(kernels: list[dict], marks: Path, deadline: float, compile_one=None) -> None:
    """Take kernels from the shared list until none is left unclaimed, compiling each into
    the cache.

    A kernel is taken once the helpers it ``needs`` from the list are finished, the
    longest chain first (:func:`ranked`), so each core takes the next kernel when it is
    free, however long the last one took here (a process's first compile carries numba's
    set-up; the run reads its scenario meanwhile). When nothing is ready and nothing is
    being compiled (a cycle), or after ``deadline``, the first kernel left is taken: its
    compile then compiles what it lacks itself.
    """
    by = {k["name"]: k for k in kernels}

    def finished(name: str) -> bool:  # (what the run compiles while checking the scenario is
        # in the cache before the run marks it, and a kernel may need it meanwhile)
        return _finished(marks, name) or (by[name].get("at_load", False) and _in_cache(by[name]))

    pending = ranked(kernels)
    while True:
        pending = [k for k in pending if not _claimed(marks, k["name"])]
        if not pending:
            return
        stuck = time.monotonic() > deadline or all(finished(n) for n in by if _claimed(marks, n))
        ready = [k for k in pending if all(finished(d) for d in k.get("needs", ()) if d in by)]
        if not ready and not stuck:
            time.sleep(0.005)
            continue
        k = (ready or pending)[0]
        if _claim(marks, k["name"]):
            _finish(marks, k, compile_one)


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


# begun: (what this process claimed, the kernels, children, marker folder, deadline)
_PENDING: dict[str, tuple[list[dict], list[dict], list[int], Path, float]] = {}


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


def _plan(method: str, background: bool = False):
    """The cold kernels of ``method`` as (what this process compiles first, all of them,
    how many children to fork), or None where nothing is to be done or compiling cannot
    be spread. ``background``: this process compiles nothing first (the children take
    it all, for a run that comes later)."""
    if os.environ.get("CROWDMOTION_PRECOMPILE", "1") == "0" or not can_fork():
        return None
    todo = _cold_kernels(method)
    n_cores = cores()
    if not todo or n_cores < 2:
        return None
    # what reading and checking a scenario calls (RVO's line-of-sight test, for one) this
    # process compiles anyway, with its helpers: it claims them, so no child compiles them too
    first = [] if background else _closure(todo, {k["name"] for k in todo if k.get("at_load")})
    if len(first) == len(todo):
        return None  # this process compiles it all while checking the scenario
    return first, todo, min(n_cores - 1, len(todo) - len(first))


def _fork(n: int, kernels: list[dict], marks: Path, deadline: float) -> list[int]:
    """``n`` children taking kernels from the shared list (:func:`_work`) and leaving
    once none is left; their pids."""
    children = []
    for _ in range(n):
        sys.stdout.flush()
        sys.stderr.flush()
        pid = fork()
        if pid == 0:
            code = 0
            try:
                _work(kernels, marks, deadline)
            except BaseException:
                code = 1
            os._exit(code)
        children.append(pid)
    return children


def _wait(children: list[int], deadline: float) -> None:
    """Wait for the children; one still compiling after the deadline is stopped (the run
    then compiles what it lacks as usual)."""
    for pid in children:
        _reap(pid, deadline, 0.02)


def _reap(pid: int, deadline: float, poll: float) -> None:
    """Wait for child ``pid`` to end, every ``poll`` seconds; one still there after
    ``deadline`` (time.monotonic) is killed and reaped."""
    while os.waitpid(pid, os.WNOHANG) == (0, 0):
        if time.monotonic() > deadline:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            return
        time.sleep(poll)


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


def _launch(method: str, background: bool = False):
    plan = _plan(method, background)
    if plan is None:
        return None
    first, todo, n_children = plan
    _load_registries()
    marks = Path(tempfile.mkdtemp(prefix="crowdmotion-compiling-"))
    for k in first:
        _claim(marks, k["name"])
    deadline = time.monotonic() + CHILD_TIMEOUT_S
    return first, todo, _fork(n_children, todo, marks, deadline), marks, deadline


def fork() -> int:
    """``os.fork()`` with SIGINT and SIGTERM held back across it. The child resets both to
    their defaults before letting them through, so a signal that arrives just after the
    fork ends the child instead of running the parent's handler there (which could raise
    into, and run on in, the parent's code); it installs its own handlers after. The
    parent lets them through as before."""
    held = {signal.SIGINT, signal.SIGTERM}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        pid = os.fork()
    except BaseException:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
        raise
    if pid == 0:
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_SETMASK, old)
    return pid


STOP_GRACE_S = 5.0  # a child that outlives a polite signal this long is killed


def stop_children(pids: list[int], sig: int = signal.SIGKILL) -> None:
    """Send ``sig`` to each child process and reap it (one already gone is skipped); one
    still there ``STOP_GRACE_S`` after a signal other than SIGKILL is killed."""
    for pid in pids:
        try:
            os.kill(pid, sig)
            if sig == signal.SIGKILL:
                os.waitpid(pid, 0)
            else:
                _reap(pid, time.monotonic() + STOP_GRACE_S, 0.01)
        except (OSError, ChildProcessError):
            pass


def _stop_pending() -> None:
    """At exit: children begun for a run that never started (a scenario refused) stop."""
    for _, _, children, marks, _ in _PENDING.values():
        stop_children(children)
        shutil.rmtree(marks, ignore_errors=True)
    _PENDING.clear()


def begin(method: str, background: bool = False) -> None:
    """Start the children compiling ``method``'s cold kernels now, before this process
    reads and checks the scenario (about a second of imports and set-up that the
    compiling then overlaps); :func:`start` joins them and waits. ``background``: for a
    run that comes later (the demo's next method while this one's scenes run)."""
    if method in _PENDING:
        return
    launched = _launch(method, background)
    if launched is None:
        return
    if not _PENDING:
        atexit.register(_stop_pending)
    _PENDING[method] = launched


def start(method: str) -> int:
    """Compile ``method``'s recorded kernels missing from the cache on all cores, waiting
    until every one is done; returns how many kernels were compiled (0 when the cache
    already had them, on one core, or where fork is missing). Finishes what
    :func:`begin` started, if it did: this process compiles what it claimed, then takes
    kernels from the shared list beside the children."""
    launched = _PENDING.pop(method, None) or _launch(method)
    if launched is None:
        return 0
    first, todo, children, marks, deadline = launched
    try:
        for k in first:
            _finish(marks, k)
        _work(todo, marks, deadline)
        _wait(children, deadline)
    finally:
        shutil.rmtree(marks, ignore_errors=True)
    return len(todo)


def warm_up(method: str) -> int:
    """Have every recorded kernel of ``method`` ready in this process: those missing from
    numba's cache compiled on all cores (:func:`start`; here, one after another where
    it cannot fork), then each compiled or loaded from the cache here, so that no later
    step stops for one (a game's first frames). Returns how many kernels are ready."""
    start(method)
    try:
        record = json.loads(RECORD.read_text()).get(method, [])
    except (OSError, ValueError):
        return 0
    for kernel in record:
        _compile_one(kernel)
    return len(record)
