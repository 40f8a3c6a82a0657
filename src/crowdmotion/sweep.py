"""Ensembles and parameter sweeps of a scenario on Dask: every (seed, setting) run on a
``LocalCluster`` (or any Dask cluster by address), one trajectory file per run and one
Parquet table with every run's metrics.

>>> table = sweep("street.toml", seeds=range(8), settings={"rvo.safety": [1, 3, 7.5]},
...               out="sweeps/street")                                    # doctest: +SKIP
"""

from __future__ import annotations

import itertools
import json
import warnings
from pathlib import Path
from typing import Any, Iterable, Sequence

import pyarrow as pa
import pyarrow.parquet as pq

from crowdmotion._validation import shown
from crowdmotion.io.atomic import atomic_path
from crowdmotion.io.longform import json_text
from crowdmotion.progress import counter
from crowdmotion.scenario import Scenario, build, load_scenario, validate_spec

SUMMARY_KEYS = ("agents", "frames", "duration_s", "mean_path_length_m", "mean_speed_mps", "max_speed_mps",
                "agent_agent_overlaps", "agent_obstacle_penetrations", "worst_agent_agent_penetration_m",
                "worst_agent_obstacle_penetration_m", "arrival_rate", "mean_time_to_goal_s", "steps",
                "all_recovered")
COUNT_KEYS = ("agents", "frames", "agent_agent_overlaps", "agent_obstacle_penetrations", "steps")  # whole numbers


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
        build(validate_spec(data, "sweep " + ", ".join(f"{n} = {shown(v)}" for n, v in zip(names, combo))), "sweep")
        for seed in seeds:
            runs.append((data, seed, dict(zip(names, combo))))
    return runs


def run_one(data: dict, seed: int, setting: dict, path: str) -> dict:
    """Run one scenario dict with ``seed``; write its trajectories to ``path`` (Parquet);
    return its row of the summary table."""
    from crowdmotion.scenario import run_scenario

    with warnings.catch_warnings():  # the scenario's own warnings: plan() has shown them
        warnings.simplefilter("ignore")
        sc = build(validate_spec(data, "sweep"), "sweep")
    result = run_scenario(sc, seed=seed, progress=False)
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


def clear_earlier(out: Path, overwrite: bool) -> None:
    """Refuse a folder holding an earlier sweep (unless ``overwrite``: then remove its
    ``runs/*.parquet``, ``sweep.parquet`` and ``report.json``, nothing else) or a run's files."""
    if (out / "manifest.json").is_file():
        raise ValueError(f"{out} holds a run's files (manifest.json): give the sweep a folder of its own with -o")
    earlier = sorted((out / "runs").glob("*.parquet")) if (out / "runs").is_dir() else []
    table = out / "sweep.parquet"
    if not (earlier or table.is_file()):
        return
    if not overwrite:
        raise ValueError(f"{out} holds an earlier sweep ({'sweep.parquet, ' if table.is_file() else ''}"
                         f"{len(earlier)} runs in runs/): give another folder with -o, or --overwrite to replace it")
    for f in [*earlier, table, out / "report.json"]:
        f.unlink(missing_ok=True)


def _cell(value: Any) -> Any:
    """A setting as a table cell: numbers, booleans and strings as they are (a column of
    whole numbers stays whole; 1 beside 2.5 becomes 1.0), anything else as JSON."""
    if isinstance(value, (bool, str, int, float)):
        return value
    return json.dumps(value)


def _run_name(seed: int, setting: dict) -> str:
    parts = [f"seed{seed}"] + [f"{k}={v}".replace("/", "_") for k, v in setting.items()]
    return "_".join(parts)


def sweep(scenario: Scenario | str | Path, seeds: Iterable[int] = range(8),
          settings: dict[str, Sequence[Any]] | None = None, out: str | Path = "sweep",
          scheduler: str | None = None, workers: int | None = None, processes: bool = True,
          progress: bool = True, overwrite: bool = False) -> pa.Table:
    """Run the scenario for every seed × every combination of ``settings`` (dotted field
    -> values) on Dask; one ``<out>/runs/<seed_settings>.parquet`` per run and the table
    ``<out>/sweep.parquet`` (one row per run: seed, settings, file, metrics), returned.

    ``scheduler``: address of a running Dask scheduler; default a ``LocalCluster`` with
    ``workers`` workers (default: the machine's cores), in separate processes unless
    ``processes=False``. An earlier sweep in ``out`` is refused (ValueError), or with
    ``overwrite`` its runs, table and report removed first; a run's folder is refused.
    """
    from dask.distributed import Client, LocalCluster, as_completed

    runs = plan(scenario, seeds, settings)
    out = Path(out)
    clear_earlier(out, overwrite)
    (out / "runs").mkdir(parents=True, exist_ok=True)
    files = [str(out / "runs" / f"{_run_name(seed, setting)}.parquet") for _, seed, setting in runs]
    cluster = None
    if scheduler:
        client = Client(scheduler)
    else:
        import os

        cluster = LocalCluster(n_workers=workers or min(len(runs), os.cpu_count() or 1), threads_per_worker=1,
                               processes=processes, dashboard_address=":0")  # any free port: no clashes
        client = Client(cluster)
    rows = []
    try:
        futures = [client.submit(run_one, data, seed, setting, file, pure=False)
                   for (data, seed, setting), file in zip(runs, files)]
        with counter(len(futures), "sweep runs", "run", progress, leave=True) as bar:
            for fut in as_completed(futures):
                rows.append(fut.result())
                bar.update(1)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    order = {file: k for k, file in enumerate(files)}
    rows.sort(key=lambda r: order[r["file"]])  # as planned: the values in the order given, then the seeds
    table = pa.Table.from_pylist(rows)
    with atomic_path(out / "sweep.parquet") as tmp:
        pq.write_table(table, tmp)
    return table
