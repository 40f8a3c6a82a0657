"""Recording a live RVO simulation as :class:`~crowdmotion.trajectories.Trajectories`: what a
game or robot controller that steps :class:`~crowdmotion.rvo.simulator.Simulator` itself
hands to the audit, the exports and the player.

``rec = Recorder(sim)`` takes the frame now; ``rec.record()`` after each ``sim.step()``
takes the next. ``rec.trajectories()`` gives every agent the simulator ever held, those
added later absent (``active`` False) in the frames before they came in, each shown
where it first stood; the scene with every obstacle that stood and when
(``metadata["scene"]``, so the HTML player and the audit see each in its own frames);
and, by default, the steps relaxed for the characters that play them, as ``rvo.simulate``
relaxes its runs (``RVOParams.smoothing``; :func:`crowdmotion.path_relaxation.relaxed_steps`).
An agent moved by ``place()`` jumps: ``metadata["jumps"]`` lists ``[time, agent]`` (the
time of the frame it leaves, seconds from the first frame), and the continuous-time audit
(:func:`crowdmotion.metrics.collision_audit`), path lengths and speeds do not take that
frame's move as walked; the relaxation keeps such an agent's own path.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from crowdmotion.rvo.personality import personality_metadata
from crowdmotion.trajectories import Trajectories, held_absent

#: seconds of the moving average the relaxed steps are drawn towards (``RVOParams.smoothing_window``)
SMOOTHING_WINDOW_S = 1.0


class Recorder:
    """The frames of a live :class:`~crowdmotion.rvo.simulator.Simulator`, one per step.

    ``Recorder(sim)`` records the simulator's state now; call :meth:`record` after every
    ``sim.step()`` (a frame missed or taken twice is refused: the frames are one step
    apart). Memory: 17 bytes per agent and frame while recording."""

    def __init__(self, sim):
        self.sim = sim
        self._positions: list[np.ndarray] = []
        self._present: list[np.ndarray] = []
        self._steps: list[int] = []
        self._jumps: list[tuple[int, int]] = []  # (frame the jump leaves, agent) of each place()
        self._placed = len(sim.placements)  # place() calls seen so far (earlier ones are in the first frame)
        self.record()

    def record(self) -> None:
        """Take the frame of the simulator's state now (after a ``step()``)."""
        steps = self.sim.steps
        if self._steps and steps != self._steps[-1] + 1:
            raise ValueError(f"Recorder.record: the simulator is at step {steps} and the last frame was taken at step "
                             f"{self._steps[-1]}: record once after every step()")
        for at, ids in self.sim.placements[self._placed:]:
            if self._steps and at == self._steps[-1]:  # placed after the last frame: it jumps on the way to this one
                self._jumps += [(len(self._steps) - 1, int(i)) for i in ids]
        self._placed = len(self.sim.placements)
        self._positions.append(self.sim.positions.copy())
        self._present.append(self.sim.present.copy())
        self._steps.append(steps)

    @property
    def n_frames(self) -> int:
        return len(self._steps)

    def trajectories(self, smoothing: Literal["relaxed", "none"] = "relaxed",
                     window_s: float = SMOOTHING_WINDOW_S) -> Trajectories:
        """The frames so far as Trajectories (one per step, ``dt`` the simulator's step).

        ``smoothing = "relaxed"`` (default) relaxes the steps for characters over
        ``window_s`` seconds, as a scenario's RVO run is; ``"none"`` keeps them as
        stepped (what ``step()`` gave, for analysis). Groups are named after the
        ``add_agents`` call that added each agent ("agents 0", "agents 1", ...)."""
        if smoothing not in ("relaxed", "none"):
            raise ValueError(f"smoothing must be 'relaxed' or 'none', got {smoothing!r}")
        if not (np.isfinite(window_s) and window_s > 0):
            raise ValueError(f"window_s must be a positive number of seconds, got {window_s!r}")
        sim = self.sim
        n = sim.n_agents
        frames = np.zeros((self.n_frames, n, 2))
        present = np.zeros((self.n_frames, n), dtype=bool)
        for f, (pos, here) in enumerate(zip(self._positions, self._present)):
            frames[f, :len(pos)] = pos
            present[f, :len(here)] = here
        # before an agent was added (or while it waited off-scene) it is drawn where it first stood
        held_absent(frames, present)
        metadata = {"method": "rvo", "live": True, "scene": sim.scene.to_dict(), "steps": int(self._steps[-1]),
                    "jumps": [[f * sim.dt, i] for f, i in self._jumps],
                    "first_step": int(self._steps[0]), "stats": dict(sim.stats),
                    **personality_metadata(sim.personality)}
        traj = Trajectories(frames, sim.dt, group=np.array([f"agents {g}" for g in sim.group], dtype=object),
                            radius=sim.params["radius"], active=None if present.all() else present, metadata=metadata)
        if smoothing == "relaxed":
            from crowdmotion.path_relaxation import relaxed_steps

            traj = relaxed_steps(traj, window_s, sim.scene, sim.params["max_speed"])
        return traj
