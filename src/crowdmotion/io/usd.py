"""USD files (``usd-core``) that Blender, Houdini, Maya and Unity import.

The stage is Y-up (USD's and Maya's, Houdini's and Unity's default; Blender converts on
import), ``metersPerUnit`` = 1 and ``timeCodesPerSecond`` = ``framesPerSecond`` = 24 (or
the run's own rate when that is 25, 30, 48, 50, 60 or an NTSC rate: 23.976, 29.97,
59.94): each frame of the run is sampled at time code t × rate, so an MDP run stepping
every 0.85 s plays at its true speed in a 24 fps scene (USD interpolates between samples). World (x, y[, z]) with z up maps to USD
(x, z, −y): a 2D run lies on the ground plane at height 0.

Prototype axes: the instancer's orientations turn a prototype whose up and forward axes
are ``prototype_up`` and ``prototype_forward`` (its own coordinates; by default Z up and
facing −Y, a character as Blender models it) so that it stands on the stage's up (+Y) and
faces the agent's facing. The stage stays Y-up; only the prototypes' frame is chosen.
``customLayerData`` says which (``crowdmotion_prototype_up``,
``crowdmotion_prototype_forward``). Under ``/World``:

- ``Agents`` — a ``UsdGeomPoints`` of purpose ``guide`` (not rendered: importers leave
  it out unless asked for guides, e.g. Blender's *Guide* purpose option) with
  time-sampled ``points``, ``velocities`` (m/s, for motion blur: central differences,
  one-sided at the ends of a stay; :func:`frame_velocity`), ``widths`` (body
  diameters; 0 while an agent is inactive), ``ids`` and a per-point ``displayColor`` by
  group, and primvars ``group`` (the index of the agent's group in ``/World/Crowd``'s
  prototypes), ``speed`` (m/s), ``orient`` (the instancer's orientation of each agent, a
  quaternion, as Houdini's point attribute of that name) and the locomotion channels
  (below), all time-sampled but ``group``;
- ``Crowd`` — a ``UsdGeomPointInstancer`` with one prototype per group, named after it (a
  capsule of the group's body size in the prototype axes: for walkers along the up axis,
  standing on the point, 1.7 m tall; in 3D along the forward axis, centred on the
  point), time-sampled ``positions``, ``velocities``, ``orientations`` (the prototype's
  forward axis turned to the agent's facing, :attr:`Trajectories.facing`, about the up
  axis and, in 3D, raised by its ``facing_pitch``; its up axis to the stage's up) and
  ``invisibleIds`` for inactive agents, and the same ``speed`` and locomotion primvars
  per instance;
- ``userProperties:crowdmotion:fps``, ``:prototype_up``, ``:prototype_forward`` on
  ``/World`` itself: the stage's rate and prototype axes again, where Blender's importer
  reads them (as custom properties of the World object; the add-on uses them);
- ``Obstacles`` — cylinders, spheres, cubes and polygon prisms for the scene's static
  obstacles (moving ones at their start place, with their path as ``translate`` samples
  at t × rate; a box's translate comes before its scale in ``xformOpOrder``; one that
  stands only for a while, added or removed during a live run, with ``visibility``
  samples: invisible before its start and from its end, held between them).

Locomotion primvars (:mod:`crowdmotion.locomotion`), one value per agent, time-sampled:
``distance`` (float, m), ``gait_phase`` (float, strides in [0, 1); −1 for agents that are
not walkers), ``gait_state`` (int: 0 idle, 1 walk, 2 run, 3 turn, 4 move), ``turn_rate``
(float, rad/s about the up axis, counter-clockwise seen from above) and ``contact_left``
/ ``contact_right`` (int, 1 while the foot is down; 0 for agents that are not walkers).

Every boundable prim has its ``extent`` (time-sampled on the agents and the instancer),
as renderers and USD validators expect. ``customLayerData`` keeps crowdmotion's metadata
(method, seed, parameters, the locomotion parameters) as JSON.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from crowdmotion.io.atomic import atomic_path
from crowdmotion.io.longform import metadata_json
from crowdmotion.locomotion import Locomotion, LocomotionParams
from crowdmotion.trajectories import Trajectories

AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0),
        "-X": (-1.0, 0.0, 0.0), "-Y": (0.0, -1.0, 0.0), "-Z": (0.0, 0.0, -1.0)}
PROTOTYPE_UP = "Z"  # a character as Blender models it: Z up ...
PROTOTYPE_FORWARD = "-Y"  # ... facing -Y (Blender's front view looks along +Y at its face)


def _pxr():
    try:
        from pxr import Gf, Sdf, Usd, UsdGeom, Vt
    except ImportError as exc:  # pragma: no cover - usd-core is a dependency
        raise ImportError("USD export needs the usd-core package: pip install usd-core") from exc
    return Gf, Sdf, Usd, UsdGeom, Vt


def to_usd_frame(points: np.ndarray) -> np.ndarray:
    """World (x, y[, z]) with z up -> USD Y-up (x, z, −y)."""
    p = np.asarray(points, float)
    z = p[..., 2] if p.shape[-1] == 3 else np.zeros(p.shape[:-1])
    return np.stack([p[..., 0], z, -p[..., 1]], axis=-1)


def from_usd_frame(points: np.ndarray, dim: int) -> np.ndarray:
    """Inverse of :func:`to_usd_frame`."""
    p = np.asarray(points, float)
    world = np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1)
    return world[..., :dim]


def axis_name(axis: str, what: str) -> str:
    """``axis`` ("X", "-y", "+Z", ...) as one of :data:`AXES`' names; a ValueError naming
    ``what`` and the value otherwise."""
    name = str(axis).strip().upper().lstrip("+") if isinstance(axis, str) else None
    if name not in AXES:
        raise ValueError(f"{what} must be one of {', '.join(AXES)} (an axis of the prototype's own "
                         f"coordinates), got {axis!r}")
    return name


def prototype_axes(up: str = PROTOTYPE_UP, forward: str = PROTOTYPE_FORWARD) -> np.ndarray:
    """(4,) quaternion (real, i, j, k) turning a prototype with these up and forward axes
    into the stage frame's upright, +X facing pose (up -> +Y, forward -> +X); a ValueError
    when either is not an axis or they are not perpendicular."""
    up, forward = axis_name(up, "prototype_up"), axis_name(forward, "prototype_forward")
    u, f = np.array(AXES[up]), np.array(AXES[forward])
    if abs(float(u @ f)) > 0.5:
        raise ValueError(f"prototype_up and prototype_forward must be perpendicular axes, got up {up!r} and "
                         f"forward {forward!r}")
    rows = np.array([f, u, np.cross(f, u)])  # the rotation taking f, u, f x u to X, Y, Z
    return _quaternion_from_matrix(rows)


def _quaternion_from_matrix(m: np.ndarray) -> np.ndarray:
    """(real, i, j, k) of a proper rotation matrix (Shepperd's method)."""
    tr = np.trace(m)
    k = int(np.argmax([tr, m[0, 0], m[1, 1], m[2, 2]]))
    if k == 0:
        w = np.sqrt(1 + tr) / 2
        q = [w, (m[2, 1] - m[1, 2]) / (4 * w), (m[0, 2] - m[2, 0]) / (4 * w), (m[1, 0] - m[0, 1]) / (4 * w)]
    else:
        i, j, l = (k - 1, k % 3, (k + 1) % 3)
        r = np.sqrt(1 + m[i, i] - m[j, j] - m[l, l]) / 2
        q = np.zeros(4)
        q[0] = (m[l, j] - m[j, l]) / (4 * r)
        q[1 + i] = r
        q[1 + j] = (m[j, i] + m[i, j]) / (4 * r)
        q[1 + l] = (m[l, i] + m[i, l]) / (4 * r)
    q = np.asarray(q, float)
    return q / np.linalg.norm(q)


def quaternion_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(..., 4) a · b of quaternions (real, i, j, k): b's rotation first, then a's."""
    aw, ax, ay, az = (a[..., k] for k in range(4))
    bw, bx, by, bz = (b[..., k] for k in range(4))
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def rotate(quat: np.ndarray, v) -> np.ndarray:
    """(..., 3) ``v`` turned by quaternions (..., 4) stored as USD stores them (i, j, k, real)."""
    q, w = quat[..., :3], quat[..., 3:]
    v = np.broadcast_to(np.asarray(v, float), q.shape)
    t = 2 * np.cross(q, v)
    return v + w * t + np.cross(q, t)


def facing_from_orientations(quat: np.ndarray, dim: int, forward: str = "X") -> dict:
    """The facing the instancer's orientations carry: (T, N, 4) quaternions as USD
    stores them (i, j, k, real) -> ``{"facing": yaw, "facing_pitch": pitch}`` (world
    radians; the prototype's ``forward`` axis turned by each quaternion, back in the z-up
    frame)."""
    world = from_usd_frame(rotate(quat, AXES[axis_name(forward, "prototype_forward")]), 3)
    out = {"facing": np.arctan2(world[..., 1], world[..., 0])}
    if dim == 3:
        out["facing_pitch"] = np.arctan2(world[..., 2], np.linalg.norm(world[..., :2], axis=-1))
    return out


# video rates, the NTSC ones (24000/1001, 30000/1001, 60000/1001: written 23.976, 29.97,
# 59.94) among them
STANDARD_RATES = (24.0, 25.0, 30.0, 48.0, 50.0, 60.0, 24000 / 1001, 30000 / 1001, 60000 / 1001)
RATE_MATCH = 1e-3  # frames per second: a rate this near a standard one is that one, as written
DCC_FPS = 24.0  # a run with fewer frames a second is written at this rate, along its B-spline


def _video_rate(fps: float) -> bool:
    """Whether ``fps`` is one of the STANDARD_RATES (24, 25, 30, 23.976, ...)."""
    return any(abs(fps - r) < RATE_MATCH for r in STANDARD_RATES)


def too_few_frames(traj: Trajectories) -> bool:
    """Whether a character bound to ``traj`` would jolt at every frame: fewer than
    ``DCC_FPS`` a second, and not a video rate of its own (23.976)."""
    return traj.fps < DCC_FPS - RATE_MATCH and not _video_rate(traj.fps)


def stage_rate(traj: Trajectories) -> float:
    """Time codes per second of the stage: the run's own rate when it is a standard video
    rate (24, 25, 30, 23.976, ...) or any whole number of frames a second (12, 40: what
    ``export --fps N`` asked for), else 24, the rate Blender, Maya and Houdini scenes
    start at. Samples sit at t × rate, so the motion plays at its true speed at that rate;
    at the run's own rate each frame is a whole time code, and nothing is interpolated
    between samples (a DCC interpolating the gait phase between two samples either side
    of its wrap from 1 to 0 showed half a stride back)."""
    fps = traj.fps
    whole = fps >= 1.0 - RATE_MATCH and abs(fps - round(fps)) < RATE_MATCH
    # as the user wrote it (29.97, not the 29.969999999999995 of 1 / dt): DCCs match rates exactly
    return round(fps, 6) if whole or _video_rate(fps) else 24.0


def orientations(heading: np.ndarray, pitch: np.ndarray) -> np.ndarray:
    """(..., 4) quaternions (real, i, j, k) in the USD frame turning a prototype's +X to the
    heading (radians about world z, USD +Y) after raising it by the pitch (about its own
    lateral axis, USD +Z before the turn): q = q_yaw · q_pitch."""
    cy, sy = np.cos(heading / 2), np.sin(heading / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    return np.stack([cy * cp, sy * sp, sy * cp, cy * sp], axis=-1)


def capsule_mesh(radius: float, height: float, up, forward, segments: int = 12, rings: int = 4
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A capsule ``height`` tall (at least 2 × ``radius``) standing on the origin along the
    ``up`` vector: (points (V, 3), face vertex counts, face vertex indices), faces wound
    counter-clockwise seen from outside. ``forward`` fixes where its seam lies."""
    up, forward = np.asarray(up, float), np.asarray(forward, float)
    side = np.cross(forward, up)
    r = float(radius)
    h = max(float(height), 2 * r)
    theta = np.linspace(0.0, np.pi / 2, rings + 1)[1:]  # cap rings, from the equator to the pole
    # the profile (distance from the axis, height), bottom pole excluded, top pole excluded
    low = [(r * np.cos(a), r - r * np.sin(a)) for a in theta[::-1][1:]]
    high = [(r * np.cos(a), h - r + r * np.sin(a)) for a in theta[:-1]]
    profile = np.array(low + [(r, r), (r, h - r)] + high)
    phi = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    around = np.cos(phi)[:, None] * forward + np.sin(phi)[:, None] * side  # (S, 3)
    ring_pts = profile[:, 0, None, None] * around[None] + profile[:, 1, None, None] * up  # (R, S, 3)
    points = np.concatenate([[0 * up], ring_pts.reshape(-1, 3), [h * up]])
    n_rings = len(profile)
    ring = lambda i, j: 1 + i * segments + (j % segments)  # noqa: E731
    faces = [[0, ring(0, j + 1), ring(0, j)] for j in range(segments)]
    faces += [[ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j)]
              for i in range(n_rings - 1) for j in range(segments)]
    top = len(points) - 1
    faces += [[ring(n_rings - 1, j), ring(n_rings - 1, j + 1), top] for j in range(segments)]
    # wind each face outward: its normal away from the axis (or along the axis at the poles)
    out = []
    for f in faces:
        a, b, c = points[f[0]], points[f[1]], points[f[2]]
        centre = points[f].mean(axis=0)
        axis_point = up * (centre @ up)
        away = centre - axis_point if np.linalg.norm(centre - axis_point) > 1e-9 * r else centre - up * h / 2
        out.append(f if np.cross(b - a, c - a) @ away > 0 else f[::-1])
    counts = np.array([len(f) for f in out], np.int32)
    return points, counts, np.array([i for f in out for i in f], np.int32)


def _set_extent(prim, UsdGeom, time=None) -> None:
    """Author a boundable prim's extent from its own schema (at ``time`` if given)."""
    from pxr import Usd

    tc = Usd.TimeCode.Default() if time is None else time
    extent = UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Boundable(prim), tc)
    if extent is not None:
        UsdGeom.Boundable(prim).CreateExtentAttr().Set(extent, tc)


OBSTACLE_HEIGHT = 2.0  # metres: a 2D scene's obstacles stand this tall on the stage (cubes, cylinders, prisms)


def frame_velocity(traj: Trajectories) -> np.ndarray:
    """(T, N, D) each agent's velocity at each frame (m/s), as motion blur reads it: the
    central difference of its neighbouring frames, one-sided at the ends of each stay in
    the scene (never across a frame it is absent from), 0 where it stands alone or is
    absent. (The forward difference of ``Trajectories.velocity`` read 0 at a leaver's last
    visible frame and half its speed on entering.)"""
    p = np.nan_to_num(traj.positions)
    act = traj.active_mask
    if traj.n_frames < 2:
        return np.zeros_like(p)
    fwd = np.zeros_like(p)
    fwd[:-1] = (p[1:] - p[:-1]) / traj.dt  # the step from each frame on
    back = np.zeros_like(p)
    back[1:] = fwd[:-1]  # the step into each frame
    has_next = np.zeros_like(act)
    has_next[:-1] = act[:-1] & act[1:]
    has_prev = np.zeros_like(act)
    has_prev[1:] = act[1:] & act[:-1]
    both = (has_next & has_prev)[..., None]
    return np.where(both, (fwd + back) / 2, np.where(has_next[..., None], fwd, np.where(has_prev[..., None], back, 0.0)))


def _face_normal(points: np.ndarray, face: list[int]) -> np.ndarray:
    """The (unnormalised) normal of a planar face by the right-hand rule (Newell's method)."""
    p = points[face]
    q = np.roll(p, -1, axis=0)
    return np.array([np.sum((p[:, 1] - q[:, 1]) * (p[:, 2] + q[:, 2])),
                     np.sum((p[:, 2] - q[:, 2]) * (p[:, 0] + q[:, 0])),
                     np.sum((p[:, 0] - q[:, 0]) * (p[:, 1] + q[:, 1]))])


def polygon_prism(vertices: np.ndarray, height: float) -> tuple[np.ndarray, list[int], list[int]]:
    """A 2D polygon obstacle as a closed prism ``height`` tall on the stage (points in the
    USD frame, face vertex counts and indices, every face wound to face outwards: the
    top up, the bottom down, each side away from the polygon), whichever way round its
    vertices were given (a flat face wound one way faced into the ground)."""
    v = to_usd_frame(np.asarray(vertices, float))
    n = len(v)
    points = np.vstack([v, v + [0.0, height, 0.0]])
    top = list(range(n, 2 * n))
    if _face_normal(points, top)[1] < 0:
        top = top[::-1]
    ring = [i - n for i in top]  # the bottom's vertices in the top's order
    bottom = ring[::-1]
    centre = v.mean(axis=0)
    faces = [top, bottom]
    for a, b in zip(ring, ring[1:] + ring[:1]):
        side = [a, b, b + n, a + n]
        out = (v[a] + v[b]) / 2 - centre
        if float(np.dot(_face_normal(points, side), out)) < 0:
            side = side[::-1]
        faces.append(side)
    return points, [len(f) for f in faces], [i for f in faces for i in f]


def _obstacles(stage, scene_dict: dict, UsdGeom, Gf, Sdf, rate: float) -> None:
    from crowdmotion.scene import Box, Circle, Polygon, Scene, Sphere

    scene = Scene.from_dict(scene_dict)
    UsdGeom.Xform.Define(stage, "/World/Obstacles")
    for k, ob in enumerate(scene.obstacles):
        name = f"/World/Obstacles/obstacle_{k}"
        if isinstance(ob, Circle):
            prim = UsdGeom.Cylinder.Define(stage, name)
            prim.CreateRadiusAttr(float(ob.radius))
            prim.CreateHeightAttr(OBSTACLE_HEIGHT)
            prim.CreateAxisAttr("Y")
            centre = to_usd_frame(ob.center) + [0.0, OBSTACLE_HEIGHT / 2, 0.0]
        elif isinstance(ob, Sphere):
            prim = UsdGeom.Sphere.Define(stage, name)
            prim.CreateRadiusAttr(float(ob.radius))
            centre = to_usd_frame(ob.center)
        elif isinstance(ob, Box):
            prim = UsdGeom.Cube.Define(stage, name)
            prim.CreateSizeAttr(1.0)
            lo, hi = ob.lower, ob.upper
            if scene.dim == 2:
                lo, hi = np.append(lo, 0.0), np.append(hi, OBSTACLE_HEIGHT)
            a, b = to_usd_frame(lo), to_usd_frame(hi)
            centre = (a + b) / 2
            size = np.abs(b - a)
        elif isinstance(ob, Polygon):
            prim = UsdGeom.Mesh.Define(stage, name)
            points, counts, indices = polygon_prism(ob.vertices, OBSTACLE_HEIGHT)
            prim.CreatePointsAttr([Gf.Vec3f(*p) for p in points.tolist()])
            prim.CreateFaceVertexCountsAttr(counts)
            prim.CreateFaceVertexIndicesAttr(indices)
            centre = np.zeros(3)
        else:  # pragma: no cover
            continue
        _set_extent(prim, UsdGeom)
        op = prim.AddTranslateOp()  # first in xformOpOrder: the translate is not scaled
        if isinstance(ob, Box):
            prim.AddScaleOp().Set(Gf.Vec3f(*size.tolist()))
        if ob.is_moving:  # keyframes in seconds -> time codes
            for t, shift in zip(ob.path.times, ob.path.positions - ob.center):
                op.Set(Gf.Vec3d(*(centre + to_usd_frame(shift)).tolist()), round(float(t) * rate, 9))
        else:
            op.Set(Gf.Vec3d(*np.asarray(centre, float).tolist()))
        if ob.is_timed:  # standing only in [start, end): visibility is held between its samples
            start, end = ob.present
            vis = prim.CreateVisibilityAttr()
            if np.isfinite(start):
                vis.Set(UsdGeom.Tokens.invisible, round(min(float(start) * rate, 0.0) - 1.0, 9))
                vis.Set(UsdGeom.Tokens.inherited, round(float(start) * rate, 9))
            else:
                vis.Set(UsdGeom.Tokens.inherited, round(min(float(end) * rate, 0.0) - 1.0, 9))
            if np.isfinite(end):
                vis.Set(UsdGeom.Tokens.invisible, round(float(end) * rate, 9))
            # the same window as user properties (time codes): Blender's importer keeps them as the
            # object's custom properties, where the add-on keys its visibility (it reads no visibility samples)
            for key, value in (("present_from", start), ("present_until", end)):
                if np.isfinite(value):
                    prim.GetPrim().CreateAttribute(f"userProperties:crowdmotion:{key}", Sdf.ValueTypeNames.Double,
                                                   custom=True).Set(round(float(value) * rate, 9))


def _locomotion_primvars(loco: Locomotion) -> dict:
    """name -> ((T, N) values, USD type name) of the locomotion primvars (no NaN: −1 phase
    and 0 contacts for agents that are not walkers)."""
    walker = loco.walker[None, :]
    return {"distance": (loco.distance.astype(np.float32), "FloatArray"),
            "gait_phase": (np.where(walker, np.mod(loco.gait_phase.astype(np.float32), np.float32(1.0)), -1.0)
                           .astype(np.float32), "FloatArray"),
            "gait_state": (loco.gait_state.astype(np.int32), "IntArray"),
            "turn_rate": (loco.turn_rate.astype(np.float32), "FloatArray"),
            "contact_left": (loco.contact_left.astype(np.int32), "IntArray"),
            "contact_right": (loco.contact_right.astype(np.int32), "IntArray")}


def write(traj: Trajectories, path: Path, locomotion: LocomotionParams | None = None,
          prototype_up: str = PROTOTYPE_UP, prototype_forward: str = PROTOTYPE_FORWARD, dcc_rate: bool = True) -> None:
    """Write ``traj`` to the USD file ``path``, atomically (see the module docstring).

    With ``dcc_rate`` (the default), a run with fewer than ``DCC_FPS`` frames a second is
    written at that rate, along the B-spline of its frames and audited as ``crowdmotion
    export`` does (:func:`crowdmotion.smoothing.at_rate`): a character bound to its steps
    would jolt at every one. ``False`` writes the frames as they are.

    Parameters
    ----------
    traj : Trajectories
    path : Path
        ``.usd`` / ``.usdc`` (binary) or ``.usda`` (text).
    locomotion : LocomotionParams, optional
        Parameters of the locomotion primvars (the documented defaults when None).
    prototype_up, prototype_forward : str
        The prototypes' up and forward axes in their own coordinates, each one of ``X``,
        ``Y``, ``Z``, ``-X``, ``-Y``, ``-Z`` and perpendicular to each other: ``Z`` and
        ``-Y`` (a Blender character) by default; ``Y`` and ``Z`` for a character modelled
        Y up facing +Z (Maya, Houdini, Unity).
    """
    axes = prototype_axes(prototype_up, prototype_forward)
    up, forward = axis_name(prototype_up, "prototype_up"), axis_name(prototype_forward, "prototype_forward")
    if dcc_rate and too_few_frames(traj):  # a character would jolt at every step: frames between them
        from crowdmotion.smoothing import at_rate

        traj = at_rate(traj, DCC_FPS)
    Gf, Sdf, Usd, UsdGeom, Vt = _pxr()
    rate = stage_rate(traj)
    # the time code of each frame, rounded off the float noise of dt × rate (7, not 6.999999999999999)
    codes = np.round(np.arange(traj.n_frames) * traj.dt * rate, 9)
    pos = to_usd_frame(traj.positions).astype(np.float32)
    act = traj.active_mask
    loco = traj.locomotion(locomotion)  # derived once per run: every file shares them
    channels = _locomotion_primvars(loco)
    # Vt.QuathArray.FromNumpy takes (i, j, k, real)
    orient = quaternion_product(orientations(traj.facing, traj.facing_pitch), axes)[..., [1, 2, 3, 0]]
    quat = orient.astype(np.float16)
    orient = orient.astype(np.float32)
    ids = np.asarray(traj.ids, np.int64)
    width = (2 * traj.radius).astype(np.float32)
    groups = list(dict.fromkeys(traj.group.tolist()))
    proto_index = np.array([groups.index(g) for g in traj.group.tolist()], np.int32)
    with atomic_path(path) as tmp:
        layer_path = tmp.with_suffix(path.suffix)  # USD picks the file format from the suffix
        stage = Usd.Stage.CreateNew(str(layer_path))
        ok = False
        try:
            UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
            UsdGeom.SetStageMetersPerUnit(stage, 1.0)
            stage.SetTimeCodesPerSecond(rate)
            stage.SetFramesPerSecond(rate)
            stage.SetStartTimeCode(0)
            stage.SetEndTimeCode(float(np.ceil(codes[-1] - 1e-9)))
            stage.SetMetadata("customLayerData", {
                "crowdmotion": metadata_json(traj, loco), "crowdmotion_dim": traj.dim,
                "crowdmotion_prototype_up": up, "crowdmotion_prototype_forward": forward,
                "crowdmotion_axes": f"stage Y-up in metres: world (x east, y north, z up) is USD (x, z, -y); "
                                    f"prototypes are modelled {up} up, facing {forward}: the instancer's "
                                    f"orientations (and the points' orient) stand them on +Y facing their "
                                    f"agent's way"})
            world = UsdGeom.Xform.Define(stage, "/World")
            stage.SetDefaultPrim(world.GetPrim())
            # the same facts as user properties: Blender's importer makes them custom properties
            # of the World object, where the add-on (with no USD library of its own) reads them
            for key, value, kind in (("fps", float(rate), "Double"), ("prototype_up", up, "String"),
                                     ("prototype_forward", forward, "String")):
                world.GetPrim().CreateAttribute(f"userProperties:crowdmotion:{key}", getattr(Sdf.ValueTypeNames, kind),
                                                custom=True).Set(value)
            points = UsdGeom.Points.Define(stage, "/World/Agents")
            points.CreatePurposeAttr(UsdGeom.Tokens.guide)  # a guide to instance on, not rendered
            points.CreateIdsAttr(Vt.Int64Array.FromNumpy(ids))
            p_attr, w_attr = points.CreatePointsAttr(), points.CreateWidthsAttr()
            inst = UsdGeom.PointInstancer.Define(stage, "/World/Crowd")
            inst.CreateIdsAttr(Vt.Int64Array.FromNumpy(ids))
            inst.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(proto_index))
            targets = []
            from pxr import Tf

            for k, g in enumerate(groups):  # a prototype per group, named after it
                name = f"/World/Crowd/Prototypes/{Tf.MakeValidIdentifier(str(g))}_{k}"
                r = float(traj.radius[traj.group == g].max())
                if traj.dim == 2:  # a walker standing on the point: a mesh with no transform of its own
                    proto = UsdGeom.Mesh.Define(stage, name)
                    verts, counts, indices = capsule_mesh(r, 1.7, AXES[up], AXES[forward])
                    proto.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(verts.astype(np.float32)))
                    proto.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(counts))
                    proto.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(indices))
                    proto.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
                else:  # a flyer centred on the point, its body along its forward axis
                    proto = UsdGeom.Capsule.Define(stage, name)
                    proto.CreateRadiusAttr(r)
                    proto.CreateHeightAttr(2 * r)
                    proto.CreateAxisAttr(forward[-1])
                _set_extent(proto.GetPrim(), UsdGeom)
                proto.GetPrim().SetCustomDataByKey("crowdmotion:group", str(g))
                targets.append(proto.GetPath())
            inst.CreatePrototypesRel().SetTargets(targets)
            ip_attr, io_attr, iv_attr = inst.CreatePositionsAttr(), inst.CreateOrientationsAttr(), \
                inst.CreateInvisibleIdsAttr()
            # velocities (m/s) for motion blur; a colour per agent by group (displayColor)
            frame_vel = frame_velocity(traj)
            vel = to_usd_frame(frame_vel).astype(np.float32)
            pv_attr, iv_vel = points.CreateVelocitiesAttr(), inst.CreateVelocitiesAttr()
            from crowdmotion.render.colours import group_colours

            colours = group_colours(groups)
            rgb = np.array([colours[g][:3] for g in traj.group.tolist()], np.float32)
            points.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(Vt.Vec3fArray.FromNumpy(rgb))
            primvars = UsdGeom.PrimvarsAPI(points)
            primvars.CreatePrimvar("group", Sdf.ValueTypeNames.IntArray, UsdGeom.Tokens.vertex).Set(
                Vt.IntArray.FromNumpy(proto_index))
            speed = np.linalg.norm(frame_vel, axis=-1).astype(np.float32)
            channels = {"speed": (speed, "FloatArray"), **channels}
            # per point and per instance: speed, the locomotion channels; orient on the points
            varying = []
            for api in (primvars, UsdGeom.PrimvarsAPI(inst)):
                for name, (values, kind) in channels.items():
                    var = api.CreatePrimvar(name, getattr(Sdf.ValueTypeNames, kind), UsdGeom.Tokens.vertex)
                    varying.append((var, values, getattr(Vt, kind)))
            orient_var = primvars.CreatePrimvar("orient", Sdf.ValueTypeNames.QuatfArray, UsdGeom.Tokens.vertex)
            pe_attr, ie_attr = points.CreateExtentAttr(), inst.CreateExtentAttr()
            for f in range(traj.n_frames):
                tc = Usd.TimeCode(float(codes[f]))
                p_attr.Set(Vt.Vec3fArray.FromNumpy(pos[f]), tc)
                w_attr.Set(Vt.FloatArray.FromNumpy(np.where(act[f], width, 0.0).astype(np.float32)), tc)
                ip_attr.Set(Vt.Vec3fArray.FromNumpy(pos[f]), tc)
                pv_attr.Set(Vt.Vec3fArray.FromNumpy(vel[f]), tc)
                for var, values, array in varying:
                    var.Set(array.FromNumpy(values[f]), tc)
                orient_var.Set(Vt.QuatfArray.FromNumpy(orient[f]), tc)
                iv_vel.Set(Vt.Vec3fArray.FromNumpy(vel[f]), tc)
                io_attr.Set(Vt.QuathArray.FromNumpy(quat[f]), tc)
                iv_attr.Set(Vt.Int64Array.FromNumpy(ids[~act[f]]), tc)
                pe_attr.Set(UsdGeom.Points.ComputeExtent(p_attr.Get(tc), w_attr.Get(tc)), tc)
                ie_attr.Set(inst.ComputeExtentAtTime(tc, tc), tc)
            if traj.metadata.get("scene"):
                _obstacles(stage, traj.metadata["scene"], UsdGeom, Gf, Sdf, rate)
            stage.GetRootLayer().Save()
            ok = True
        finally:
            del stage
            if not ok:
                layer_path.unlink(missing_ok=True)
        layer_path.replace(tmp)


def read(path: Path) -> Trajectories:
    """The ``/World/Agents`` points of a file written by :func:`write` as Trajectories."""
    _, _, Usd, UsdGeom, _ = _pxr()
    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise ValueError(f"{path} is not a readable USD file")
    prim = stage.GetPrimAtPath("/World/Agents")
    if not prim.IsValid():
        raise ValueError(f"{path} has no /World/Agents points (not written by crowdmotion)")
    points = UsdGeom.Points(prim)
    layer_data = stage.GetMetadata("customLayerData") or {}
    meta = json.loads(layer_data.get("crowdmotion", "{}"))
    dim = int(layer_data.get("crowdmotion_dim", 3))
    codes = points.GetPointsAttr().GetTimeSamples()  # the run's frames, at t × rate
    frames = [np.asarray(points.GetPointsAttr().Get(c), float) for c in codes]
    widths = [np.asarray(points.GetWidthsAttr().Get(c), float) for c in codes]
    rate = stage.GetTimeCodesPerSecond()
    dt = (codes[1] - codes[0]) / rate if len(codes) > 1 else 1.0 / rate
    pos = from_usd_frame(np.array(frames), dim)
    active = np.array(widths) > 0
    radius = np.array(widths).max(axis=0) / 2
    ids = np.asarray(points.GetIdsAttr().Get(), np.int64)
    inst = UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/Crowd"))
    group = np.array(["agents"] * len(ids), dtype=object)
    if inst:
        names = [stage.GetPrimAtPath(p).GetCustomDataByKey("crowdmotion:group") for p in
                 inst.GetPrototypesRel().GetTargets()]
        group = np.array([names[k] for k in inst.GetProtoIndicesAttr().Get()], dtype=object)
    facing = {}
    if inst and inst.GetOrientationsAttr().GetTimeSamples():
        facing = facing_from_orientations(np.array([np.asarray(inst.GetOrientationsAttr().Get(c), float)
                                                    for c in codes]), dim,
                                          layer_data.get("crowdmotion_prototype_forward", "X"))
    return Trajectories(pos, dt, ids=ids, group=group, radius=radius,
                        active=None if active.all() else active, metadata=meta, **facing)


def read_locomotion(path: Path) -> Locomotion:
    """The locomotion primvars of ``/World/Agents`` in a file written by :func:`write`."""
    from crowdmotion.locomotion import LocomotionParams

    _, _, Usd, UsdGeom, _ = _pxr()
    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise ValueError(f"{path} is not a readable USD file")
    points = UsdGeom.Points(stage.GetPrimAtPath("/World/Agents"))
    api = UsdGeom.PrimvarsAPI(points)
    names = ("distance", "gait_phase", "gait_state", "turn_rate", "contact_left", "contact_right")
    missing = [n for n in names if not api.HasPrimvar(n)]
    if not points or missing:
        raise ValueError(f"{path} has no locomotion primvars {missing} on /World/Agents (not written by crowdmotion)")
    codes = points.GetPointsAttr().GetTimeSamples()
    grid = {n: np.array([np.asarray(api.GetPrimvar(n).Get(c)) for c in codes]) for n in names}
    meta = json.loads((stage.GetMetadata("customLayerData") or {}).get("crowdmotion", "{}")).get("locomotion") or {}
    traj = read(path)
    kinds = meta.get("kinds") or {}
    kind = np.array([kinds.get(str(g), "walker") for g in traj.group], dtype=object)
    walker = (kind == "walker")[None, :]
    params = LocomotionParams(**meta["params"]) if meta.get("params") else LocomotionParams()
    return Locomotion(grid["distance"].astype(float), np.where(walker, grid["gait_phase"], np.nan),
                      grid["gait_state"].astype(np.int8), grid["turn_rate"].astype(float),
                      grid["contact_left"] == 1, grid["contact_right"] == 1, kind, params)
