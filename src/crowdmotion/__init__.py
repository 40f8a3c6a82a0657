"""crowdmotion: collision-free crowd and group motion from four published methods.

Public API: Scene and obstacle shapes, Group and regions, Trajectories, the metrics,
``load_scenario`` and ``run``.
"""

from crowdmotion.groups import Disc, Group, Lattice, MovingTarget, Points, Rect
from crowdmotion.scene import Box, Circle, Polygon, Scene, Sphere
from crowdmotion.trajectories import Trajectories

__version__ = "0.1.0"


def load_scenario(path):
    """Read and validate a scenario TOML file (see :mod:`crowdmotion.scenario`)."""
    from crowdmotion.scenario import load_scenario as _load

    return _load(path)


def run(scenario, seed=None, progress=True):
    """Run a loaded scenario (or a path to one) and return its :class:`RunResult`."""
    from crowdmotion.scenario import run_scenario

    return run_scenario(scenario, seed=seed, progress=progress)


__all__ = [
    "Box", "Circle", "Disc", "Group", "Lattice", "MovingTarget", "Points", "Polygon", "Rect", "Scene", "Sphere",
    "Trajectories", "load_scenario", "run", "__version__",
]
