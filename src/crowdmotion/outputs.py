"""Write a run's files: trajectories in the requested formats, summary.json, figures and
the HTML player."""

from __future__ import annotations

import json
from pathlib import Path

from crowdmotion.io.atomic import atomic_path
from crowdmotion.registry import get_method


def write_run(result, out) -> list[Path]:
    """Write everything a scenario asks for into folder ``out``; returns the paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    spec = result.scenario.spec
    written = [result.trajectories.save(out / f"trajectories.{fmt}") for fmt in spec.output.formats]
    summary = {"scenario": spec.name, "seed": result.seed, **result.summary}
    with atomic_path(out / "summary.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2, default=str))
    written.append(out / "summary.json")
    module = get_method(spec.method).module
    if spec.output.plots and hasattr(module, "write_plots"):
        written += module.write_plots(result.scenario.scene, result.extras, out, spec.output.plots, spec.name)
    if "player" in spec.output.plots:
        from crowdmotion.render.player import write_player

        written.append(write_player(result.trajectories, out / "view.html"))
    return written
