"""The ``crowdmotion`` command: parses arguments, calls the API, prints. No simulation here."""

from __future__ import annotations

import argparse
import math
import os
import re
import sys
import warnings
from pathlib import Path

from crowdmotion import __version__
from crowdmotion.builtin import builtin_scenarios  # noqa: F401  (also the CLI's public name for them)


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings as one clean line on stderr, without the library's file and line."""
    print(f"crowdmotion: warning: {message}", file=sys.stderr)


def scenario_path(name: str) -> Path:
    """A scenario file, or the built-in scene of that name (``crowdmotion run rvo_doorway``)."""
    import difflib

    path = Path(name)
    if path.is_file():
        return path
    builtins = {p.stem: p for p in builtin_scenarios()}
    if name in builtins:
        return builtins[name]
    if path.is_dir():
        tomls = sorted(p.name for p in path.glob("*.toml"))
        held = f" (it holds {', '.join(tomls[:3])}{', ...' if len(tomls) > 3 else ''})" if tomls else ""
        raise FileNotFoundError(f"{name} is a folder, not a scenario file{held}")
    if path.suffix == "" or not path.exists():
        close = difflib.get_close_matches(path.stem, list(builtins), n=1)
        hint = f"; did you mean the built-in {close[0]!r}?" if close else "; `crowdmotion scenarios` lists the built-ins"
        raise FileNotFoundError(f"no scenario file at {name} and no built-in scene of that name{hint}")
    return path


def _output_folder(args, sc) -> Path:
    """``-o``, or by default out/<scenario name> (refused if the name leads out of out/)."""
    from crowdmotion.outputs import folder_inside

    return Path(args.output) if args.output else folder_inside("out", sc.spec.name)


def _size_estimate(sc) -> str:
    """Upper bounds a user can plan with: steps, agent-steps, trajectory memory."""
    from crowdmotion.memory import human_bytes
    from crowdmotion.scenario import size_estimate

    est = size_estimate(sc)
    return (f"{est.agents} agents x at most {est.steps} steps = {est.agents * est.steps:,} agent-steps; "
            f"trajectories up to {human_bytes(est.bytes)} in memory")


def _whole(text: str, least: int) -> int:
    try:
        value = int(text.strip())
    except ValueError:
        value = None
    if value is None or value < least:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number of at least {least}")
    return value


def _positive_int(text: str) -> int:
    """A whole number of at least 1 (``--jobs``, ``--workers``, ``--max-frames``)."""
    return _whole(text, 1)


def _seed(text: str) -> int:
    """A whole number of at least 0 (``--seed``)."""
    return _whole(text, 0)


def _number(text: str, positive: bool) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and (value > 0 if positive else value >= 0)):
        raise argparse.ArgumentTypeError(f"{text!r} is not a {'positive' if positive else 'non-negative'} "
                                         f"finite number")
    return value


def _positive_number(text: str) -> float:
    """A finite number above 0 (``--cell``)."""
    return _number(text, True)


def _nonnegative_number(text: str) -> float:
    """A finite number of at least 0 (``--trail``)."""
    return _number(text, False)


MAX_FPS = 1000.0  # frames per second a command may resample to


def _fps(text: str) -> float:
    """A frame rate above 0 and at most MAX_FPS (``--fps``)."""
    value = _number(text, True)
    if value > MAX_FPS:
        raise argparse.ArgumentTypeError(f"{text!r} frames per second is more than {MAX_FPS:g}")
    return value


def _memory_size(text: str) -> int:
    """``--max-memory``: 8G, 512MiB, 2.5GB or bytes."""
    from crowdmotion.memory import parse_size

    try:
        return parse_size(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _plot_list(text: str) -> list[str]:
    """``--plots``: names from [output] plots, comma-separated, or 'none'."""
    from crowdmotion.scenario import PLOTS

    names = [] if text.strip() == "none" else [n.strip() for n in text.split(",") if n.strip()]
    wrong = [n for n in names if n not in PLOTS]
    if wrong:
        raise argparse.ArgumentTypeError(f"--plots {text!r}: {', '.join(map(repr, wrong))} is not one of "
                                         f"{', '.join(PLOTS)} (comma-separated), or 'none'")
    if not names and text.strip() != "none":
        raise argparse.ArgumentTypeError(f"--plots {text!r} names no picture: give some of {', '.join(PLOTS)} "
                                         f"(comma-separated), or 'none'")
    return names


def _begin_compiling(path, quiet: bool = False) -> None:
    """On a cold numba cache, say so (unless ``quiet``) and set the kernels of the file's
    method compiling on the other cores before the scenario is read and checked (a glance
    at its ``method`` line; the file is judged properly by load_scenario)."""
    import tomllib

    from crowdmotion import _precompile

    try:
        method = tomllib.loads(Path(path).read_text()).get("method")
    except (OSError, ValueError, UnicodeDecodeError):
        return
    if not isinstance(method, str):
        return
    seconds = _precompile.cold_seconds(method)
    if seconds and not quiet:
        print(f"crowdmotion: a first {method} run here: compiling its kernels ({seconds:.0f} s of one core's compiling, "
              f"shared over {_precompile.cores()} cores); later runs load them from numba's cache", file=sys.stderr,
              flush=True)
    _precompile.begin(method)


def cmd_run(args) -> int:
    path = scenario_path(args.scenario)
    _begin_compiling(path, args.quiet)
    from crowdmotion import _precompile
    from crowdmotion.interrupts import Interrupts, is_interrupt
    from crowdmotion.metrics import headline
    from crowdmotion.outputs import MANIFEST, PictureError, claim_output_folder, write_run
    from crowdmotion.render.background import PictureProcess
    from crowdmotion.scenario import load_scenario, run_scenario

    stop = getattr(args, "interrupts", None) or Interrupts()
    sc = load_scenario(path, max_memory=args.max_memory)
    # held from before, not after, the simulation until the files are written: a second run is refused
    with claim_output_folder(_output_folder(args, sc), args.overwrite) as out:
        plots = sc.spec.output.plots if args.plots is None else args.plots
        _precompile.start(sc.method)  # a cold cache: compiled on every core before the picture process takes one
        pictures = PictureProcess.start() if plots else None  # imports matplotlib while this process simulates
        try:
            with stop.simulating():
                result = run_scenario(sc, seed=args.seed, progress=not args.quiet)
            if result.summary["partial"] and stop.signum is not None:
                print(f"crowdmotion: {stop.name}: stopped after {result.summary['frames']} frames; writing them "
                      f"({stop.again()})", file=sys.stderr, flush=True)
            with stop.writing():
                files = write_run(result, out, plots=plots, pictures=pictures)
        except PictureError as exc:
            if args.debug:
                raise exc.cause from None
            print(f"{sc.spec.name}: {headline(result.summary)}")
            for f in exc.written:
                print(f"  wrote {f}")
            print(f"crowdmotion: internal error drawing the pictures: {exc} (the run's files above are kept; "
                  f"`crowdmotion render {out}` draws again; run again with --debug for the traceback, and please "
                  f"report it)", file=sys.stderr)
            return 1
        except (KeyboardInterrupt, SystemError) as exc:
            if not is_interrupt(exc):
                raise
            print(f"crowdmotion: {stop.name or 'interrupted'}: stopped; no file of this run is left in {out}",
                  file=sys.stderr)
            return stop.exit_code or 130
        finally:
            if pictures is not None:
                pictures.close()
    print(f"{sc.spec.name}: {headline(result.summary)}")
    for f in files:
        print(f"  wrote {f}")
    s = result.summary
    if s["partial"] or stop.signum is not None:
        if s["partial"]:
            print(f"crowdmotion: {stop.name or 'interrupted'}: kept the {s['frames']} frames simulated so far "
                  f"(summary.json and {MANIFEST} say partial = true)", file=sys.stderr)
        else:
            print(f"crowdmotion: {stop.name}: the run had finished; its files were written whole first",
                  file=sys.stderr)
        return stop.exit_code or 130
    if (s["agent_agent_overlaps"] or s["agent_obstacle_penetrations"]) and not args.allow_collisions:
        print(f"crowdmotion: error: the run ends with {s['agent_agent_overlaps']} agent overlaps and "
              f"{s['agent_obstacle_penetrations']} obstacle penetrations{_first_event(s)}; the files are written "
              f"for inspection; pass --allow-collisions to accept them", file=sys.stderr)
        return 3
    return 0


def _first_event(summary: dict) -> str:
    """`` (first: agent 3 and agent 7 overlap by 0.02 m at t = 4.25 s, frame 17)``, or nothing."""
    events = summary.get("first_events") or []
    if not events:
        return ""
    e = events[0]
    other = f"agent {e['b']}" if e["kind"] == "agent-agent" else f"obstacle {e['b']}"
    return (f" (first: agent {e['a']} and {other} overlap by {float(e['penetration']):.3g} m at "
            f"t = {float(e['time']):.2f} s, frame {e['frame']})")


def cmd_demo(args) -> int:
    from crowdmotion import _precompile
    from crowdmotion.demo import DemoScene, run_one, run_parallel
    from crowdmotion.outputs import check_writable, folder_inside
    from crowdmotion.workers import default_jobs

    root = Path(args.output)
    scenes = [DemoScene.read(path) for path in builtin_scenarios()]
    if args.only:
        unknown = sorted(set(args.only) - {sc.name for sc in scenes})
        if unknown:
            print(f"crowdmotion: error: --only: no built-in scene named {', '.join(map(repr, unknown))} "
                  f"(`crowdmotion scenarios` lists them)", file=sys.stderr)
            return 2
        scenes = [sc for sc in scenes if sc.name in args.only]
    check_writable(root)  # a file in the way or no write access: said once, before any scene
    jobs = min(args.jobs or default_jobs(len(scenes)), len(scenes))
    if jobs > 1:
        print(f"running {len(scenes)} built-in scenes on {jobs} processes", flush=True)
        failed = [d for d in run_parallel(scenes, root, jobs, progress=not args.quiet) if d.error is not None]
    else:
        failed = []
        for i, sc in enumerate(scenes):
            print(f"running {sc.name}: {sc.description}", flush=True)
            later = [s.method for s in scenes[i + 1:] if s.method != sc.method]
            if later:  # the next method's kernels compile on the other cores while this one's scenes run
                _precompile.begin(later[0], background=True)
            done = run_one(sc.path, folder_inside(root, sc.name), progress=not args.quiet)
            print(f"  {done.headline} ({done.seconds:.1f} s)")
    print(f"demo output in {root.resolve()}/ (trajectories.parquet, summary.json, pictures and view.html per scene)")
    if failed:
        print(f"crowdmotion: error: {len(failed)} scene(s) failed: {', '.join(d.name for d in failed)}",
              file=sys.stderr)
        return 1
    return 0


def cmd_validate(args) -> int:
    from crowdmotion.outputs import EarlierRunError, check_output_folder
    from crowdmotion.scenario import load_scenario

    path = scenario_path(args.scenario)
    sc = load_scenario(path, max_memory=args.max_memory)
    out = _output_folder(args, sc)
    try:
        check_output_folder(out, args.overwrite)
        earlier = None
    except EarlierRunError as exc:  # nothing wrong with the scenario: validate writes nothing there
        earlier = exc
    n_obs, n_groups = len(sc.scene.obstacles), len(sc.groups)
    print(f"{path}: OK: {sc.scene.dim}D scene, {n_obs} obstacle{'' if n_obs == 1 else 's'}, "
          f"{n_groups} group{'' if n_groups == 1 else 's'}, method {sc.method}; {_size_estimate(sc)}; "
          f"output folder {out}")
    if earlier is not None:
        print(f"note: output folder {out} holds {earlier.what} ({earlier.names}): `run` would refuse it as it "
              f"stands; give run --overwrite to replace it (only the files its manifest.json lists are removed), "
              f"or another folder with -o")
    return 0


def cmd_bench(args) -> int:
    if args.method != "mdp":  # the package's side-by-side benchmarks take their own options
        import importlib

        importlib.import_module(f"crowdmotion.bench.{args.method}").main(args.options)
        return 0
    from crowdmotion.mdp.benchmark import print_tables, run_paper_tables

    # its options may also come after the method's name (crowdmotion bench mdp -q), as for the others
    own = argparse.ArgumentParser(prog="crowdmotion bench mdp")
    own.add_argument("--no-reference", action="store_true", default=args.no_reference)
    own.add_argument("--repeats", type=_positive_int, default=args.repeats)
    own.add_argument("-q", "--quiet", action="store_true", default=args.quiet)
    opts = own.parse_args(args.options)
    rows = run_paper_tables(reference=not opts.no_reference, repeats=opts.repeats, progress=not opts.quiet)
    print_tables(rows)
    return 0


def _find_trajectories(out: Path) -> Path:
    if out.is_file():
        return out
    if not out.exists():
        raise FileNotFoundError(f"no run folder or trajectory file at {out}")
    for name in ("trajectories.parquet", "trajectories.csv"):
        if (out / name).is_file():
            return out / name
    if (out.parent / "sweep.parquet").is_file():  # a sweep's runs/: its runs are the files in it
        raise FileNotFoundError(f"no trajectories.parquet or trajectories.csv in {out}: it holds a sweep's runs; "
                                f"give the sweep's folder ({out.parent}) to take them all, or one of its files")
    if (out / "runs").is_dir() and any((out / "runs").glob("*.parquet")):  # a sweep stopped before its table
        raise FileNotFoundError(f"no trajectories.parquet or trajectories.csv in {out}, and no sweep.parquet: its "
                                f"runs/ holds a sweep's runs, but the sweep stopped before it listed them; "
                                f"crowdmotion sweep ... -o {out} --resume runs them again and writes the table")
    raise FileNotFoundError(f"no trajectories.parquet or trajectories.csv in {out}")


def _load_trajectories(path: Path):
    """Trajectories read from ``path``, with the scene its metadata holds checked too; a
    file that cannot be used is refused with a ValueError that names it."""
    import json

    from crowdmotion.scene import Scene
    from crowdmotion.trajectories import Trajectories

    try:
        traj = Trajectories.load(path)
        if not isinstance(traj.metadata, dict):
            raise TypeError("metadata is not a table")
        if traj.metadata.get("scene"):  # a damaged scene is refused here, not half-way through a picture
            Scene.from_dict(traj.metadata["scene"])
    except FileNotFoundError:
        raise
    except json.JSONDecodeError as exc:
        where = f"{path.name}.meta.json beside it" if path.suffix.lower() == ".csv" else "the file"
        raise ValueError(f"{path}: a damaged trajectory file: its metadata (in {where}) is not JSON: {exc}") from None
    except KeyError as exc:
        raise ValueError(f"{path}: a damaged trajectory file: its metadata lacks {exc.args[0]!r}") from None
    except (TypeError, AttributeError, IndexError):
        raise ValueError(f"{path}: a damaged trajectory file: its metadata is not laid out as crowdmotion "
                         f"writes it") from None
    except (ValueError, OSError) as exc:
        msg = str(exc)
        raise ValueError(msg if str(path) in msg else f"{path}: a damaged trajectory file: {msg}") from None
    return traj


def _load_run(output: str):
    """(trajectory file, Trajectories) of a run folder or a trajectory file."""
    path = _find_trajectories(Path(output))
    return path, _load_trajectories(path)


def _beside(src: Path, name: str) -> Path:
    """Where a picture or player of the trajectories in ``src`` goes: ``name`` in its folder
    for a run's own file (trajectories.*), ``<stem>.<name>`` for another (an export beside
    it: two exports' players must not overwrite each other)."""
    return src.parent / (name if src.stem == "trajectories" else f"{src.stem}.{name}")


def _read_json(path: Path, what: str) -> dict:
    """A JSON table written by a run (summary.json, ...); a ValueError naming the file when
    it is not one."""
    import json

    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: a damaged {what}: not JSON ({exc})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: a damaged {what}: not a JSON table")
    return data


REPORT_COLUMNS = [("agents", "agents", "{:d}"), ("lateral_spread_m", "spread m", "{:.2f}"),
                  ("lateral_deviation_m", "deviation m", "{:.2f}"),
                  ("heading_change_rate_rad_s", "turn rad/s", "{:.3f}"), ("mean_speed_mps", "speed m/s", "{:.2f}"),
                  ("speed_density_slope", "speed/density", "{:.3f}"), ("mixing_index", "mixing", "{:.2f}"),
                  ("same_group_neighbors", "same-group nb", "{:.2f}"), ("cluster_size", "cluster size", "{:.2f}"),
                  ("clusters", "clusters", "{:.1f}"), ("time_to_goal_s", "to goal s", "{:.1f}"),
                  ("path_length_ratio", "path ratio", "{:.3f}")]


REPORT_LEGEND = ("speed/density: the slope of speed (m/s) on local density (persons/m²: the others within 2 m "
                 "of each agent over the walkable part of that disc, inside the bounds and outside obstacles), "
                 "m/s per person/m²; docs/rvo.md names every measure")


def _print_report_table(rows: dict, cell) -> None:
    print(f"{'group':12s}" + "".join(f"{h:>15s}" for _, h, _ in REPORT_COLUMNS))
    for name, row in rows.items():
        print(f"{name:12s}" + "".join(f"{cell(row, k, fmt):>15s}" for k, _, fmt in REPORT_COLUMNS))
    print(REPORT_LEGEND)


def _run_report(path: Path, traj, groups: dict | None = None) -> tuple[dict, str]:
    """(metrics.group_report of one run, with the arrival times its summary measured and,
    for a group on a route, its ``journeys``: the time its agents spent in each stage,
    their waits in each queue and their use of each exit (from summary.json); a line
    saying what the measures were taken on). The group measures are the run's own where
    it gave them (``groups``, or summary.json's ``groups``): an RVO run takes them on its
    steps as simulated, the model's motion, not on the frames relaxed for characters that
    its file holds."""
    from crowdmotion.metrics import group_report, with_arrival_times

    summary_file = path.parent / "summary.json"
    summary = _read_json(summary_file, "run summary") if summary_file.is_file() else {}
    own = _own_groups(groups if groups is not None else summary.get("groups"))
    report = group_report(traj) if own is None else own
    if summary_file.is_file():  # arrival times the method measured (agents that stay at the goal too)
        by_group = summary.get("time_to_goal_by_group_s", {})
        if not isinstance(by_group, dict):
            raise ValueError(f"{summary_file}: a damaged run summary: time_to_goal_by_group_s is not a table")
        journeys = summary.get("journeys")
        if journeys is not None and not (isinstance(journeys, dict) and isinstance(journeys.get("stages"), dict)):
            raise ValueError(f"{summary_file}: a damaged run summary: journeys is not a table of stages")
        with_arrival_times(report, by_group)  # measured by the method, where the frames may miss the last
        for name, row in report.items():
            if journeys is not None and name in journeys["stages"]:
                row["journeys"] = {"stages": journeys["stages"][name],
                                   **journeys.get("groups", {}).get(name, {"queues": {}, "exits": {}})}
    if not summary_file.is_file():  # a file on its own: its frames as written (an RVO run's relaxed for characters)
        source = (f"measured on the frames of {path.name} (no summary.json of the run beside it): an RVO run's "
                  f"relaxed frames, and an agent still in the last frame counts as not arrived; the run's own "
                  f"folder gives the run's own measures")
    elif own is not None:
        how = {"rvo": "on its steps as simulated", "formation": "to goal: each formation as one unit, from entering",
               "pso": "to goal: the mean over the particles that arrived"}.get(summary.get("method"))
        source = f"measured by the run itself ({summary_file.name}{'; ' + how if how else ''})"
        arrived = summary.get("arrival_rate")
        if isinstance(arrived, (int, float)) and arrived < 1.0:
            source += f"; {1.0 - arrived:.0%} of the agents never arrived"
            if summary.get("partial"):
                source += " before the run was interrupted"
    else:
        source = f"measured on the frames of {path.name}, with the arrival times of {summary_file.name}"
    return report, source


def _own_groups(groups) -> dict | None:
    """A run's own per-group measures (name -> {column: value}) where they hold every
    column of the report, else None (a run written before they were kept: measured again
    from its file)."""
    ok = isinstance(groups, dict) and all(isinstance(row, dict) and all(k in row for k, _, _ in REPORT_COLUMNS)
                                          for row in groups.values())
    return {name: dict(row) for name, row in groups.items()} if ok else None


def _print_journeys(report: dict) -> None:
    """Per group on a route: each stage's agents and time spent, its waits per queue and
    its exits, under the report's table."""
    def secs(v) -> str:
        return "-" if v is None else f"{v:.1f}"

    for name, row in report.items():
        j = row.get("journeys")
        if j is None:
            continue
        print(f"\n{name}: route stages (reached, time in stage mean / longest s)")
        for st in j["stages"]:
            chosen = f", options taken {st['chosen']}" if "chosen" in st else ""
            print(f"  {st['id']:3d} {st['kind']:7s} {st['name'][:40]:40s} {st['reached']:6d} "
                  f"{secs(st['mean_time_s']):>8s} / {secs(st['max_time_s'])}{chosen}")
        for q, v in j["queues"].items():
            print(f"  queue {q}: {v['served']} served, wait mean {secs(v['mean_wait_s'])} s, "
                  f"longest {secs(v['max_wait_s'])} s")
        for e, v in j["exits"].items():
            print(f"  exit {e}: {v['left']} left, first at {secs(v['first_s'])} s, last at "
                  f"{secs(v['evacuation_time_s'])} s")


def cmd_report(args) -> int:
    from crowdmotion.io.atomic import atomic_path
    from crowdmotion.io.longform import json_text
    from crowdmotion.outputs import adding_to_run

    folder = Path(args.output)
    if (folder / "sweep.parquet").is_file():
        return _sweep_report(folder)
    path, traj = _load_run(args.output)
    report, source = _run_report(path, traj)
    _print_report_table(report, lambda row, k, fmt: "-" if row[k] is None else fmt.format(row[k]))
    _print_journeys(report)
    print(source)
    dest = path.parent / "report.json"
    with adding_to_run(dest.parent) as add:  # listed with the run's files: run --overwrite removes it too
        with atomic_path(dest) as tmp:
            tmp.write_text(json_text(report, indent=2))
        add(dest)
    print(f"wrote {dest}")
    return 0


def _sweep_groups(text, folder: Path) -> dict:
    """A sweep row's ``groups`` cell (JSON) as a table."""
    import json

    try:
        return json.loads(text)
    except (TypeError, ValueError):
        raise ValueError(f"{folder / 'sweep.parquet'}: a damaged sweep table: a run's group measures are not JSON") \
            from None


def _sweep_report(folder: Path) -> int:
    """A sweep's runs, for each combination of its swept settings on its own: every group's
    measures as mean ± 95 % confidence interval over the runs, and the personality paper's
    §6 claims its groups allow (crowdmotion.rvo.claims)."""
    import pyarrow.parquet as pq

    from crowdmotion.io.atomic import atomic_path
    from crowdmotion.io.longform import json_text
    from crowdmotion.progress import tracked
    from crowdmotion.rvo.claims import check_claims, format_claims, mean_ci
    from crowdmotion.sweep import SUMMARY_KEYS, sweep_record

    try:
        arrow = pq.read_table(folder / "sweep.parquet")
    except Exception as exc:  # pyarrow raises several types for damaged files
        raise ValueError(f"{folder / 'sweep.parquet'}: a damaged sweep table: {exc}") from None
    table, record = arrow.to_pylist(), sweep_record(arrow) or {}
    partial = bool(record.get("partial"))
    if partial:  # a sweep stopped part way: its finished runs, said so
        why = "failed" if record.get("stopped_by") == "error" else "was interrupted"
        print(f"the sweep {why}: {len(table)} of {record.get('planned', '?')} planned runs finished, reported "
              f"here (crowdmotion sweep ... -o {folder} --resume runs the rest)\n")
    if not table:
        raise ValueError(f"{folder / 'sweep.parquet'} lists no runs")
    if not all(isinstance(row.get("file"), str) for row in table):
        raise ValueError(f"{folder / 'sweep.parquet'}: a damaged sweep table: a row names no trajectory file")
    runs = []
    for row in tracked(table, "report runs", "run"):
        path = Path(row["file"])
        if not path.is_file():  # the sweep folder was moved: its runs/ sits beside sweep.parquet
            path = folder / "runs" / path.name
        own = row.get("groups")  # the run's own group measures (older sweep tables have none)
        runs.append(_run_report(path, _load_trajectories(path), None if own is None else _sweep_groups(own, folder))[0])
    # the swept settings (columns beside seed, file and the measures): each combination is
    # reported on its own, as pooling them would mix what the sweep set out to compare
    names = [k for k in table[0] if k not in {"scenario", "seed", "file", "groups", *SUMMARY_KEYS}]
    combos: dict[tuple, list[int]] = {}
    for i, row in enumerate(table):
        combos.setdefault(tuple(row.get(n) for n in names), []).append(i)

    def cell(row, k, fmt):
        mean, half, n = row[k]
        if n == 0:
            return "-"
        if k == "agents":
            return f"{mean:.0f}"
        return fmt.format(mean) + ("" if n < 2 else f" ±{half:.2g}")

    parts = []
    for values, rows in combos.items():
        chosen = [runs[i] for i in rows]
        groups = list(dict.fromkeys(g for r in chosen for g in r))
        stats = {g: {k: mean_ci([r[g][k] for r in chosen if g in r and r[g][k] is not None])
                     for k, _, _ in REPORT_COLUMNS} for g in groups}
        claims = check_claims(chosen)
        setting = dict(zip(names, values))
        if names:
            print(("\n" if parts else "") + ", ".join(f"{n} = {_shown(v)}" for n, v in setting.items()) + ":")
        print(f"{len(chosen)} runs; mean ± half-width of the 95 % confidence interval (Student's t)")
        _print_report_table(stats, cell)
        if any(c["a"] != "all" for c in claims):
            print("\nthe personality paper's §6 observations (paired over runs):\n")
            print(format_claims(claims))
        parts.append({"setting": setting, "runs": len(chosen), "groups": stats, "claims": claims})
    report = {"runs": len(runs), **({"partial": True, "planned": record.get("planned")} if partial else {}),
              "per_run": runs,
              "run_keys": [{"seed": row.get("seed"), "setting": {n: row.get(n) for n in names}} for row in table]}
    if names:
        report.update({"settings": names, "by_setting": parts})
    else:
        report.update({"groups": parts[0]["groups"], "claims": parts[0]["claims"]})
    dest = folder / "report.json"
    with atomic_path(dest) as tmp:
        tmp.write_text(json_text(report, indent=2))
    print(f"wrote {dest}")
    return 0


def _shown(value) -> str:
    """A swept setting's value as the table holds it, plainly (5.0 as 5)."""
    return f"{value:g}" if isinstance(value, float) else str(value)


USD_FORMATS = ("usd", "usda", "usdc")
EXPORT_FORMATS = {"parquet": ".parquet", "csv": ".csv", "sqlite": ".sqlite", "jupedsim": ".sqlite",
                  "usd": ".usdc", "usda": ".usda", "usdc": ".usdc"}
# what -o may end in for each --to (the file's format follows its name)
EXPORT_SUFFIXES = {**{k: (v,) for k, v in EXPORT_FORMATS.items()}, "usd": (".usd", ".usdc"), "usdc": (".usdc", ".usd")}


def cmd_export(args) -> int:
    if args.dest and Path(args.dest).suffix.lower() not in EXPORT_SUFFIXES[args.to]:
        raise ValueError(f"--to {args.to} writes a {' or '.join(EXPORT_SUFFIXES[args.to])} file, but -o "
                         f"{args.dest} ends in {Path(args.dest).suffix or 'no suffix'}: name it "
                         f"{Path(args.dest).with_suffix(EXPORT_FORMATS[args.to]).name}, or give the --to its "
                         f"name asks for")
    from crowdmotion.io.csv import sidecar
    from crowdmotion.outputs import adding_to_run, read_manifest

    options = {}
    if args.prototype_up is not None or args.prototype_forward is not None:
        if args.to not in USD_FORMATS:
            raise ValueError(f"--prototype-up and --prototype-forward set the axes of USD prototypes; --to {args.to} "
                             f"has none (use --to usd, usdc or usda)")
        from crowdmotion.io.usd import PROTOTYPE_FORWARD, PROTOTYPE_UP, prototype_axes

        options = {"prototype_up": args.prototype_up or PROTOTYPE_UP,
                   "prototype_forward": args.prototype_forward or PROTOTYPE_FORWARD}
        try:
            prototype_axes(options["prototype_up"], options["prototype_forward"])
        except ValueError as exc:
            raise ValueError(str(exc).replace("prototype_up", "--prototype-up")
                             .replace("prototype_forward", "--prototype-forward")) from None
    src, traj = _load_run(args.output)
    folder = src.parent
    # named after what it exports (a run's trajectories.parquet: trajectories.usdc), so that two
    # files exported side by side do not overwrite each other's export
    dest = Path(args.dest) if args.dest else folder / f"{src.stem}{EXPORT_FORMATS[args.to]}"
    if dest.resolve() == src.resolve():
        raise ValueError(f"{dest} is the file being exported: name the export with -o")
    if not dest.parent.is_dir():  # said now, not after minutes of resampling
        raise ValueError(f"-o {dest}: the folder {dest.parent} does not exist")
    own_folder = dest.parent.resolve() == folder.resolve()
    manifest = read_manifest(dest.parent)
    if not own_folder and manifest is not None and dest.name in manifest["files"]:  # its summary would lie
        raise ValueError(f"-o {dest}: {dest.parent} holds another run, and {dest.name} is one of its files; the "
                         f"export would replace it: name another file, or export into a folder of its own")
    if not args.overwrite:
        _refuse_foreign(dest, manifest if own_folder else None)
    fps = args.fps
    if traj.n_frames < 2:
        raise ValueError(f"{src} holds one frame: there is no motion to export (a run's fps too low for its "
                         f"length keeps only its first frame)")
    if fps is not None and math.isfinite(fps) and fps > 0 and traj.times[-1] * fps < 1.0 - 1e-9:
        raise ValueError(f"--fps {fps:g} leaves one frame of the run's {traj.times[-1]:g} s: give at least "
                         f"{1.0 / traj.times[-1]:.3g} frames a second for two")
    if args.to in USD_FORMATS:  # a DCC plays 24 frames a second; an --fps below it is the user's to ask for
        from crowdmotion.io.usd import DCC_FPS, too_few_frames

        if fps is None and too_few_frames(traj):
            fps = DCC_FPS
        options["dcc_rate"] = False  # the rate is settled here, not again by the writer
    if fps is not None and abs(fps * traj.dt - 1.0) > 1e-9:  # the run's own rate keeps its frames
        traj = _at_fps(traj, fps, args.interpolation)
    # into the run's own folder: listed with its files (run --overwrite removes it with them);
    # into another run's folder: not that run's file, so its run --overwrite leaves it be
    with adding_to_run(dest.parent if own_folder else None) as add:
        traj.save(dest, **options)
        add(dest)
        if dest.suffix.lower() == ".csv":
            add(sidecar(dest))
    print(f"wrote {dest} ({traj.n_agents} agents, {traj.n_frames} frames at {traj.fps:g} fps)")
    print(_file_root_motion(traj))
    return 0


def _file_root_motion(traj) -> str:
    """One line on how smooth the written frames play: summary.json's root_motion is
    taken on the B-spline before an export's collision check, which may keep a step on
    the spline through the frames or straight, turning more sharply there."""
    from crowdmotion.metrics import root_motion

    rm = root_motion(traj, fps=traj.fps)
    acc, turn = rm.get("acceleration_mps2") or {}, rm.get("turn_rate_rad_s") or {}
    if acc.get("p95") is None or turn.get("p95") is None:
        return "  root motion: nobody moves faster than 0.3 m/s over three frames here"
    # p95 and max at the same precision: a max printed to 0.1 read "p95 0.05, max 0.0"
    return (f"  root motion of these frames (moving agents): acceleration p95 {acc['p95']:.2f} m/s², max "
            f"{acc['max']:.2f}; turn rate p95 {turn['p95']:.2f} rad/s, max {turn['max']:.2f}")


def _refuse_foreign(dest: Path, manifest: dict | None) -> None:
    """A ValueError when writing ``dest`` would replace a file crowdmotion did not write
    (the user's own scene, a CSV of theirs): one the run folder's ``manifest`` does not
    list and that does not read as crowdmotion trajectories (a CSV's sidecar goes with it)."""
    from crowdmotion.io import read_trajectories

    if not dest.exists() or (manifest and dest.name in manifest["files"]):
        return
    if dest.is_file():
        try:
            read_trajectories(dest)
            return  # an earlier export: replaced as asked
        except Exception:  # noqa: BLE001 - a file that does not read as ours is the user's
            pass
    raise ValueError(f"-o {dest}: the file exists and crowdmotion did not write it; the export would replace it: "
                     f"name another file, or give --overwrite to replace it")


def _at_fps(traj, fps: float, interpolation: str = "b-spline"):
    """The run resampled to ``fps`` (along the B-spline of its frames, by default),
    re-audited against the run's scene: steps where the spline would bring bodies
    together or past their max speed follow the spline through the frames, or keep
    straight moves (a warning says how many)."""
    from crowdmotion.smoothing import at_rate

    if not (fps > 0 and math.isfinite(fps)):
        raise ValueError(f"--fps must be a positive number of frames per second, got {fps!r}")
    return at_rate(traj, float(fps), interpolation)  # never faster than its own fastest step


def cmd_blender_addon(args) -> int:
    from crowdmotion.blender import write_addon

    dest = write_addon(Path(args.dest))
    print(f"wrote {dest}: in Blender (4.4 or later), Edit > Preferences > Add-ons > Install from Disk, pick it, "
          f"then File > Import > crowdmotion run (.usd)")
    return 0


def cmd_render(args) -> int:
    from crowdmotion.outputs import adding_to_run
    from crowdmotion.render import plot_paths
    from crowdmotion.render.animation import VIDEO_FPS, animate, plot_density, video_rate
    from crowdmotion.scene import scene_of

    src, traj = _load_run(args.output)
    folder = src.parent
    with adding_to_run(folder) as add:  # a run's folder: listed with its files
        written = [animate(traj, _beside(src, f"animation.{args.to}"), fps=args.fps, trail_s=args.trail,
                           max_frames=args.max_frames, progress=not args.quiet)]
        add(written[-1])
        written.append(plot_density(traj, _beside(src, "density.png"), cell=args.cell))
        add(written[-1])
        scene = scene_of(traj)
        paths = _beside(src, "paths.png")
        if scene is not None and not paths.exists():  # the run's own has its goals and name
            written.append(plot_paths(traj, scene, paths, title=traj.metadata.get("scenario", "")))
            add(written[-1])
    duration = (traj.n_frames - 1) * traj.dt
    fps = args.fps or VIDEO_FPS
    rate = video_rate(traj, args.fps, args.max_frames)
    for f in written:
        note = ""
        if f == written[0] and rate < fps - 1e-9:  # a long run is shown faster than it ran: say so
            note = (f" ({duration:.0f} s shown in {duration * rate / fps:.0f} s: {fps / rate:.2f}x real "
                    f"time; --max-frames {math.ceil(duration * fps) + 1} plays it at its own pace)")
        print(f"wrote {f}{note}")
    return 0


def cmd_view(args) -> int:
    from crowdmotion.outputs import adding_to_run
    from crowdmotion.render.player import write_player

    src, traj = _load_run(args.output)
    dest = Path(args.dest) if args.dest else _beside(src, "view.html")
    with adding_to_run(dest.parent) as add:  # into a run's folder: listed with its files
        add(write_player(traj, dest, max_frames=args.max_frames))
    print(f"wrote {dest}: open it in a browser (one self-contained file, works offline)")
    return 0


MAX_SEEDS = 1_000_000  # runs one sweep may ask for


def _seeds(text: str) -> list[int]:
    """``0:100`` (a range), ``1,4,9`` or ``7``: distinct whole numbers of at least 0."""
    how = f"--seeds must look like 0:100, 1,4,9 or 7 (whole numbers of at least 0), got {text!r}"
    try:
        if ":" in text:
            a, b = (int(x) for x in text.split(":", 1))
            if b - a > MAX_SEEDS:
                raise argparse.ArgumentTypeError(f"--seeds {text!r} asks for {b - a:,} runs, more than {MAX_SEEDS:,}")
            seeds = list(range(a, b))
        else:
            seeds = [int(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(how) from None
    if not seeds:
        raise argparse.ArgumentTypeError(f"--seeds {text!r} names no seed (a range a:b runs a up to b - 1)")
    if min(seeds) < 0:
        raise argparse.ArgumentTypeError(how)
    if len(set(seeds)) != len(seeds):
        raise argparse.ArgumentTypeError(f"--seeds {text!r} names a seed twice")
    return seeds


def _setting(text: str) -> tuple[str, list]:
    """``rvo.safety=1,3,7.5`` -> ("rvo.safety", [1, 3, 7.5]); values read as TOML."""
    import tomllib

    if "=" not in text or not text.split("=", 1)[0].strip():
        raise argparse.ArgumentTypeError(f"--set must look like field=value1,value2, got {text!r}")
    key, values = text.split("=", 1)
    key = key.strip()
    if key == "seed":
        raise argparse.ArgumentTypeError(f"--set {text!r}: the seed is not a setting: give the seeds to run with "
                                         f"--seeds (e.g. --seeds {values})")
    out = []
    for v in _top_level_items(values):
        try:
            out.append(tomllib.loads(f"v = {v}")["v"])
        except tomllib.TOMLDecodeError:
            out.append(v.strip())
    return key, out


def _top_level_items(text: str) -> list[str]:
    """``text`` split at the commas outside brackets, braces and quotes:
    ``[4.3, 3.7],[5, 6]`` -> ``["[4.3, 3.7]", "[5, 6]"]``."""
    items, depth, quote, start = [], 0, "", 0
    for i, c in enumerate(text):
        if quote:
            quote = "" if c == quote else quote
        elif c in "\"'":
            quote = c
        elif c in "[{":
            depth += 1
        elif c in "]}":
            depth -= 1
        elif c == "," and depth == 0:
            items.append(text[start:i])
            start = i + 1
    return items + [text[start:]]


def cmd_sweep(args) -> int:
    from crowdmotion.outputs import folder_inside
    from crowdmotion.sweep import sweep, sweep_record

    settings: dict[str, list] = {}
    for key, values in args.set or []:
        if key in settings:
            raise ValueError(f"--set {key} is given twice: give all its values once, comma-separated "
                             f"(--set {key}=v1,v2)")
        settings[key] = values
    if args.resume and args.overwrite:
        raise ValueError("--resume keeps the earlier sweep's finished runs and --overwrite removes them: give one")
    source = scenario_path(args.scenario)
    out = Path(args.output) if args.output else folder_inside("sweeps", source.stem)
    table = sweep(source, args.seeds, settings, out, scheduler=args.scheduler, workers=args.workers,
                  progress=not args.quiet, overwrite=args.overwrite, resume=args.resume)
    record = sweep_record(table) or {}
    if record.get("stopped_by") == "interrupt":  # Ctrl-C or SIGTERM: the runs finished are kept
        stop = getattr(args, "interrupts", None)
        name = (stop.name if stop is not None else "") or "interrupted"
        if not record.get("partial"):
            kept = f"every run had finished; {table.num_rows} runs in {out / 'sweep.parquet'}"
        elif table.num_rows:
            kept = (f"{table.num_rows} of {record['planned']} runs finished; {out / 'sweep.parquet'} lists them "
                    f"(partial); the same command with --resume runs the rest")
        else:
            kept = f"no run of {record['planned']} had finished"
        print(f"crowdmotion: {name}: stopped; {kept}", file=sys.stderr)
        return (stop.exit_code if stop is not None else None) or 130
    print(f"{table.num_rows} runs; table {out / 'sweep.parquet'}, trajectories in {out / 'runs'}/")
    return 0


def cmd_verify(args) -> int:
    from crowdmotion import verify
    from crowdmotion.io.atomic import atomic_path
    from crowdmotion.io.longform import json_text
    from crowdmotion.progress import counter
    from crowdmotion.workers import default_jobs, map_in_workers

    pairs = verify.select(quick=args.quick, names=args.case, methods=args.method, empirical=args.empirical)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    jobs = min(args.jobs or default_jobs(len(pairs)), len(pairs))
    with counter(len(pairs), "verify", "case", not args.quiet) as bar:
        if jobs > 1:  # the long cases (those not in --quick) start first, the table keeps its order
            order = sorted(range(len(pairs)), key=lambda i: pairs[i][0].quick)
            done = map_in_workers(verify.run_named, [(pairs[i][0].name, pairs[i][1], str(out)) for i in order], jobs,
                                  lambda *_: bar.update(1))
            verdicts = [v for _, v in sorted(zip(order, done), key=lambda iv: iv[0])]
        else:
            verdicts = []
            for case, method in pairs:
                verdicts.append(verify.run_case(case, method, out=out))
                bar.update(1)
    print(verify.table(verdicts))
    with atomic_path(out / "verify.json") as tmp:
        tmp.write_text(json_text([v.as_dict() for v in verdicts], indent=2))
    failed = [f"{v.case}/{v.method}" for v in verdicts if not v.passed]
    print(f"{len(verdicts) - len(failed)}/{len(verdicts)} passed; pictures and verify.json in {out}/"
          + (f"; failed: {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


def cmd_list(args) -> int:
    from crowdmotion.demo import DemoScene

    for path in builtin_scenarios():  # name and description read from the file (tests check they load)
        sc = DemoScene.read(path)
        print(f"{sc.name:28s} {path}\n    {sc.description}")
    return 0


_TEMP_NAME = re.compile(r"\.([^/\\\s'\"]+?)\.[A-Za-z0-9_]+\.tmp\b")  # atomic_path's hidden .NAME.xxxx.tmp
_NUMPY_REPR = re.compile(r"\bnp\.(?:float|int|uint|bool|str)\w*\(([^()]*)\)")  # np.float64(0.0) -> 0.0


def _user_message(exc: BaseException) -> str:
    """An error as one line in the user's terms: the file a write was for (never its
    temporary name), numbers as numbers (never np.float64(...))."""
    if isinstance(exc, OSError) and exc.strerror and exc.filename is not None:
        text = f"{exc.strerror}: {exc.filename}"
    else:
        text = str(exc) or type(exc).__name__
    text = _TEMP_NAME.sub(r"\1", text)
    return _NUMPY_REPR.sub(r"\1", text)


def main(argv=None) -> int:
    """The command; returns its exit status (EXIT_STATUS): 0 done, 2 refused (the message
    says why), 3 a run that ends with collisions, 130/143 interrupted, 1 an internal error."""
    args = build_parser().parse_args(_joined_negative_seeds(sys.argv[1:] if argv is None else list(argv)))
    warnings.showwarning = _one_line_warning
    streams = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = _ReaderMayLeave(sys.stdout), _ReaderMayLeave(sys.stderr)
    try:
        return _command(args)
    finally:
        sys.stdout, sys.stderr = streams


class _ReaderMayLeave:
    """A stream that goes quiet when its reader has gone (``crowdmotion run x | head -1``):
    the pipe's end closed, printing raised BrokenPipeError and the run stopped unwritten
    after simulating. Once gone, what is written goes nowhere and the command finishes
    its work (its files)."""

    def __init__(self, stream):
        self._stream, self._gone = stream, False

    def _leave(self) -> None:
        self._gone = True
        try:  # the interpreter flushes the stream again at exit: let that go nowhere too
            os.dup2(os.open(os.devnull, os.O_WRONLY), self._stream.fileno())
        except (OSError, ValueError, AttributeError):  # not a file (a test's capture)
            pass

    def write(self, text: str) -> int:
        if not self._gone:
            try:
                return self._stream.write(text)
            except BrokenPipeError:
                self._leave()
        return len(text)

    def flush(self) -> None:
        if not self._gone:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._leave()

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _command(args) -> int:
    """Run the parsed command (see :func:`main`)."""
    from crowdmotion.interrupts import Interrupts, is_interrupt

    with Interrupts() as stop:  # SIGTERM as Ctrl-C, for this command only
        args.interrupts = stop
        if args.debug:  # every error with its traceback
            return args.func(args)
        try:
            return args.func(args)
        except (ValueError, FileNotFoundError, MemoryError, OSError, RecursionError) as exc:
            print(f"crowdmotion: error: {_user_message(exc)}", file=sys.stderr)
            return 2
        except (KeyboardInterrupt, SystemError) as exc:
            if not is_interrupt(exc):  # SystemError: a bug of ours
                return _internal_error(exc)
            print(f"crowdmotion: interrupted{f' ({stop.name})' if stop.name else ''}", file=sys.stderr)
            return stop.exit_code or 130
        except Exception as exc:  # a bug of ours
            return _internal_error(exc)


def _joined_negative_seeds(argv: list) -> list:
    """``--seeds -1:2`` as ``--seeds=-1:2``: argparse takes ``-1:2`` for an option (it knows
    only plain numbers as negative) and says "expected one argument" instead of what is wrong."""
    out: list = []
    for arg in argv:
        if out and out[-1] == "--seeds" and isinstance(arg, str) and arg[:2] in {f"-{d}" for d in "0123456789"}:
            out[-1] = f"--seeds={arg}"
        else:
            out.append(arg)
    return out


def _internal_error(exc: Exception) -> int:
    """A bug of ours as one line, and how to see the rest."""
    print(f"crowdmotion: internal error: {type(exc).__name__}: {_user_message(exc)} (run again with --debug "
          f"for the traceback, and please report it)", file=sys.stderr)
    return 1


EXIT_STATUS = """\
exit status:
  0    done
  1    demo: a scene failed; verify: a case failed its criterion; an internal error
       (a bug of ours: --debug shows its traceback; run: one drawing the pictures keeps
       the run's trajectories and summary.json)
  2    refused or failed, with a message naming what: a bad argument, scenario or
       trajectory file; an output folder in use by another run, holding an earlier run
       (run without --overwrite; validate only notes it) or files no run listed; a file
       that could not be read or
       written (a full disk: none of the run's files are kept)
  3    run: the run ends with agent overlaps or obstacle penetrations (its files are
       written; --allow-collisions exits 0)
  130  stopped by Ctrl-C; run: the frames simulated so far are written, marked
       partial = true (while the files are written, a first Ctrl-C lets the writing
       finish, a second stops it and keeps none of the run's files); sweep: the runs
       finished are kept, listed in sweep.parquet marked partial (--resume runs the rest)
  143  stopped by SIGTERM (timeout, kill, a batch scheduler), as by Ctrl-C
"""


def build_parser() -> argparse.ArgumentParser:
    """The command line: one subcommand per job, every argument with its help."""
    parser = argparse.ArgumentParser(prog="crowdmotion", description="Collision-free crowd and group motion.",
                                     epilog=EXIT_STATUS, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"crowdmotion {__version__}")
    parser.add_argument("--debug", action="store_true",
                        help="show the traceback of an error instead of its one-line message")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("run", help="run a scenario file and write its outputs",
                       description="Run a scenario and write its trajectories, summary.json and pictures into "
                                   "an output folder, which the run holds alone while it lasts; manifest.json "
                                   "lists the files it wrote (--overwrite removes those and nothing else).",
                       epilog=EXIT_STATUS, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scenario", help="a scenario TOML file, or the name of a built-in scene (see `scenarios`)")
    p.add_argument("-o", "--output", help="output folder (default ./out/<scenario name>)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an earlier run in the output folder: remove the files its manifest.json lists, "
                        "and nothing else (default: refuse; a folder holding files no run listed is refused "
                        "either way)")
    p.add_argument("--allow-collisions", action="store_true",
                   help="exit 0 even if the audit finds overlaps or penetrations (default: exit 3)")
    p.add_argument("--seed", type=_seed, help="override the scenario's seed (a whole number of at least 0)")
    p.add_argument("--plots", type=_plot_list, metavar="LIST",
                   help="pictures to write instead of the scenario's [output] plots: a comma-separated list of "
                        "paths, values, snapshots, player (view.html), or 'none' for trajectories and "
                        "summary.json alone (the pictures take 0.3-3 s of a run)")
    p.add_argument("--max-memory", type=_memory_size, metavar="SIZE",
                   help="refuse a run whose trajectories may take more memory than this (e.g. 8G, 512MiB; "
                        "default: the memory available now)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("demo", help="run the built-in scenes (offline, no arguments needed)")
    p.add_argument("-o", "--output", default="crowdmotion-demo",
                   help="folder for the scenes' outputs, one subfolder each (default ./crowdmotion-demo)")
    p.add_argument("--only", nargs="*", help="names of built-in scenes to run")
    p.add_argument("-j", "--jobs", type=_positive_int, metavar="N",
                   help="scenes run side by side in N processes (default: one per core, at least two scenes "
                        "each, as many as the free memory holds at 600 MB each; 1 runs them one after another "
                        "in this process, with a progress bar per scene)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("validate", help="check a scenario as `run` would, without simulating")
    p.add_argument("scenario", help="a scenario TOML file, or the name of a built-in scene")
    p.add_argument("-o", "--output", help="the output folder `run` would use (default ./out/<scenario name>)")
    p.add_argument("--overwrite", action="store_true",
                   help="as for run: an earlier run there may be replaced (without it, validate notes an earlier "
                        "run there, which run would refuse)")
    p.add_argument("--max-memory", type=_memory_size, metavar="SIZE",
                   help="refuse a run whose trajectories may take more memory than this (e.g. 8G, 512MiB; "
                        "default: the memory available now)")
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("bench", help="side-by-side benchmarks: the papers' tables beside our solvers and peers",
                       description="mdp: paper 000's Tables 1-2 beside our fast solver and scipy. rvo: our step "
                                   "against pyrvo (RVO2) and JuPedSim. pso: against PySwarms and the paper's plain "
                                   "Python. formation: paper 003's Table 1 (mesh and deformation time). startup: cold and "
                                   "warm `crowdmotion run` of every built-in scene. Peers come "
                                   "with pip install \"crowdmotion[bench]\"; options after the method go to "
                                   "that benchmark (e.g. crowdmotion bench rvo --sizes 1000 --steps 10).")
    p.add_argument("method", choices=["mdp", "rvo", "pso", "formation", "startup", "validate"],
                   help="which benchmark: a method's, startup (cold and warm runs of the built-in scenes) or "
                        "validate (refusing runs too large for memory, against the count)")
    p.add_argument("--no-reference", action="store_true", help="mdp: skip the slow plain-Python solvers")
    p.add_argument("--repeats", type=_positive_int, default=3, help="mdp: runs per timing (the paper used 3)")
    p.add_argument("-q", "--quiet", action="store_true", help="mdp: no progress bar")
    p.add_argument("options", nargs=argparse.REMAINDER,
                   help="rvo, pso, formation, startup, validate: their own options (--help)")
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("report", help="per-group behaviour report of a run, or of a sweep's runs with confidence "
                                      "intervals and the personality paper's claims")
    p.add_argument("output", help="a run's output folder (or a trajectories file), or a sweep's output folder")
    p.set_defaults(func=cmd_report)

    p = sub.add_parser("export", help="write a run's trajectories as Parquet, CSV, JuPedSim SQLite or USD")
    p.add_argument("output", help="a run's output folder (or a trajectories file)")
    p.add_argument("--to", required=True, type=str.lower, choices=sorted(EXPORT_FORMATS),
                   help="sqlite/jupedsim: JuPedSim v2 (PedPy reads it); usd/usdc: binary USD; usda: text USD")
    p.add_argument("-o", "--dest", help="file to write (default: beside the input, named as it is: a run's "
                                        "trajectories.<ext>, session.<ext> for session.parquet)")
    p.add_argument("--fps", type=_fps, help="resample to this frame rate first (e.g. 24 for Blender's default; "
                                             "USD is written at 24 fps unless the run has more frames a second)")
    p.add_argument("--interpolation", choices=("b-spline", "catmull-rom", "linear"), default="b-spline",
                   help="how frames between the run's steps are made: b-spline (default: smooth root motion, "
                        "continuous acceleration), catmull-rom (through every step's position) or linear "
                        "(straight moves); splines are re-checked for collisions")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a file at -o that crowdmotion did not write (an earlier export is replaced "
                        "without it)")
    p.add_argument("--prototype-up", metavar="AXIS",
                   help="usd: the up axis your characters are modelled with, one of X Y Z -X -Y -Z (default Z, "
                        "Blender's; Y for Maya, Houdini, Unity); the stage stays Y-up")
    p.add_argument("--prototype-forward", metavar="AXIS",
                   help="usd: the way your characters face in their own coordinates (default -Y, Blender's; "
                        "Z for Maya, Houdini, Unity); write a negative axis with '=': --prototype-forward=-X")
    p.set_defaults(func=cmd_export)

    p = sub.add_parser("blender-addon", help="write the Blender add-on (crowdmotion_blender.zip) that imports a "
                                             "run's USD as walking characters")
    p.add_argument("-o", "--dest", default=".",
                   help="an existing folder to write crowdmotion_blender.zip into (default: the current folder)")
    p.set_defaults(func=cmd_blender_addon)

    p = sub.add_parser("render",
                       help="animation (MP4/GIF) and density map of a run (and its paths if the run drew none)")
    p.add_argument("output", help="a run's output folder (or a trajectories file: another than the run's own "
                   "gets pictures named after it, a.csv: a.animation.mp4, a.density.png)")
    p.add_argument("--to", type=str.lower, choices=["mp4", "gif"], default="mp4",
                   help="animation format (default mp4, H.264)")
    p.add_argument("--fps", type=_fps,
                   help="video frames per second (default 24; the run is resampled to it)")
    p.add_argument("--trail", type=_nonnegative_number, default=2.0, help="seconds of trail behind each agent")
    p.add_argument("--max-frames", type=_positive_int, default=600,
                   help="at most this many frames (a longer run is sampled evenly and plays faster than real "
                        "time, which the command says; default 600)")
    p.add_argument("--cell", type=_positive_number, default=0.5, help="density map cell, metres")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("view", help="write a self-contained HTML player of a run (works offline)")
    p.add_argument("output", help="a run's output folder (or a trajectories file)")
    p.add_argument("-o", "--dest", help="HTML file to write (default: view.html beside the input; <name>.view.html "
                   "beside a trajectories file other than the run's own)")
    p.add_argument("--max-frames", type=_positive_int, default=3000,
                   help="at most this many frames in the page (a longer run is sampled evenly; default 3000)")
    p.set_defaults(func=cmd_view)

    p = sub.add_parser("sweep", help="run a scenario over seeds and parameter values on Dask")
    p.add_argument("scenario", help="a scenario TOML file, or the name of a built-in scene")
    p.add_argument("--seeds", type=_seeds, default="0:8", help="0:100 (a range), 1,4,9 or 7 (default 0:8)")
    p.add_argument("--set", type=_setting, action="append", metavar="FIELD=V1,V2",
                   help="e.g. rvo.safety=1,3,7.5 (repeatable, one field each time; not seed: see --seeds)")
    p.add_argument("--scheduler", help="address of a running Dask scheduler (default: a LocalCluster)")
    p.add_argument("--workers", type=_positive_int, help="LocalCluster workers (default: the machine's cores)")
    p.add_argument("-o", "--output", help="output folder (default ./sweeps/<scenario>)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an earlier sweep in the output folder (its runs/, sweep.parquet and report.json)")
    p.add_argument("--resume", action="store_true",
                   help="finish an earlier sweep in the output folder (one stopped by Ctrl-C): its finished runs "
                        "are kept, the others run; refused if it ran another scenario, seeds or settings")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("verify", help="the field's public test cases (RiMEA, SteerBench) with their pass criteria")
    p.add_argument("--quick", action="store_true", help="only the quick subset (seconds)")
    p.add_argument("--empirical", action="store_true",
                   help="compare with measured crowds instead: speed against density, bottleneck flow against "
                        "width, a narrow door, counterflow lanes (FZJ, Weidmann, Kretz, Seyfried; 3 seeds each, the door 5; "
                        "minutes)")
    p.add_argument("--case", nargs="*", help="only these cases (names as in the table)")
    p.add_argument("--method", nargs="*", choices=["rvo", "mdp", "formation"], help="only these methods")
    p.add_argument("-o", "--output", default="verify", help="folder for the pictures and verify.json (default ./verify)")
    p.add_argument("-j", "--jobs", type=_positive_int, metavar="N",
                   help="cases run side by side in N processes (default: one per core, at least two cases each, "
                        "as many as the free memory holds at 600 MB each; 1: one after another in this process)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_verify)

    p = sub.add_parser("scenarios", help="list the built-in scenarios")
    p.set_defaults(func=cmd_list)

    return parser


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
