"""A first-come-first-served queue while it runs: who is in line in what order, who is
walking up to its end, and the service at its head (one at a time, at a rate)."""

from __future__ import annotations

import numpy as np

from crowdmotion.groups import Points
from crowdmotion.stages import Queue

REACH_SLACK_M = 0.1  # service starts once the first in line is within one spacing (and this) of the head
OVERTAKEN_S = 5.0  # a first in line kept out of reach this long, while a later one stands within reach, loses its turn


def wait_row(waits: np.ndarray) -> dict:
    """The mean and longest of some waits in line (s), None without any."""
    return {"mean_wait_s": float(waits.mean()) if len(waits) else None,
            "max_wait_s": float(waits.max()) if len(waits) else None}


class ServiceQueue:
    """One queue of a run: its places, the agents in line (``members``, first the head,
    in the order they joined) and those walking to its end (``approaching``).

    Parameters
    ----------
    stage : Queue
        Where it is and how fast it serves.
    places : int
        How many places in line it lays out (the most agents that may queue at once).
    """

    def __init__(self, stage: Queue, places: int):
        self.stage = stage
        self.slots = stage.slots(max(int(places), 1))
        self.region = Points(self.slots)  # the guidance field of the whole line: solved once
        self.members: list[int] = []
        self.approaching = np.zeros(0, dtype=np.int64)
        self.serving = False
        self.service_end = -np.inf  # when the service under way ends (or the last ended), seconds
        self.joined_at: dict[int, float] = {}
        self.served: list[tuple[int, float, float]] = []  # (agent, joined, released), in service order
        self.stalled_since = np.inf  # since when the first in line stands out of reach while a later one is within
        self.lengths: list[tuple[float, int]] = []       # (second, agents in line), sampled

    @property
    def tail(self) -> np.ndarray:
        """The first free place: where an agent joining now stands."""
        return self.slots[min(len(self.members), len(self.slots) - 1)]

    @property
    def bound(self) -> int:
        """Agents in line or walking to it."""
        return len(self.members) + len(self.approaching)

    def grow(self, more: int) -> None:
        """Lay out ``more`` places in line beyond those there are (a new field for the line)."""
        self.slots = self.stage.slots(len(self.slots) + max(int(more), 0))
        self.region = Points(self.slots)

    def remove(self, agents) -> bool:
        """Take ``agents`` out of the line and off the way to it (rerouted or gone); a
        head being served is no longer. True if the line itself changed."""
        agents = np.asarray(agents, dtype=np.int64)
        self.approaching = self.approaching[~np.isin(self.approaching, agents)]
        drop = set(agents.tolist())
        out = [a for a in self.members if a in drop]
        if not out:
            return False
        if self.serving and self.members[0] in drop:
            self.serving = False
        self.members = [a for a in self.members if a not in drop]
        for a in out:
            self.joined_at.pop(a, None)
        return True

    def approach(self, agents: np.ndarray) -> None:
        """``agents`` walk to the end of the line (they join on arriving there)."""
        self.approaching = np.concatenate([self.approaching, np.asarray(agents, dtype=np.int64)])

    def join(self, agents: np.ndarray, positions: np.ndarray, time: float) -> np.ndarray:
        """Approaching ``agents`` that reached the end join the line, nearest the end first
        (ties by id); returns their places (K, 2) in that order, and ``agents`` reordered."""
        agents = np.asarray(agents, dtype=np.int64)
        order = np.lexsort((agents, np.linalg.norm(positions - self.tail, axis=1)))
        agents = agents[order]
        self.approaching = self.approaching[~np.isin(self.approaching, agents)]
        start = len(self.members)
        self.members.extend(int(a) for a in agents)
        for a in agents:
            self.joined_at[int(a)] = time
        return agents, self.slots[np.minimum(np.arange(start, start + len(agents)), len(self.slots) - 1)]

    def places(self) -> np.ndarray:
        """(len(members), 2) each member's place in line now."""
        return self.slots[np.minimum(np.arange(len(self.members)), len(self.slots) - 1)]

    def along(self, points: np.ndarray) -> np.ndarray:
        """(K,) how far back along the line from the head each of ``points`` (K, 2)
        stands: its projection onto the polyline through the places, metres."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        if len(self.slots) < 2:
            return np.linalg.norm(points - self.slots[0], axis=1)
        a, b = self.slots[:-1], self.slots[1:]
        ab = b - a
        length = np.linalg.norm(ab, axis=1)
        start = np.concatenate([[0.0], np.cumsum(length)[:-1]])
        rel = points[:, None, :] - a[None]
        t = np.clip((rel * ab[None]).sum(axis=2) / np.maximum(length * length, 1e-12)[None], 0.0, 1.0)
        gap = np.linalg.norm(rel - t[..., None] * ab[None], axis=2)
        k = np.argmin(gap, axis=1)
        return start[k] + t[np.arange(len(points)), k] * length[k]

    def reorder_overtaken(self, positions: np.ndarray, radii: np.ndarray, time: float) -> bool:
        """Let the first in line lose its turn to those it stands behind, once it has stood
        out of reach of the head for ``OVERTAKEN_S`` seconds while a later member stood
        within reach (``positions`` (len(members), 2) and ``radii`` (len(members),): the
        members', in line order). It moves back behind every member that stands ahead of
        it along the line by more than their two radii (a body's width: not beside it);
        the others keep their order. A first in line pushed out of a single-file gate and
        overtaken there cannot pass those now before it, who stand on their places:
        without this the line waited for it for good. Only while no one is being served.
        True if the order changed."""
        if self.serving or len(self.members) < 2:
            self.stalled_since = np.inf
            return False
        positions = np.asarray(positions, dtype=float)
        reach = self.stage.spacing + REACH_SLACK_M
        off = np.linalg.norm(positions - self.stage.head, axis=1)
        if off[0] <= reach or not (off[1:] <= reach).any():
            self.stalled_since = np.inf
            return False
        self.stalled_since = min(self.stalled_since, time)
        if time - self.stalled_since < OVERTAKEN_S - 1e-9:
            return False
        self.stalled_since = np.inf
        along = self.along(positions)
        ahead = along[0] - along[1:] > radii[0] + np.asarray(radii, dtype=float)[1:]
        if not ahead.any():
            return False
        first, rest = self.members[0], self.members[1:]
        self.members = ([a for a, before in zip(rest, ahead) if before] + [first]
                        + [a for a, before in zip(rest, ahead) if not before])
        return True

    def release(self, time: float) -> int | None:
        """The head whose service has ended by ``time``, now out of line (the others
        move up a place), or None."""
        if not (self.serving and time + 1e-9 >= self.service_end):
            return None
        released = self.members.pop(0)
        self.served.append((released, self.joined_at.pop(released), time))
        self.serving = False
        return released

    def start(self, time: float, head_position: np.ndarray, just_freed: bool) -> bool:
        """Start serving the first in line if it stands within one spacing of the head
        (``head_position``: where it stands): from the end of the last service when the
        counter was freed this very step, so a full line passes ``rate`` persons per
        second whatever the time step, else from ``time``."""
        if self.serving or not self.members:
            return False
        if np.linalg.norm(head_position - self.stage.head) > self.stage.spacing + REACH_SLACK_M:
            return False
        begin = self.service_end if just_freed else time
        self.service_end = begin + 1.0 / self.stage.rate
        self.serving = True
        return True

    def sample(self, time: float, dt: float) -> None:
        """Record the line's length at each whole second passed in the last step."""
        for second in range(int(np.floor(time - dt + 1e-9)) + 1, int(np.floor(time + 1e-9)) + 1):
            if second >= 0:
                self.lengths.append((float(second), len(self.members)))

    def report(self) -> dict:
        """For summary.json: agents served, the mean and longest wait in line (joining
        to release, s), the service interval (s), the line's length each second, and the
        waits over time: when each agent was served (``served_s``) and how long it had
        waited in line (``wait_s``), in service order."""
        waits = np.array([r - j for _, j, r in self.served])
        released = np.array([r for _, _, r in self.served])
        return {"served": len(self.served), "still_in_line": len(self.members), **wait_row(waits),
                "mean_service_interval_s": float(np.diff(released).mean()) if len(released) > 1 else None,
                "length_per_s": [n for _, n in self.lengths],
                "served_s": released.tolist(), "wait_s": waits.tolist()}
