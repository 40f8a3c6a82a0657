"""Records what each method's runs compile, for :mod:`crowdmotion._precompile`: the numba
kernels a few small built-in scenes of the method compile, the helpers each calls, their
argument types and how long each takes to compile, written to ``_precompile.json``.

A developer's tool, run when a kernel's arguments or helpers change (tests/test_precompile.py
says when)::

    python -m crowdmotion.precompile_record --record

It runs scenarios, so it lives above the scenario loader; ``_precompile``, which the
loader's runs use, only reads the record.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
import time

from crowdmotion._precompile import RECORD, _closure, _compile_one, _dispatcher, parse_signature

# the built-ins whose runs are recorded (rvo_blocked_street: walkers there yield, so the
# stand-off rules' kernels are in the record)
SCENES = {"rvo": ("rvo_street_O", "rvo_doorway", "rvo_blocked_street"),
          "pso": ("pso_gathering", "pso_avoidance", "pso_two_swarms_2d"),
          "formation": ("formation_exchange", "formation_army"), "mdp": ("mdp_robots_2d", "mdp_drones_3d")}


def _fresh_run(*args: str, stdin: str = "") -> object:
    """``python -m crowdmotion.precompile_record ARGS`` in a fresh process on an empty cache,
    with nothing precompiled; its last line of output, read as JSON."""
    import subprocess

    cache = tempfile.mkdtemp(prefix="crowdmotion-record-")
    try:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache, "CROWDMOTION_PRECOMPILE": "0"}
        done = subprocess.run([sys.executable, "-m", "crowdmotion.precompile_record", *args], env=env, input=stdin,
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

    from crowdmotion.builtin import builtin_scenarios
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
        sys.exit("usage: python -m crowdmotion.precompile_record --record")
    data = record()
    tmp = RECORD.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1) + "\n")
    tmp.replace(RECORD)
    for m, ks in data.items():
        print(f"{m}: {len(ks)} kernels, {sum(k['seconds'] for k in ks):.1f} s of compiling")
