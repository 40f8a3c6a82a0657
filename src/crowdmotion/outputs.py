"""Write a run's files: trajectories in the requested formats, summary.json, figures and
the HTML player."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

from crowdmotion.io.atomic import atomic_path
from crowdmotion.registry import get_method


# what ``crowdmotion run`` and the commands that read a run folder write into it
RUN_FILES = ("trajectories.parquet", "trajectories.csv", "trajectories.csv.meta.json", "trajectories.sqlite",
             "trajectories.usdc", "trajectories.usda", "summary.json", "report.json", "paths.png", "values.png",
             "snapshots.png", "field.png", "density.png", "formation.gif", "animation.mp4", "animation.gif",
             "view.html")


class OutputFolderError(ValueError):
    """An output folder a run cannot use: not writable, or holding an earlier run."""


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
    draws the pictures while this process writes the trajectories and summary."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    spec = result.scenario.spec
    plots = spec.output.plots if plots is None else list(plots)
    job = (spec.method, result.scenario.scene, result.extras, result.trajectories, out, plots, spec.name)
    if pictures is not None and plots:
        pictures.submit(draw_pictures, job)
    written = [result.trajectories.save(out / f"trajectories.{fmt}") for fmt in spec.output.formats]
    summary = {"scenario": spec.name, "seed": result.seed, **result.summary}
    with atomic_path(out / "summary.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2, default=str))
    written.append(out / "summary.json")
    if pictures is not None and plots:
        return written + pictures.result()
    return written + draw_pictures(*job)


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
