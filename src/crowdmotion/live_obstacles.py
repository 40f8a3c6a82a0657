"""Obstacles put in, moved and taken out while a stepping simulator runs (a door that
opens, a barrier): the live API the RVO and formation simulators share."""

from __future__ import annotations

import numpy as np

from crowdmotion.geometry import finite_array
from crowdmotion.scene import Box, Circle, Obstacle, Polygon, Scene


class LiveObstacles:
    """``add_obstacle``, ``remove_obstacle`` and ``move_obstacle`` for a stepping
    simulator, with the checks a scenario's obstacles get.

    ``scene`` keeps every obstacle that ever stood, each with its time window
    (:meth:`crowdmotion.scene.Obstacle.during`), so that an audit or a player of the run
    sees each where and when it stood; the caller's scene is never changed (the
    simulator takes its own copy at the first edit). :attr:`scene_now` is the scene as
    it stands now, what the simulator steps in.

    The simulator sets ``scene``, ``_now`` (the scene, at first), ``_scene_owned``
    (False), and keeps ``time``, ``steps`` and ``dt``; it provides:

    - ``_bodies() -> (ids, positions, radii)``: the agents in the scene now, which an
      obstacle may not be put on;
    - ``_obstacles_rebuilt(now)``: rebuild what the obstacles standing now shape
      (contact primitives, fields); nothing may fail here;
    - ``_obstacles_check()``: re-solve what a new obstacle may make impossible (a goal
      it covers), raising ValueError; called after an obstacle went in, which is then
      taken out again.
    """

    scene: Scene
    _now: Scene
    _scene_owned: bool
    time: float
    steps: int
    dt: float

    @property
    def scene_now(self) -> Scene:
        """The scene as it stands now: the obstacles present now, each for good."""
        return self._now

    def _clearance(self, points: np.ndarray) -> np.ndarray:
        """Metres from each point to the nearest wall or static obstacle standing now."""
        return self._now.clearance(points)

    def add_obstacle(self, obstacle: Obstacle) -> int:
        """Put an obstacle into the scene now (the live API: a door that closes, a barrier);
        returns its index in ``scene.obstacles``. A ValueError, changing nothing, if it is
        not a 2D shape, lies wholly outside the scene's bounds (nobody would meet it: an
        obstacle moved out of the way is taken out with :meth:`remove_obstacle`), any
        agent still walking stands within its radius of it, or it covers an agent's goal."""
        self._check_new_obstacle(obstacle)
        return self._put_in(obstacle)

    def _put_in(self, obstacle: Obstacle) -> int:
        """:meth:`add_obstacle` for one its first checks passed: in, and out again (a
        ValueError) if it covers a goal."""
        scene = self._own_scene()
        scene.obstacles.append(obstacle.during(self._clock(), np.inf))
        self._obstacles_changed()
        try:
            self._obstacles_check()  # a goal it covers, or a way it closes for good, shows here
        except ValueError as exc:
            scene.obstacles.pop()
            self._obstacles_changed()
            raise ValueError(f"add_obstacle: {obstacle!r} cannot go in: {exc}") from None
        return len(scene.obstacles) - 1

    def _check_new_obstacle(self, obstacle) -> None:
        """:meth:`add_obstacle`'s checks that need nothing changed first: the shape, the
        bounds and the agents it would stand on (ValueError; :meth:`move_obstacle` runs
        them before it takes the old one out)."""
        if not isinstance(obstacle, Obstacle):
            raise ValueError(f"add_obstacle: a Circle, Box or Polygon is needed, got {obstacle!r}")
        if obstacle.dim != 2 or obstacle.is_timed:
            raise ValueError(f"add_obstacle: a 2D obstacle that stands from now on is needed, got {obstacle!r}")
        lo, hi = obstacle.bounds()
        if np.any(hi <= self.scene.lower) or np.any(lo >= self.scene.upper):
            raise ValueError(f"add_obstacle: {obstacle!r} lies wholly outside the scene's bounds "
                             f"{self.scene.lower.tolist()}-{self.scene.upper.tolist()}; remove_obstacle takes "
                             "one out of the scene")
        live, pos, rad = self._bodies()
        clear = obstacle.signed_distance(pos - obstacle.offset(self.time)) - rad
        if len(live) and clear.min() < 0:
            k = int(np.argmin(clear))
            raise ValueError(f"add_obstacle: agent {int(live[k])} at {np.round(pos[k], 3).tolist()} "
                             f"would stand inside {obstacle!r} (penetration {-clear[k]:.3f} m)")

    def remove_obstacle(self, index: int) -> None:
        """Take obstacle ``index`` of ``scene.obstacles`` out of the scene now (the live API:
        a door that opens). ``scene`` keeps it, with the time it stood, for the audit."""
        self._obstacle_index(index, "remove_obstacle")
        if not self.scene.obstacles[index].present_at(self._clock()):
            raise ValueError(f"remove_obstacle: obstacle {index} is not in the scene now")
        self._take_out(index)
        self._obstacles_changed()

    def _take_out(self, index: int) -> None:
        """Obstacle ``index`` (standing now) ends now, in ``scene``; what the obstacles
        shape is not rebuilt yet."""
        scene = self._own_scene()
        old = scene.obstacles[index]
        scene.obstacles[index] = old.during(old.present[0], self._clock())

    def move_obstacle(self, index: int, to) -> int:
        """Move obstacle ``index`` of ``scene.obstacles`` now (the live API: a barrier
        pushed aside): ``to`` is the obstacle in its new place (a Circle, Box or Polygon)
        or an offset (dx, dy) of the old one. Done as :meth:`remove_obstacle` then
        :meth:`add_obstacle`, with their checks (what the obstacles shape is rebuilt
        once): a ValueError, changing nothing (the run goes on exactly as without the
        call), if the obstacle is not in the scene now or
        moves along a path, or if in its new place it is no 2D shape at rest, lies wholly
        outside the bounds or an agent still walking would stand inside it. One that would
        cover an agent's goal is put back where it stood, with a ValueError too; the
        fields are then rebuilt, as for any change of the obstacles. ``scene``
        keeps the old one, standing until now, and the moved one from now on, so the audit
        and the player see each where it stood; returns the moved one's index."""
        obs = self.scene.obstacles
        self._obstacle_index(index, "move_obstacle")
        old = obs[index]
        if not old.present_at(self._clock()):
            raise ValueError(f"move_obstacle: obstacle {index} is not in the scene now")
        if old.is_moving:
            raise ValueError(f"move_obstacle: obstacle {index} moves along its path; it cannot be moved as well")
        new = to if isinstance(to, Obstacle) else shifted(old, to)
        moved = f"move_obstacle: obstacle {index} moved,"
        try:  # refused before anything changes: the fields and the run go on as they were
            self._check_new_obstacle(new)
        except ValueError as exc:
            raise ValueError(str(exc).replace("add_obstacle:", moved, 1)) from None
        self._take_out(index)  # (rebuilt once, as the moved one goes in)
        try:
            return self._put_in(new)
        except ValueError as exc:  # a goal it would cover: put back as it stood, the fields rebuilt
            self.scene.obstacles[index] = old
            self._obstacles_changed()
            raise ValueError(str(exc).replace("add_obstacle:", moved, 1)) from None

    def _obstacle_index(self, index, what: str) -> None:
        """Refuse an index that names no obstacle of ``scene.obstacles``."""
        n = len(self.scene.obstacles)
        if isinstance(index, (bool, np.bool_)) or not isinstance(index, (int, np.integer)):
            raise ValueError(f"{what}: the obstacle index must be an int (add_obstacle returns it), got "
                             f"{index!r} ({type(index).__name__})")
        if not 0 <= index < n:
            raise ValueError(f"{what}: no obstacle {index!r} (indices run from 0 to {n - 1})")

    def _clock(self) -> float:
        """The time now as frames count it (steps × dt), so windows match ``Trajectories.times``."""
        return self.steps * self.dt

    def _own_scene(self) -> Scene:
        """The simulator's own copy of the scene (the caller's is never changed)."""
        if not self._scene_owned:
            self.scene = Scene((self.scene.lower, self.scene.upper), list(self.scene.obstacles))
            self._scene_owned = True
        return self.scene

    def _obstacles_changed(self) -> None:
        """The scene standing now, and what its obstacles shape, rebuilt."""
        self._now = self.scene.at_time(self._clock())
        self._obstacles_rebuilt(self._now)

    # provided by the simulator
    def _bodies(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - overridden
        raise NotImplementedError

    def _obstacles_rebuilt(self, now: Scene) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def _obstacles_check(self) -> None:  # pragma: no cover - overridden
        raise NotImplementedError


def shifted(obstacle: Obstacle, offset) -> Obstacle:
    """A fresh copy of a 2D obstacle at rest, moved by ``offset`` (dx, dy)."""
    d = finite_array(offset, "move_obstacle: offset")
    if d.shape != (2,):
        raise ValueError(f"move_obstacle: an obstacle or an offset (dx, dy) is needed, got {offset!r}")
    if isinstance(obstacle, Circle):
        return Circle(obstacle.center + d, obstacle.radius)
    if isinstance(obstacle, Box):
        return Box(obstacle.lower + d, obstacle.upper + d)
    if isinstance(obstacle, Polygon):
        return Polygon(np.asarray(obstacle.geometry.exterior.coords)[:-1] + d)
    raise ValueError(f"move_obstacle: cannot move {obstacle!r} by an offset; give it in its new place")
