"""JuPedSim trajectory SQLite files (schema version 2), which PedPy reads with
``load_trajectory_from_jupedsim_sqlite`` and ``load_walkable_area_from_jupedsim_sqlite``.

Tables as JuPedSim writes them: ``trajectory_data(frame, id, pos_x, pos_y, ori_x, ori_y)``
(one row per present agent and frame; the orientation is the unit facing direction),
``metadata(key, value)`` with ``version`` = 2, ``fps`` and the bounds ``xmin`` .. ``ymax``,
``geometry(hash, wkt)`` holding the walkable area (one polygon: see :func:`walkable_area`)
and ``frame_data(frame, geometry_hash)``. Positions are written with a fixed jitter of
at most ``JITTER_M`` (1 µm, the ``jitter_m`` metadata entry) so that PedPy's Voronoi
density (GEOS) runs on every frame: it fails on exact lattices and coincident points. crowdmotion adds
``crowdmotion_agents(id, grp, radius)`` and a ``crowdmotion`` metadata entry (JSON) so
that its own reader gets the groups, radii and metadata back, and the locomotion channels
(:mod:`crowdmotion.locomotion`) in ``crowdmotion_locomotion(frame, id, distance,
gait_phase, gait_state, turn_rate, contact_left, contact_right)``, one row per row of
``trajectory_data`` (phase and contacts NULL for agents that are not walkers; the state a
code into ``crowdmotion_gait_states(code, name)``); for runs whose agents follow routes,
each present agent's stage id per frame in ``crowdmotion_stages(frame, id, stage)`` (the
ids named in the metadata's ``stages``); JuPedSim and PedPy ignore them. 3D runs are projected onto the ground plane (x, y): the ``projection`` metadata
entry says so, and so does a ``UserWarning`` on writing. Drones stacked in z then stand
1 µm apart on the ground: their Voronoi density there is meaningless.
"""

from __future__ import annotations

import json
import sqlite3
import sys
import warnings
import zlib
from pathlib import Path

import numpy as np
import shapely

from crowdmotion.io.atomic import atomic_path
from crowdmotion.io.longform import metadata_json
from crowdmotion.locomotion import IDLE, STATES, Locomotion, LocomotionParams
from crowdmotion.scene import Box, Circle, Polygon, Scene, Sphere
from crowdmotion.trajectories import Trajectories

VERSION = 2
JITTER_M = 1e-6  # positions are written within this many metres of the run's (see write)


def _footprint(ob) -> shapely.Geometry | None:
    """An obstacle's outline in the ground plane (x, y)."""
    if isinstance(ob, (Circle, Sphere)):
        return shapely.Point(ob.center[:2]).buffer(ob.radius, quad_segs=16)
    if isinstance(ob, Box):
        return shapely.box(*ob.lower[:2], *ob.upper[:2])
    if isinstance(ob, Polygon):
        return ob.geometry
    return None


def _sample_xy(positions: np.ndarray, active: np.ndarray, most: int = 200_000) -> np.ndarray:
    """(k, 2) ground-plane positions of active agents, evenly thinned to at most ``most``."""
    xy = positions[..., :2][active]
    return xy[:: max(1, len(xy) // most)]


def walkable_area(scene_dict: dict | None, positions: np.ndarray, active: np.ndarray | None = None
                  ) -> tuple[shapely.Polygon, str | None]:
    """One polygon, the ground-plane region the agents use, as PedPy and JuPedSim need it:
    the scene's bounds less the footprints of its static obstacles, except, in 3D, footprints
    that an agent's centre enters (agents flying over or under an obstacle). When obstacles cut
    the bounds into pieces, the piece holding the most agent positions. Without a scene,
    the box round every position, 1 m wider. Returns the polygon and a warning (or None)
    when agents stand outside it."""
    if active is None:
        active = np.ones(positions.shape[:2], bool)
    xy = _sample_xy(positions, active)
    if not scene_dict:
        lo, hi = xy.min(axis=0) - 1.0, xy.max(axis=0) + 1.0
        return shapely.box(*lo, *hi), None
    scene = Scene.from_dict(scene_dict)
    area = shapely.box(*scene.lower[:2], *scene.upper[:2])
    holes = []
    for ob in scene.obstacles:
        foot = None if ob.is_moving else _footprint(ob)  # a moving one is walkable at times
        if foot is None or (scene.dim == 3 and shapely.contains_xy(foot, xy[:, 0], xy[:, 1]).any()):
            continue  # moving, or flown over (under) in 3D
        holes.append(foot)
    if holes:
        area = shapely.make_valid(area.difference(shapely.union_all(holes)))
    parts = [g for g in shapely.get_parts(area) if isinstance(g, shapely.Polygon) and g.area > 0]
    inside = [int(shapely.intersects_xy(g, xy[:, 0], xy[:, 1]).sum()) for g in parts]
    best = int(np.argmax(inside))
    left_out = len(xy) - inside[best]
    note = None
    if left_out:
        why = (f"obstacles cut the scene into {len(parts)} pieces; the one most agents use is kept"
               if len(parts) > 1 else "inside obstacles or out of bounds")
        note = f"{left_out} of {len(xy)} agent positions lie outside the walkable area written ({why})"
    return parts[best], note


def _orientation(traj: Trajectories) -> np.ndarray:
    h = traj.facing
    return np.stack([np.cos(h), np.sin(h)], axis=-1)


def _first_caller_outside_package() -> int:
    """``stacklevel`` pointing a warning at the user's line, however deep the library calls.

    (Python 3.12's ``skip_file_prefixes`` does this; the package supports 3.11.)
    """
    package = str(Path(__file__).resolve().parent.parent)
    frame = sys._getframe(2)  # the caller of the function that warns
    level = 2
    while frame is not None and str(Path(frame.f_code.co_filename).resolve()).startswith(package):
        frame = frame.f_back
        level += 1
    return level


def write(traj: Trajectories, path: Path, locomotion: LocomotionParams | None = None) -> None:
    """Write ``traj`` and its locomotion channels (derived with ``locomotion``'s
    parameters, the defaults when None) to ``path``, atomically."""
    if traj.dim == 3:
        warnings.warn(f"{path.name}: JuPedSim files are 2D; the 3D run is projected onto the ground plane (x, y)",
                      UserWarning, stacklevel=_first_caller_outside_package())
    t, n, _ = traj.positions.shape
    act = traj.active_mask
    frame, agent = np.nonzero(act)
    # a fixed sub-micrometre jitter: GEOS's Voronoi (PedPy's density) fails on exact lattices
    # (MDP cells, formation templates) and on drones stacked in z once projected
    pos = traj.positions[frame, agent, :2] + np.random.default_rng(0).uniform(-JITTER_M, JITTER_M, (len(frame), 2))
    ori = _orientation(traj)[frame, agent]
    rows = np.column_stack([frame, traj.ids[agent], pos, ori])
    loco = traj.locomotion(locomotion)  # derived once per run: every file shares them
    walker = loco.walker[agent]

    def gait(values):  # NULL (NaN) for agents that are not walkers
        return np.where(walker, values[frame, agent], np.nan).tolist()

    gait_rows = zip(frame.tolist(), traj.ids[agent].tolist(), loco.distance[frame, agent].tolist(),
                    gait(loco.gait_phase), loco.gait_state[frame, agent].tolist(), loco.turn_rate[frame, agent].tolist(),
                    gait(loco.contact_left.astype(float)), gait(loco.contact_right.astype(float)))
    area, note = walkable_area(traj.metadata.get("scene"), traj.positions, act)
    if note:
        warnings.warn(f"{path.name}: {note}", UserWarning, stacklevel=_first_caller_outside_package())
    geo = area.wkt
    geo_hash = zlib.crc32(geo.encode())
    xmin, ymin, xmax, ymax = area.bounds
    meta = [("version", str(VERSION)), ("fps", repr(traj.fps)), ("xmin", repr(xmin)), ("xmax", repr(xmax)),
            ("ymin", repr(ymin)), ("ymax", repr(ymax)), ("crowdmotion", metadata_json(traj, loco)),
            ("crowdmotion_frames", str(t)), ("jitter_m", repr(JITTER_M))]
    if traj.dim == 3:
        meta.append(("projection", "3D run projected onto the ground plane (x, y); z dropped"))
    with atomic_path(path) as tmp:
        tmp.unlink()  # sqlite wants to create the file itself
        con = sqlite3.connect(tmp)
        try:
            cur = con.cursor()
            cur.execute("CREATE TABLE trajectory_data (frame INTEGER NOT NULL, id INTEGER NOT NULL, "
                        "pos_x REAL NOT NULL, pos_y REAL NOT NULL, ori_x REAL NOT NULL, ori_y REAL NOT NULL)")
            cur.executemany("INSERT INTO trajectory_data VALUES(?, ?, ?, ?, ?, ?)",
                            ((int(f), int(i), float(x), float(y), float(ox), float(oy))
                             for f, i, x, y, ox, oy in rows))
            cur.execute("CREATE INDEX frame_id_idx ON trajectory_data(frame, id)")
            cur.execute("CREATE TABLE metadata(key TEXT NOT NULL UNIQUE PRIMARY KEY, value TEXT NOT NULL)")
            cur.executemany("INSERT INTO metadata VALUES(?, ?)", meta)
            cur.execute("CREATE TABLE geometry(hash INTEGER NOT NULL, wkt TEXT NOT NULL)")
            cur.execute("CREATE UNIQUE INDEX geometry_hash on geometry(hash)")
            cur.execute("INSERT INTO geometry VALUES(?, ?)", (geo_hash, geo))
            cur.execute("CREATE TABLE frame_data(frame INTEGER NOT NULL, geometry_hash INTEGER NOT NULL)")
            cur.executemany("INSERT INTO frame_data VALUES(?, ?)", ((f, geo_hash) for f in range(t)))
            cur.execute("CREATE TABLE crowdmotion_agents(id INTEGER NOT NULL, grp TEXT NOT NULL, radius REAL NOT NULL)")
            cur.executemany("INSERT INTO crowdmotion_agents VALUES(?, ?, ?)",
                            ((int(i), str(g), float(r)) for i, g, r in zip(traj.ids, traj.group, traj.radius)))
            cur.execute("CREATE TABLE crowdmotion_locomotion (frame INTEGER NOT NULL, id INTEGER NOT NULL, "
                        "distance REAL NOT NULL, gait_phase REAL, gait_state INTEGER NOT NULL, turn_rate REAL NOT NULL, "
                        "contact_left INTEGER, contact_right INTEGER)")
            cur.executemany("INSERT INTO crowdmotion_locomotion VALUES(?, ?, ?, ?, ?, ?, ?, ?)", gait_rows)
            cur.execute("CREATE INDEX crowdmotion_locomotion_idx ON crowdmotion_locomotion(frame, id)")
            cur.execute("CREATE TABLE crowdmotion_gait_states(code INTEGER NOT NULL PRIMARY KEY, name TEXT NOT NULL)")
            cur.executemany("INSERT INTO crowdmotion_gait_states VALUES(?, ?)", enumerate(STATES))
            if traj.stage is not None:
                cur.execute("CREATE TABLE crowdmotion_stages (frame INTEGER NOT NULL, id INTEGER NOT NULL, "
                            "stage INTEGER NOT NULL)")
                cur.executemany("INSERT INTO crowdmotion_stages VALUES(?, ?, ?)",
                                zip(frame.tolist(), traj.ids[agent].tolist(), traj.stage[frame, agent].tolist()))
                cur.execute("CREATE INDEX crowdmotion_stages_idx ON crowdmotion_stages(frame, id)")
            con.commit()
        finally:
            con.close()


def read(path: Path) -> Trajectories:
    """A JuPedSim v2 file (ours or JuPedSim's) as 2D Trajectories; agents absent from a
    frame are inactive there."""
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
        try:
            rows = np.array(con.execute("SELECT frame, id, pos_x, pos_y, ori_x, ori_y FROM trajectory_data")
                            .fetchall(), float)
            meta = dict(con.execute("SELECT key, value FROM metadata").fetchall())
            try:
                agents = con.execute("SELECT id, grp, radius FROM crowdmotion_agents").fetchall()
            except sqlite3.OperationalError:
                agents = []
            try:
                stages = np.array(con.execute("SELECT frame, id, stage FROM crowdmotion_stages").fetchall(),
                                  np.int64).reshape(-1, 3)
            except sqlite3.OperationalError:  # a run without routes, or JuPedSim's own file
                stages = None
        finally:
            con.close()
    except sqlite3.DatabaseError as exc:
        raise ValueError(f"{path} is not a JuPedSim trajectory SQLite file: {exc}") from exc
    if "fps" not in meta or rows.size == 0:
        raise ValueError(f"{path} is not a JuPedSim trajectory SQLite file (no frame rate or no trajectory rows)")
    frames = rows[:, 0].astype(np.int64)
    ids, col = np.unique(rows[:, 1].astype(np.int64), return_inverse=True)
    f0 = frames.min()
    # frames after the last active agent have no rows: the frame count says how many there were
    t = max(int(frames.max() - f0) + 1, int(meta.get("crowdmotion_frames", 0)) - int(f0))
    pos = np.zeros((t, len(ids), 2))
    facing = np.zeros((t, len(ids)))
    active = np.zeros((t, len(ids)), bool)
    pos[frames - f0, col] = rows[:, 2:4]
    facing[frames - f0, col] = np.arctan2(rows[:, 5], rows[:, 4])
    active[frames - f0, col] = True
    for k in range(1, t):  # absent agents keep their last place and facing (they are inactive there)
        gone = ~active[k]
        pos[k, gone] = pos[k - 1, gone]
        facing[k, gone] = facing[k - 1, gone]
    extra = {int(i): (g, r) for i, g, r in agents}
    group = np.array([extra.get(int(i), ("agents", 0.0))[0] for i in ids], dtype=object)
    radius = np.array([extra.get(int(i), ("agents", 0.0))[1] for i in ids], float)
    metadata = json.loads(meta["crowdmotion"]) if "crowdmotion" in meta else {}
    stage = None
    if stages is not None:  # frames without a row: the agent was absent there (-1)
        stage = np.full((t, len(ids)), -1, dtype=np.int16)
        stage[stages[:, 0] - f0, np.searchsorted(ids, stages[:, 1])] = stages[:, 2]
    return Trajectories(pos, 1.0 / float(meta["fps"]), ids=ids, group=group, radius=radius,
                        active=None if active.all() else active, metadata=metadata, facing=facing, stage=stage)


def read_locomotion(path: Path) -> Locomotion:
    """The locomotion channels of a file written by :func:`write`; an agent's frames
    without a row (it was absent) hold its distance and phase, idle, feet down."""
    traj = read(path)
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
        try:
            rows = con.execute("SELECT frame, id, distance, gait_phase, gait_state, turn_rate, contact_left, "
                               "contact_right FROM crowdmotion_locomotion").fetchall()
        finally:
            con.close()
    except sqlite3.DatabaseError as exc:
        raise ValueError(f"{path} has no crowdmotion_locomotion table (not written by crowdmotion): {exc}") from None
    data = np.array(rows, dtype=float).reshape(-1, 8)  # NULL -> NaN
    meta = traj.metadata.get("locomotion") or {}
    kinds = meta.get("kinds") or {}
    kind = np.array([kinds.get(str(g), "walker") for g in traj.group], dtype=object)
    t, n = traj.n_frames, traj.n_agents
    f0 = int(data[:, 0].min()) if len(data) else 0
    f = data[:, 0].astype(np.int64) - f0
    a = np.searchsorted(traj.ids, data[:, 1].astype(np.int64))
    present = np.zeros((t, n), bool)
    present[f, a] = True
    grids = []
    for k in (2, 3, 5):
        g = np.full((t, n), np.nan)
        g[f, a] = data[:, k]
        grids.append(g)
    distance, phase, rate = grids
    held = np.maximum.accumulate(np.where(present, np.arange(t)[:, None], 0), axis=0)  # absent: held
    distance = np.nan_to_num(np.take_along_axis(distance, held, axis=0))
    phase = np.take_along_axis(phase, held, axis=0)
    rate[~present] = 0.0
    state = np.full((t, n), IDLE, np.int8)
    state[f, a] = data[:, 4]
    walker = kind == "walker"
    left = np.tile(walker, (t, 1))
    right = left.copy()
    left[f, a] = data[:, 6] == 1
    right[f, a] = data[:, 7] == 1
    params = LocomotionParams(**meta["params"]) if meta.get("params") else LocomotionParams()
    return Locomotion(distance, phase, state, rate, left, right, kind, params)
