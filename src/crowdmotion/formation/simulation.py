"""The formation method on a Scene and its Groups: one guiding mesh per group, stepped
until every group has reached its target area and recovered, output as Trajectories
with the formation measures of each group."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from crowdmotion.facing import MAX_TURN_RATE, limit_turn, wrap
from crowdmotion.formation.params import FormationParams, make_params
from crowdmotion.formation.simulator import Simulator, _rotation
from crowdmotion.formation.templates import Template, from_spec
from crowdmotion.groups import Group, Lattice, Points
from crowdmotion.interrupts import step_loop
from crowdmotion.metrics import edge_length_error, kabsch_rms
from crowdmotion.scene import Scene
from crowdmotion.trajectories import Trajectories, resample


FACING = ("formation: cars along their body (their pair's angle less 90 degrees), soldiers their formation's "
          "heading, dislocated agents on the move their way of travel; turns bounded by MAX_TURN_RATE")


def group_template(group: Group) -> Template:
    """The template a Group asks for in ``attributes["formation"]`` (a template spec, a
    dict with a ``kind``, or a Template); a Points spawn without one is used as is."""
    spec = group.attributes.get("formation")
    if isinstance(group.spawn, Lattice):
        raise ValueError(f"group {group.name!r} spawn: a lattice spreads a crowd's agents over a rectangle, but a "
                         f"formation keeps its template's shape, placed at the spawn's centre: give the spawn as a "
                         f"point or rect, or list the agents' points")
    how = ("give the group a template, e.g. formation = { kind = \"block\", rows = 4, cols = 4 } in its "
           "[[groups]] table (Python: attributes[\"formation\"]), placed at the spawn's centre")
    if spec is None:
        if isinstance(group.spawn, Points) and len(group.spawn.points) == group.count:
            return Template(group.spawn.points - group.spawn.points.mean(axis=0))
        if isinstance(group.spawn, Points):
            raise ValueError(f"group {group.name!r}: count = {group.count} but the spawn gives "
                             f"{len(group.spawn.points)} position(s), and without a formation template the "
                             f"spawn points are the formation: {how}, or list {group.count} spawn points")
        raise ValueError(f"group {group.name!r}: the formation method needs a template: {how}, "
                         f"or a spawn of shape \"points\" listing each agent")
    tpl = from_spec(spec)
    if tpl.count != group.count:
        raise ValueError(f"group {group.name!r}: count = {group.count} but its formation template "
                         f"({tpl.kind}) holds {tpl.count} agents")
    return tpl


@dataclass
class FormationRun:
    """``trajectories`` (resampled to ``params.fps``), the ``simulator`` at the end, the
    raw frames (one per step), each group's mesh vertices per step, and per-group
    measures (``report``)."""

    trajectories: Trajectories
    simulator: Simulator
    frames: np.ndarray
    vertices: list[np.ndarray]
    torn: list[np.ndarray]
    dislocated: list[np.ndarray]
    report: dict = field(default_factory=dict)
    journeys: Any = None  # the route state machine (crowdmotion.journeys.Journeys), None without routes
    active: np.ndarray | None = None  # (steps, agents) still in the scene (a group that left by a route's exit is not)

    def snapshot(self, step: int) -> list[dict]:
        """Every group's mesh and agents at raw step ``step`` (for figures); a group that
        has left the scene is not drawn."""
        out = []
        for k, g in enumerate(self.simulator.groups):
            if self.active is not None and not self.active[step][g.agents].any():
                continue  # it has left the scene
            out.append({"name": g.name, "vertices": self.vertices[k][step], "edges": g.mesh.edges,
                        "torn": self.torn[k][step],
                        "agents": self.frames[step][g.agents], "radius": g.radius,
                        "dislocated": self.dislocated[k][step]})
        return out


def build_simulator(scene: Scene, groups: Sequence[Group], params: FormationParams,
                    rng: np.random.Generator) -> Simulator:
    """A Simulator with one formation per group: the template centred on the spawn
    region's centre, facing the goal."""
    if not groups:
        raise ValueError("formation: at least one group is needed")
    from crowdmotion.checks import where
    from crowdmotion.journeys import unit_entry_time

    sim = Simulator(scene, params.time_step, params, rng)
    for k, g in enumerate(groups):
        tpl = group_template(g)
        kw = dict(name=g.name, radius=g.radius, max_speed=g.max_speed, pref_speed=g.pref_speed)
        if "enter" in g.attributes:
            kw["enter_at"] = unit_entry_time(g.attributes["enter"], f"{where(k, g)}: enter")
        if "reassign" in g.attributes:
            kw["reassign"] = bool(g.attributes["reassign"])
        if isinstance(g.spawn, Points) and g.attributes.get("formation") is None:
            sim.add_group(g.spawn.points, g.goal, **kw)
        else:
            if "heading_deg" in g.attributes:
                kw["heading"] = np.deg2rad(float(g.attributes["heading_deg"]))
            sim.add_group(tpl, g.goal, start=np.asarray(g.spawn.center, float), **kw)
    return sim


def run(scene: Scene, groups: Sequence[Group], params: FormationParams | dict | None = None,
        rng: np.random.Generator | None = None, progress: Callable[[int], None] | None = None) -> FormationRun:
    """Step every formation until all have recovered in their target areas (or
    ``params.max_steps``); returns the run with its Trajectories and measures."""
    params = params if isinstance(params, FormationParams) else make_params(params)
    rng = np.random.default_rng(0) if rng is None else rng
    sim = build_simulator(scene, groups, params, rng)
    journeys = build_journeys(sim, groups)
    frames = [sim.positions.copy()]
    present = [sim.active.copy()]
    stages = [] if journeys is None else [_stage_frame(sim)]
    facing = [sim.facing()]
    headings = [[g.heading] for g in sim.groups]
    verts = [[g.vertices.copy()] for g in sim.groups]
    torn = [[g.mesh.torn.copy()] for g in sim.groups]
    field_steps = [[False] for _ in sim.groups]
    dislocated = [[np.zeros(len(g.agents), bool)] for g in sim.groups]
    with step_loop() as loop:  # Ctrl-C: keep the steps so far, marked partial
        for _ in range(params.max_steps):
            sim.step()  # groups bound for an exit leave there; the rest move on along their routes
            if journeys is not None:
                stages.append(_stage_frame(sim))
            frames.append(sim.positions.copy())
            present.append(sim.active.copy())
            facing.append(sim.facing())
            for k, g in enumerate(sim.groups):
                verts[k].append(g.vertices.copy())
                headings[k].append(g.heading)
                torn[k].append(g.mesh.torn.copy())
                field_steps[k].append(g.handles > 0)
                dislocated[k].append(g.guide.dislocated.copy())
            if progress is not None:
                progress(1)
            if sim.done and (journeys is None or not journeys.busy(sim.walkers.active)):
                break
    partial = loop.stopped
    n = min(len(frames), len(facing), len(present), len(stages) if journeys is not None else len(frames),
            *(len(x) for lists in (verts, torn, field_steps, dislocated) for x in lists))
    active = np.array(present[:n])
    frames = np.array(frames[:n])
    facing = limit_turn(np.array(facing[:n]), MAX_TURN_RATE * sim.dt)
    verts, torn = [v[:n] for v in verts], [t[:n] for t in torn]
    field_steps, dislocated = [f[:n] for f in field_steps], [d[:n] for d in dislocated]
    from crowdmotion import __version__

    names = np.concatenate([np.full(len(g.agents), g.name, dtype=object) for g in sim.groups])
    metadata = {}
    if journeys is not None:
        metadata["stages"] = journeys.stage_table([g.name for g in sim.groups])
    traj = Trajectories(frames, sim.dt, group=names, radius=sim.radius.copy(), facing=facing,
                        active=None if active.all() else active,
                        stage=None if journeys is None else np.array(stages[:n]),
                        metadata=metadata | {"method": "formation", "params": params.model_dump(), "scene": scene.to_dict(),
                                  "version": __version__, "steps": sim.steps, "stats": dict(sim.stats),
                                  "partial": partial, "facing": FACING,
                                  "bodies": {g.name: "car" if g.cars else "walker" for g in sim.groups}})
    dislocated = [np.array(d) for d in dislocated]
    report = {g.name: _group_report(sim, k, g, np.array(field_steps[k]), dislocated[k].sum(axis=1))
              for k, g in enumerate(sim.groups)}
    for k, g in enumerate(sim.groups):
        if len(g.template.pairs):
            report[g.name].update(car_measures(frames, facing, np.array(headings[k][:n]), g.agents[g.template.pairs]))
    out = traj if params.fps is None else resample(traj, params.fps, "linear")
    return FormationRun(out, sim, frames, [np.array(v) for v in verts], [np.array(t) for t in torn], dislocated,
                        report, journeys, active)


def build_journeys(sim: Simulator, groups: Sequence[Group]):
    """The route state machine with each formation as one walker (``sim.journeys``, None
    when no group has a route: the simulator's ``rng`` is then left untouched), already
    moved on to every group's first stage; each ``sim.step()`` moves the groups on. A
    queue stage is refused, naming it."""
    from crowdmotion.checks import where
    from crowdmotion.formation.routes import check_formation_route

    routes = [g.attributes.get("route") for g in groups]
    if all(r is None for r in routes):
        return None
    for k, r in enumerate(routes):
        if r is not None:
            check_formation_route(r, where(k, groups[k]))
    sim.follow_routes(routes, [g.spawn for g in groups])
    return sim.journeys


def _stage_frame(sim: Simulator) -> np.ndarray:
    """(N,) each agent's stage id: its group's, -1 once the group left."""
    return sim.journeys.frame(sim.walkers.active)[sim.group_of]


def _group_report(sim: Simulator, k: int, g, in_field: np.ndarray, dislocated: np.ndarray) -> dict:
    """Formation measures of one group: edge-length error (final and worst), Kabsch RMS to
    the template (final), time to recover after the last obstacle contact, dislocations."""
    slots = sim.slot_positions(k)
    mean, worst = edge_length_error(slots, g.mesh.rest, g.mesh.edges)
    err = np.array([0.0] + g.edge_error)
    last_contact = int(np.flatnonzero(in_field).max()) if in_field.any() else None
    recovery = None
    if last_contact is not None:
        after = np.flatnonzero((err[last_contact:] < sim.params.recovered_error) & (dislocated[last_contact:] == 0))
        recovery = float(after[0] * sim.dt) if len(after) else None
    turn = orientation(sim, g, slots)
    return {
        "agents": int(len(g.agents)),
        "mesh": g.mesh.kind,
        "edge_length_error_mean": mean,
        "edge_length_error_max": worst,
        "worst_mean_edge_length_error": float(err.max()),
        "kabsch_rms_m": kabsch_rms(slots, g.mesh.rest),
        **turn,
        "arrived_s": g.arrived_at,
        "recovered_s": g.recovered_at,
        "recovery_after_obstacles_s": recovery,
        "dislocations": int(g.guide.dislocations),
        "reassignments": int(g.guide.reassignments),
        "edges_torn": int(g.torn),
        "edges_relinked": int(g.relinked),
        "factorisations": int(g.solver.stats["factorisations"]),
        "factor_cache_hits": int(g.solver.stats["cache_hits"]),
    }


def orientation(sim: Simulator, g, slots: np.ndarray) -> dict:
    """How the final shape is turned against the way it should face: ``heading_deg``, the
    way it should face (the caller's start heading, else its route's last leg into the
    goal: ``Simulator.recovery_heading``, up to a turn that maps its slots onto
    themselves, the one nearest the shape's), ``orientation_error_deg``, the best-fit turn
    of the rest shape onto the final slots off it, and ``oriented_rms_m``, the RMS distance
    of the slots to the rest shape at that heading (best translation only). Kabsch RMS and
    the edge error forgive any turn: a block that re-formed as a diamond has 0 % edge
    error and a Kabsch RMS of 0.03 m, but an orientation error of 42° and an oriented
    RMS of 3 m."""
    a = g.mesh.rest - g.mesh.rest.mean(axis=0)
    b = slots - slots.mean(axis=0)
    fit = g.fitted_heading(slots)
    ref = sim.recovery_heading(g)
    want = min((ref + s for s in g.symmetry), key=lambda h: abs(float(wrap(h - fit))))
    placed = a @ _rotation(want - g.heading0).T
    return {"heading_deg": float(np.degrees(wrap(want))),
            "orientation_error_deg": float(np.degrees(abs(wrap(fit - want)))),
            "oriented_rms_m": float(np.sqrt(np.mean(np.sum((placed - b) ** 2, axis=1))))}


def car_measures(frames: np.ndarray, facing: np.ndarray, heading: np.ndarray, pairs: np.ndarray) -> dict:
    """Cars (003 Fig. 7): how far a car's two agents ever were from its width
    (``pair_width_error_max``, a share of the width) and how far a car ever turned from its
    formation's heading (``car_heading_deviation_max_deg``: the twist the police car
    causes), over every step; ``frames`` (T, n, 2), ``facing`` (T, n), ``heading`` (T,)."""
    width = np.linalg.norm(frames[0, pairs[:, 1]] - frames[0, pairs[:, 0]], axis=1)
    d = np.linalg.norm(frames[:, pairs[:, 1]] - frames[:, pairs[:, 0]], axis=2)
    turn = np.abs(wrap(facing[:, pairs[:, 0]] - heading[:, None]))
    return {"cars": int(len(pairs)), "pair_width_error_max": float(np.abs(d / width - 1).max()),
            "car_heading_deviation_max_deg": float(np.degrees(turn.max()))}


def simulate(scene: Scene, groups: Sequence[Group], params: FormationParams | dict | None = None,
             rng: np.random.Generator | None = None, progress: bool = False) -> Trajectories:
    """The formation method end to end: ``formation.simulate(scene, groups, params, rng) -> Trajectories``;
    ``progress=True`` shows the command's bar of steps on stderr (``crowdmotion.progress.step_bar``)."""
    from crowdmotion.progress import step_bar

    params = params if isinstance(params, FormationParams) else make_params(params)
    with step_bar(params.max_steps, "formation steps", progress) as bar:
        return run(scene, groups, params, rng, progress=bar.advance).trajectories
