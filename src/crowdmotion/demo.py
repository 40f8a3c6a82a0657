"""``crowdmotion demo``: the built-in scenes, side by side on the machine's cores.

Each scene is a job of its own: simulate, then write trajectories, pictures and player
(about half of a scene's time is the pictures, which run on one core in matplotlib).
With more than one core the scenes run in a pool of worker processes, one per core (at
most one per scene), so one scene's pictures are drawn while another simulates. The
scenes are handed out one method at a time in turn (formation, mdp, pso, rvo, then the
next of each), so that on a cold numba cache the first workers compile different
methods' kernels rather than the same ones twice, and the heaviest scenes (formation)
start first.

How many workers, and their threads: :mod:`crowdmotion.workers`. Results do not depend
on the number of workers: every scene runs with its own seed in a process of its own.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path

from crowdmotion.workers import map_in_workers


@dataclass(frozen=True)
class DemoScene:
    """A scenario file as the demo lists it: read for its name, method and description
    only (each worker loads and checks its own scenes in full)."""

    path: Path
    name: str
    method: str
    description: str = ""

    @classmethod
    def read(cls, path) -> "DemoScene":
        import tomllib

        data = tomllib.loads(Path(path).read_text())
        return cls(Path(path), str(data.get("name", Path(path).stem)), str(data.get("method", "")),
                   str(data.get("description", "")))


@dataclass(frozen=True)
class SceneDone:
    """One scene's outcome: its headline (or the error it raised) and its wall time."""

    name: str
    headline: str
    seconds: float
    error: str | None = None


def interleave(scenes: list) -> list:
    """Scenes (anything with a ``method``) in the order the workers take them: the first
    scene of each method (alphabetical methods), then the second of each, and so on."""
    by_method: dict[str, list] = {}
    for sc in scenes:
        by_method.setdefault(sc.method, []).append(sc)
    queues = [by_method[m] for m in sorted(by_method)]
    order = []
    for i in range(max((len(q) for q in queues), default=0)):
        order += [q[i] for q in queues if i < len(q)]
    return order


def run_one(path: str, out: str, progress: bool = False) -> SceneDone:
    """Run one scenario file and write everything it asks for into folder ``out``
    (held while the scene runs, an earlier demo's files replaced)."""
    from crowdmotion.metrics import headline
    from crowdmotion.outputs import claim_output_folder, write_run
    from crowdmotion.scenario import load_scenario, run_scenario

    t0 = time.perf_counter()
    sc = load_scenario(path)
    with claim_output_folder(out, overwrite=True) as folder:  # the demo's own folders
        # (kernels compiled on every core on a cold cache: the demo is the command's; in a
        # worker CROWDMOTION_PRECOMPILE=0 leaves it to the workers themselves)
        result = run_scenario(sc, progress=progress, precompile=True)
        write_run(result, folder)
    return SceneDone(sc.spec.name, headline(result.summary), time.perf_counter() - t0)


def _safe_run_one(job: tuple[str, str]) -> SceneDone:
    """:func:`run_one` of (scenario file, output folder) in a worker: an error comes back
    as the scene's outcome rather than ending the demo."""
    path, out = job
    t0 = time.perf_counter()
    try:
        return run_one(path, out)
    except Exception as exc:  # reported by the parent, which exits non-zero
        return SceneDone(Path(path).stem, "", time.perf_counter() - t0, f"{type(exc).__name__}: {exc}")


def run_parallel(scenes: list[DemoScene], root: Path, jobs: int, progress: bool = True,
                 file=None) -> list[SceneDone]:
    """Run ``scenes`` in ``jobs`` worker processes, each into ``root / <scene name>``;
    prints one line per scene as it finishes (with a bar over the scenes when
    ``progress``). Returns the outcomes in finishing order."""
    from crowdmotion.outputs import folder_inside
    from crowdmotion.progress import counter

    file = sys.stdout if file is None else file
    order = interleave(scenes)
    done: list[SceneDone] = []
    with counter(len(order), "demo", "scene", progress) as bar:
        def report(_, outcome: SceneDone) -> None:
            done.append(outcome)
            line = (f"{outcome.name}: {outcome.headline} ({outcome.seconds:.1f} s)" if outcome.error is None
                    else f"{outcome.name}: failed: {outcome.error}")
            bar.write(line, file=file)
            bar.update(1)

        map_in_workers(_safe_run_one, [(str(sc.path), str(folder_inside(root, sc.name))) for sc in order], jobs,
                       report)
    return done
