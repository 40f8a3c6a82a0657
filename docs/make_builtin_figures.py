"""Draw the docs' pictures of whole runs: built-in scenes, and the scenario files that
docs/rvo.md lists in full (room_exit, stream), each run as `crowdmotion run` runs it and
drawn by the same code (`paths.png`, and an MDP run's `values.png`), then copied into
docs/img under the names the docs use.

    python docs/make_builtin_figures.py            # about 1 min on 2 cores
    python docs/make_builtin_figures.py rvo_doorway mdp_robots_2d
"""

from __future__ import annotations

import argparse
import re
import shutil
import sys
import tempfile
from pathlib import Path

from crowdmotion.builtin import builtin_scenarios
from crowdmotion.outputs import draw_pictures
from crowdmotion.scenario import parse_scenario, run_scenario

DOCS = Path(__file__).resolve().parent
IMG = DOCS / "img"

# source -> {picture the run writes: name in docs/img}
FIGURES = {
    "mdp_robots_2d": {"paths.png": "mdp_robots_2d_paths.png", "values.png": "mdp_robots_2d_values.png"},
    "mdp_drones_3d": {"paths.png": "mdp_drones_3d_paths.png"},
    "mdp_doorway_2000": {"paths.png": "mdp_doorway_2000_paths.png"},
    "rvo_antipodal_circle": {"paths.png": "rvo_antipodal_circle.png"},
    "rvo_doorway": {"paths.png": "rvo_doorway.png"},
    "rvo_blocked_street": {"paths.png": "rvo_blocked_street.png"},
    "rvo_stand_evacuation": {"paths.png": "rvo_stand_nearest.png"},
    "rvo.md:room_exit": {"paths.png": "rvo_room_exit.png"},
    "rvo.md:stream": {"paths.png": "rvo_entering_stream.png"},
}


def scenario_text(source: str) -> str:
    """A built-in's TOML, or (``doc.md:name``) the ```toml block of docs/doc.md whose
    name is ``name``: the file the docs show, so the picture is of that very file."""
    if ":" not in source:
        return next(p for p in builtin_scenarios() if p.stem == source).read_text()
    doc, name = source.split(":")
    blocks = re.findall(r"```toml\n(.*?)```", (DOCS / doc).read_text(), flags=re.S)
    found = [b for b in blocks if re.search(rf'^name = "{re.escape(name)}"$', b, flags=re.M)]
    if len(found) != 1:
        raise SystemExit(f"{doc}: {len(found)} toml blocks named {name!r}, not one")
    return found[0]


def draw(source: str, names: dict[str, str]) -> None:
    sc = parse_scenario(scenario_text(source), source)
    res = run_scenario(sc, progress=False)
    with tempfile.TemporaryDirectory() as tmp:
        kinds = sorted({"values" if f == "values.png" else "paths" for f in names})
        draw_pictures(sc.method, sc.scene, res.extras, res.trajectories, Path(tmp), kinds, sc.spec.name)
        for made, name in names.items():
            shutil.copyfile(Path(tmp) / made, IMG / name)
            print(f"{source}: wrote docs/img/{name}", flush=True)
    s = res.summary
    print(f"  {s['agents']} agents, {s['frames']} frames, overlaps {s['agent_agent_overlaps']}, penetrations "
          f"{s['agent_obstacle_penetrations']}, arrived {s.get('arrival_rate', float('nan')):.0%}", flush=True)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sources", nargs="*", help=f"some of {' '.join(FIGURES)} (default: all)")
    args = ap.parse_args(argv)
    unknown = [s for s in args.sources if s not in FIGURES]
    if unknown:
        sys.exit(f"unknown: {unknown}; known: {list(FIGURES)}")
    for source in args.sources or FIGURES:
        draw(source, FIGURES[source])


if __name__ == "__main__":
    main()
