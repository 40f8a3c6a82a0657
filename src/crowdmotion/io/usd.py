"""USD files (``usd-core``) that Blender, Houdini, Maya and Unity import.

The stage is Y-up (USD's and Maya's, Houdini's and Unity's default; Blender converts on
import), ``metersPerUnit`` = 1 and ``timeCodesPerSecond`` = ``framesPerSecond`` = 24 (or
the run's own rate when that is 25, 30, 48, 50 or 60): each frame of the run is sampled at
time code t × rate, so an MDP run stepping every 0.85 s plays at its true speed in a 24 fps
scene (USD interpolates between samples). World (x, y[, z]) with z up maps to USD
(x, z, −y): a 2D run lies on the ground plane at height 0. Under ``/World``:

- ``Agents`` — a ``UsdGeomPoints`` with time-sampled ``points``, ``velocities`` (m/s, for
  motion blur), ``widths`` (body diameters; 0 while an agent is inactive), ``ids`` and a
  per-point ``displayColor`` by group, and primvars ``group`` (the index of the agent's
  group in ``/World/Crowd``'s prototypes) and ``speed`` (m/s, time-sampled) for shaders
  and Houdini/Blender attributes;
- ``Crowd`` — a ``UsdGeomPointInstancer`` with one prototype per group, named after it (a
  capsule of the group's body size: in 2D standing on the point, 1.7 m tall; in 3D lying
  along the body's forward axis, centred on the point), time-sampled ``positions``,
  ``velocities``, ``orientations`` (the prototype's +X turned to the agent's facing,
  :attr:`Trajectories.facing`, about the up axis and, in 3D, raised by its
  ``facing_pitch``) and ``invisibleIds`` for inactive agents;
- ``Obstacles`` — cylinders, spheres, cubes and flat polygon meshes for the scene's static
  obstacles (moving ones at their start place, with their path as ``translate`` samples
  at t × rate; a box's translate comes before its scale in ``xformOpOrder``).

Every boundable prim has its ``extent`` (time-sampled on the agents and the instancer),
as renderers and USD validators expect. ``customLayerData`` keeps crowdmotion's metadata
(method, seed, parameters) as JSON.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from crowdmotion.io.atomic import atomic_path
from crowdmotion.io.longform import metadata_json
from crowdmotion.trajectories import Trajectories


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


def facing_from_orientations(quat: np.ndarray, dim: int) -> dict:
    """The facing the instancer's orientations carry: (T, N, 4) quaternions as USD
    stores them (i, j, k, real) -> ``{"facing": yaw, "facing_pitch": pitch}`` (world
    radians; the prototype's +X turned by each quaternion, back in the z-up frame)."""
    x, y, z, w = (quat[..., k] for k in range(4))
    forward = np.stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)], axis=-1)
    world = from_usd_frame(forward, 3)
    out = {"facing": np.arctan2(world[..., 1], world[..., 0])}
    if dim == 3:
        out["facing_pitch"] = np.arctan2(world[..., 2], np.linalg.norm(world[..., :2], axis=-1))
    return out


STANDARD_RATES = (24.0, 25.0, 30.0, 48.0, 50.0, 60.0)


def stage_rate(traj: Trajectories) -> float:
    """Time codes per second of the stage: the run's own rate when it is a standard video
    rate (24, 25, 30, ...), else 24, the rate Blender, Maya and Houdini scenes start at.
    Samples sit at t × rate, so the motion plays at its true speed at that rate (USD
    interpolates between samples)."""
    return traj.fps if traj.fps in STANDARD_RATES else 24.0


def orientations(heading: np.ndarray, pitch: np.ndarray) -> np.ndarray:
    """(..., 4) quaternions (real, i, j, k) in the USD frame turning a prototype's +X to the
    heading (radians about world z, USD +Y) after raising it by the pitch (about its own
    lateral axis, USD +Z before the turn): q = q_yaw · q_pitch."""
    cy, sy = np.cos(heading / 2), np.sin(heading / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    return np.stack([cy * cp, sy * sp, sy * cp, cy * sp], axis=-1)


def _set_extent(prim, UsdGeom, time=None) -> None:
    """Author a boundable prim's extent from its own schema (at ``time`` if given)."""
    from pxr import Usd

    tc = Usd.TimeCode.Default() if time is None else time
    extent = UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Boundable(prim), tc)
    if extent is not None:
        UsdGeom.Boundable(prim).CreateExtentAttr().Set(extent, tc)


def _obstacles(stage, scene_dict: dict, UsdGeom, Gf, rate: float) -> None:
    from crowdmotion.scene import Box, Circle, Polygon, Scene, Sphere

    scene = Scene.from_dict(scene_dict)
    UsdGeom.Xform.Define(stage, "/World/Obstacles")
    for k, ob in enumerate(scene.obstacles):
        name = f"/World/Obstacles/obstacle_{k}"
        if isinstance(ob, Circle):
            prim = UsdGeom.Cylinder.Define(stage, name)
            prim.CreateRadiusAttr(float(ob.radius))
            prim.CreateHeightAttr(2.0)
            prim.CreateAxisAttr("Y")
            centre = to_usd_frame(ob.center) + [0.0, 1.0, 0.0]
        elif isinstance(ob, Sphere):
            prim = UsdGeom.Sphere.Define(stage, name)
            prim.CreateRadiusAttr(float(ob.radius))
            centre = to_usd_frame(ob.center)
        elif isinstance(ob, Box):
            prim = UsdGeom.Cube.Define(stage, name)
            prim.CreateSizeAttr(1.0)
            lo, hi = ob.lower, ob.upper
            if scene.dim == 2:
                lo, hi = np.append(lo, 0.0), np.append(hi, 2.0)
            a, b = to_usd_frame(lo), to_usd_frame(hi)
            centre = (a + b) / 2
            size = np.abs(b - a)
        elif isinstance(ob, Polygon):
            prim = UsdGeom.Mesh.Define(stage, name)
            v = to_usd_frame(ob.vertices)
            prim.CreatePointsAttr([Gf.Vec3f(*p) for p in v.tolist()])
            prim.CreateFaceVertexCountsAttr([len(v)])
            prim.CreateFaceVertexIndicesAttr(list(range(len(v)))[::-1])  # face up (+Y)
            centre = np.zeros(3)
        else:  # pragma: no cover
            continue
        _set_extent(prim, UsdGeom)
        op = prim.AddTranslateOp()  # first in xformOpOrder: the translate is not scaled
        if isinstance(ob, Box):
            prim.AddScaleOp().Set(Gf.Vec3f(*size.tolist()))
        if ob.is_moving:  # keyframes in seconds -> time codes
            for t, shift in zip(ob.path.times, ob.path.positions - ob.center):
                op.Set(Gf.Vec3d(*(centre + to_usd_frame(shift)).tolist()), float(t) * rate)
        else:
            op.Set(Gf.Vec3d(*np.asarray(centre, float).tolist()))


def write(traj: Trajectories, path: Path) -> None:
    Gf, Sdf, Usd, UsdGeom, Vt = _pxr()
    rate = stage_rate(traj)
    codes = np.arange(traj.n_frames) * traj.dt * rate  # the time code of each frame
    pos = to_usd_frame(traj.positions).astype(np.float32)
    act = traj.active_mask
    # Vt.QuathArray.FromNumpy takes (i, j, k, real)
    quat = orientations(traj.facing, traj.facing_pitch)[..., [1, 2, 3, 0]].astype(np.float16)
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
            stage.SetMetadata("customLayerData", {"crowdmotion": metadata_json(traj), "crowdmotion_dim": traj.dim})
            world = UsdGeom.Xform.Define(stage, "/World")
            stage.SetDefaultPrim(world.GetPrim())
            points = UsdGeom.Points.Define(stage, "/World/Agents")
            points.CreateIdsAttr(Vt.Int64Array.FromNumpy(ids))
            p_attr, w_attr = points.CreatePointsAttr(), points.CreateWidthsAttr()
            inst = UsdGeom.PointInstancer.Define(stage, "/World/Crowd")
            inst.CreateIdsAttr(Vt.Int64Array.FromNumpy(ids))
            inst.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(proto_index))
            targets = []
            from pxr import Tf

            for k, g in enumerate(groups):  # a prototype per group, named after it
                cap = UsdGeom.Capsule.Define(stage, f"/World/Crowd/Prototypes/{Tf.MakeValidIdentifier(str(g))}_{k}")
                r = float(traj.radius[traj.group == g].max())
                cap.CreateRadiusAttr(r)
                if traj.dim == 2:  # a walker standing on the point
                    cap.CreateHeightAttr(max(1.7 - 2 * r, 0.1))
                    cap.CreateAxisAttr("Y")
                    cap.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.85, 0.0))
                else:  # a flyer centred on the point, its body along its forward axis
                    cap.CreateHeightAttr(2 * r)
                    cap.CreateAxisAttr("X")
                _set_extent(cap.GetPrim(), UsdGeom)
                cap.GetPrim().SetCustomDataByKey("crowdmotion:group", str(g))
                targets.append(cap.GetPath())
            inst.CreatePrototypesRel().SetTargets(targets)
            ip_attr, io_attr, iv_attr = inst.CreatePositionsAttr(), inst.CreateOrientationsAttr(), \
                inst.CreateInvisibleIdsAttr()
            # velocities (m/s) for motion blur; a colour per agent by group (displayColor)
            vel = to_usd_frame(np.nan_to_num(traj.velocity)).astype(np.float32)
            pv_attr, iv_vel = points.CreateVelocitiesAttr(), inst.CreateVelocitiesAttr()
            from crowdmotion.render.colours import group_colours

            colours = group_colours(groups)
            rgb = np.array([colours[g][:3] for g in traj.group.tolist()], np.float32)
            points.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(Vt.Vec3fArray.FromNumpy(rgb))
            primvars = UsdGeom.PrimvarsAPI(points)
            primvars.CreatePrimvar("group", Sdf.ValueTypeNames.IntArray, UsdGeom.Tokens.vertex).Set(
                Vt.IntArray.FromNumpy(proto_index))
            speed = np.nan_to_num(traj.speed).astype(np.float32)
            speed_var = primvars.CreatePrimvar("speed", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex)
            pe_attr, ie_attr = points.CreateExtentAttr(), inst.CreateExtentAttr()
            for f in range(traj.n_frames):
                tc = Usd.TimeCode(float(codes[f]))
                p_attr.Set(Vt.Vec3fArray.FromNumpy(pos[f]), tc)
                w_attr.Set(Vt.FloatArray.FromNumpy(np.where(act[f], width, 0.0).astype(np.float32)), tc)
                ip_attr.Set(Vt.Vec3fArray.FromNumpy(pos[f]), tc)
                pv_attr.Set(Vt.Vec3fArray.FromNumpy(vel[f]), tc)
                speed_var.Set(Vt.FloatArray.FromNumpy(speed[f]), tc)
                iv_vel.Set(Vt.Vec3fArray.FromNumpy(vel[f]), tc)
                io_attr.Set(Vt.QuathArray.FromNumpy(quat[f]), tc)
                iv_attr.Set(Vt.Int64Array.FromNumpy(ids[~act[f]]), tc)
                pe_attr.Set(UsdGeom.Points.ComputeExtent(p_attr.Get(tc), w_attr.Get(tc)), tc)
                ie_attr.Set(inst.ComputeExtentAtTime(tc, tc), tc)
            if traj.metadata.get("scene"):
                _obstacles(stage, traj.metadata["scene"], UsdGeom, Gf, rate)
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
                                                    for c in codes]), dim)
    return Trajectories(pos, dt, ids=ids, group=group, radius=radius,
                        active=None if active.all() else active, metadata=meta, **facing)
