"""Ensembles and parameter sweeps of a scenario on Dask: every (seed, setting) run on a
``LocalCluster`` (or any Dask cluster by address), one trajectory file per run and one
Parquet table with every run's metrics. A sweep stopped by Ctrl-C (or by a failing run)
keeps its finished runs, listed in a table marked partial, and ``resume`` finishes it.

>>> table = sweep("street.toml", seeds=range(8), settings={"rvo.safety": [1, 3, 7.5]},
...               out="sweeps/street")                                    # doctest: +SKIP
"""

from __future__ import annotations

import ctypes
import hashlib
import itertools
import json
import logging
import pickle
import re
import sys
import threading
import traceback
import uuid
import warnings
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Iterator, Sequence

import pyarrow as pa
import pyarrow.parquet as pq

from crowdmotion._validation import shown
from crowdmotion.interrupts import is_interrupt
from crowdmotion.io.atomic import atomic_path, remove_stale_temps
from crowdmotion.io.longform import json_text
from crowdmotion.progress import counter
from crowdmotion.scenario import Scenario, build, load_scenario, validate_spec

SUMMARY_KEYS = ("agents", "frames", "duration_s", "mean_path_length_m", "mean_speed_mps", "max_speed_mps",
                "agent_agent_overlaps", "agent_obstacle_penetrations", "worst_agent_agent_penetration_m",
                "worst_agent_obstacle_penetration_m", "arrival_rate", "mean_time_to_goal_s", "steps",
                "all_recovered")
COUNT_KEYS = ("agents", "frames", "agent_agent_overlaps", "agent_obstacle_penetrations", "steps")  # whole numbers
RECORD_KEY = b"crowdmotion.sweep"  # sweep.parquet's schema metadata: partial, planned runs, what each run was made from


def _with_setting(data: dict, dotted: str, value: Any) -> dict:
    """A copy of the scenario dict with ``dotted`` (e.g. ``rvo.safety``, ``groups.0.count``)
    set to ``value``; a name that leads nowhere in the scenario is refused, naming it."""
    out = json.loads(json.dumps(data))
    keys = dotted.split(".")
    node = out
    for depth, k in enumerate(keys):
        here = ".".join(keys[:depth + 1])
        last = depth == len(keys) - 1
        if isinstance(node, list):
            if not k.isdigit():
                raise ValueError(f"sweep setting {dotted}: {'.'.join(keys[:depth])} is a list: {here} needs a "
                                 f"whole number (0 for its first entry), not {k!r}")
            if int(k) >= len(node):
                raise ValueError(f"sweep setting {dotted}: {'.'.join(keys[:depth])} has {len(node)} "
                                 f"entr{'y' if len(node) == 1 else 'ies'} (0 to {len(node) - 1}), no {k}")
            if last:
                node[int(k)] = value
            else:
                node = node[int(k)]
        elif isinstance(node, dict):
            if last:
                node[k] = value
            elif k not in node and keys[depth + 1].isdigit():
                raise ValueError(f"sweep setting {dotted}: the scenario gives no {here} to set entry "
                                 f"{keys[depth + 1]} of")
            else:
                node = node.setdefault(k, {})
        else:
            raise ValueError(f"sweep setting {dotted}: {'.'.join(keys[:depth])} is a value "
                             f"({shown(node)}), not a table with fields")
    return out


def plan(scenario: Scenario | str | Path, seeds: Iterable[int], settings: dict[str, Sequence[Any]] | None = None
         ) -> list[tuple[dict, int, dict]]:
    """Every (scenario dict, seed, setting) of the sweep, each validated now so that a bad
    value is refused, naming the field, before anything runs."""
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    base = sc.spec.model_dump(mode="json", exclude_unset=True)  # as the file says it: no other method's block
    settings = settings or {}
    names = list(settings)
    if "seed" in names:
        raise ValueError("sweep: seed cannot be a setting: give the seeds to run as seeds (--seeds 1,2)")
    runs = []
    seeds = [int(s) for s in seeds]
    if not seeds or min(seeds) < 0:
        raise ValueError(f"sweep: seeds must be non-negative integers, got {seeds}")
    for combo in itertools.product(*[list(settings[n]) for n in names]) if names else [()]:
        data = base
        for n, v in zip(names, combo):
            data = _with_setting(data, n, v)
        label = combination_label(dict(zip(names, combo)))
        build(validate_spec(data, label), label)  # a combination the method refuses is named too
        for seed in seeds:
            runs.append((data, seed, dict(zip(names, combo))))
    return runs


def combination_label(setting: dict) -> str:
    """``sweep groups.0.count = 400, mdp.tau = 0.5``: a combination of settings as errors name it."""
    return "sweep" + ("" if not setting else " " + ", ".join(f"{n} = {shown(v)}" for n, v in setting.items()))


# --- run file names --------------------------------------------------------------------

SAFE_TEXT = re.compile(r"[A-Za-z0-9][A-Za-z0-9._+-]*")  # a file name part as it is, on every system
MAX_VALUE_TEXT = 40  # a plain value longer than this is named by its digest
# a run's file stem at most: with ".parquet" and the temporary name a write goes through
# (".<name>.<8 characters>.tmp") it stays well inside the 255 bytes systems allow
MAX_STEM = 200


def _digest(value: Any) -> str:
    """A short stable digest of a setting's value (its JSON, keys sorted): the same value
    gives the same digest in every sweep and on every machine."""
    text = json.dumps(value, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:10]


def _plain_text(value: Any) -> str | None:
    """A setting's value as a file name gives it, when it can be written as it is: a number,
    true/false or a short word of letters, digits and ``. _ + -``; None otherwise."""
    if isinstance(value, (bool, int, float)) or (isinstance(value, str) and len(value) <= MAX_VALUE_TEXT):
        text = str(value)
        return text if SAFE_TEXT.fullmatch(text) else None
    return None


def _value_texts(values: Sequence[Any]) -> list[str]:
    """Each value of one setting as its run files name it: plain values as written (``0.5``,
    ``O+``); lists, tables, and text with spaces, quotes or slashes as ``@`` and a digest of
    the value (``@3f2a9c1b07``; ``@`` is in no plain value's name). Two values whose plain
    names would meet (``1`` and ``"1"``, or ``O+`` and ``o+`` on a system that does not tell
    case apart) are both named by their digests."""
    plain = [_plain_text(v) for v in values]
    seen: dict[str, set[str]] = {}
    for v, text in zip(values, plain):
        if text is not None:
            seen.setdefault(text.casefold(), set()).add(json.dumps(v, sort_keys=True))
    return [text if text is not None and len(seen[text.casefold()]) == 1 else "@" + _digest(v)
            for v, text in zip(values, plain)]


def run_names(runs: Sequence[tuple[dict, int, dict]]) -> list[str]:
    """The file stem of each planned run (as :func:`plan` gives them): ``seed3`` without
    settings, ``seed3_mdp.tau=0.5`` with plain values, ``seed3_scene.obstacles=@3f2a9c1b07``
    for a list or table; a stem that would grow past ``MAX_STEM`` characters is
    ``seed3_settings=@<digest of every setting>``. Short, safe on every system and the same
    for the same sweep; the sweep table keeps the settings' full values. Two runs named
    alike (a digest shared, which should not happen) are refused before anything runs."""
    values: dict[str, list] = {}
    for _, _, setting in runs:
        for k, v in setting.items():
            known = values.setdefault(k, [])
            if not any(json.dumps(v, sort_keys=True) == json.dumps(u, sort_keys=True) for u in known):
                known.append(v)
    texts = {k: dict(zip((json.dumps(v, sort_keys=True) for v in vs), _value_texts(vs))) for k, vs in values.items()}
    fields = {k: k if SAFE_TEXT.fullmatch(k) and len(k) <= MAX_VALUE_TEXT else "@" + _digest(k) for k in values}
    names, taken = [], {}
    for _, seed, setting in runs:
        stem = "_".join([f"seed{seed}"] + [f"{fields[k]}={texts[k][json.dumps(v, sort_keys=True)]}"
                                            for k, v in setting.items()])
        if len(stem) > MAX_STEM:
            stem = f"seed{seed}_settings=@{_digest(sorted(setting.items()))}"
        other = taken.setdefault(stem.casefold(), (seed, setting))
        if other != (seed, setting):
            raise ValueError(f"sweep: two runs would share the file name {stem}.parquet (seed {other[0]}, "
                             f"{combination_label(other[1])} and seed {seed}, {combination_label(setting)}): "
                             f"give these values apart")
        names.append(stem)
    return names


def run_key(data: dict, seed: int) -> str:
    """What one run is made from (the scenario as the sweep set it, and the seed), as a
    digest: a resumed sweep keeps an earlier run only where its key is the same."""
    return hashlib.sha256(json.dumps([data, int(seed)], sort_keys=True).encode()).hexdigest()[:16]


# --- one run, on a worker -----------------------------------------------------------------

STOPPED = "stopped"  # what run_one returns for a run the sweep's stop ended: no file written


@dataclass
class RunFailed:
    """A run that raised, returned as a value (Dask's worker would otherwise log its own
    traceback of it): the error, and its traceback as text."""

    error: BaseException
    trace: str


_RUNNING: dict[int, str] = {}  # thread id -> sweep id, for the runs this process simulates now
_STOPPED: set[str] = set()  # sweeps stopped: their runs not yet started return at once
_LOCK = threading.Lock()


def stop_runs(sweep_id: str) -> int:
    """On a worker: end the runs of sweep ``sweep_id``, those under way (a KeyboardInterrupt
    in their thread: the step loop ends, and the run writes nothing) and those not yet
    started (they return at once). Returns how many were under way."""
    with _LOCK:
        _STOPPED.add(sweep_id)
        threads = [t for t, s in _RUNNING.items() if s == sweep_id]
        for t in threads:
            ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(t), ctypes.py_object(KeyboardInterrupt))
    return len(threads)


def run_one(data: dict, seed: int, setting: dict, path: str, label: str = "sweep",
            sweep_id: str | None = None) -> dict | str | RunFailed:
    """Run one scenario dict with ``seed``; write its trajectories to ``path`` (Parquet);
    return its row of the summary table. A run stopped (Ctrl-C, or :func:`stop_runs` for
    ``sweep_id``) writes nothing and returns ``STOPPED``; one that fails returns
    :class:`RunFailed`, its error naming ``label`` (the combination) and the seed."""
    me = threading.get_ident()
    try:
        if sweep_id is not None:
            with _LOCK:
                if sweep_id in _STOPPED:
                    return STOPPED
                _RUNNING[me] = sweep_id
        try:
            return _simulate(data, seed, setting, path, label)
        finally:
            if sweep_id is not None:
                with _LOCK:
                    _RUNNING.pop(me, None)
    except (KeyboardInterrupt, SystemError) as exc:
        if is_interrupt(exc):
            return STOPPED
        return _failed(exc, label, seed)
    except Exception as exc:
        return _failed(exc, label, seed)


def _failed(exc: BaseException, label: str, seed: int) -> RunFailed:
    """A run's error as a :class:`RunFailed` that travels back from a worker process, named
    by its combination and seed: a ValueError for the user's to fix (a bad value, a file
    that cannot be written), a RuntimeError for anything else (a bug of ours)."""
    trace = "".join(traceback.format_exception(exc))
    if isinstance(exc, (ValueError, OSError)):
        return RunFailed(ValueError(f"{label}, seed {seed}: {exc}"), trace)
    return RunFailed(RuntimeError(f"{label}, seed {seed}: {type(exc).__name__}: {exc}"), trace)


def _simulate(data: dict, seed: int, setting: dict, path: str, label: str) -> dict | str:
    """One run and its table row (``STOPPED`` when an interrupt ended its step loop)."""
    from crowdmotion.scenario import run_scenario

    with warnings.catch_warnings():  # the scenario's own warnings: plan() has shown them
        warnings.simplefilter("ignore")
        sc = build(validate_spec(data, label), label)
    result = run_scenario(sc, seed=seed, progress=False)
    if result.summary.get("partial"):  # stopped part way: not a run to keep
        return STOPPED
    result.trajectories.save(path)
    s = result.summary
    row = {"scenario": sc.spec.name, "seed": seed, "file": path, **{k: _cell(v) for k, v in setting.items()}}
    for k in SUMMARY_KEYS:  # every row has every column (null where a method has no such metric)
        v = s.get(k)
        number = isinstance(v, (int, float)) and not isinstance(v, bool)
        row[k] = (int(v) if k in COUNT_KEYS else float(v)) if number else v
    # the per-group measures as the run's summary took them (RVO: on its steps as simulated,
    # not the relaxed frames the file holds), for crowdmotion report
    row["groups"] = json_text(s["groups"]) if isinstance(s.get("groups"), dict) else None
    return row


def dask_setup(worker) -> None:
    """Dask preload hook, run in each worker process of the sweep's LocalCluster as it
    starts: Ctrl-C and SIGTERM are the sweep's to handle (a terminal or ``timeout`` sends
    them to the workers too; a worker dying of them printed a traceback, and one killed
    mid-write left its files). The sweep stops the runs itself (:func:`stop_runs`)."""
    import signal

    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)


# --- the sweep folder ---------------------------------------------------------------------

def sweep_record(table_or_schema: pa.Table | pa.Schema) -> dict | None:
    """What a sweep table records of its sweep (None for a table of an older crowdmotion):
    ``partial`` (stopped before every run finished), ``planned`` (runs asked for),
    ``stopped_by`` ("interrupt" or "error" where the sweep was stopped, even after its
    last run had finished; else None) and ``keys`` (file name -> :func:`run_key`)."""
    schema = table_or_schema.schema if isinstance(table_or_schema, pa.Table) else table_or_schema
    raw = (schema.metadata or {}).get(RECORD_KEY)
    if raw is None:
        return None
    try:
        record = json.loads(raw)
    except ValueError:
        return None
    return record if isinstance(record, dict) else None


def _refuse_run_folder(out: Path) -> None:
    """A ValueError when ``out`` holds a run's files: a sweep needs a folder of its own."""
    if (out / "manifest.json").is_file():
        raise ValueError(f"{out} holds a run's files (manifest.json): give the sweep a folder of its own with -o")


def clear_earlier(out: Path, overwrite: bool) -> None:
    """Refuse a folder holding an earlier sweep (unless ``overwrite``: then remove its
    ``runs/*.parquet``, ``sweep.parquet`` and ``report.json``, nothing else) or a run's files."""
    _refuse_run_folder(out)
    earlier = sorted((out / "runs").glob("*.parquet")) if (out / "runs").is_dir() else []
    table = out / "sweep.parquet"
    if not (earlier or table.is_file()):
        return
    if not overwrite:
        raise ValueError(f"{out} holds an earlier sweep ({'sweep.parquet, ' if table.is_file() else ''}"
                         f"{len(earlier)} runs in runs/): give another folder with -o, --resume to finish it "
                         f"(its finished runs are kept), or --overwrite to replace it")
    for f in [*earlier, table, out / "report.json"]:
        f.unlink(missing_ok=True)
    remove_stale_temps(out / "runs")


def earlier_runs(out: Path, names: Sequence[str], keys: Sequence[str]) -> dict[str, dict]:
    """The rows of ``out``'s earlier sweep to keep in a resumed one (run name -> row):
    those whose file is still there and that were made from what this sweep plans for that
    name. An earlier sweep of another scenario, or of runs this sweep does not plan, is
    refused (ValueError naming a run); planned runs no table lists are run again."""
    _refuse_run_folder(out)
    planned = {f"{n}.parquet": k for n, k in zip(names, keys)}
    how = "give the scenario, --seeds and --set of the earlier sweep, another folder with -o, or --overwrite " \
          "to replace it"
    on_disk = {f.name for f in (out / "runs").glob("*.parquet")} if (out / "runs").is_dir() else set()
    table_path = out / "sweep.parquet"
    kept: dict[str, dict] = {}
    listed: set[str] = set()
    if table_path.is_file():
        try:
            table = pq.read_table(table_path)
        except Exception as exc:  # pyarrow raises several types for damaged files
            raise ValueError(f"--resume: {table_path}: a damaged sweep table ({exc}): --overwrite to replace it") \
                from None
        record = sweep_record(table)
        if record is None or not isinstance(record.get("keys"), dict):
            raise ValueError(f"--resume: {table_path} was written by an earlier crowdmotion, which kept no record "
                             f"of what each run was made from, so its runs cannot be checked: --overwrite to run "
                             f"them again")
        for row in table.to_pylist():
            name = Path(str(row.get("file"))).name
            listed.add(name)
            if name not in planned:
                raise ValueError(f"--resume: {out} holds run {name} (seed {row.get('seed')}), which this sweep does "
                                 f"not plan: its seeds or settings differ from the earlier sweep's; {how}")
            if record["keys"].get(name) != planned[name]:
                raise ValueError(f"--resume: {out}'s run {name} was made from another scenario than this sweep "
                                 f"would give it (the scenario file, or a value behind it, changed since); {how}")
            if name in on_disk:
                kept[Path(name).stem] = {**row, "file": str(out / "runs" / name)}
    strays = sorted(on_disk - listed - set(planned))
    if strays:
        more = f" and {len(strays) - 1} more" if len(strays) > 1 else ""
        raise ValueError(f"--resume: {out / 'runs'} holds {strays[0]}{more}, which this sweep does not plan and no "
                         f"sweep table lists; {how}")
    unlisted = sorted(on_disk - listed)
    if unlisted:
        warnings.warn(f"{out / 'runs'}: {len(unlisted)} run file{'' if len(unlisted) == 1 else 's'} no sweep table "
                      f"lists (their sweep stopped before it could): run again", stacklevel=3)
    remove_stale_temps(out / "runs")
    return kept


def _cell(value: Any) -> Any:
    """A setting as a table cell: numbers, booleans and strings as they are (a column of
    whole numbers stays whole; 1 beside 2.5 becomes 1.0), anything else as JSON."""
    if isinstance(value, (bool, str, int, float)):
        return value
    return json.dumps(value)


# --- started from a script ----------------------------------------------------------------

GUARD_MESSAGE = ("sweep: Dask starts the sweep's worker processes by running {script} again, and there it would "
                 "start the sweep again: put the sweep under `if __name__ == \"__main__\":` (see docs/sweeps.md), "
                 "or pass processes=False (workers as threads) or scheduler=")


def _top_of_main() -> tuple[Any, int] | None:
    """The ``__main__`` script and the line of its top level that is running now (the
    statement that led to this call), or None when not called from a script's top level."""
    main = sys.modules.get("__main__")
    frame = sys._getframe(1)
    found = None
    while frame is not None:
        if frame.f_code.co_name == "<module>" and main is not None and frame.f_globals is vars(main):
            found = (main, frame.f_lineno)
        frame = frame.f_back
    return found


def _under_main_guard(source: str, line: int) -> bool | None:
    """Whether ``line`` of a script lies in the body of an ``if __name__ == "__main__":``
    block (None where the script cannot be read)."""
    import ast

    try:
        tree = ast.parse(source)
    except (SyntaxError, ValueError):
        return None

    def is_guard(test) -> bool:
        if not (isinstance(test, ast.Compare) and len(test.ops) == 1 and isinstance(test.ops[0], ast.Eq)):
            return False
        sides = {type(x).__name__ + ":" + str(getattr(x, "id", getattr(x, "value", "")))
                 for x in (test.left, test.comparators[0])}
        return sides == {"Name:__name__", "Constant:__main__"}

    for node in ast.walk(tree):
        if isinstance(node, ast.If) and is_guard(node.test) and node.body:
            if node.body[0].lineno <= line <= (node.body[-1].end_lineno or node.body[-1].lineno):
                return True
    return False


def refuse_unguarded_script() -> None:
    """Refuse (RuntimeError, telling the user what to add) a sweep that Dask's worker
    processes would start again: one called from the top level of a script outside an
    ``if __name__ == "__main__":`` block (each worker runs the script anew), or called
    while a worker process runs the script so."""
    top = _top_of_main()
    if top is None:
        return
    main, line = top
    script = getattr(main, "__file__", None) or "the script"
    if main.__name__ == "__mp_main__":  # a worker process running the script again
        raise RuntimeError(GUARD_MESSAGE.format(script=script))
    import dask

    if dask.config.get("distributed.worker.multiprocessing-method", "spawn") == "fork" or script == "the script":
        return
    try:
        source = Path(script).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return
    if _under_main_guard(source, line) is False:
        raise RuntimeError(GUARD_MESSAGE.format(script=script))


# --- the sweep ------------------------------------------------------------------------------

@contextmanager
def _quiet_shutdown() -> Iterator[None]:
    """Dask's warnings while a cluster closes (a worker still busy killed, tasks cancelled)
    held back: the sweep says itself what it kept."""
    loggers = [logging.getLogger(n) for n in ("distributed", "distributed.nanny", "distributed.worker",
                                             "distributed.scheduler", "distributed.client", "distributed.core")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


def _finish_stopped(client, futures: dict, sweep_id: str, rows: dict) -> None:
    """After an interrupt or a failed run: stop the sweep's runs on every worker, then
    take the rows of runs that finished meanwhile (their files are written)."""
    from dask.distributed import wait

    try:
        client.run(stop_runs, sweep_id, wait=True)
    except Exception:  # a worker gone or not answering: cancelling below still ends its tasks
        pass
    try:
        wait(list(futures), timeout=3)
    except Exception:  # dask's TimeoutError: those still going are cancelled
        pass
    client.cancel([f for f in futures if not f.done()])
    for fut, name in futures.items():
        if name not in rows and fut.status == "finished":
            got = fut.result()
            if isinstance(got, dict):
                rows[name] = got


def _write_table(out: Path, rows: list[dict], record: dict) -> pa.Table:
    """``out/sweep.parquet`` from ``rows``, with the sweep's record in its metadata."""
    table = pa.Table.from_pylist(rows)
    table = table.replace_schema_metadata({**(table.schema.metadata or {}), RECORD_KEY: json.dumps(record)})
    if rows:
        with atomic_path(out / "sweep.parquet") as tmp:
            pq.write_table(table, tmp)
    return table


def sweep(scenario: Scenario | str | Path, seeds: Iterable[int] = range(8),
          settings: dict[str, Sequence[Any]] | None = None, out: str | Path = "sweep",
          scheduler: str | None = None, workers: int | None = None, processes: bool = True,
          progress: bool = True, overwrite: bool = False, resume: bool = False) -> pa.Table:
    """Run the scenario for every seed × every combination of ``settings`` (dotted field
    -> values) on Dask; one ``<out>/runs/<name>.parquet`` per run (:func:`run_names`) and
    the table ``<out>/sweep.parquet`` (one row per run: seed, settings, file, metrics), returned.

    ``scheduler``: address of a running Dask scheduler; default a ``LocalCluster`` with
    ``workers`` workers (default: the machine's cores), in separate processes unless
    ``processes=False`` (then called from a script, the call must sit under
    ``if __name__ == "__main__":``, or RuntimeError). An earlier sweep in ``out`` is
    refused (ValueError), or with ``overwrite`` its runs, table and report removed first,
    or with ``resume`` its finished runs kept and only the others run (refused if they
    were made from another scenario or settings); a run's folder is refused.

    Ctrl-C (KeyboardInterrupt) stops the runs under way and returns the table of those
    finished, written and marked partial (:func:`sweep_record`); ``resume`` then finishes
    the sweep. A run that fails is raised (ValueError or RuntimeError naming its
    combination and seed) after the table of the runs finished is written likewise.
    """
    if resume and overwrite:
        raise ValueError("sweep: resume keeps an earlier sweep's runs and overwrite removes them: give one")
    if not scheduler and processes:
        refuse_unguarded_script()
    runs = plan(scenario, seeds, settings)
    names = run_names(runs)
    keys = [run_key(data, seed) for data, seed, _ in runs]
    out = Path(out)
    rows: dict[str, dict] = earlier_runs(out, names, keys) if resume else {}
    if not resume:
        clear_earlier(out, overwrite)
    (out / "runs").mkdir(parents=True, exist_ok=True)
    files = {name: str(out / "runs" / f"{name}.parquet") for name in names}
    todo = [(run, name) for run, name in zip(runs, names) if name not in rows]
    record = {"planned": len(runs), "keys": {f"{n}.parquet": k for n, k in zip(names, keys)}}
    stopped_by, failure = None, None
    if todo:
        sweep_id = uuid.uuid4().hex
        client = cluster = None
        futures: dict = {}
        try:
            from dask.distributed import Client, LocalCluster, as_completed

            if scheduler:
                client = Client(scheduler)
            else:
                import os

                import dask

                n = workers or min(len(todo), os.cpu_count() or 1)
                extra = {"preload": [*dask.config.get("distributed.worker.preload", []), __name__]} if processes \
                    else {}
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=processes,
                                       dashboard_address=":0", **extra)  # any free port: no clashes
                client = Client(cluster)
            futures = {client.submit(run_one, data, seed, setting, files[name],
                                     combination_label(setting), sweep_id, pure=False): name
                       for (data, seed, setting), name in todo}
            with counter(len(runs), "sweep runs", "run", progress, leave=True) as bar:
                bar.update(len(rows))
                for fut in as_completed(futures):
                    try:
                        got = fut.result()
                    except Exception as exc:  # the worker itself failed (killed, out of memory)
                        data, seed, setting = runs[names.index(futures[fut])]
                        got = _failed(exc, combination_label(setting), seed)
                    if isinstance(got, RunFailed):
                        failure = got
                        break
                    if got == STOPPED:  # stopped from outside the sweep: as an interrupt
                        stopped_by = "interrupt"
                        break
                    rows[futures[fut]] = got
                    bar.update(1)
        except (KeyboardInterrupt, SystemError) as exc:
            if not is_interrupt(exc):
                raise
            stopped_by = "interrupt"
        try:
            if client is not None and (stopped_by or failure):
                with _quiet_shutdown():
                    _finish_stopped(client, futures, sweep_id, rows)
        except (KeyboardInterrupt, SystemError) as exc:  # a second Ctrl-C: the rows so far
            if not is_interrupt(exc):
                raise
        finally:
            with _quiet_shutdown():
                if client is not None:
                    client.close()
                if cluster is not None:
                    cluster.close()
    if failure is not None:
        stopped_by = "error"
    order = {name: k for k, name in enumerate(names)}
    # as planned: the values in the order given, then the seeds
    kept = [rows[n] for n in sorted(rows, key=order.__getitem__)]
    record.update({"partial": len(kept) < len(runs), "stopped_by": stopped_by})
    table = _write_table(out, kept, record)
    if failure is not None:
        error = failure.error
        if kept:
            error = type(error)(f"{error}; the {len(kept)} runs finished are kept in {out / 'sweep.parquet'} "
                                f"(partial: --resume runs the rest)")
        error.add_note(f"the run's traceback, in its worker:\n{failure.trace}")
        raise error
    return table
