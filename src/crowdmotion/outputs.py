"""Write a run's files: trajectories in the requested formats, summary.json, figures and
the HTML player."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

from crowdmotion._precompile import cores
from crowdmotion.io.atomic import atomic_path
from crowdmotion.registry import get_method


# what ``crowdmotion run`` and the commands that read a run folder write into it
RUN_FILES = ("trajectories.parquet", "trajectories.csv", "trajectories.csv.meta.json", "trajectories.sqlite",
             "trajectories.usdc", "trajectories.usda", "summary.json", "report.json", "paths.png", "values.png",
             "snapshots.png", "field.png", "density.png", "formation.gif", "animation.mp4", "animation.gif",
             "view.html")


class OutputFolderError(ValueError):
    """An output folder a run cannot use: not writable, or holding an earlier run."""


def folder_inside(root, name: str) -> Path:
    """``root / name``, the folder a name gives (a scenario's out/<name>, a demo scene's
    subfolder), refused unless, resolved, it lies strictly inside ``root``: a name such
    as ``..``, ``../x`` or ``/tmp/x`` must never send a run's files elsewhere."""
    root = Path(root)
    folder = root / name
    try:
        inside = root.resolve() in folder.resolve().parents
    except (OSError, ValueError, RuntimeError):  # a NUL in the name, a symlink loop
        inside = False
    if not inside:
        raise OutputFolderError(f"the name {name!r} would put the output folder outside {root}/ "
                                f"(at {str(folder)!r}); give a plain folder name, or a folder with -o")
    return folder


def check_output_folder(out, overwrite: bool = False) -> list[Path]:
    """Refuse a folder ``run`` could not write, or one holding an earlier run's files
    (unless ``overwrite``); creates nothing. Returns the earlier run's files found."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise OutputFolderError(f"output folder {out} is a file, not a folder")
    old = [out / n for n in RUN_FILES if (out / n).exists()]
    if old and not overwrite:
        names = ", ".join(p.name for p in old[:4]) + (", ..." if len(old) > 4 else "")
        raise OutputFolderError(f"output folder {out} holds an earlier run ({names}): pass --overwrite to replace "
                                f"it, or choose another folder with -o")
    probe = out
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise OutputFolderError(f"cannot make output folder {out}: {probe} is a file")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise OutputFolderError(f"cannot write to output folder {out}: {probe} is not writable")
    return old


def prepare_output_folder(out, overwrite: bool = False) -> Path:
    """Make ``out`` ready for one run before simulating: checked, created, probed with a
    real write, and cleared of an earlier run's files when ``overwrite``."""
    out = Path(out)
    old = check_output_folder(out, overwrite)
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=out, prefix=".crowdmotion-probe-"):
            pass
    except OSError as exc:
        raise OutputFolderError(f"cannot write to output folder {out}: {exc.strerror or exc}") from None
    for f in old:
        f.unlink()
    return out


def write_run(result, out, plots=None, pictures=None) -> list[Path]:
    """Write everything a scenario asks for into folder ``out``; returns the paths.
    ``plots`` (names as in [output] plots) replaces the scenario's own list.
    ``pictures``: a started :class:`~crowdmotion.render.background.PictureProcess` that
    draws the pictures, in parts side by side, while this process writes the
    trajectories and summary.json."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    spec = result.scenario.spec
    plots = spec.output.plots if plots is None else list(plots)
    run = (spec.method, result.scenario.scene, result.extras, result.trajectories, out)
    pictures = pictures if plots else None  # nothing to draw: no job for it
    if pictures is not None:
        split = getattr(get_method(spec.method).module, "PICTURE_PARTS", None)
        pictures.submit(draw_pictures, [(*run, part, spec.name) for part in picture_parts(plots, cores(), split)])
    written = [result.trajectories.save(out / f"trajectories.{fmt}") for fmt in spec.output.formats]
    summary = {"scenario": spec.name, "seed": result.seed, **result.summary}
    with atomic_path(out / "summary.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2, default=str))
    written.append(out / "summary.json")
    drawn = pictures.result() if pictures is not None else draw_pictures(*run, plots, spec.name)
    return written + sorted(drawn, key=lambda p: RUN_FILES.index(p.name) if p.name in RUN_FILES else len(RUN_FILES))


# what each picture costs to draw, about, against a paths picture (formation_army: paths
# 0.21 s, values 0.24 s, snapshots figure 0.4 s, its GIF 1.1 s, player 0.07 s)
PICTURE_COST = {"snapshots": 7.0, "snapshots-animation": 5.0, "snapshots-figure": 2.0, "player": 0.5}


def picture_parts(plots: list[str], parts: int, split: dict | None = None) -> list[list[str]]:
    """``plots`` in up to ``parts`` lists of about equal drawing time (the longest
    first, each to the lightest list so far), in their given order within a list.
    ``split``: names that stand for pictures drawable apart (a method's
    ``PICTURE_PARTS``), replaced by those."""
    names = [part for n in plots for part in (split or {}).get(n, (n,))]
    lists: list[list[str]] = [[] for _ in range(max(1, min(parts, len(names))))]
    load = [0.0] * len(lists)
    for name in sorted(names, key=lambda n: -PICTURE_COST.get(n, 1.0)):
        k = load.index(min(load))
        lists[k].append(name)
        load[k] += PICTURE_COST.get(name, 1.0)
    return [[n for n in names if n in part] for part in lists if part]


def draw_pictures(method: str, scene, extras, trajectories, out: Path, plots: list[str], title: str) -> list[Path]:
    """The pictures named in ``plots`` (the method's figures, and ``player`` for
    view.html) of one run, written into ``out``; returns their paths."""
    written = []
    module = get_method(method).module
    pictures = [p for p in plots if p != "player"]
    if pictures and hasattr(module, "write_plots"):
        written += module.write_plots(scene, extras, out, pictures, title)
    if "player" in plots:
        from crowdmotion.render.player import write_player

        written.append(write_player(trajectories, out / "view.html"))
    return written
