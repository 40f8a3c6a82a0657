"""Lane choice: a named term of the RVO velocity choice that turns a walker's preferred
velocity towards the side with the clearest way ahead (least oncoming traffic, fewest
people), so opposing streams sort themselves into lanes instead of meeting front to
front, and a crowd turning a corner spreads over the corridor's width.

Eq. (3) looks at the M nearest neighbours; in a crowd those are the agent's own stream,
and the oncoming front is met only when it is too late to do more than stop. Real
walkers read the oncoming stream metres ahead and step towards the gaps in it, and
settle behind someone going their way (Moussaïd, Helbing & Theraulaz 2011 choose the
heading with the clearest way ahead; lane formation follows). Here each agent weighs the
agents within ``LOOK_M`` metres ahead (nearer ones more; one going our way counts as
far as it is slower than we would walk, up to ``CROWD_WEIGHT`` of an oncoming one),
spread over the lateral offset, and among the lateral offsets ``OFFSETS_M`` it can walk
to in a straight line takes the one with the least of

    pressure(offset) + SIDE_COST · |offset| − RIGHT_BONUS · offset

(right is +: a slight preference for the right, the pedestrians' convention, breaks the
tie of two fronts meeting exactly). It then aims at that offset ``AIM_M`` metres ahead at
the same preferred speed. With nobody ahead the term changes nothing; in a uniform
crowd every offset weighs the same and the straight line wins. Agents wider than a
person (radius above 0.4 m: robots, vehicles) keep their v_pref. ``lane_choice = false``
switches the term off.

Walkers choose their lane every ``DECIDE_S`` seconds, not every step: the agents take
turns (agent i at the steps where (step + i) is a multiple of the period's steps), so each
step weighs the crowd ahead for the same share of them. In between, an agent keeps the
turn it chose, applied to its v_pref of the moment. It chooses again at once when its
v_pref has turned by more than ``RETHINK_DEG`` since its choice, when it enters, and when
it is placed or given a new goal; within ``NEAR_GOAL_M`` of its goal (walking up to its
place in a queue, stepping in at a door) it chooses at every step, as the turn kept from
farther off would carry it past the spot. People settle on a gap and walk for it rather than
re-deciding several times a second, and a walker that holds its gap for a second keeps to
the lane it forms (the BOT-360 corridors: 35 of 54 runs within 0.2 m/s of the measured
speed, against 27 choosing every half second; docs/verification.md). At the default
0.25 s step this does a quarter of the term's work; at a game's 60 frames a second it is
done for one agent in 60 each frame.
"""

from __future__ import annotations

import numpy as np

from crowdmotion.rvo import _kernels as K
from crowdmotion.rvo.density import PERSON_MAX_RADIUS_M

LOOK_M = 6.0          # oncoming agents up to this far ahead count
SPREAD_M = 0.35       # lateral width of an oncoming body's weight
_STEPS = np.arange(1, 9) * 0.3
OFFSETS_M = np.concatenate([[0.0], np.ravel(np.c_[_STEPS, -_STEPS])])  # straight on first, then ±0.3 … ±2.4
AIM_M = 2.0           # the chosen offset is aimed at this far ahead (≤ 50° off the way)
SIDE_COST = 0.3       # per metre of offset: stepping aside has a price
RIGHT_BONUS = 0.1     # per metre to the right
SAFETY_REFERENCE = 5.0  # w of eq. (3) at which the pressure counts as it is (the default w)
FULL_DENSITY = 1.0    # persons/m² sensed ahead from which the term acts in full (0 in the open)
MIN_PRESSURE = 0.05   # below this on the straight line, nobody is coming
CROWD_WEIGHT = 1.0    # weight of an agent ahead going our way but standing (1 for an oncoming one)
DECIDE_S = 1.0        # seconds between an agent's lane choices
RETHINK_DEG = 20.0    # a v_pref turned this far since the last choice chooses again at once
NEAR_GOAL_M = 2.0 * AIM_M  # this near its goal, an agent chooses at every step


def lane_velocities(pos, vel, vpref, radius, safety, density, active, grid, prims) -> np.ndarray:
    """(N, 2) ``vpref`` turned towards each ``active`` walker's chosen lane, chosen now
    (see the module docstring); the others' ``vpref`` as it is."""
    out = np.empty_like(vpref)
    weight = safety / SAFETY_REFERENCE * np.minimum(density / FULL_DENSITY, 1.0)
    walkers = active & (radius <= PERSON_MAX_RADIUS_M)
    K.lane_choice(pos, vel, vpref, radius, weight, walkers, *grid, prims.circ_c, prims.circ_r, prims.seg_a, prims.seg_b,
                  LOOK_M, SPREAD_M, OFFSETS_M, AIM_M, SIDE_COST, RIGHT_BONUS, MIN_PRESSURE, CROWD_WEIGHT, out)
    return out


class LaneChoice:
    """The walkers' lane choices over time: each chooses every ``DECIDE_S`` seconds, in
    turn, and keeps its turn of v_pref in between (see the module docstring)."""

    def __init__(self, dt: float):
        self.period = max(1, int(round(DECIDE_S / dt)))  # steps between an agent's choices
        self.turn = np.zeros(0)              # radians v_pref was turned at the last choice (+ = left)
        self.heading = np.zeros((0, 2))      # unit v_pref at the last choice (0: choose at the next step)
        self.steps = 0

    def grow(self, n: int) -> None:
        """Make room for ``n`` new agents (they choose at their first step)."""
        self.turn = np.concatenate([self.turn, np.zeros(n)])
        self.heading = np.concatenate([self.heading, np.zeros((n, 2))])

    def forget(self, ids: np.ndarray) -> None:
        """Agents ``ids`` (placed elsewhere, or given a new goal) choose at their next step."""
        self.turn[ids] = 0.0
        self.heading[ids] = 0.0

    def velocities(self, pos, vel, vpref, radius, safety, density, active, grid, prims, goals) -> np.ndarray:
        """(N, 2) ``vpref`` of the ``active`` agents turned towards their lanes: chosen
        now by those whose turn it is (or whose way turned, or near their ``goals``),
        kept by the others."""
        due = np.empty(len(vpref), dtype=np.bool_)
        K.lanes_due(vpref, self.heading, pos, goals, active, self.steps, self.period, np.cos(np.deg2rad(RETHINK_DEG)),
                    NEAR_GOAL_M, due)
        self.steps += 1
        out = lane_velocities(pos, vel, vpref, radius, safety, density, due, grid, prims)
        K.lanes_keep(vpref, out, due, active, self.turn, self.heading)
        return out
