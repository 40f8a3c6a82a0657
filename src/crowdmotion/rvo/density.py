"""Density-aware speed: a named term of the RVO velocity choice that slows walkers in a
crowd as real pedestrians slow (the fundamental diagram).

Eq. (3) slows an agent only for a relative velocity: walkers moving together at 2
persons/m² keep their free speed, where Weidmann's (1993) fundamental diagram and the
FZJ corridor experiments give about 0.55-0.6 m/s. Following Best, Narang, Curtis &
Manocha's DenseSense (2014), each agent senses the density ρ of the space it is about to
walk into and caps the speed of its preferred velocity at the share of its own free
speed that the fundamental diagram allows there:

    |v_pref| ≤ v_pref,i · f(ρ),   f(ρ) = 1 − exp(−γ · (1/ρ − 1/5.4))

Weidmann's form (Kladek's formula; γ = 1.913 /m² in Weidmann's curve
v = 1.34 · f(ρ) m/s), with γ = ``GAMMA`` = 1.63 /m², the least-squares fit of that form
to the FZJ/Hermes 1.8 m closed-corridor runs (Zhang et al. 2011; fitted free speed
1.13 m/s): the two sources disagree by up to 0.27 m/s near 1.5 persons/m², and the fit
lies between them. The sensed density is a Gaussian kernel estimate
(σ = ``SIGMA_M``) of the other agents round the point ``AHEAD_M`` metres in front of the
agent along its v_pref, divided by the share of the kernel that falls on walkable floor
(so a crowd in a 1.8 m corridor is not taken as half as dense as it is because the walls
hold nobody), and relaxed over ``RELAX_S`` seconds, as people adjust their pace over a
step or two rather than at once. The slowing counts the people who stand or walk our
way; one coming towards us counts the less the faster it comes, nothing from
``ONCOMING_MPS`` on. Eq. (3) already slows us for them (they have a relative velocity),
and the stream we walk in is what holds us to the crowd's pace. Counting the oncoming stream
here as well (so twice) held the walkers of the FZJ counterflow runs (BOT-360)
0.30-0.37 m/s below the measured speeds, against 0.02-0.34 m/s with it left out. Following and lane choice read
the density of everyone (``density``). Eq. (3) then chooses among the candidates as before,
with the capped v_pref; the OCEAN parameters, the hard obstacle constraint and the
safety pass are untouched. Agents wider than a person (radius above
``PERSON_MAX_RADIUS_M``: robots, vehicles) are counted by the people round them but are
not slowed by it: the curve is a measurement of people. ``density_slowing = false``
switches the term off.

**Passing in counterflow and crossing streams** (``counterflow_safety``). The same sensing
also counts, round the same point, the people bound the other way or across our way: those
whose wanted direction is over 60° from ours and whose goal lies another way too: the
straight lines to the two goals over 120° apart, or over 60° apart with their goal
farther from ours than we are (two converging on one door from either side face each
other, but are bound to one place). While that density is above 0, a walker's w in
eq. (3) falls linearly to ``counterflow_safety`` × w, reached from ``AGAINST_FULL_DENSITY``
on, and scaled by the density of everyone sensed there, in full from
``EASE_FULL_DENSITY`` (as lane choice is): in a thin crowd a walker keeps its own w, the
one its personality gives it (paper 004, Table 4), and passes at the distance that
personality keeps. Real walkers in counterflow pass each other at a close range,
shoulder past shoulder; with the full w, eq. (3) values a short time to collision with
each oncoming walker so highly that walkers back off instead: in the FZJ BOT-360 runs
rebuilt (3.6 m corridor, entrances 0.9-2.5 m) 20-25 % of the walkers in the measurement
area walked backwards at any moment, and they walked 0.2-0.3 m/s slower than the people
did. The share is fitted to those runs without the crowd scaling (mean absolute speed
error over 27 runs 0.21 m/s with w throughout, 0.17 at 0.2, 0.16 at 0.15, 0.18 at 0.1,
0.21 at 0.05, where the choice gets too close to keep moving); eased so in every crowd,
the street crossings of paper 004 §6 (about 0.6 persons/m² where they meet) lost three
of the personality claims that hold there, and with the scaling they keep them, at 0.20
over the 27 runs. Crossing streams count since two streams meeting at right angles in a
junction of 6 m corridors (100 each way, seeds 1-8) stood in a block where they met and
carried 40 walkers each run more than 3 m into the side arms, the last out at 84 s on
average (27 s walking free); with those crossing counted, 32 walkers and 79 s, and the
BOT-360 runs, where walkers turn across the oncoming stream to their side exits, came
within 0.2 m/s of the measured speed in 132 of 144 runs (122 before). Flows bound one
way (bottlenecks, doors) are unchanged. Eased, walkers also pass in corridors two bodies
wide where pairs walking abreast would stand. Bodies wider than a person keep w.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter

from crowdmotion.floor import WalkableFloor
from crowdmotion.rvo import _kernels as K
from crowdmotion.scene import Scene

WEIDMANN_FREE = 1.34   # m/s, free walking speed of Weidmann's curve
WEIDMANN_GAMMA = 1.913  # 1/m²
WEIDMANN_JAM = 5.4     # persons/m² at which the curve reaches 0
GAMMA = 1.63           # 1/m²: Weidmann's form fitted to the FZJ closed-corridor runs
AHEAD_M = 3.0          # the density is sensed round this point in front of the agent (~2.2 s of walking)
SIGMA_M = 0.7          # kernel width, metres
RELAX_S = 0.5          # the sensed density follows the crowd over this many seconds
MIN_FACTOR = 0.05      # never quite a standstill: a jam clears as its front moves
PERSON_MAX_RADIUS_M = 0.4  # wider agents (robots, vehicles) are no persons: eq. (3) alone
FLOOR_SHARE_MIN = 0.25  # the floor share is taken as at least this (a point deep in a wall)
ONCOMING_MPS = 0.5     # a neighbour coming towards us this fast or faster counts 0 in the slowing density
COUNTERFLOW_SAFETY = 0.15  # share of w kept while walking into people bound the other way or across (fitted, BOT-360)
AGAINST_FULL_DENSITY = 0.05  # persons/m² bound the other way or across from which w is eased in full ...
EASE_FULL_DENSITY = 1.0  # ... in a crowd of this many persons/m² (less in a thinner one)


def speed_share(density, gamma: float = GAMMA) -> np.ndarray:
    """f(ρ) = 1 − exp(−γ (1/ρ − 1/5.4)): the share of the free walking speed left at
    ``density`` persons/m² (1 in the open, 0 from 5.4 /m² on)."""
    rho = np.maximum(np.asarray(density, dtype=float), 0.05)  # below 0.05 /m² the share is 1
    return np.clip(1.0 - np.exp(-gamma * (1.0 / rho - 1.0 / WEIDMANN_JAM)), 0.0, 1.0)


def weidmann_speed(density) -> np.ndarray:
    """Weidmann's (1993) walking speed at ``density`` persons/m², m/s: 1.34 · f(ρ) with
    γ = 1.913 (1.06, 0.61, 0.33, 0.16 m/s at 1, 2, 3, 4 /m²)."""
    return WEIDMANN_FREE * speed_share(density, WEIDMANN_GAMMA)


class FloorShare:
    """Share of a Gaussian kernel of width ``SIGMA_M`` round each point that falls on
    walkable floor (inside the bounds, outside static obstacles: the cells whose centre
    is, :class:`crowdmotion.floor.WalkableFloor`): 1 in the open, about 0.5 against a long
    wall, less in a corner."""

    def __init__(self, scene: Scene):
        floor = WalkableFloor(scene)
        self.cell, self.origin = floor.cell, floor.origin
        free = (~floor.blocked).astype(float)
        self.share = gaussian_filter(free, SIGMA_M / self.cell, mode="constant", cval=0.0, truncate=3.0)

    def at(self, points: np.ndarray) -> np.ndarray:
        """(N,) the floor share at each point (nearest raster cell; 0 outside the bounds)."""
        out = np.empty(len(points))
        K.raster_at(self.share, float(self.origin[0]), float(self.origin[1]), float(self.cell),
                    np.ascontiguousarray(points, dtype=float), out)
        return out


class DensitySlowing:
    """Per-agent sensed density and the speed factor it allows (see the module docstring)."""

    def __init__(self, scene: Scene, enabled: bool = True, sense: bool | None = None):
        """``enabled``: slow agents; ``sense``: keep the sensed density up to date (default:
        when enabled; following in a crowd reads it too)."""
        self.enabled = bool(enabled)
        self.sensing = self.enabled if sense is None else bool(sense)
        self.floor = FloorShare(scene) if self.sensing else None
        self.density = np.zeros(0)
        self.density_with = np.zeros(0)
        self.density_against = np.zeros(0)
        self._fresh = np.zeros(0, dtype=bool)

    def refloor(self, scene: Scene) -> None:
        """Measure the walkable floor again (obstacles were added or removed)."""
        if self.sensing:
            self.floor = FloorShare(scene)

    def grow(self, n: int) -> None:
        """Make room for ``n`` new agents (their density is sensed afresh on their first step)."""
        self.density = np.concatenate([self.density, np.zeros(n)])
        self.density_with = np.concatenate([self.density_with, np.zeros(n)])
        self.density_against = np.concatenate([self.density_against, np.zeros(n)])
        self._fresh = np.concatenate([self._fresh, np.ones(n, dtype=bool)])

    def sense(self, pos, vel, heading, radius, active, grid, dt: float, goals) -> np.ndarray:
        """Update the sensed densities (agents/m² ahead of each agent along ``heading``,
        its wanted direction): ``density`` of everyone, ``density_with`` of those not
        coming towards it, ``density_against`` of those bound the other way or across its
        way (see the module docstring; ``goals``: (N, 2) the agents' goal points); return
        ``density``."""
        raw = np.zeros(len(pos))
        raw_with = np.zeros(len(pos))
        raw_against = np.zeros(len(pos))
        s = np.flatnonzero(active & (radius <= PERSON_MAX_RADIUS_M))
        head = np.empty((len(s), 2))  # the unit heading ...
        centre = np.empty((len(s), 2))  # ... and the point sensed round, AHEAD_M in front (the agent itself if standing)
        K.points_ahead(pos, heading, s, AHEAD_M, centre, head)
        counts = np.empty(len(s))
        counts_with = np.empty(len(s))
        counts_against = np.empty(len(s))
        K.density_ahead(centre, s, pos, vel, head, ONCOMING_MPS, heading, goals, *grid, SIGMA_M, counts, counts_with,
                        counts_against)
        kernel_area = 2.0 * np.pi * SIGMA_M * SIGMA_M * (1.0 - np.exp(-4.5))  # its mass within 3σ
        norm = kernel_area * np.maximum(self.floor.at(centre), FLOOR_SHARE_MIN)
        raw[s] = counts / norm
        raw_with[s] = counts_with / norm
        raw_against[s] = counts_against / norm
        sensed = np.zeros(len(pos), dtype=bool)
        sensed[s] = True
        a = min(1.0, dt / RELAX_S)

        def relax(old, new):  # a fresh agent takes what it senses at once
            return np.where(self._fresh, new, old + a * (new - old))

        self.density, self.density_with = relax(self.density, raw), relax(self.density_with, raw_with)
        self.density_against = relax(self.density_against, raw_against)
        self._fresh &= ~sensed
        return self.density

    def safety_factors(self, share: float) -> np.ndarray:
        """(N,) the factor on each agent's w (eq. (3)) in counterflow and crossing streams: 1 −
        (1 − ``share``) × min(1, ρ_against / AGAINST_FULL_DENSITY) × min(1, ρ /
        EASE_FULL_DENSITY), ρ_against the density of those bound the other way or across
        our way and ρ that of everyone, as last sensed (1
        for everyone when nothing is sensed)."""
        against = np.minimum(self.density_against / AGAINST_FULL_DENSITY, 1.0)
        crowd = np.minimum(self.density / EASE_FULL_DENSITY, 1.0)
        return 1.0 - (1.0 - share) * against * crowd

    def factors(self, pos, vel, heading, radius, active, grid, dt: float, goals) -> np.ndarray:
        """(N,) the factor on each agent's preferred speed: f(ρ) of the density of those
        standing or walking its way (``density_with``), at least MIN_FACTOR (1 for
        everyone when the term is off). ``vel``: the agents' current velocities."""
        if not self.sensing:
            return np.ones(len(pos))
        self.sense(pos, vel, heading, radius, active, grid, dt, goals)
        if not self.enabled:
            return np.ones(len(pos))
        return np.maximum(speed_share(self.density_with), MIN_FACTOR)
