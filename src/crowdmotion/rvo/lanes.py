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


def lane_velocities(pos, vel, vpref, radius, safety, density, active, grid, prims) -> np.ndarray:
    """(N, 2) ``vpref`` turned towards each agent's chosen lane (see the module docstring)."""
    out = np.empty_like(vpref)
    weight = safety / SAFETY_REFERENCE * np.minimum(density / FULL_DENSITY, 1.0)
    walkers = active & (radius <= PERSON_MAX_RADIUS_M)
    K.lane_choice(pos, vel, vpref, radius, weight, walkers, *grid, prims.circ_c, prims.circ_r, prims.seg_a, prims.seg_b,
                  LOOK_M, SPREAD_M, OFFSETS_M, AIM_M, SIDE_COST, RIGHT_BONUS, MIN_PRESSURE, CROWD_WEIGHT, out)
    return out
