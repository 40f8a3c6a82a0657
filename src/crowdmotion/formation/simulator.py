"""The guiding-mesh formation simulator (§4): groups whose agents follow a deformable
mesh that obstacles' potential fields push aside, then recover to the rest shape.

One step (§4.2–4.3), for every group:

1. the mesh advances toward the group's target area (attraction, the same velocity for
   every vertex); vertices inside a potential field — of the scene's obstacles, eq. (2),
   or of another group seen as a moving disc — also get the repulsion and a tangential
   push round the obstacle, and become the handles;
2. edges stretched beyond ``tear_ratio`` × rest length are torn (their triangles leave
   the deformation); torn edges back within ``relink_ratio`` are relinked;
3. the two-step as-rigid-as-possible solve gives every other vertex its desired position;
   each moves with the attraction plus a correction proportional to its error; with
   comfortable motion (``crowdmotion.formation.comfort``) a vertex's velocity changes by
   at most ``mesh_acceleration`` per second and vertices nearer each other than the
   agents' bodies are pushed apart;
4. each agent follows its vertex; a dislocated agent heads for the nearest unoccupied
   vertex, eqs. (3)–(4), with local repulsion from other agents; a car's two agents
   (the ``cars`` template's pairs, §5 traffic) move as one rigid body: the pair's centre
   goes where their vertices go, its axis turns toward theirs at a bounded rate, and
   they stay exactly a car width apart;
5. a safety pass keeps bodies apart: moves toward an obstacle (static or moving, the
   scene's bounds included) are shortened so as not to touch within the step, and of two
   agents that would touch one stands (continuous time, as the audit checks); a car whose
   one wheel is held back is re-made rigid, and stands whole when that is not safe.

In its target area a group feels no forces: its mesh relaxes to the rest shape.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from crowdmotion._contact import grid_for, line_of_sight, obstacle_safe_moves, resolve_conflicts
from crowdmotion._validation import id_range
from crowdmotion.formation.arap import ARAPSolver
from crowdmotion.formation.comfort import clip_rows, limit_acceleration, spread_vertices, stopping_speed
from crowdmotion.formation.field import PotentialField, disc_field
from crowdmotion.formation.guidance import REBALANCE_MAX, AttractionGuide, attraction_magnitude
from crowdmotion.formation.mesh import FormationMesh, MeshView
from crowdmotion.formation.params import FormationParams, make_params
from crowdmotion.formation.routes import FormationWalkers, check_formation_route
from crowdmotion.formation.templates import Template, from_spec
from crowdmotion.facing import MAX_TURN_RATE, wrap
from crowdmotion.geometry import positive_number, require_finite_agents, row_norms
from crowdmotion.groups import Disc, MovingTarget, Points, Rect, as_region
from crowdmotion.formation._kernels import edge_length_error as edge_errors
from crowdmotion.formation._kernels import repulsion
from crowdmotion.live_obstacles import LiveObstacles
from crowdmotion.obstacle_primitives import ObstacleSet
from crowdmotion.placement import standing_centre
from crowdmotion.routing import DistanceFields, default_cell, distance_fields
from crowdmotion.scene import Scene

GROUP_FIELDS = ("radius", "max_speed", "pref_speed", "start", "heading", "name", "reassign", "enter_at")
ENTRY_GAP_M = 0.05  # clearance an entering formation needs round each of its bodies
SLOW_DOWN = 2.0  # metres from the goal over which the attraction fades
FACE_TRAVEL_SPEED = 0.5  # a group under way faster than this share of pref_speed ...
FACE_TRAVEL_MAX = np.pi / 4  # ... whose travel lies within this of its heading: soldiers face the travel ...
FACE_TRAVEL_TAU_S = 1.0  # ... followed with this time constant (no faster than MAX_TURN_RATE)
BACK_SPEED_SHARE = 0.5  # a soldier walking back to his place faster than this share of pref_speed ...
BACK_TURN_DEG = 100.0  # ... more than this off the way his rank faces turns round to face his way ...
STILL_SPEED_SHARE = 0.25  # ... until he slows below this share ...
FRONT_DEG = 60.0  # ... or walks within this of his rank's way (facing())
SQUARE_TAU_S = 2.0  # a mesh turned off its rest shape in the open squares up with this time constant ...
SQUARE_RATE = 0.15  # ... at most this many radians a second (a 6 x 6 block's corners 0.8 m/s faster) ...
SQUARE_START = np.radians(10.0)  # ... from this far off ...
SQUARE_DONE = np.radians(1.0)  # ... down to this ...
SQUARE_FIT_M = 0.3  # ... when its shape is the rest shape's, turned, to this (rms; _square_up)
NEAR_VERTEX_M = 1.5  # a dislocated soldier this near his vertex, in sight of it, walks straight to it
ARRIVAL_TURN_MAX = np.pi / 4  # a mesh that arrives turned less than this from its start heading recovers square to it
ROUTE_LOOKAHEAD_M = 1.5  # vertices aim at least this far down the route to the goal ...
ROUTE_PULL_M = 8.0  # ... and at the farthest point of it they see within this far
ROUTE_PULL_STRIDE_M = 0.5  # the points of the route tried for sight, this far apart
STALL_PROGRESS_M = 0.5  # a group that has not come this much nearer its goal ...
STALL_S = 8.0  # ... for this many seconds is stalled: ...
STALL_RELIEF_S = 10.0  # ... and bends with uniform handles for this long
VERTEX_CLEARANCE = 0.05  # metres beyond an agent's radius that a vertex keeps from static obstacles
ROUTE_PROBE_M = 4.0  # a vertex whose march would meet a static obstacle this soon takes its own route
PAIR_TOLERANCE = 0.01  # a car's wheels further off its width than this share are re-made rigid
CAR_TURN_RADIUS = 4.0  # metres: a car turns at most |v| / radius rad/s (a kinematic car), ...
CAR_TURN_MIN = 0.3  # ... and at least this many rad/s, so a standing car can still straighten up
REBALANCE_EVERY = 2.0  # seconds between whole-group reassignments in the target area
SETTLED_M = 0.01  # a recovered group has settled when vertices and agents are this near their places ...
SETTLE_WAIT_S = 5.0  # ... or this long after it recovered with nobody walking faster than SETTLE_STILL_MPS ...
SETTLE_STILL_MPS = 0.05
SETTLE_MAX_S = 30.0  # ... or this long after it recovered, however they walk


def rotational_symmetry(points: np.ndarray) -> tuple:
    """The quarter turns (0, π/2, π, 3π/2 radians) about the centroid that map a point
    set onto itself (each point onto some point, within a millionth of its extent)."""
    p = points - points.mean(axis=0)
    tree = cKDTree(p)
    tol = 1e-6 * max(float(np.abs(p).max()), 1e-9)
    return tuple(k * np.pi / 2 for k in range(4)
                 if k == 0 or tree.query(p @ _rotation(k * np.pi / 2).T)[0].max() <= tol)


def best_turn(a: np.ndarray, b: np.ndarray) -> float:
    """The turn (radians) that best maps the centred points ``a`` onto the centred points
    ``b`` (least squares, 2D Kabsch)."""
    return float(np.arctan2(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), np.sum(a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1])))


def _rotation(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


@dataclass
class FormationGroup:
    """One group's state: its mesh, solver, guide, vertex positions and history."""

    name: str
    template: Template
    mesh: FormationMesh
    solver: ARAPSolver
    guide: AttractionGuide
    vertices: np.ndarray
    agents: np.ndarray  # global agent indices of this group
    goal: Any
    goal_center: np.ndarray
    pref_speed: float
    max_speed: float
    radius: float
    extent: float
    heading0: float = 0.0  # the rest shape's heading as placed
    heading: float = 0.0   # where the rest shape faces now (turned to the direction of travel)
    heading_given: bool = False  # the caller gave the start heading (else: along the route's first leg)
    arrival_heading: float | None = None  # the way the route's last leg runs into the goal (planned_legs)
    half_width: float = 0.0  # half its width across its front (the template's y), bodies included
    symmetry: tuple = (0.0,)  # turns (radians) that map the rest shape's slots onto themselves
    facing_offset: float = 0.0  # soldiers face heading + this (set on arrival: see _arrive)
    squaring: bool = False  # turning back square to its rest shape in the open (_square_up) ...
    pressed: bool = False  # ... which only a mesh that obstacles or groups have pushed does
    travel: float | None = None  # under way, the way its soldiers face (see Simulator._face_travel)
    arrived_at: float | None = None
    recovered_at: float | None = None
    handles: int = 0
    rebalanced_step: int = -10**9
    best_progress: float = float("inf")  # least distance to the goal so far (route field or straight)
    stale_steps: int = 0  # steps since it last came nearer
    uniform_until: float = float("-inf")  # stall relief: uniform handles until then
    settled_at: float | None = None  # recovered and standing on its places (see Simulator._settle)
    left_at: float | None = None  # when it left the scene (a route's leave stage: Simulator.remove_group)
    enter_at: float = 0.0  # when it is due to enter, seconds
    entered_at: float | None = 0.0  # when it entered (None while it waits off-scene for its time or for room)
    vertex_velocity: np.ndarray | None = None  # (n, 2) each vertex's move over the last step / dt

    @property
    def in_scene(self) -> bool:
        """Entered and not left: it moves, and the others avoid it."""
        return self.entered_at is not None and self.left_at is None

    @property
    def cars(self) -> bool:
        """A traffic formation (pairs of agents as rigid cars): keeps its own kinematics."""
        return bool(len(self.template.pairs))

    def comfortable(self, params: FormationParams) -> bool:
        """Whether the mesh moves comfortably (mesh_acceleration on; walkers, not cars)."""
        return params.mesh_acceleration > 0 and not self.cars

    def rest_shape(self) -> np.ndarray:
        """The rest shape about its centre, turned to the group's heading now."""
        return (self.mesh.rest - self.mesh.rest.mean(axis=0)) @ _rotation(self.heading - self.heading0).T

    def fitted_heading(self, points: np.ndarray) -> float:
        """The heading (radians) at which the rest shape best fits ``points`` (one per
        vertex): the start heading plus the best-fit turn (least squares, about their
        centres) of the rest shape onto them."""
        return self.heading0 + best_turn(self.mesh.rest - self.mesh.rest.mean(axis=0), points - points.mean(axis=0))

    @property
    def all_vertices(self) -> np.ndarray:
        return np.arange(len(self.vertices))

    @property
    def span(self) -> slice:
        """The group's agents in the simulator's arrays (added together: contiguous)."""
        return slice(int(self.agents[0]), int(self.agents[-1]) + 1)
    torn: int = 0
    relinked: int = 0
    edge_error: list = field(default_factory=list)


def _region_goal(goal) -> tuple[Any, np.ndarray]:
    g = as_region(goal, "formation goal")
    if isinstance(g, MovingTarget):
        raise ValueError("formation: a group's goal is a target area (point, rect or disc), not a moving target")
    if g.dim != 2:
        raise ValueError(f"formation: the goal must be 2D, got {g.dim}D")
    return g, np.asarray(g.center, float)


class Simulator(LiveObstacles):
    """Formation groups in a 2D scene, stepped together.

    >>> sim = Simulator(scene, time_step=0.1)
    >>> gid = sim.add_group(block(10, 10), goal=(60, 0), start=(0, 0))   # doctest: +SKIP
    >>> sim.step(); sim.positions.shape                                   # doctest: +SKIP
    """

    def __init__(self, scene: Scene, time_step: float = 0.1, params: FormationParams | dict | None = None,
                 rng: np.random.Generator | None = None, **overrides):
        self.params = make_params(params, time_step=time_step, **overrides)
        self.scene = scene  # with every obstacle ever in it, each with the time it stood (for the audit)
        self._now = scene  # the obstacles standing now
        self._scene_owned = False
        self.journeys = None  # the route state machine, once a route is set (set_route, or a scenario's)
        self._walkers: FormationWalkers | None = None
        self._held: set[int] = set()  # groups the route field says walls cut off now: they stand
        self.dt = float(self.params.time_step)
        self.field = PotentialField(scene, self.params.field_range, self.params.field_cell)
        self._route: DistanceFields | None = None  # routes round static walls to each group's goal
        self._route_stale = True
        self._routes_solved: dict[tuple, DistanceFields] = {}  # by the groups' goals: a goal met again re-solves nothing
        self.obstacles = ObstacleSet(scene, "formation", "the guiding-mesh method")
        self.rng = np.random.default_rng(0) if rng is None else rng
        self.groups: list[FormationGroup] = []
        self.positions = np.zeros((0, 2))
        self.velocities = np.zeros((0, 2))
        self.turned_round = np.zeros(0, bool)  # soldiers walking back to their places facing their way (facing())
        self.radius = np.zeros(0)
        self.max_speed = np.zeros(0)
        self.group_of = np.zeros(0, np.int64)
        self.active = np.zeros(0, bool)  # in the scene (a group that left by remove_group is not)
        self.pairs = np.zeros((0, 2), np.int64)  # cars: the two agents of each (global indices)
        self.pair_length = np.zeros(0)  # and their distance, the car width
        self.time = 0.0
        self.steps = 0
        self._grid = None
        self.stats = {"agent_steps": 0, "safety_stops": 0, "obstacle_cuts": 0}

    # ---- building ------------------------------------------------------------------------
    def add_group(self, template, goal, **params) -> int:
        """Add a formation; returns its group id.

        ``template``: a :class:`Template` (see :mod:`crowdmotion.formation.templates`), a
        template spec or its dict form (``{"kind": "block", "rows": 4, "cols": 5}``), or an
        (n, 2) array of start positions (any point set). ``goal``: a
        point or a Rect / Disc target area. Keywords: ``start`` (where the template's
        centre starts; default: the array's own positions, or the origin), ``heading``
        (radians; default: facing the goal), ``radius``, ``max_speed``, ``pref_speed``,
        ``name``, ``reassign`` (default: the simulator's; a template with pairs, cars,
        never reassigns: a car's agents keep their vertices and each other), ``enter_at``
        (seconds; default: now): until then, and after it while any body or obstacle
        stands within its agents' bodies plus ENTRY_GAP_M of their start places, the group
        waits off-scene (``active`` False: not drawn, not avoided, not stepped) and comes
        in whole at the start of the first step it fits.
        """
        unknown = set(params) - set(GROUP_FIELDS)
        if unknown:
            raise ValueError(f"formation.add_group: unknown parameter(s) {sorted(unknown)}; "
                             f"expected some of {list(GROUP_FIELDS)}")
        name = str(params.get("name", f"group{len(self.groups)}"))
        what = f"formation group {name!r}"
        radius = positive_number(params.get("radius", 0.25), f"{what}: radius")
        max_speed = positive_number(params.get("max_speed", 1.5), f"{what}: max_speed")
        pref_speed = positive_number(params.get("pref_speed", min(1.3, max_speed)), f"{what}: pref_speed")
        if pref_speed > max_speed:
            raise ValueError(f"{what}: pref_speed {pref_speed} exceeds max_speed {max_speed}")
        region, gc = _region_goal(goal)
        heading = 0.0
        legs = None  # the first and last legs of its centre's way, where it takes its headings from them
        if isinstance(template, (np.ndarray, list, tuple)):  # start positions, any point set
            pts = np.asarray(template, float)
            start_pos = pts
            tpl = Template(np.asarray(pts, float) - pts.mean(axis=0) if pts.ndim == 2 else pts)
        else:
            tpl = from_spec(template)
            start = np.asarray(params.get("start", (0.0, 0.0)), float).ravel()
            if start.shape != (2,) or not np.isfinite(start).all():
                raise ValueError(f"{what}: start must be a finite 2D point, got {params.get('start')!r}")
            heading = params.get("heading")  # the caller's, else along its centre's first leg (round walls)
            if heading is None:
                legs = self.planned_legs(start, region, gc, radius, self._half_width(tpl.points, radius))
                heading = legs[0]
            if not np.isfinite(float(heading)):
                raise ValueError(f"{what}: heading must be a finite angle in radians, got {heading!r}")
            start_pos = tpl.placed(start, float(heading))
        self._check_inside(start_pos, radius, what)  # (first: a template of 1e300 m breaks the mesh's search)
        mesh = FormationMesh(start_pos, what)  # checks NaN, duplicates; warns on a chain
        due = params.get("enter_at")
        due = self.time if due is None else float(due) if isinstance(due, (int, float, np.integer, np.floating)) \
            and not isinstance(due, bool) and np.isfinite(due) and due >= 0 else None
        if due is None:
            raise ValueError(f"{what}: enter_at must be a number of seconds >= 0, got {params.get('enter_at')!r}")
        later = "enter_at" in params and params["enter_at"] is not None
        self._check_start(start_pos, radius, gc, what, bodies=not later)
        p = self.params
        n = len(start_pos)
        solver = ARAPSolver(mesh, p.handle_weight, p.anchor_weight)
        reassign = bool(params.get("reassign", p.reassign)) and not len(tpl.pairs)
        guide = AttractionGuide(n, p.occupy_distance, reassign)
        extent = float(np.linalg.norm(start_pos - start_pos.mean(axis=0), axis=1).max()) + radius
        idx = np.arange(len(self.positions), len(self.positions) + n)
        grp = FormationGroup(name, tpl, mesh, solver, guide, start_pos.copy(), idx, region, gc, pref_speed, max_speed,
                             radius, extent, float(heading), float(heading), symmetry=rotational_symmetry(mesh.rest),
                             heading_given=legs is None, arrival_heading=None if legs is None else legs[1],
                             half_width=self._half_width(tpl.points, radius),
                             vertex_velocity=np.zeros_like(start_pos), enter_at=due,
                             entered_at=None if later else self.time)
        self._route_stale = True
        self.groups.append(grp)
        self.positions = np.concatenate([self.positions, start_pos])
        self.velocities = np.concatenate([self.velocities, np.zeros((n, 2))])
        self.turned_round = np.concatenate([self.turned_round, np.zeros(n, bool)])
        self.radius = np.concatenate([self.radius, np.full(n, radius)])
        self.max_speed = np.concatenate([self.max_speed, np.full(n, max_speed)])
        self.group_of = np.concatenate([self.group_of, np.full(n, len(self.groups) - 1)])
        self.active = np.concatenate([self.active, np.full(n, not later)])
        if len(tpl.pairs):
            self.pairs = np.concatenate([self.pairs, idx[tpl.pairs]])
            self.pair_length = np.concatenate([self.pair_length, np.linalg.norm(
                start_pos[tpl.pairs[:, 1]] - start_pos[tpl.pairs[:, 0]], axis=1)])
        return len(self.groups) - 1

    def set_goal(self, group: int, goal) -> None:
        """Send a group to a new goal from the next step on (the live API): a point or a
        Rect / Disc target area, as in :meth:`add_group`. The group keeps its shape and
        walks there; one that had arrived (or recovered) sets off again. A goal outside
        the bounds, inside an obstacle or cut off by walls raises ValueError and the
        group keeps its goal."""
        self._retarget(self._group(group, "formation.set_goal"), goal, refuse_cut_off=True)

    def _retarget(self, group: int, goal, refuse_cut_off: bool) -> None:
        """:meth:`set_goal`; a route's stage (``refuse_cut_off`` False) may send a group
        where a closed door cuts it off for now: it stands until a way opens."""
        g = self.groups[group]
        what = f"formation group {g.name!r}"
        region, gc = self._goal_checked(goal, g, what)
        old = (g.goal, g.goal_center)
        g.goal, g.goal_center = region, gc
        try:
            self._build_route()
            if refuse_cut_off and group in self.cut_off():
                raise ValueError(f"{what}: the goal {gc.tolist()} cannot be reached: walls close the way")
        except ValueError:
            g.goal, g.goal_center = old
            self._build_route()
            raise
        g.arrived_at = g.recovered_at = g.settled_at = None
        g.facing_offset = 0.0
        if not g.heading_given:  # it recovers along the new route's last leg
            g.arrival_heading = self.planned_legs(g.vertices.mean(axis=0), region, gc, g.radius, g.half_width)[1]
        g.best_progress, g.stale_steps, g.uniform_until = float("inf"), 0, float("-inf")

    def _goal_checked(self, goal, g: FormationGroup, what: str) -> tuple[Any, np.ndarray]:
        """``goal`` as (region, centre) for group ``g``: a ValueError naming ``what`` if
        its centre, where the group recovers its shape, is outside the bounds or inside
        an obstacle standing now."""
        region, gc = _region_goal(goal)
        self._check_inside(gc[None], g.radius, what, point="the goal")
        gclear = float(self._now.obstacle_distance(gc[None], self.time)[0])
        if gclear < g.radius:
            raise ValueError(f"{what}: the goal {gc.tolist()} is inside an obstacle (clearance {gclear:.3g} m)")
        return region, gc

    def _group_id(self, group, what: str) -> int:
        """``group`` as the id of a group the simulator has, in the scene or gone
        (ValueError naming ``what`` otherwise)."""
        if isinstance(group, bool) or not isinstance(group, (int, np.integer)) or not 0 <= group < len(self.groups):
            raise ValueError(f"{what}: no group {group!r} ({id_range(len(self.groups), 'groups')})")
        return int(group)

    def _group(self, group, what: str) -> int:
        """``group`` as the id of a group still in the scene (ValueError naming ``what`` otherwise)."""
        g = self.groups[self._group_id(group, what)]
        if g.left_at is not None:
            raise ValueError(f"{what}: formation group {g.name!r} left the scene at t = {g.left_at:g} s")
        return int(group)

    def set_route(self, group: int, route) -> None:
        """Send a group along a route of stages from now on (the live API): ``route`` is a
        list of :mod:`crowdmotion.stages` stages (GoTo, Wait, Choose, Leave), as a
        scenario's ``[[groups.route]]`` gives them (a Choose's options may be branches:
        lists of stages). The group follows them as one unit,
        keeping its shape (see :mod:`crowdmotion.formation.routes`); each step moves it on
        (``sim.journeys``, a :class:`crowdmotion.journeys.Journeys` with one walker per
        group, holds where each group is: ``sim.journeys.stage[group]``). A group on
        another route leaves its stage at once.

        Refused (ValueError naming the stage, ``formation.set_route: route.0 (queue
        'gate'): a formation does not queue; ...``, nothing changed): a stage a formation
        does not follow (queue), stages out of order, an area outside the scene or
        covered by obstacles standing now, an area whose centre (where the group
        recovers its shape) a body cannot stand on; and, as :meth:`set_goal`, an unknown
        group or one that left."""
        from crowdmotion.checks import check_live_route
        from crowdmotion.stages import check_route, flat_stages, stage_label

        k = self._group(group, "formation.set_route")
        g = self.groups[k]
        what = "formation.set_route"
        route = check_route(route, f"{what}: route")
        check_formation_route(route, f"{what}:")
        check_live_route(self._now, route, len(g.agents), g.radius, self.positions[g.span].mean(axis=0), what)
        for path, st, _ in flat_stages(route):
            if getattr(st, "area", None) is not None:
                try:
                    self._goal_checked(st.area, g, f"formation group {g.name!r}")
                except ValueError as exc:
                    raise ValueError(f"{what}: {stage_label(path, st)}: {exc}") from None
        if self.journeys is None:
            self.follow_routes([None] * len(self.groups), [None] * len(self.groups))
        self.journeys.set_route([k], route, self.walkers, self._extents(), [h.pref_speed for h in self.groups])

    def follow_routes(self, routes: list, spawns: list) -> None:
        """Give the groups their routes (per group a list of stages or None, checked
        with :mod:`crowdmotion.formation.routes`) and begin them: from now on each step
        moves the groups on along them (``sim.journeys``). ``spawns``: per group the
        region a route that begins with a wait waits in. The scenario runner's way in;
        :meth:`set_route` sets one group's route while running."""
        from crowdmotion._rng import step_key
        from crowdmotion.journeys import Journeys

        self.journeys = Journeys(routes, np.arange(len(self.groups)), spawns, self._extents(),
                                 [g.pref_speed for g in self.groups], step_key(self.rng), self._clearance)
        self.journeys.update(self.walkers, self.dt)

    @property
    def walkers(self) -> FormationWalkers:
        """The groups as :class:`crowdmotion.journeys.Journeys` sees them: one walker each."""
        if self._walkers is None:
            self._walkers = FormationWalkers(self)
        return self._walkers

    def _extents(self) -> np.ndarray:
        return np.array([g.extent for g in self.groups], dtype=float)

    def remove_group(self, group: int) -> None:
        """Take a group out of the scene (the live API; a route's leave stage on arrival):
        its agents stop, keep their last positions, no longer count as bodies or
        obstacles to the others (``active`` False) and the group counts as done."""
        g = self.groups[self._group_id(group, "formation.remove_group")]
        if g.left_at is None:
            g.left_at = self.time
            self.active[g.span] = False
            self.velocities[g.span] = 0.0
            self._grid = None

    # ---- obstacles while running (LiveObstacles: add_obstacle, remove_obstacle, move_obstacle)
    def _bodies(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The agents in the scene now (ids, positions, radii): no obstacle goes in on them."""
        live = np.flatnonzero(self.active)
        return live, self.positions[live], self.radius[live]

    def _obstacles_rebuilt(self, now: Scene) -> None:
        """Rebuild what the obstacles standing now shape: contact primitives, the
        potential field, the route fields (solved again when next needed)."""
        self.obstacles = ObstacleSet(now, "formation", "the guiding-mesh method")
        self.field = PotentialField(now, self.params.field_range, self.params.field_cell)
        self._routes_solved = {}
        self._route_stale = True

    def _obstacles_check(self) -> None:
        """A new obstacle may not cover a group's goal (where it recovers its shape); the
        route fields are solved again now. A group it cuts off from its goal stands where
        it is until a way opens (:meth:`cut_off` lists it), as walkers behind a shut door do."""
        for g in self.groups:
            if g.left_at is None:
                self._goal_checked(g.goal, g, f"formation group {g.name!r}")
        self._build_route()

    def _check_inside(self, pos: np.ndarray, radius: float, what: str, point: str = "agent") -> None:
        """A ValueError naming ``what`` if a body of ``radius`` at one of ``pos`` reaches
        past the scene's bounds; ``point``: what the points are ("agent": agent i; else
        that word)."""
        lo, hi = self.scene.lower, self.scene.upper
        out = ~np.all(np.isfinite(pos), axis=1) | np.any((pos - radius < lo) | (pos + radius > hi), axis=1)
        if out.any():
            i = int(np.flatnonzero(out)[0])
            which = f"agent {i}" if point == "agent" else point
            raise ValueError(f"{what}: {which} at {pos[i].round(3).tolist()} is outside the scene bounds "
                             f"{lo.tolist()}-{hi.tolist()} (a body of radius {radius:g} m)")

    def _check_start(self, pos: np.ndarray, radius: float, goal: np.ndarray, what: str, bodies: bool = True) -> None:
        self._check_inside(pos, radius, what)
        clear = self._now.obstacle_distance(pos, self.time)
        if np.any(clear < radius):
            i = int(np.argmin(clear))
            raise ValueError(f"{what}: agent {i} starts at {pos[i].round(3).tolist()} inside or touching an obstacle "
                             f"(clearance {clear[i]:.3g} m < radius {radius} m)")
        gclear = float(self._now.obstacle_distance(goal[None], self.time)[0])
        if gclear < radius:
            raise ValueError(f"{what}: the goal {goal.tolist()} is inside an obstacle (clearance {gclear:.3g} m)")
        pairs = cKDTree(pos).query_pairs(2 * radius, output_type="ndarray")
        if len(pairs):
            i, j = (int(v) for v in pairs[0])
            raise ValueError(f"{what}: agents {i} and {j} overlap at the start ({np.linalg.norm(pos[i] - pos[j]):.3g} m "
                             f"apart < 2 x radius {2 * radius} m); widen the template's spacing")
        live = np.flatnonzero(self.active)
        if bodies and len(live):  # (one entering later comes in when there is room)
            d, j = cKDTree(self.positions[live]).query(pos)
            j = live[j]
            bad = d < radius + self.radius[j]
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise ValueError(f"{what}: agent {i} overlaps agent {int(j[i])} of group "
                                 f"{self.groups[self.group_of[j[i]]].name!r} at the start")

    # ---- stepping ------------------------------------------------------------------------
    def _discs(self) -> tuple[np.ndarray, np.ndarray]:
        """Each group as a moving disc: its agents' centre and reach."""
        c = np.array([self.positions[g.span].mean(axis=0) for g in self.groups]).reshape(-1, 2)
        r = np.array([np.linalg.norm(self.positions[g.span] - c[k], axis=1).max() + g.radius
                      for k, g in enumerate(self.groups)])
        return c, r

    def _advance_mesh(self, k: int, g: FormationGroup, centers: np.ndarray, reach: np.ndarray) -> None:
        p = self.params
        dt = self.dt
        V = g.vertices
        centroid = V.mean(axis=0)
        in_area = g.arrived_at is not None
        comfortable = g.comfortable(p)
        if not in_area:
            to_goal = self._standing_centre(g, obstacles=False) - centroid
            dist = float(np.linalg.norm(to_goal))
            inside = isinstance(g.goal, (Rect, Disc)) and bool(g.goal.contains(centroid[None])[0])
            if dist <= p.arrive_distance or inside:
                g.arrived_at = self.time
                in_area = True
                self._arrive(g, V)
                g.goal_center = self._standing_centre(g)  # it recovers where its rest shape fits
        if in_area:  # the heading stays as it arrived
            u = np.zeros(2)
            handles = np.zeros(0, np.int64)
            fvec = np.zeros((len(V), 2))
            fmag = np.zeros(len(V))
        else:
            # the mesh waits for its agents: the attraction fades as more are dislocated
            wait = max(0.1, 1.0 - 2.0 * float(g.guide.dislocated.mean()))
            u = wait * g.pref_speed * self._route_directions(k, V, to_goal / dist) * min(1.0, dist / SLOW_DOWN)
            if k in self._held:  # walled off from its goal (a shut door): it stands until a way opens
                u = np.zeros(2)
            fvec, fmag = self.field.sample(V)
            others = (np.arange(len(self.groups)) != k) & np.array([h.in_scene for h in self.groups])
            if others.any():
                gv, gf = disc_field(V, centers[others], reach[others], p.field_range)
                fvec = fvec + gv
                fmag = np.maximum(fmag, gf)
            handles = np.flatnonzero(fmag > 0)
        g.handles = len(handles)
        drift = u.mean(axis=0) if u.ndim == 2 else u
        turn = self._turn(g, drift, V, centroid)  # the rest shape turns to the direction of travel
        g.pressed |= len(handles) > 0
        if not in_area and not g.cars and len(handles) == 0 and g.pressed:  # pushed round, now clear: square up
            turn += self._square_up(g, V, centroid)
        moved = centroid + (V - centroid) @ _rotation(turn).T + dt * u
        if in_area:  # recovery: back to the rest shape, facing the way it arrived, on the goal
            slot = g.rest_shape() + g.goal_center
            gap = slot - V
            gl = np.linalg.norm(gap, axis=1, keepdims=True)
            speed = g.pref_speed
            if comfortable:  # no faster than it can stop in at the comfortable deceleration
                speed = np.minimum(speed, stopping_speed(gl, p.mesh_acceleration))
            moved = V + gap * np.minimum(1.0, speed * dt / np.maximum(gl, 1e-300))
            if self._now.static_obstacles and (gl[:, 0] > p.occupy_distance).any():
                # a vertex a wall hides from its place (left behind a door the rest went
                # through, the mesh torn there) comes round it down the route, not into the wall
                far = np.flatnonzero(gl[:, 0] > p.occupy_distance)
                hid = far[~self._in_reach(V[far], slot[far], g.radius)]
                if len(hid):
                    if self._route_stale:
                        self._build_route()
                    if self._route is not None:
                        way = self._descent(k, V[hid], gap[hid[0]] / gl[hid[0]])
                        moved[hid] = V[hid] + dt * np.minimum(g.pref_speed, gl[hid]) * way
        # every vertex is pulled weakly to its place in the rest shape (with the group's
        # heading) centred on the mesh: torn-off vertices come back until their edges
        # relink, and the formation keeps facing the way it set out
        anchor = g.rest_shape() + centroid + dt * drift
        if self.steps % max(1, int(round(p.tear_interval / dt))) == 0:  # the mesh changes at most this often
            torn, relinked = g.mesh.update_tearing(V, p.tear_ratio, p.relink_ratio)
            g.torn += torn
            g.relinked += relinked
        targets = V[handles] + dt * self._steer(V[handles], np.broadcast_to(u, V.shape)[handles], fvec[handles],
                                                fmag[handles], V[handles] - centroid, g.pref_speed, g.max_speed)
        if p.handles == "exact" and not self._stall_relief(k, g, centroid, in_area):
            # the paper's handles: only field vertices are constrained; the others move
            # toward their ARAP position at a speed set by the error
            desired = g.solver.deform(handles, targets, anchor, p.arap)
            new = moved + min(1.0, p.shape_gain * dt) * (desired - moved)
            new[handles] = desired[handles]  # the field's push, held back by the mesh
        else:
            # every vertex is a handle of the same weight: field vertices aimed where the
            # field pushes them, the others where the attraction takes them; one
            # factorisation per topology serves every step
            aim = moved.copy()
            aim[handles] = targets
            new = g.solver.deform(g.all_vertices, aim, anchor, p.arap)
        velocity = (new - V) / dt
        if comfortable:  # the mesh changes velocity no faster than the walkers on it
            velocity = limit_acceleration(g.vertex_velocity, velocity, p.mesh_acceleration, dt)
        new = V + dt * clip_rows(velocity, g.max_speed)
        if p.vertex_gap > 0 and not g.cars:  # room for the agents' bodies between the vertices
            new = spread_vertices(new, 2 * g.radius + p.vertex_gap)
        g.vertices = self._clear_of_walls(np.clip(new, self.scene.lower + g.radius, self.scene.upper - g.radius),
                                          g.radius + VERTEX_CLEARANCE)
        g.vertex_velocity = (g.vertices - V) / dt

    def _stall_relief(self, k: int, g: FormationGroup, centroid: np.ndarray, in_area: bool) -> bool:
        """With the paper's handle rule a mesh pressed against a wide obstacle across its
        path can stand for good: its field vertices are held while the rest pull round
        both sides, and no edge stretches enough to tear (a 7 x 7 block in front of a
        3 m x 12 m planter stood for 200 s). When a group on its way has not come
        STALL_PROGRESS_M nearer its goal for STALL_S seconds, it takes uniform handles
        (which bend and tear) for STALL_RELIEF_S seconds. Returns whether relief is on."""
        if in_area:
            return False
        far = float(self._route.at(k, centroid[None])[0]) if self._route is not None else np.inf
        if not np.isfinite(far):
            far = float(np.linalg.norm(g.goal_center - centroid))
        if far < g.best_progress - STALL_PROGRESS_M:
            g.best_progress = far
            g.stale_steps = 0
        else:
            g.stale_steps += 1
            if g.stale_steps * self.dt >= STALL_S:
                g.uniform_until = self.time + STALL_RELIEF_S
                g.stale_steps = 0
                g.best_progress = far
                self.stats["stall_reliefs"] = self.stats.get("stall_reliefs", 0) + 1
        return self.time < g.uniform_until

    def _clear_of_walls(self, V: np.ndarray, need: float) -> np.ndarray:
        """Vertices nearer a static obstacle than ``need`` (an agent's radius and a margin)
        pushed straight out to that distance (along the distance's gradient, by central
        differences): a vertex an agent cannot stand on would only dislocate its agent.
        So the mesh itself narrows to a gate's width.

        The potential field serves as the broad phase: a vertex that near an obstacle lies
        in a painted cell whenever the field reaches a cell's diagonal beyond ``need``, so
        only vertices in the field get the exact (per obstacle) distance."""
        if not self._now.static_obstacles:
            return V
        dist = self._now.static_obstacle_distance
        look = np.arange(len(V))
        if self.params.field_range > need + self.params.field_cell * np.sqrt(2.0):
            look = np.flatnonzero(self.field.sample(V)[1] > 0)
        d = dist(V[look])
        near = look[d < need]
        if not len(near):
            return V
        V = V.copy()
        gap = need - d[d < need]
        h = 0.02
        for sweep in range(2):  # a corner may need a second push
            p = V[near]
            if sweep:
                gap = need - dist(p)
            grad = np.stack([dist(p + [h, 0]) - dist(p - [h, 0]), dist(p + [0, h]) - dist(p - [0, h])], axis=1)
            gl = np.linalg.norm(grad, axis=1, keepdims=True)
            push = np.where(gap[:, None] > 0, grad / np.maximum(gl, 1e-12) * gap[:, None], 0.0)
            V[near] = p + push
        return V

    def _route_directions(self, k: int, V: np.ndarray, straight: np.ndarray) -> np.ndarray:
        """(n, 2) unit directions for the mesh's vertices.

        The mesh marches as one: every vertex takes the centroid's direction (straight at
        the goal when the centroid sees it past every obstacle, else down the exact
        distance field to the group's goal, crowdmotion.routing, ROUTE_LOOKAHEAD_M
        ahead), as the paper's attraction gives every vertex the same velocity. A vertex
        whose march would meet a static obstacle within ROUTE_PROBE_M takes its own
        route instead (straight at the goal if it sees it, else down the field): so the
        outer ranks converge on a gate only as they reach its wall, a column bends round
        a corridor's corner, and a block opens round rocks. Vertices off the field take
        the others' mean direction."""
        if self._route_stale:
            self._build_route()
        if self._route is None:
            return np.broadcast_to(straight, V.shape)
        g = self.groups[k]
        centroid = V.mean(axis=0, keepdims=True)
        lead = straight if self._in_reach(centroid, g.goal_center[None], g.radius)[0] \
            else self._descent(k, centroid, straight)[0]
        clear = self._in_reach(V, V + ROUTE_PROBE_M * lead, g.radius)
        out = np.empty_like(V)
        out[clear] = lead
        own = np.flatnonzero(~clear)
        if len(own):
            see = self._in_reach(V[own], np.broadcast_to(g.goal_center, (len(own), 2)), g.radius)
            out[own] = self._descent(k, V[own], straight)
            out[own[see]] = straight  # vertices that see the goal head straight for it
        return out

    def _in_reach(self, A: np.ndarray, B: np.ndarray, radius: float) -> np.ndarray:
        """(m,) whether a body of ``radius`` walks from each point of A to the same row of
        B in a straight line past the static obstacles placed now."""
        clear = np.empty(len(A), dtype=bool)
        prims = self._prims
        line_of_sight(A, B, np.full(len(A), radius), np.ones(len(A), dtype=bool), prims.circ_c, prims.circ_r,
                      prims.seg_a, prims.seg_b, clear)
        return clear

    def _way_to(self, k: int, X: np.ndarray, d: np.ndarray, dist: np.ndarray) -> np.ndarray:
        """Unit directions for dislocated agents at X (m, 2) to their vertices ``d`` away
        (``dist`` metres): straight (eqs. (3)-(4)), or down group ``k``'s route to its
        goal (string-pulled, :meth:`_descent`) where a static obstacle stands between. The
        mesh lies on that route, so an agent cut off behind a wall (pushed out of a door
        the rest went through) comes round it instead of pressing on the wall for good."""
        way = np.divide(d, dist[:, None], out=np.zeros_like(d), where=dist[:, None] > 0)
        if self._route_stale:
            self._build_route()
        if self._route is None:
            return way
        clear = self._in_reach(X, X + d, self.groups[k].radius)
        if not clear.all():
            way[~clear] = self._descent(k, X[~clear], way[~clear].mean(axis=0))
        return way

    def _descent(self, k: int, X: np.ndarray, straight: np.ndarray) -> np.ndarray:
        """Unit directions down group ``k``'s distance field from points X (m, 2), string-
        pulled: at the farthest point within ROUTE_PULL_M along the field's path (cell by
        cell, crowdmotion.routing) that a body of the group's radius reaches in a straight
        line, or ROUTE_LOOKAHEAD_M down the path where none is. The path's cells go
        diagonally first, as an 8-connected field does: followed a short way ahead, it
        points 45° into a corridor's wall while the group slides along it; pulled taut it
        points down the corridor and round its corner. Points off the field take the
        others' mean (or ``straight``)."""
        cell = self._route.cell
        steps = max(1, int(np.ceil(ROUTE_PULL_M / cell)))
        path = self._route.descent_path(k, X, steps)
        near = min(steps, max(1, int(np.ceil(ROUTE_LOOKAHEAD_M / cell))))
        target = path[:, near].copy()
        left = np.arange(len(X))
        for s in range(steps, near, -max(1, int(round(ROUTE_PULL_STRIDE_M / cell)))):
            if not len(left):
                break
            seen = self._in_reach(X[left], path[left, s], self.groups[k].radius)
            target[left[seen]] = path[left[seen], s]
            left = left[~seen]
        d = target - X
        n = np.linalg.norm(d, axis=1, keepdims=True)
        on = n[:, 0] > 1e-9
        out = np.divide(d, n, out=np.zeros_like(d), where=n > 0)
        mean = out[on].sum(axis=0) if on.any() else straight
        out[~on] = mean / max(float(np.linalg.norm(mean)), 1e-12)
        return out

    def cut_off(self) -> list[int]:
        """Groups whose every vertex the route field says cannot reach the goal (walled
        off; one a shut door cuts off stands where it is until a way opens)."""
        if self._route_stale:
            self._build_route()
        return self._cut_off()

    def _cut_off(self) -> list[int]:
        if self._route is None:
            return []
        return [k for k, g in enumerate(self.groups) if not np.isfinite(self._route.at(k, g.vertices)).any()]

    def _build_route(self) -> None:
        self._route_stale = False
        self._route = None
        if self.groups and self._now.static_obstacles:
            goals = [g.goal if isinstance(g.goal, (Rect, Disc)) else Points([g.goal_center]) for g in self.groups]
            key = tuple((type(r).__name__, repr(r)) for r in goals)
            if key not in self._routes_solved:  # a route's stages come back to the same goals
                self._routes_solved[key] = distance_fields(self._now, goals, min(g.radius for g in self.groups))
            self._route = self._routes_solved[key]
        self._held = set(self._cut_off())  # (none without a route field)

    @staticmethod
    def _half_width(points: np.ndarray, radius: float) -> float:
        """Half a template's width across its front (its +x), bodies included."""
        y = np.asarray(points, float)[:, 1]
        return float(np.abs(y - y.mean()).max()) + radius if len(y) else radius

    def planned_legs(self, start, goal, centre, radius: float, half_width: float = 0.0) -> tuple[float, float]:
        """(first, last): the directions (radians) of the first and the last straight leg
        of the way a group's centre should walk from ``start`` to its goal (``goal`` a point
        or a Rect / Disc area, ``centre`` its centre, where the group recovers). Straight at
        the centre where a body of ``radius`` walks there in a straight line past the
        obstacles; else down the goal's distance field (crowdmotion.routing) solved with a
        clearance of ``half_width`` (the group's half width: it walks down a street's
        middle, not along the wall a body's shortest way hugs), halved until the start
        reaches the goal (a gate narrower than the group), down to ``radius``; pulled taut:
        the first leg ends at the farthest point of that path seen from the start (every
        point before it seen too), the last begins at the first point of it from which the
        rest of the path sees the centre. A group that gives no heading sets out along the
        first leg and recovers its shape along the last: an 8 x 10 block sent round a
        corner from a 16 m street to the north street starts facing east (0.2°) and ends
        facing north (89°); it faced the straight line to its goal, 49° through the wall,
        walked the street as a diamond and re-formed at 49°. Straight at the centre where
        no path is found."""
        start = np.asarray(start, float).reshape(2)
        centre = np.asarray(centre, float).reshape(2)
        to = centre - start
        straight = float(np.arctan2(to[1], to[0]))
        if not self._now.static_obstacles or not np.isfinite(start).all():
            return straight, straight
        prims = self.obstacles.at(self.time, self.dt)

        def sight(A, B, radius=radius):
            out = np.empty(len(A), dtype=bool)
            line_of_sight(A, B, np.full(len(A), radius), np.ones(len(A), dtype=bool), prims.circ_c, prims.circ_r,
                          prims.seg_a, prims.seg_b, out)
            return out

        if sight(start[None], centre[None])[0]:
            return straight, straight
        area = goal if isinstance(goal, (Rect, Disc)) else Points([centre])
        cell = default_cell(self._now, radius)
        fields, far = None, np.inf
        clearance = max(float(half_width), radius)
        while not np.isfinite(far):  # the widest clearance, halved, by which the start reaches the goal
            key = ("legs", type(area).__name__, repr(area), clearance, cell)
            try:
                if key not in self._routes_solved:
                    self._routes_solved[key] = distance_fields(self._now, [area], clearance, cell=cell)
                fields = self._routes_solved[key]
                far = float(fields.at(0, start[None])[0])
            except ValueError:  # the goal has no free cell at this clearance
                far = np.inf
            if not np.isfinite(far):
                if clearance <= radius:
                    return straight, straight  # no path: walled off
                clearance = max(radius, clearance / 2) if clearance / 2 > 1.5 * radius else radius
        path = fields.descent_path(0, start[None], int(np.ceil(far / cell)) + 2)[0]
        stride = max(1, int(round(ROUTE_PULL_STRIDE_M / cell)))
        path = np.vstack([path[::stride], path[-1:], centre[None]])
        seen = sight(np.broadcast_to(start, (len(path) - 1, 2)), path[1:], clearance)  # pulled taut, as wide
        run = int(np.argmin(seen)) if not seen.all() else len(seen)  # path[1:run + 1] all seen
        first = path[max(run, 1)] - start
        sees = sight(path[:-1], np.broadcast_to(centre, (len(path) - 1, 2)), clearance)
        j = int(np.flatnonzero(~sees).max()) + 1 if not sees.all() else 0
        last = centre - path[min(j, len(path) - 2)]
        if np.hypot(*last) < 1e-9:
            last = to
        return float(np.arctan2(first[1], first[0])), float(np.arctan2(last[1], last[0]))

    def _standing_centre(self, g: FormationGroup, obstacles: bool = True) -> np.ndarray:
        """Where the group's rest shape, at its heading now, stands nearest its goal's
        centre with every slot inside the bounds and (``obstacles``) clear of the static
        obstacles: a block sent to a strip along the scene's edge narrower than the block
        walks up to the edge and recovers there (centred on the strip its slots would
        stand outside the scene, and it never recovered). On its way a group aims only
        inside the bounds (exact and cheap; its route field leads it round obstacles); it
        recovers clear of both."""
        return standing_centre(self._now, g.goal_center, g.rest_shape(), g.radius + VERTEX_CLEARANCE,
                               obstacles=obstacles)

    def _arrive(self, g: FormationGroup, V: np.ndarray) -> None:
        """The heading a group recovers with in its target area. The mesh stands turned
        ``fit`` from its rest shape (best fit); its slots at its start heading, or at a
        turn of it under which the slots map onto themselves (a square block: every
        quarter turn), lie nearest that. Within ARRIVAL_TURN_MAX of them it recovers
        square to them, and further where the way it travelled lies nearer them than
        the way it stands (obstacles turned it on its way) and its slots at that heading
        stand clear of walls and obstacles (room to turn back); otherwise (a column that
        came round corners into a narrow area) as it stands, so it need not spin round.
        Soldiers then face whichever of the equivalent headings lies nearest the way the
        group travelled. (A wedge swung 100° by two small obstacles on its way recovered
        turned 52° in an open square, every soldier facing 52° off its march.)"""
        fit = g.fitted_heading(V)
        off = lambda x, y: abs(float(wrap(x - y)))  # noqa: E731
        square = min((self.recovery_heading(g) + s for s in g.symmetry), key=lambda h: off(h, fit))
        travelled = g.heading
        g.heading = square
        if off(square, fit) > ARRIVAL_TURN_MAX:  # turned on its way, with room to turn back?
            slots = g.rest_shape() + self._standing_centre(g)
            room = bool((self._now.clearance(slots) >= g.radius + VERTEX_CLEARANCE).all())
            if not (room and off(square, travelled) < off(fit, travelled)):
                g.heading = fit
        g.facing_offset = min(g.symmetry, key=lambda s: off(g.heading + s, travelled))

    @staticmethod
    def recovery_heading(g: FormationGroup) -> float:
        """The heading (radians) a group recovers its shape square to in its target area
        (up to a turn that maps its slots onto themselves; :meth:`_arrive`): the caller's
        start heading where one was given, else the way its route's last leg runs into
        the goal (:meth:`planned_legs`)."""
        return g.heading0 if g.heading_given or g.arrival_heading is None else g.arrival_heading

    def _square_up(self, g: FormationGroup, V: np.ndarray, centroid: np.ndarray) -> float:
        """The rigid turn (radians, this step) that brings a mesh turned off its rest shape
        back square to the group's heading: the best-fit turn of the rest shape onto the
        mesh, taken back over ``SQUARE_TAU_S`` and at most ``SQUARE_RATE`` radians a second,
        from ``SQUARE_START`` off down to ``SQUARE_DONE``.
        The mesh's own energy (as rigid as possible) does not mind a turn, so a block an
        obstacle swung round marched on turned, as a diamond (a 6 x 6 block through a 5 m
        gap: 35° off its march for the 20 s to its goal); called only in the open, and only
        for a mesh whole and in its shape (no torn edge, the turned rest shape within
        ``SQUARE_FIT_M`` of it, root mean square): a block still split round a planter has
        a best fit that points nowhere."""
        rest = g.rest_shape()
        b = V - centroid
        off = best_turn(rest, b)
        g.squaring = abs(off) > (SQUARE_DONE if g.squaring else SQUARE_START)
        if not g.squaring or g.mesh.torn.any() or \
                np.sqrt(np.mean(np.sum((rest @ _rotation(off).T - b) ** 2, axis=1))) > SQUARE_FIT_M:
            return 0.0
        return -float(np.clip(off * self.dt / SQUARE_TAU_S, -SQUARE_RATE * self.dt, SQUARE_RATE * self.dt))

    def _turn(self, g: FormationGroup, drift: np.ndarray, V: np.ndarray, centroid: np.ndarray) -> float:
        """Turn the group's rest heading toward its direction of travel, at most
        pref_speed / extent radians per second; returns the rigid turn the mesh makes
        this step (about its centroid).

        Confined (walls): a turn that would swing the rest shape's slots into a static
        obstacle is not made; a mesh whose rest shape does not fit where it stands (a
        column rounding a corridor's corner) bends by its vertices' own routes, and its
        heading follows the mesh's own orientation (the best-fit turn) without turning
        the mesh rigidly, but only toward the direction of travel and no further: a
        block split round a planter has a best fit that points nowhere (it swung the
        heading 28° off the travel, and a vertex that the turned rest shape pulled aside
        was still 10 m from its place on arrival)."""
        if not np.any(drift):
            return 0.0
        want = float(np.arctan2(drift[1], drift[0]))  # the template's front (its +x) leads
        delta = (want - g.heading + np.pi) % (2 * np.pi) - np.pi
        limit = g.pref_speed / max(g.extent, 1.0) * self.dt
        turn = float(np.clip(delta, -limit, limit))
        if self._now.static_obstacles and turn != 0.0 and not g.cars:  # cars keep their own kinematics
            need = g.radius + VERTEX_CLEARANCE
            rest = g.mesh.rest - g.mesh.rest.mean(axis=0)
            short = lambda h: float(np.maximum(need - self._now.static_obstacle_distance(  # noqa: E731
                rest @ _rotation(h - g.heading0).T + centroid), 0.0).sum())
            now = short(g.heading)
            if now > 1e-9:  # the rest shape does not fit here: follow the mesh's own orientation
                b = V - centroid
                fit = g.heading0 + float(np.arctan2(np.sum(rest[:, 0] * b[:, 1] - rest[:, 1] * b[:, 0]),
                                                    np.sum(rest[:, 0] * b[:, 0] + rest[:, 1] * b[:, 1])))
                step = float(np.clip(wrap(fit - g.heading), -limit, limit))
                if step * delta > 0:  # toward the way it travels, and no further than that
                    g.heading += float(np.clip(step, -abs(delta), abs(delta)))
                return 0.0
            if short(g.heading + turn) > 1e-9:  # turning would swing slots into a wall
                return 0.0
        g.heading += turn
        return turn

    def _steer(self, X, u, fvec, fmag, side, pref, vmax) -> np.ndarray:
        """Velocity at points X (k, 2) in a potential field: the attraction u (k, 2) plus
        the repulsion (the field's f·direction × ``repulsion`` × pref speed), plus a slide
        along the obstacle when the attraction drives into it: tangential, on the side
        where the attraction leans or, head on, on the side given by ``side`` (k, 2)."""
        if len(X) == 0:
            return np.zeros((0, 2))
        vel = u + self.params.repulsion * pref * fvec
        norm = np.linalg.norm(fvec, axis=1, keepdims=True)
        rhat = np.divide(fvec, norm, out=np.zeros_like(fvec), where=norm > 0)
        into = np.einsum("ij,ij->i", rhat, u) < 0
        tang = np.stack([-rhat[:, 1], rhat[:, 0]], axis=1)
        lean = np.einsum("ij,ij->i", tang, u)
        sign = np.where(np.abs(lean) > 1e-9 * pref, np.sign(lean),
                        np.where(np.einsum("ij,ij->i", tang, side) >= 0, 1.0, -1.0))
        vel += (into * fmag * pref * sign)[:, None] * tang
        sp = np.linalg.norm(vel, axis=1, keepdims=True)
        return np.where(sp > vmax, vel * vmax / np.maximum(sp, 1e-300), vel)

    def _agent_velocities(self) -> None:
        p = self.params
        dt = self.dt
        want = np.zeros_like(self.positions)
        for k, g in enumerate(self.groups):
            if not g.in_scene:
                continue
            o = self.positions[g.span]
            # whole-group reassignment (the least summed squared distance): in the target
            # area, and on the way whenever no vertex is in a field; agents left behind the
            # formation (after a gate, round rocks) cannot get past its back rank to the
            # free vertices in front: everyone moves up by a place instead
            calm = g.arrived_at is not None or g.handles == 0
            since = (self.steps - g.rebalanced_step) * dt
            if calm and g.guide.reassign and g.guide.dislocated.any() and since >= REBALANCE_EVERY:
                g.guide.rebalance(o, g.vertices)
                g.rebalanced_step = self.steps
                since = 0.0
            # in the target area the whole-group assignment above decides; the nearest-free-
            # vertex rule would undo it (an agent sent forward is "dislocated" and takes its
            # old vertex back), and a column in a corridor would never close up
            hold = (g.arrived_at is not None or (calm and since < REBALANCE_EVERY)) and len(o) <= REBALANCE_MAX
            lost = g.guide.update(o, g.vertices, hold=hold)
            target = g.vertices[g.guide.assignment]
            v = (target - o) / dt  # occupied: follow the vertex
            if lost.any():  # dislocated: eqs. (3)-(4), full speed at distance L and beyond
                R = p.attraction_radius or max(2 * g.extent, 2 * p.occupy_distance + 2 * g.radius)
                d = target[lost] - o[lost]
                l = np.linalg.norm(d, axis=1)
                f = attraction_magnitude(l, R, g.radius)
                scale = np.minimum(1.0, f / attraction_magnitude(p.occupy_distance, R, g.radius))
                v[lost] = g.max_speed * scale[:, None] * self._way_to(k, o[lost], d, l)
                v[lost] += self._repulsion(g.agents[lost], g.max_speed)
                fvec, fmag = self.field.sample(o[lost])  # small obstacles push too, and slide round
                # ... but not one whose vertex is near and in sight: the vertex keeps clear of the
                # walls itself, and a wall's push held a soldier 0.65 m short of his place by the
                # scene's edge for good (the safety pass keeps him off the wall)
                near = (l < NEAR_VERTEX_M) & self._in_reach(o[lost], target[lost], g.radius)
                fmag = np.where(near, 0.0, fmag)
                fvec = np.where(near[:, None], 0.0, fvec)
                v[lost] = self._steer(o[lost], v[lost], fvec, fmag, o[lost] - o.mean(axis=0), g.max_speed,
                                      g.max_speed)
            want[g.span] = v
        self.velocities = clip_rows(want, self.max_speed[:, None])

    def _obstacle_pass(self, active: np.ndarray) -> np.ndarray:
        """Every move made safe from the obstacles placed now (in place); returns each
        agent's kept share of its move."""
        prims = self._prims
        scale = np.ones(len(self.positions))
        obstacle_safe_moves(self.positions, self.velocities, self.radius, self.max_speed, active, self.dt,
                            prims.circ_c, prims.circ_r, prims.circ_v, prims.seg_a, prims.seg_b, prims.seg_v, scale)
        return scale

    def _rigid_pairs(self) -> None:
        """Cars move as rigid bodies (003 §5, Fig. 7: a car is two agents a car width
        apart, its steering the angle of the pair). The pair's centre goes where its two
        agents' moves would take it; its axis turns toward theirs by at most
        |v|/CAR_TURN_RADIUS·dt (and never faster than MAX_TURN_RATE); both agents end the
        step exactly ``pair_length`` apart. The centre's move gives way to the turn so that
        neither agent exceeds its max speed."""
        if not len(self.pairs):
            return
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        dt = self.dt
        oa, ob = self.positions[a], self.positions[b]
        qa, qb = oa + dt * self.velocities[a], ob + dt * self.velocities[b]
        axis = ob - oa
        phi0 = np.arctan2(axis[:, 1], axis[:, 0])
        want = np.arctan2(qb[:, 1] - qa[:, 1], qb[:, 0] - qa[:, 0])
        speed = np.linalg.norm(0.5 * (qa + qb) - 0.5 * (oa + ob), axis=1) / dt
        limit = np.minimum(MAX_TURN_RATE, np.maximum(speed / CAR_TURN_RADIUS, CAR_TURN_MIN)) * dt
        phi = phi0 + np.clip(wrap(want - phi0), -limit, limit)
        half = 0.5 * self.pair_length[:, None]
        r = half * np.column_stack([np.cos(phi), np.sin(phi)]) - 0.5 * axis  # each wheel's turn (and width fix)
        reach = np.minimum(self.max_speed[a], self.max_speed[b])[:, None] * dt
        rl = np.linalg.norm(r, axis=1, keepdims=True)
        r = np.where(rl > reach, r * reach / np.maximum(rl, 1e-300), r)
        shift = 0.5 * (qa + qb) - 0.5 * (oa + ob)
        sl = np.linalg.norm(shift, axis=1, keepdims=True)
        room = np.maximum(reach - np.minimum(rl, reach), 0.0)
        shift = np.where(sl > room, shift * room / np.maximum(sl, 1e-300), shift)
        self.velocities[a] = (shift - r) / dt
        self.velocities[b] = (shift + r) / dt

    def _repair_pairs(self, active: np.ndarray) -> None:
        """After the obstacle pass: a car whose wheels no longer end the step a car width
        apart (one slid or was held back) is made rigid again about its two moves' centre;
        if the obstacles then change either move, the car stands (and, should standing not
        be safe from a moving obstacle, the obstacle pass has the last word)."""
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        dt = self.dt
        qa = self.positions[a] + dt * self.velocities[a]
        qb = self.positions[b] + dt * self.velocities[b]
        axis = qb - qa
        length = np.linalg.norm(axis, axis=1)
        bad = np.abs(length - self.pair_length) > PAIR_TOLERANCE * self.pair_length
        if not bad.any():
            return
        a, b, qa, qb, axis, length = a[bad], b[bad], qa[bad], qb[bad], axis[bad], length[bad]
        u = np.divide(axis, length[:, None], out=np.zeros_like(axis), where=length[:, None] > 0)
        c = 0.5 * (qa + qb)
        half = 0.5 * self.pair_length[bad][:, None]
        self.velocities[a] = (c - half * u - self.positions[a]) / dt
        self.velocities[b] = (c + half * u - self.positions[b]) / dt
        before = self.velocities.copy()
        self._obstacle_pass(active)
        changed = np.any(self.velocities != before, axis=1)
        stop = changed[a] | changed[b]
        if stop.any():
            self.velocities[a[stop]] = 0.0
            self.velocities[b[stop]] = 0.0
            self.stats["car_stops"] = self.stats.get("car_stops", 0) + int(stop.sum())
            self._obstacle_pass(active)

    def _stop_whole_cars(self, active: np.ndarray, priority: np.ndarray, grid) -> None:
        """A car one of whose agents had to stand stands whole; the agents its standing
        now blocks stop too, until no car is half stopped."""
        if not len(self.pairs):
            return
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        for _ in range(len(self.positions)):
            still = ~np.any(self.velocities != 0.0, axis=1)
            half = still[a] != still[b]
            if not half.any():
                return
            self.velocities[a[half]] = 0.0
            self.velocities[b[half]] = 0.0
            self.stats["safety_stops"] += resolve_conflicts(self.positions, self.velocities, self.radius, active,
                                                            priority, *grid, self.dt)

    def _repulsion(self, who: np.ndarray, speed: float) -> np.ndarray:
        """Local repulsion F_r on agents ``who`` from every agent within contact +
        ``repulsion_range``: (1 − gap/range) × speed, away from each."""
        out = np.zeros((len(who), 2))
        reach = self.params.repulsion_range
        if reach <= 0 or len(who) == 0:
            return out
        if self._grid is None:
            self._grid = grid_for(self.positions, self.active, self.radius, self.max_speed, self.dt,
                                  extra=reach + 2 * float(self.radius.max()))
        repulsion(who, self.positions, self.radius, reach, speed, *self._grid, out)
        return out

    def step(self) -> None:
        """Advance every group and agent by one time step, then move groups on along
        their routes (``journeys``); a ValueError, before anything moves, if an agent's
        position or velocity is NaN or inf (the kernels would crash)."""
        require_finite_agents({"positions": self.positions, "velocities": self.velocities})
        if not self.groups:
            self.time += self.dt
            self.steps += 1
            return
        self._admit()
        if not self.active.any():  # every group waits off-scene (or has left): time passes
            self.velocities[:] = 0.0
            self.time += self.dt
            self.steps += 1
            self._bookkeeping()
            return
        self.field.update(self.time)
        self._grid = None  # built once per step, on first need
        prims = self._prims = self.obstacles.at(self.time, self.dt)  # obstacles placed now
        centers, reach = self._discs()
        for k, g in enumerate(self.groups):
            if g.in_scene:
                self._advance_mesh(k, g, centers, reach)
        self._agent_velocities()
        self._rigid_pairs()
        active = self.active.copy()
        self.velocities[~active] = 0.0
        scale = self._obstacle_pass(active)
        self.stats["obstacle_cuts"] += int((scale < 1).sum())
        if len(self.pairs):
            self._repair_pairs(active)
        grid = grid_for(self.positions, active, self.radius, self.max_speed, self.dt) if self._grid is None \
            else self._grid
        priority = self.rng.random(len(self.positions))
        self.stats["safety_stops"] += resolve_conflicts(self.positions, self.velocities, self.radius, active,
                                                        priority, *grid, self.dt)
        self._stop_whole_cars(active, priority, grid)
        self.positions = self.positions + self.velocities * self.dt
        self.stats["agent_steps"] += int(active.sum())
        self.time += self.dt
        self.steps += 1
        self._face_travel()
        self._bookkeeping()
        if self.journeys is not None:  # groups bound for an exit leave there; the rest move on
            self.walkers.after_step()
            self.journeys.update(self.walkers, self.dt)

    def _admit(self) -> None:
        """Let in the waiting groups that are due and fit: no body in the scene (or let in
        before them this step) and no obstacle within their bodies plus ENTRY_GAP_M."""
        for g in self.groups:
            if g.entered_at is not None or g.left_at is not None or g.enter_at > self.time + 1e-9:
                continue
            pos = self.positions[g.span]
            if (self._now.obstacle_distance(pos, self.time) < g.radius + ENTRY_GAP_M).any():
                continue
            live = np.flatnonzero(self.active)
            if len(live):
                d, j = cKDTree(self.positions[live]).query(pos)
                if (d - self.radius[live][j] - g.radius < ENTRY_GAP_M).any():
                    continue
            g.entered_at = self.time
            self.active[g.span] = True
            self._grid = None

    def _bookkeeping(self) -> None:
        for g in self.groups:
            if not g.in_scene:  # as it left (or stands waiting to enter)
                g.edge_error.append(g.edge_error[-1] if g.edge_error else 0.0)
                continue
            mean, _ = edge_errors(self.positions[g.span][g.guide.slot_order], g.mesh.edges, g.mesh.rest_length)
            g.edge_error.append(mean)
            if g.recovered_at is not None and g.settled_at is None:
                self._settle(g)
            if g.arrived_at is None or g.recovered_at is not None:
                continue
            slot = g.rest_shape() + g.goal_center
            settled = np.abs(g.vertices - slot).max() < self.params.occupy_distance
            if settled and mean < self.params.recovered_error and not g.guide.dislocated.any() \
                    and not g.mesh.torn.any():  # torn edges relink first
                g.recovered_at = self.time
                self._settle(g)

    def _settle(self, g: FormationGroup) -> None:
        """A recovered group has settled once its vertices stand on their places and its
        agents on their vertices (within SETTLED_M); a run goes on until they do, or
        until SETTLE_WAIT_S after recovery nobody walks faster than SETTLE_STILL_MPS (the
        last centimetres, walked at a comfortable pace), SETTLE_MAX_S at most. Cars
        recover with their vertices up to ``occupy_distance`` off their places (in
        ``formation_traffic`` 0.35 m, the last frame's Kabsch RMS 0.1 m) and stand on them
        a few steps later. A block turning on its goal to face another way than it came
        was still walking at 0.5-0.6 m/s when a flat 5 s cut it short, one soldier out of
        place (the last frame's mean edge error 1.1 %, Kabsch RMS 0.10 m)."""
        slot = g.rest_shape() + g.goal_center
        on = self.positions[g.span] - g.vertices[g.guide.assignment]
        waited = self.time - g.recovered_at
        still = row_norms(self.velocities[g.span]).max() < SETTLE_STILL_MPS
        if waited >= SETTLE_MAX_S or (waited >= SETTLE_WAIT_S and still) or \
                max(np.abs(g.vertices - slot).max(), np.abs(on).max()) < SETTLED_M:
            g.settled_at = self.time

    @property
    def done(self) -> bool:
        """Every group is in its target area, has recovered its formation and settled
        (or has left the scene)."""
        return all(g.left_at is not None or (g.recovered_at is not None and g.settled_at is not None)
                   for g in self.groups)

    def _face_travel(self) -> None:
        """Turn each walking group's soldiers toward the way the group travels. The rest
        shape's heading turns to where the route leads; a wall's field can hold the mesh
        5-10° off that line for a whole corridor, and soldiers facing the heading then
        walked crabwise. Under way faster than FACE_TRAVEL_SPEED × pref_speed, with its
        travel (its agents' mean velocity) within FACE_TRAVEL_MAX of the heading, a group's
        soldiers face the travel, followed with time constant FACE_TRAVEL_TAU_S so that
        the step-to-step wobble of the mean does not show; otherwise they turn back to
        the heading the same way. Arrived, they face the heading (see :meth:`_arrive`)."""
        for g in self.groups:
            if not g.in_scene or g.cars or g.arrived_at is not None:
                g.travel = None
                continue
            v = self.velocities[g.span].mean(axis=0)
            way = float(np.arctan2(v[1], v[0]))
            fast = float(np.hypot(v[0], v[1])) > FACE_TRAVEL_SPEED * g.pref_speed
            target = way if fast and abs(float(wrap(way - g.heading))) < FACE_TRAVEL_MAX else g.heading
            now = g.heading if g.travel is None else g.travel
            turn = float(wrap(target - now)) * min(1.0, self.dt / FACE_TRAVEL_TAU_S)
            g.travel = float(wrap(now + np.clip(turn, -MAX_TURN_RATE * self.dt, MAX_TURN_RATE * self.dt)))

    def facing(self) -> np.ndarray:
        """(n,) the way each agent faces now, yaw radians: a car along its body (the
        angle of its pair less 90°: the first agent of a pair is on the car's right); a
        soldier in rank his formation's heading (the rest shape's, which turns to the
        direction of travel) or, under way, the group's travel (:meth:`_face_travel`), a
        dislocated agent on the move his own way of travel. A soldier walking back to his
        place (faster than ``BACK_SPEED_SHARE`` of his preferred speed, more than
        ``BACK_TURN_DEG`` off the way his rank faces: the half of a block that went
        ahead round a fountain walking 7 m back onto the goal) turns round and faces his
        way until he slows below ``STILL_SPEED_SHARE`` or walks within ``FRONT_DEG`` of
        his rank's way (a hysteresis, so that he does not spin at the threshold)."""
        out = np.empty(len(self.positions))
        speed = np.linalg.norm(self.velocities, axis=1)
        for g in self.groups:
            out[g.span] = g.heading + g.facing_offset if g.travel is None else g.travel
            v = self.velocities[g.span]
            rank = out[g.span]
            ahead = np.cos(np.arctan2(v[:, 1], v[:, 0]) - rank)  # cos of his way off his rank's
            fast = speed[g.span] > BACK_SPEED_SHARE * g.pref_speed
            slow = speed[g.span] < STILL_SPEED_SHARE * g.pref_speed
            turned = self.turned_round[g.span]
            turned = np.where(turned, ~slow & (ahead < np.cos(np.radians(FRONT_DEG))),
                              fast & (ahead < np.cos(np.radians(BACK_TURN_DEG))))
            turned &= not g.cars  # a car faces along its body (below)
            self.turned_round[g.span] = turned
            away = (g.guide.dislocated & (speed[g.span] > 0.25 * g.pref_speed)) | turned
            out[g.span][away] = np.arctan2(v[away, 1], v[away, 0])
        if len(self.pairs):
            axis = self.positions[self.pairs[:, 1]] - self.positions[self.pairs[:, 0]]
            car = np.arctan2(axis[:, 1], axis[:, 0]) - np.pi / 2
            out[self.pairs[:, 0]] = car
            out[self.pairs[:, 1]] = car
        return wrap(out)

    def mesh(self, gid: int) -> MeshView:
        """Group ``gid``'s mesh now: vertices, edges, triangles and their torn flags."""
        g = self.groups[gid]
        return g.mesh.view(g.vertices)

    def slot_positions(self, gid: int) -> np.ndarray:
        """Group ``gid``'s agents in vertex order (the agent following each vertex)."""
        g = self.groups[gid]
        return self.positions[g.span][g.guide.slot_order]
