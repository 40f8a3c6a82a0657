"""Verification cases as data: a case builds its runs (:class:`Setup`) per method, runs
them through the registry as ``crowdmotion run`` does (:func:`simulate`) and judges the
outcomes into a :class:`Verdict`; with the measures cases share (crossing times, flow, the
stationary part of an N–t curve).
The public test cases (:mod:`crowdmotion.verify`) and the comparisons with measured crowds
(:mod:`crowdmotion.empirical`) are both written in these terms."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from crowdmotion.groups import Group
from crowdmotion.registry import get_method, method_params
from crowdmotion.scene import Scene
from crowdmotion.trajectories import Trajectories


@dataclass
class Setup:
    """One simulation of a case: scene, groups and the method's parameter block."""

    scene: Scene
    groups: list[Group]
    params: dict = field(default_factory=dict)
    seed: int | None = None  # its own seed (added to the run's); None: the run's


@dataclass
class Outcome:
    """A finished setup: trajectories, the method's summary, wall time."""

    setup: Setup
    traj: Trajectories
    summary: dict
    wall_s: float


@dataclass
class Verdict:
    """What a case says about one method."""

    case: str
    method: str
    criterion: str
    measured: str
    passed: bool
    overlaps: int
    penetrations: int
    wall_s: float
    picture: Path | None = None

    @property
    def clean(self) -> bool:
        return self.overlaps == 0 and self.penetrations == 0

    def as_dict(self) -> dict:
        return {"case": self.case, "method": self.method, "criterion": self.criterion, "measured": self.measured,
                "passed": self.passed, "agent_overlaps": self.overlaps, "obstacle_penetrations": self.penetrations,
                "wall_s": round(self.wall_s, 2), "picture": None if self.picture is None else self.picture.name}


@dataclass
class Case:
    """A public test case: how to build it per method and how to judge the runs."""

    name: str
    source: str
    description: str
    methods: tuple[str, ...]
    build: Callable[[str], dict[str, Setup]]
    judge: Callable[[dict[str, Outcome]], tuple[str, str, bool]]
    quick: bool = False


def simulate(method: str, setup: Setup, seed: int = 0) -> Outcome:
    """Run one setup through the method's registry entry, as ``crowdmotion run`` does."""
    m = get_method(method)
    params = method_params(method, setup.params)
    check = getattr(m.module, "check_scenario", None)
    if check is not None:
        check(setup.scene, setup.groups, params)
    t0 = time.perf_counter()
    seed = seed if setup.seed is None else seed + setup.seed
    traj, _, summary = m.run(setup.scene, setup.groups, params, np.random.default_rng(seed), progress=False)
    return Outcome(setup, traj, summary, time.perf_counter() - t0)


# ---- measures --------------------------------------------------------------------------------
def crossing_times(traj: Trajectories, axis: int, value: float, sign: float = 1.0) -> np.ndarray:
    """(N,) first time each agent's coordinate ``axis`` passes ``value`` going the way of
    ``sign`` (linear between frames); NaN if never."""
    x = sign * (traj.positions[..., axis] - value)  # > 0 once past
    act = traj.active_mask
    out = np.full(traj.n_agents, np.nan)
    past = (x >= 0) & act
    for i in np.flatnonzero(past.any(axis=0)):
        f = int(np.argmax(past[:, i]))
        if f == 0:
            out[i] = 0.0
            continue
        a, b = x[f - 1, i], x[f, i]
        out[i] = (f - 1 + (-a / (b - a) if b != a else 1.0)) * traj.dt
    return out


def flow(times: np.ndarray) -> float:
    """Persons per second through a line: count over the span of crossing times."""
    t = np.sort(times[np.isfinite(times)])
    return float((len(t) - 1) / (t[-1] - t[0])) if len(t) > 1 and t[-1] > t[0] else float("nan")


def stationary(times: np.ndarray, low: float = 0.1, high: float = 0.9) -> tuple[float, float, float]:
    """(start, end, flow) of the stationary part of an N–t curve: between the ``low`` and
    ``high`` shares of the crossings (persons/s over that span; NaN with too few)."""
    t = np.sort(times[np.isfinite(times)])
    if len(t) < 10:
        return float("nan"), float("nan"), float("nan")
    i0, i1 = int(low * len(t)), int(high * len(t))
    return float(t[i0]), float(t[i1]), float((i1 - i0) / (t[i1] - t[i0])) if t[i1] > t[i0] else float("nan")
