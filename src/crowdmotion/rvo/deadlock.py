"""Breaking RVO stand-offs: keep right, yielding by priority, detours round gridlocks, and
arrival by contact at a shared goal point.

Eq. (3) of the paper, penalty(v′) = w / tc(v′) + ‖v_pref − v′‖, lets an agent stand still
for good: standing costs ‖v_pref‖ and every move towards a blocker costs at least as much,
so two walkers meeting head-on in a doorway wait for each other forever (up to 2w metres
apart: w · 2v / gap ≥ v). Documented rules (docs/rvo.md, "Nobody waits for good")
break that; none touches the continuous-time guarantee, which the step's safety pass
(``_contact.resolve_conflicts``) and the hard obstacle constraint keep on their own:

1. **Keep right** (in the kernel, ``_kernels._kept_right``): an agent meeting an oncoming
   neighbour turns its v_pref right by a few degrees, so head-on pairs pass left side to
   left side instead of meeting nose to nose (the pedestrians' convention that
   Helbing & Molnár's social force model also builds in).
   **Squeezing past** (in the kernel, ``squeeze_s``): a walker meeting an oncoming one in
   its way, bound the other way (the straight lines to their goals over 120° apart),
   counts a wall only when it would meet it within ``SQUEEZE_WALL_S`` seconds, so it moves
   up to the wall to let the other pass; eq. (3)'s w/tc priced that sidestep above
   standing, and two people facing each other in a narrow corridor stood for good (RVO2
   likewise gives obstacles their own, shorter time horizon). Two converging on one door
   from either side come towards each other too, but keep minding the walls: squeezing
   into the mouth's corners clogged a 0.8 m bottleneck.
   **Held up for long** (in the kernel, ``_kernels.HELD_LONG_S``): a walker that has
   stood 3 s counts a neighbour's collision only when met within 0.5 s, so it takes a
   gap between two pressed on a door's wall faces that a straight ray beyond the mouth
   would price above standing (a 1 m door before 300 people stood for good).
2. **Yielding by priority**: an agent held up (walking slower than a tenth of its
   preferred speed along v_pref) for ``patience`` seconds — counted leakily, so a second of walking
   takes back a second of waiting — whose way is blocked by an agent that is held up
   too, comes head-on (its v_pref against ours), stands on our line within our neighbour
   distance D among our six nearest, has us on its line, and has the higher priority
   (a fixed hash of the id), yields. Of those coming head-on only the nearest counts:
   when it has the lower priority, it is the one to yield, and the agent yields to
   nobody (yielding to one behind it, while that one yielded to one behind us, left two
   fronts nose to nose in a corridor waiting for each other for good). While it stands
   in the other's way a yielder backs off, away from the other and turned 30° to its
   right; once out of the way it waits until the other has walked past (or 10 s have
   gone). A one-body-wide passage thus clears. A yielder that stood through at least
   ``CORNERED_STILL_S`` of its yield and saw it run out (its way back walled off: a walker
   at a corridor's end, facing two abreast who are bound for where it stands) is
   *cornered*: until it walks freely again, it outranks every agent it meets
   head-on, so the other yields instead (a corridor two bodies wide: one of the two steps
   back into the other lane).
   Two walkers (radius up to ``PERSON_MAX_RADIUS_M``) held up and standing for
   ``ABREAST_STILL_S`` side by side, bound the same way (their v_pref within 60°) with
   each in the other's way — wedged abreast in a door
   too narrow for two — settle it the same way: the
   one of lower priority steps back (half its preferred speed, back along its way and
   away from the other) while it stands in the other's way, then waits until the other
   is a body ahead of it (or ``ABREAST_MAX_S`` have gone). One that had stood
   ``ABREAST_STILL_S + ABREAST_SWITCH_S`` when its yield began (its last yield left it
   where it stood: away from the other ran into the door's corner) and stands still steps
   straight back along its way instead. Two walkers converging on
   one door, one from beside it along the wall and one from in front (v_pref 60-90°
   apart, the straight lines to their goals within 60°), each in the other's way and both
   standing for ``DETOUR_STILL_S``, settle it as two wedged abreast do (backing off
   away from the other alone turned the one beside the mouth into the door's corner).

3. **Gridlock detour**: an agent standing (below 5 % of its preferred speed) for
   ``DETOUR_STILL_S`` seconds, held up by an agent in its way that stands as long, comes
   from the side (their v_pref 60-120° apart) and is bound elsewhere (the straight lines
   to their goals over 60° apart), walks 60° to the right of its way until it makes
   progress again (along the way it walks, turned: :meth:`Deadlock._way`): crossing
   streams locked in a crossing circulate round it, as traffic round a roundabout.
   Head-on (v_pref over 120° apart, bound the other way: goal lines over 120° apart),
   the same once both have stood ``HEADON_STILL_S``: two streams whose fronts fill a
   corridor's width nose to nose, each pressed from behind, are past what yielding
   settles (a yielder has nowhere to back off to); walking round to the right, each front
   opens a lane (the FZJ BOT-360 corridor rebuilt, 2.5 m entrances, seed 1402: without
   it 45 % got out and the rest stood for good; with it everyone, the last at 329 s).
   Standing, not slow progress, and goals apart keep it out of queues and of crowds
   converging on one door.

4. **Making room for a yielder** (``_make_room``): an agent within ``ROOM_GAP_M`` of a
   yielder's body, ahead along the yielder's step back and on its line, steps back the
   same way at half its preferred speed, and so do those in its own way back, up to
   ``ROOM_DEPTH`` bodies deep. In a packed crowd the yielder has someone right behind
   it; without this its step back goes nowhere and an arch in a door's mouth stands for
   good. Those stepping back or making room slide along the walls their bodies touch
   (within ``WALL_TOUCH_M``, :func:`_along_walls`) rather than stepping into them, which
   the obstacle constraint refuses: pressed on a door's wall face, they stood, and the
   arch with them.

Lowering w for agents held up ("impatience") was tried and dropped: in a four-way
crossing (RVO2's Blocks) everyone pushes in and the crossing jams for good.

And for goals shared by a crowd when arrivals stay (``remove_on_arrival = False``):

5. **Arrival by contact**: an agent touching (within ``CONTACT_GAP_M``) an agent already
   arrived at the same goal point, which is nearer the point than itself, has arrived too.
   The arrived agents form a packed disc round the point that grows with the queue; the
   walkers in it edge towards the point while there is room and otherwise stand
   (``Simulator._aim_points``). Eq. (3) keeps a margin round every body, so a newcomer
   pressing in stopped short of touching and slid round the disc: 0.25 m counts as
   touching (0.1 m left two of 60 walkers sent to one point circling it for good).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange
from scipy.spatial import cKDTree

from crowdmotion._contact import _off_segment, grid_for
from crowdmotion._threads import threaded
from crowdmotion.geometry import row_norms
from crowdmotion.rvo._kernels import PARALLEL_MIN_AGENTS, _cell_box, _knn, held_up_time
from crowdmotion.rvo.density import PERSON_MAX_RADIUS_M

BLOCKER_CANDIDATES = 6  # nearest neighbours searched for the one in an agent's way
KEEP_RIGHT_LOOK_S = 5.0  # keep right for an oncoming agent met within this many seconds
SQUEEZE_WALL_S = 0.5  # squeezing past an oncoming walker, a wall counts when met within this many seconds
SQUEEZE_SIDE_M = 0.2  # ... one within the sum of radii plus this of our line, either side
SQUEEZE_MAX_RADIUS_M = 0.5  # bodies up to this radius squeeze past (people, SteerSuite's 0.5 m ones too)
SLOW = 0.1             # progress along v_pref below this fraction of pref_speed is "held up"
YIELD_TURN = np.deg2rad(30.0)  # a yielding agent backs away turned this far to its right
YIELD_MAX_S = 10.0
ABREAST_MAX_S = 4.0  # longest wait of one wedged abreast at a door for the other to pass
ABREAST_STILL_S = 1.0  # wedged abreast: both have stood (not crept) this long
CONTACT_GAP_M = 0.25
HEADON_STILL_S = 8.0  # two fronts nose to nose, bound opposite ways, standing this long: a gridlock too
DETOUR_STILL_S = 3.0  # standing (not creeping in a queue) this long, and the blocker too: a gridlock
STILL = 0.05  # below this fraction of pref_speed an agent stands
DETOUR_TURN = np.deg2rad(60.0)  # a gridlocked agent walks this far to the right of its way
ROOM_GAP_M = 0.1  # an agent this near a yielder's way back makes room for it
ROOM_DEPTH = 4    # bodies deep the making of room passes on
WALL_TOUCH_M = 0.05  # a wall this near a body: one stepping back or making room slides along it
# wedged abreast, a yielder that had stood ABREAST_STILL_S + this long when its yield began
# (its last yield left it where it stood: that way back is shut) and stands still steps straight back
ABREAST_SWITCH_S = 1.0
CORNERED_STILL_S = 0.5 * YIELD_MAX_S  # a yielder that stood this long when its yield ran out could not back off


def _turn_right(v: np.ndarray, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([v[:, 0] * c + v[:, 1] * s, -v[:, 0] * s + v[:, 1] * c], axis=1)


def _unit(v: np.ndarray) -> np.ndarray:
    n = row_norms(v)[:, None]
    return np.divide(v, n, out=np.zeros_like(v), where=n > 0)


class Deadlock:
    """Per-agent stand-off state of a Simulator: blocked time, who yields to whom."""

    def __init__(self, keep_right: float, patience: float):
        """``keep_right`` in radians, ``patience`` in seconds (see the module docstring)."""
        self.keep_right = float(keep_right)
        self.patience = float(patience)
        self.stuck = np.zeros(0)
        self.yield_to = np.zeros(0, dtype=np.int64)   # -1: not yielding
        self.yield_left = np.zeros(0)                  # seconds of yielding left
        self.detour = np.zeros(0, dtype=bool)          # gridlocked: walking round to the right
        self.still = np.zeros(0)                       # seconds standing without a break
        self.abreast = np.zeros(0, dtype=bool)         # the yield is to one wedged beside it, bound its way
        self.cornered = np.zeros(0, dtype=bool)        # its last yield went nowhere: the others yield to it

    def grow(self, n: int) -> None:
        """Make room for ``n`` new agents."""
        self.stuck = np.concatenate([self.stuck, np.zeros(n)])
        self.yield_to = np.concatenate([self.yield_to, np.full(n, -1, dtype=np.int64)])
        self.yield_left = np.concatenate([self.yield_left, np.zeros(n)])
        self.detour = np.concatenate([self.detour, np.zeros(n, dtype=bool)])
        self.still = np.concatenate([self.still, np.zeros(n)])
        self.abreast = np.concatenate([self.abreast, np.zeros(n, dtype=bool)])
        self.cornered = np.concatenate([self.cornered, np.zeros(n, dtype=bool)])

    def forget(self, ids: np.ndarray) -> None:
        """Clear the stand-off state of agents ``ids`` (given a new goal or taken out):
        nobody yields to them, and they yield to nobody."""
        self.stuck[ids] = 0.0
        self.yield_to[ids] = -1
        self.yield_left[ids] = 0.0
        self.detour[ids] = False
        self.still[ids] = 0.0
        self.abreast[ids] = False
        self.cornered[ids] = False
        self.yield_to[np.isin(self.yield_to, ids)] = -1

    @staticmethod
    def priority(ids: np.ndarray) -> np.ndarray:
        """A fixed pseudo-random priority per agent id (Knuth's multiplicative hash)."""
        return (np.asarray(ids, dtype=np.uint64) * np.uint64(2654435761)) % np.uint64(2 ** 32)

    def outranks(self, j: np.ndarray, i: np.ndarray) -> np.ndarray:
        """Whether agent j outranks agent i head-on (so i yields): cornered first, then priority."""
        cj, ci = self.cornered[j], self.cornered[i]
        return (cj & ~ci) | ((cj == ci) & (self.priority(j) > self.priority(i)))

    def yielding_velocities(self, pos, wanted, pref_speed, radius, active, grid=None, prims=None) -> np.ndarray:
        """v_pref with yielding agents' replaced by a step back and to the right of the one
        they yield to, and gridlocked agents' turned right by ``DETOUR_TURN``. With
        ``grid`` (``_contact.grid_for`` over the ``active`` agents), the agents in a
        yielder's way back make room for it (rule 4). With ``prims`` (the obstacles
        placed now), those stepping back or making room slide along the walls their
        bodies touch instead of pressing into them (:func:`_along_walls`)."""
        out = np.empty_like(wanted)
        if not _yielding_velocities(pos, wanted, pref_speed, radius, active, self.yield_to, self.detour,
                                    self.abreast, self.still, self.yield_left, _DETOUR_CS[0], _DETOUR_CS[1],
                                    _YIELD_CS[0], _YIELD_CS[1], out):
            return wanted
        if grid is not None:
            _make_room(pos, out, radius, pref_speed, active, self.yield_to, *grid, ROOM_DEPTH, ROOM_GAP_M)
        if prims is not None:
            _along_walls(pos, out, wanted, active, radius, prims.seg_a, prims.seg_b, prims.seg_v, WALL_TOUCH_M)
        return out

    def breaking(self) -> np.ndarray:
        """(N,) agents yielding, walking round a gridlock or standing for the patience:
        they move off briskly."""
        return (self.yield_to >= 0) | self.detour | (self.still >= self.patience)

    def _way(self, wanted: np.ndarray) -> np.ndarray:
        """(N, 2) the way each agent makes progress along: its v_pref, turned right by
        DETOUR_TURN while it walks round a gridlock. Measured along the unturned v_pref, a
        detour walked at 60° plus a sidestep made no progress, so it never ended (Menge's
        circle: one walked 61 m for a 17 m trip, detouring for 88 of its 99 s)."""
        if not self.detour.any():
            return wanted
        way = wanted.copy()
        way[self.detour] = _turn_right(wanted[self.detour], DETOUR_TURN)
        return way

    def update(self, pos, wanted, chosen, pref_speed, radius, sight, active, dt, goals=None) -> int:
        """After a step: held-up time, end of yields, new yields and detours; returns how
        many yields began.

        ``sight`` is each agent's neighbour distance D: how far ahead a blocker counts;
        ``goals`` (N, 2) where each agent is going (detours need them).
        """
        cand = np.empty(len(pos), dtype=np.int64)
        n_cand = _settle(wanted, self._way(wanted), chosen, pos, pref_speed, radius, active, dt, self.patience,
                         self.stuck, self.yield_to, self.yield_left, self.still, self.detour, self.abreast,
                         self.cornered, cand)
        if n_cand == 0:
            return 0
        cand = cand[:n_cand]
        # the blocker is among an agent's nearest neighbours within its D (on a grid of
        # the agents where they now stand; its cell size only sets the search's speed)
        d = np.empty((n_cand, BLOCKER_CANDIDATES))
        k = np.empty((n_cand, BLOCKER_CANDIDATES), dtype=np.int64)
        _nearest(cand, pos, float(sight.max()), *grid_for(pos, active, radius, pref_speed, dt), d, k)
        return _new_yields(cand, d, k, pos, wanted, radius, sight,
                           goals if goals is not None else pos, goals is not None, self.patience, self.stuck,
                           self.yield_to, self.yield_left, self.still, self.detour, self.abreast, self.cornered)

    def update_numpy(self, pos, wanted, chosen, pref_speed, radius, sight, active, dt, goals=None) -> int:
        """:meth:`update` as numpy array operations: the rules as written, the reference
        the compiled :meth:`update` is tested against."""
        held_up_time(self._way(wanted), chosen, pref_speed, active, self.yield_to, SLOW, dt, self.stuck)
        # yields end once the other has walked past, is gone, or after YIELD_MAX_S
        y = np.flatnonzero(self.yield_to >= 0)
        if len(y):
            j = self.yield_to[y]
            self.yield_left[y] -= dt
            past = np.einsum("ij,ij->i", pos[y] - pos[j], _unit(wanted[j])) <= 0
            # one wedged abreast waits until the other is a body ahead of it
            ahead = np.einsum("ij,ij->i", pos[j] - pos[y], _unit(wanted[y])) >= radius[y] + radius[j]
            past = np.where(self.abreast[y], ahead, past)
            done = past | ~active[j] | ~active[y] | (self.yield_left[y] <= 0)
            went_nowhere = ~past & active[j] & active[y] & (self.yield_left[y] <= 0) & ~self.abreast[y] \
                & (self.still[y] >= CORNERED_STILL_S)
            self.cornered[y[went_nowhere]] = True
            self.yield_to[y[done]] = -1
            self.abreast[y[done]] = False
        standing = active & (row_norms(chosen) < STILL * pref_speed)
        self.still = np.where(standing, self.still + dt, 0.0)
        self.detour &= self.stuck >= self.patience / 2  # walking again: back on its way
        self.cornered &= (self.still > 0.0) | (self.stuck > 0.0)  # until it walks freely again
        # new yields: of two agents blocking each other for long, the lower priority steps aside
        cand = np.flatnonzero(self.stuck >= self.patience)
        if len(cand) == 0:
            return 0
        live = np.flatnonzero(active)
        # the blocker is among an agent's nearest neighbours within its D
        d, k = cKDTree(pos[live]).query(pos[cand], k=min(BLOCKER_CANDIDATES + 1, len(live)),
                                        distance_upper_bound=float(sight.max()))
        d, k = np.atleast_2d(d).reshape(len(cand), -1), np.atleast_2d(k).reshape(len(cand), -1)
        found = np.isfinite(d)
        i = np.repeat(cand, found.sum(axis=1))
        j = live[k[found]]
        gap = np.linalg.norm(pos[j] - pos[i], axis=1) - radius[i] - radius[j]
        mutual = (self.stuck[j] >= self.patience / 2) | (self.yield_to[j] >= 0)
        facing = np.einsum("ij,ij->i", _unit(wanted[i]), _unit(wanted[j]))
        blocked = (i != j) & _blocks(pos, wanted, radius, i, j, sight[i]) & mutual
        persons = (radius[i] <= PERSON_MAX_RADIUS_M) & (radius[j] <= PERSON_MAX_RADIUS_M)
        converging = np.zeros(len(i), dtype=bool)
        if goals is not None:
            # rule 3, a gridlock: both standing (not creeping, as a queue does) for
            # DETOUR_STILL_S, the blocker crossing our way from the side and bound elsewhere
            # (not one converging on the same door): walk round to the right
            bound = np.einsum("ij,ij->i", _unit(goals[i] - pos[i]), _unit(goals[j] - pos[j]))
            long = (self.still[i] >= DETOUR_STILL_S) & (self.still[j] >= DETOUR_STILL_S)
            self.detour[i[blocked & long & (np.abs(facing) < 0.5) & (bound < 0.5)]] = True
            front = (self.still[i] >= HEADON_STILL_S) & (self.still[j] >= HEADON_STILL_S)
            self.detour[i[blocked & front & (facing < -0.5) & (bound < -0.5)]] = True
            # two converging on one door at up to 90°, standing as long as a gridlock
            converging = (facing > 0.0) & (bound > 0.5) & persons & long
        # head-on (rule 2), or wedged abreast bound the same way
        walkers = persons & (self.still[i] >= ABREAST_STILL_S) & (self.still[j] >= ABREAST_STILL_S)
        mutual_way = blocked & _blocks(pos, wanted, radius, j, i, sight[j])
        # head-on, only each agent's nearest such blocker counts, whatever its priority
        head = np.flatnonzero(mutual_way & (facing < -0.5))
        head = head[_nearest_per_agent(i[head], gap[head])]
        head = head[self.outranks(j[head], i[head])]
        abreast = np.flatnonzero(mutual_way & (((facing > 0.5) & walkers) | converging)
                                 & (self.priority(j) > self.priority(i)))
        keep = np.concatenate([head, abreast])  # head-on first: it wins a tie
        i, j, gap, facing = i[keep], j[keep], gap[keep], facing[keep]
        if len(i) == 0:
            return 0
        first = _nearest_per_agent(i, gap)  # each yielder steps aside from its nearest blocker
        self.yield_to[i[first]] = j[first]
        self.abreast[i[first]] = facing[first] > 0.0
        self.yield_left[i[first]] = np.where(facing[first] > 0.0, ABREAST_MAX_S, YIELD_MAX_S)
        self.stuck[i[first]] = 0.0
        return len(first)


def _blocks(pos, wanted, radius, i, j, within: float = np.inf) -> np.ndarray:
    """Whether agent j stands in agent i's way: ahead along i's v_pref, within ``within``
    metres of touching, and on i's line (lateral offset under the sum of radii + 0.1 m)."""
    d = pos[j] - pos[i]
    u = _unit(wanted[i])
    ahead = np.einsum("ij,ij->i", d, u)
    lateral = np.abs(u[:, 0] * d[:, 1] - u[:, 1] * d[:, 0])
    reach = radius[i] + radius[j]
    return (ahead > 0) & (ahead < reach + within) & (lateral < reach + 0.1)


def _nearest_per_agent(agent: np.ndarray, gap: np.ndarray) -> np.ndarray:
    """Indices of the rows of least ``gap`` for each ``agent`` (the first of equals)."""
    if len(agent) == 0:
        return np.zeros(0, dtype=np.int64)
    order = np.lexsort((gap, agent))
    return order[np.r_[True, agent[order][1:] != agent[order][:-1]]]


def _pairs(pos, rows, cols, reach) -> np.ndarray:
    """(K, 2) agent pairs (one of ``rows``, one of ``cols``) whose centres are within ``reach``."""
    m = cKDTree(pos[rows]).sparse_distance_matrix(cKDTree(pos[cols]), reach, output_type="ndarray")
    return np.stack([rows[m["i"]], cols[m["j"]]], axis=1)


def contact_arrivals(pos, goals, dist, radius, waiting, arrived) -> np.ndarray:
    """(N,) agents that arrive by touching an arrived agent of the same goal point nearer it."""
    out = np.zeros(len(pos), dtype=bool)
    w = np.flatnonzero(waiting)
    a = np.flatnonzero(arrived)
    if len(w) == 0 or len(a) == 0:
        return out
    pairs = _pairs(pos, w, a, 2 * radius.max() + CONTACT_GAP_M)
    i, j = pairs[:, 0], pairs[:, 1]
    touching = np.linalg.norm(pos[j] - pos[i], axis=1) <= radius[i] + radius[j] + CONTACT_GAP_M
    same = np.all(goals[j] == goals[i], axis=1)
    out[i[touching & same & (dist[j] < dist[i])]] = True
    return out


# ---- the rules compiled: one pass over the agents instead of dozens of array operations -------------
_DETOUR_CS = (float(np.cos(DETOUR_TURN)), float(np.sin(DETOUR_TURN)))
_YIELD_CS = (float(np.cos(YIELD_TURN)), float(np.sin(YIELD_TURN)))
_HASH = 2654435761  # Deadlock.priority's multiplier


@njit(inline="always")
def _unit2(x, y):
    """(x, y) / its length, or (0, 0): ``_unit`` for one vector."""
    n = np.sqrt(x * x + y * y)
    if n > 0.0:
        return x / n, y / n
    return 0.0, 0.0


@njit(inline="always")
def _blocks2(pos, wanted, radius, i, j, within):
    """``_blocks`` for one pair: j in i's way."""
    dx, dy = pos[j, 0] - pos[i, 0], pos[j, 1] - pos[i, 1]
    ux, uy = _unit2(wanted[i, 0], wanted[i, 1])
    ahead = dx * ux + dy * uy
    lateral = abs(ux * dy - uy * dx)
    reach = radius[i] + radius[j]
    return ahead > 0.0 and ahead < reach + within and lateral < reach + 0.1


@njit(inline="always")
def _priority(i):
    return (np.uint64(i) * np.uint64(_HASH)) & np.uint64(0xFFFFFFFF)


@njit(inline="always")
def _outranks(j, i, cornered):
    """:meth:`Deadlock.outranks` for one pair."""
    if cornered[j] != cornered[i]:
        return cornered[j]
    return _priority(j) > _priority(i)


@njit(cache=True)
def _yielding_velocities(pos, wanted, pref_speed, radius, active, yield_to, detour, abreast, still, yield_left, dc, ds,
                         yc, ys, out):
    """:meth:`Deadlock.yielding_velocities` into ``out``; False (``out`` untouched) if
    nobody yields or detours."""
    n = pos.shape[0]
    anyone = False
    for i in range(n):
        if active[i] and (yield_to[i] >= 0 or detour[i]):
            anyone = True
            break
    if not anyone:
        return False
    for i in range(n):
        wx, wy = wanted[i, 0], wanted[i, 1]
        out[i, 0], out[i, 1] = wx, wy
        if not active[i]:
            continue
        j = yield_to[i]
        if j < 0:
            if detour[i]:
                out[i, 0], out[i, 1] = wx * dc + wy * ds, -wx * ds + wy * dc
            continue
        ax, ay = _unit2(pos[i, 0] - pos[j, 0], pos[i, 1] - pos[j, 1])
        if not _blocks2(pos, wanted, radius, j, i, np.inf):  # out of the other's way: wait
            out[i, 0], out[i, 1] = 0.0, 0.0
        elif abreast[i]:  # wedged beside it: step back along our way and away from it ...
            ux, uy = _unit2(wx, wy)
            if still[i] - (ABREAST_MAX_S - yield_left[i]) >= ABREAST_STILL_S + ABREAST_SWITCH_S:
                ax, ay = 0.0, 0.0  # ... or straight back if it stood that long when the yield began, and since
            bx, by = _unit2(ax - ux, ay - uy)
            out[i, 0], out[i, 1] = 0.5 * bx * pref_speed[i], 0.5 * by * pref_speed[i]
        else:  # head-on: back off, turned to the right
            out[i, 0] = (ax * yc + ay * ys) * pref_speed[i]
            out[i, 1] = (-ax * ys + ay * yc) * pref_speed[i]
    return True


@njit(cache=True)
def _make_room(pos, out, radius, pref_speed, active, yield_to, cell_start, items, origin_x, origin_y, h,
               nx, ny, depth, gap_max):
    """Rule 4, in place on ``out`` (v_pref after the yields): an agent (not yielding)
    within ``gap_max`` of a yielder's body, ahead along the yielder's step back and on its
    line (lateral offset under the sum of radii + ``gap_max``: a body the step back would
    graze counts), steps back the same way at half its preferred speed; so do those in
    its own way back, up to ``depth`` bodies from the yielder. Returns how many make room."""
    n = pos.shape[0]
    taken = np.zeros(n, dtype=np.bool_)  # given a way back already (or yielding)
    bx = np.zeros(n)
    by = np.zeros(n)
    front = np.empty(n, dtype=np.int64)
    nxt = np.empty(n, dtype=np.int64)
    m = 0
    for i in range(n):
        if active[i] and yield_to[i] >= 0:
            taken[i] = True
            ux, uy = _unit2(out[i, 0], out[i, 1])
            if ux != 0.0 or uy != 0.0:
                bx[i], by[i] = ux, uy
                front[m] = i
                m += 1
    moved = 0
    for _ in range(depth):
        k_n = 0
        for f in range(m):
            i = front[f]
            # the grid's cells are wider than a body and the gap: those next to i's hold them all
            gx0, gx1, gy0, gy1 = _cell_box(pos[i, 0], pos[i, 1], h, origin_x, origin_y, h, nx, ny)
            for cx in range(gx0, gx1 + 1):
                for q in range(cell_start[cx * ny + gy0], cell_start[cx * ny + gy1 + 1]):
                    k = items[q]
                    if taken[k] or not active[k]:
                        continue
                    dx, dy = pos[k, 0] - pos[i, 0], pos[k, 1] - pos[i, 1]
                    reach = radius[i] + radius[k]
                    if (dx * bx[i] + dy * by[i] <= 0.0 or abs(bx[i] * dy - by[i] * dx) >= reach + gap_max
                            or np.sqrt(dx * dx + dy * dy) - reach > gap_max):
                        continue
                    taken[k] = True
                    bx[k], by[k] = bx[i], by[i]
                    out[k, 0], out[k, 1] = 0.5 * pref_speed[k] * bx[i], 0.5 * pref_speed[k] * by[i]
                    nxt[k_n] = k
                    k_n += 1
        moved += k_n
        front, nxt = nxt, front
        m = k_n
        if m == 0:
            break
    return moved


@njit(cache=True)
def _settle(wanted, way, chosen, pos, pref_speed, radius, active, dt, patience, stuck, yield_to, yield_left, still,
            detour, abreast, cornered, cand):
    """The first part of :meth:`Deadlock.update`, in place: held-up time (along ``way``:
    :meth:`Deadlock._way`), ends of yields, standing time and ends of detours; writes the
    agents held up for the patience (the candidates to yield) into ``cand`` and returns
    how many."""
    held_up_time(way, chosen, pref_speed, active, yield_to, SLOW, dt, stuck)
    n = pos.shape[0]
    for i in range(n):  # yields end once the other has walked past, is gone, or after YIELD_MAX_S
        j = yield_to[i]
        if j < 0:
            continue
        yield_left[i] -= dt
        if abreast[i]:  # one wedged abreast waits until the other is a body ahead of it
            ux, uy = _unit2(wanted[i, 0], wanted[i, 1])
            past = (pos[j, 0] - pos[i, 0]) * ux + (pos[j, 1] - pos[i, 1]) * uy >= radius[i] + radius[j]
        else:
            ux, uy = _unit2(wanted[j, 0], wanted[j, 1])
            past = (pos[i, 0] - pos[j, 0]) * ux + (pos[i, 1] - pos[j, 1]) * uy <= 0.0
        if past or not active[j] or not active[i] or yield_left[i] <= 0.0:
            if not past and active[j] and active[i] and not abreast[i] and still[i] >= CORNERED_STILL_S:
                cornered[i] = True  # its yield ran out where it stood: it could not back off
            yield_to[i] = -1
            abreast[i] = False
    half = patience / 2
    n_cand = 0
    for i in range(n):
        cx, cy = chosen[i, 0], chosen[i, 1]
        if active[i] and np.sqrt(cx * cx + cy * cy) < STILL * pref_speed[i]:
            still[i] = still[i] + dt
        else:
            still[i] = 0.0
        if detour[i] and not stuck[i] >= half:  # walking again: back on its way
            detour[i] = False
        if cornered[i] and still[i] == 0.0 and not stuck[i] > 0.0:  # walking freely again
            cornered[i] = False
        if stuck[i] >= patience:
            cand[n_cand] = i
            n_cand += 1
    return n_cand


@threaded(min_items=PARALLEL_MIN_AGENTS)
def _nearest(cand, pos, dmax, cell_start, items, origin_x, origin_y, h, nx, ny, d, k):
    """Each candidate's ``d.shape[1]`` nearest other agents within ``dmax`` (as cKDTree's
    query of the agents would give them, less the agent itself): their distances, nearest
    first, into ``d`` (inf where fewer), their ids into ``k``."""
    m = d.shape[1]
    block = 64
    for blk in prange((cand.shape[0] + block - 1) // block):
        idx = np.empty(m, dtype=np.int64)  # scratch once per block of candidates
        d2 = np.empty(m)
        for r in range(blk * block, min(cand.shape[0], (blk + 1) * block)):
            found = _knn(cand[r], pos, m, dmax, cell_start, items, origin_x, origin_y, h, nx, ny, idx, d2)
            for q in range(m):
                if q < found:
                    d[r, q] = np.sqrt(d2[q])
                    k[r, q] = idx[q]
                else:
                    d[r, q] = np.inf
                    k[r, q] = 0


@njit(cache=True)
def _new_yields(cand, d, k, pos, wanted, radius, sight, goals, use_goals, patience, stuck, yield_to,
                yield_left, still, detour, abreast, cornered):
    """The second part of :meth:`Deadlock.update`: of the candidates' nearest neighbours
    (``d``, ``k`` as :func:`_nearest` gives them: distances, agent ids), detours round gridlocks
    and new yields, each yielder to its nearest blocker. All decisions read the state from
    before any of them; returns how many yields began."""
    half = patience / 2
    n_c, m = k.shape
    pick = np.empty(n_c, dtype=np.int64)
    side = np.zeros(n_c, dtype=np.bool_)  # the pick is wedged abreast, bound our way
    for r in range(n_c):
        i = cand[r]
        pick[r] = -1
        best_gap = np.inf
        head_j = -1  # the nearest blocker head-on, whatever its priority
        head_gap = np.inf
        fx, fy = _unit2(wanted[i, 0], wanted[i, 1])
        gix, giy = _unit2(goals[i, 0] - pos[i, 0], goals[i, 1] - pos[i, 1])
        for c in range(m):
            if not np.isfinite(d[r, c]):
                continue
            j = k[r, c]
            if i == j:
                continue
            if not ((stuck[j] >= half) or (yield_to[j] >= 0)):
                continue
            if not _blocks2(pos, wanted, radius, i, j, sight[i]):
                continue
            ox, oy = _unit2(wanted[j, 0], wanted[j, 1])
            facing = fx * ox + fy * oy
            bound = 0.0  # (without goals, not known to be bound for the same place)
            if use_goals:
                # rule 3, a gridlock: both standing (not creeping, as a queue does) for
                # DETOUR_STILL_S, the blocker crossing our way from the side and bound
                # elsewhere (not one converging on the same door): walk round to the right
                gjx, gjy = _unit2(goals[j, 0] - pos[j, 0], goals[j, 1] - pos[j, 1])
                bound = gix * gjx + giy * gjy
                if (still[i] >= DETOUR_STILL_S and still[j] >= DETOUR_STILL_S and abs(facing) < 0.5
                        and bound < 0.5):
                    detour[i] = True
                if (still[i] >= HEADON_STILL_S and still[j] >= HEADON_STILL_S and facing < -0.5
                        and bound < -0.5):
                    detour[i] = True
            # head-on (rule 2), or wedged abreast bound the same way
            # (converging on one door at up to 90°: only once both have stood as long as a gridlock)
            wait = ABREAST_STILL_S if facing > 0.5 else DETOUR_STILL_S
            abreast_ok = ((facing > 0.5 or (facing > 0.0 and bound > 0.5)) and radius[i] <= PERSON_MAX_RADIUS_M
                          and radius[j] <= PERSON_MAX_RADIUS_M and still[i] >= wait and still[j] >= wait)
            if not ((facing < -0.5 or abreast_ok) and _blocks2(pos, wanted, radius, j, i, sight[j])):
                continue
            dx, dy = pos[j, 0] - pos[i, 0], pos[j, 1] - pos[i, 1]
            gap = np.sqrt(dx * dx + dy * dy) - radius[i] - radius[j]
            if facing < -0.5:
                if gap < head_gap:
                    head_gap, head_j = gap, j
                continue
            if _priority(j) > _priority(i) and gap < best_gap:  # abreast: its nearest (the first of equals)
                best_gap = gap
                pick[r] = j
                side[r] = True
        # head-on, only the nearest counts: the one facing us yields, or we do (by priority); yielding
        # to one behind it, while it yielded to one behind us, left both fronts waiting for good
        if head_j >= 0 and _outranks(head_j, i, cornered) and head_gap <= best_gap:
            pick[r] = head_j
            side[r] = False
    count = 0
    for r in range(n_c):
        if pick[r] >= 0:
            i = cand[r]
            yield_to[i] = pick[r]
            abreast[i] = side[r]
            yield_left[i] = ABREAST_MAX_S if side[r] else YIELD_MAX_S
            stuck[i] = 0.0
            count += 1
    return count


@njit(cache=True)
def _along_walls(pos, out, wanted, active, radius, seg_a, seg_b, seg_v, touch):
    """Agents stepping back or making room (``out`` not their ``wanted``, and moving)
    slide along the static walls (segments) within ``touch`` metres of their bodies: the
    part of ``out`` into each such wall is taken away, in place. A yielder pressed on a
    door's wall or corner otherwise steps into it, the obstacle constraint leaves it
    standing, and the arch it is part of stands too."""
    for i in range(pos.shape[0]):
        vx, vy = out[i, 0], out[i, 1]
        if not active[i] or (vx == wanted[i, 0] and vy == wanted[i, 1]) or (vx == 0.0 and vy == 0.0):
            continue
        px, py, r = pos[i, 0], pos[i, 1], radius[i]
        for o in range(seg_a.shape[0]):
            if seg_v[o, 0] != 0.0 or seg_v[o, 1] != 0.0:
                continue
            nx, ny = _off_segment(px, py, seg_a[o, 0], seg_a[o, 1], seg_b[o, 0], seg_b[o, 1])
            d = np.sqrt(nx * nx + ny * ny)
            if d <= 0.0 or d > r + touch:
                continue
            nx, ny = nx / d, ny / d
            into = vx * nx + vy * ny
            if into < 0.0:
                vx, vy = vx - into * nx, vy - into * ny
        out[i, 0], out[i, 1] = vx, vy
