"""Import a crowdmotion run into Blender and bind a walking character to every agent.

Reading: Blender's own USD importer brings ``/World/Agents`` in as a point cloud (the
*Guide* purpose) whose attributes are the locomotion primvars; each frame's attributes
are read once with ``foreach_get``, then the point cloud and the ``/World/Crowd``
instancer are removed (the obstacles stay). Binding: per agent an armature object and a
body object sharing their group's armature and mesh (linked duplicates); the root path as
F-curves per agent (location, heading) written in bulk (``foreach_set``). The built-in
walker's legs are posed per agent and frame with each foot planted through its contacts
(footlock.py), written as F-curves in the same action. A user's own character plays its
walk action as an NLA strip whose *animated strip time* follows the agent's gait phase,
and an idle strip above it whose animated influence fades the walk out while the agent
stands. Runs inside Blender: bpy and numpy only.
"""

from __future__ import annotations

import math
import time

import bpy
import numpy as np

from . import footlock
from . import walker as walker_rig

IDLE, WALK, RUN, TURN, MOVE = range(5)
LAST_TIMES: dict = {}  # the seconds each stage of the last import took (the operator reports them too)
BLEND_S = 0.3  # s: walk to idle (and back) fades over this long
SWITCH = 1.02  # a cycle is kept until another's stride is this much nearer the agent's


class Run:
    """A run read from its USD: per frame (T) and agent (N) ``position`` (T, N, 3) in
    Blender's world, ``forward`` (T, N, 3) the way each faces, ``phase`` (strides, [0, 1);
    −1 for agents that do not walk), ``state`` (0 idle, 1 walk, 2 run, 3 turn, 4 move),
    ``distance`` (m), ``contact_left``/``contact_right``, ``active``; per agent ``group``
    (index) and per group ``colour``; ``fps``, ``frame_start``."""


def _stage_rate(world) -> float | None:
    """The stage's frames per second, as the file says it (a custom property of /World)."""
    if world is not None and "crowdmotion:fps" in world.keys():
        return float(world["crowdmotion:fps"])
    return None


def _stage_forward(world) -> np.ndarray:
    """The prototypes' forward axis the file was written with (default -Y)."""
    name = str(world.get("crowdmotion:prototype_forward", "-Y")) if world is not None else "-Y"
    axis = {"X": (1, 0, 0), "Y": (0, 1, 0), "Z": (0, 0, 1)}[name[-1].upper()]
    return -np.array(axis, float) if name.startswith("-") else np.array(axis, float)


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vectors ``v`` (..., 3) turned by unit quaternions ``q`` (..., 4) as (w, x, y, z)."""
    w, u = q[..., :1], q[..., 1:]
    t = 2 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def read_run(filepath: str, scene=None, obstacles: bool = True) -> Run:
    """Import ``filepath`` (a USD file crowdmotion wrote) into ``scene``: set the scene's
    frame rate and range from it, keep its obstacles, and return its agents' channels."""
    scene = scene or bpy.context.scene
    before, colls_before = set(bpy.data.objects), set(bpy.data.collections)
    bpy.ops.wm.usd_import(filepath=bpy.path.abspath(filepath), import_guide=True, set_frame_range=True)
    new = [o for o in bpy.data.objects if o not in before]
    new_colls = [c for c in bpy.data.collections if c not in colls_before]
    imported_obstacles = [o for o in new if o.name.startswith("obstacle_")]  # not the user's own of that name
    world = next((o for o in new if "crowdmotion:fps" in o.keys()), None)
    agents = next((o for o in new if o.type == "POINTCLOUD" and o.name.startswith("Agents")), None)
    if agents is None:
        raise ValueError(f"{filepath} has no /World/Agents points: not a crowdmotion USD file")
    rate = _stage_rate(world)
    if rate:
        scene.render.fps, scene.render.fps_base = (round(rate), round(rate) / rate) if rate >= 1 else (1, 1 / rate)
    frames = range(scene.frame_start, scene.frame_end + 1)
    rot = np.array(agents.matrix_world.to_3x3())
    shift = np.array(agents.matrix_world.translation)
    fwd = _stage_forward(world)
    graph = bpy.context.evaluated_depsgraph_get()
    cols = {"position": ("vector", 3, np.float32), "orient": ("value", 4, np.float32),
            "gait_phase": ("value", 1, np.float32), "gait_state": ("value", 1, np.int32),
            "distance": ("value", 1, np.float32), "radius": ("value", 1, np.float32),
            "contact_left": ("value", 1, np.int32), "contact_right": ("value", 1, np.int32)}
    out = {k: [] for k in cols}
    group = colour = None
    for f in frames:
        scene.frame_set(f)
        data = agents.evaluated_get(graph).data
        n = len(data.points)
        for name, (prop, width, dtype) in cols.items():
            arr = np.empty(n * width, dtype)
            data.attributes[name].data.foreach_get(prop, arr)
            out[name].append(arr.reshape(n, width) if width > 1 else arr)
        if group is None:
            group = np.empty(n, np.int32)
            data.attributes["group"].data.foreach_get("value", group)
            rgba = np.empty(n * 4, np.float32)
            data.attributes["displayColor"].data.foreach_get("color", rgba)
            rgba = rgba.reshape(n, 4)
            colour = {int(g): tuple(rgba[np.argmax(group == g)]) for g in np.unique(group)}
    run = Run()
    pos = np.stack(out["position"]).astype(float) @ rot.T + shift
    q = np.stack(out["orient"]).astype(float)
    run.forward = _rotate(q, fwd) @ rot.T
    run.phase = np.stack(out["gait_phase"]).astype(float)
    run.state = np.stack(out["gait_state"])
    run.distance = np.stack(out["distance"]).astype(float)
    run.contact_left = np.stack(out["contact_left"]).astype(bool)
    run.contact_right = np.stack(out["contact_right"]).astype(bool)
    run.active = np.stack(out["radius"]) > 0
    # an inactive agent's position may be anything: hold its nearest active one
    pos[~run.active] = np.nan
    for k in range(pos.shape[0] - 2, -1, -1):  # before its first: its first
        pos[k] = np.where(np.isnan(pos[k]), pos[k + 1], pos[k])
    for k in range(1, pos.shape[0]):  # after its last: its last
        pos[k] = np.where(np.isnan(pos[k]), pos[k - 1], pos[k])
    run.position = np.nan_to_num(pos)
    run.group, run.colour = group, colour
    run.fps = scene.render.fps / scene.render.fps_base
    run.frame_start = scene.frame_start
    for ob in new:  # the guide points and the capsule instancer: the characters replace them
        if ob.type == "POINTCLOUD" or ob.name.startswith("Crowd") or ob.parent is not None and \
                ob.parent.name.startswith("Crowd") or any(c.name.startswith("proto") for c in ob.users_collection):
            bpy.data.objects.remove(ob)
    for coll in [c for c in new_colls if c.name.startswith("proto") and not c.objects]:
        bpy.data.collections.remove(coll)
    if not obstacles:
        for ob in imported_obstacles:
            bpy.data.objects.remove(ob)
    else:
        show_while_present(imported_obstacles, scene.frame_start)
    scene.frame_set(scene.frame_start)
    return run


def show_while_present(objects, frame_start: int) -> None:
    """Key the visibility of obstacles that stood only for a while (added or removed during
    a live run): hidden before ``crowdmotion:present_from`` and from
    ``crowdmotion:present_until`` (custom properties, in frames, that the USD file carries;
    Blender's importer puts a mesh prim's on its mesh)."""
    for ob in objects:
        keys = ("crowdmotion:present_from", "crowdmotion:present_until")
        props = ob.data if ob.data is not None and any(k in ob.data.keys() for k in keys) else ob
        start, end = (props.get(k) for k in keys)
        if start is None and end is None:
            continue
        hidden_from = [(frame_start, start is not None and start > frame_start)]  # (frame, hidden) keys
        if start is not None and start > frame_start:
            hidden_from.append((math.ceil(start - 1e-6), False))
        if end is not None:
            hidden_from.append((max(math.ceil(end - 1e-6), frame_start), True))
        for frame, hidden in hidden_from:
            ob.hide_viewport = ob.hide_render = hidden
            ob.keyframe_insert("hide_viewport", frame=frame)
            ob.keyframe_insert("hide_render", frame=frame)


def heading(forward: np.ndarray) -> np.ndarray:
    """(T, N) rotation about Z, unwrapped over time, that turns a character facing −Y to
    ``forward``."""
    yaw = np.arctan2(forward[..., 1], forward[..., 0])
    return np.unwrap(yaw + math.pi / 2, axis=0)


def cycle_time(run: Run, table, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """(strip time (T, N): the action frame each agent's pose is read from, idle weight
    (T, N) in [0, 1]). The cycle is the one of the table whose stride is nearest the
    agent's (distance over phase, which the stride model makes exact; kept until another
    is 2 % nearer, so it does not flicker), walk or run as its state says; the time within
    it its gait phase."""
    t, n = run.phase.shape
    stepping = (run.state == WALK) | (run.state == RUN)
    dphase = np.mod(np.diff(run.phase, axis=0), 1.0)
    dist = np.diff(run.distance, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        stride = np.where(stepping[1:] & (dphase > 1e-6), dist / dphase, np.nan)
    stride = np.vstack([stride[:1], stride])
    log_s = np.log(table.stride)
    chosen = np.zeros(n, np.int64)
    known = np.zeros(n, bool)
    out = np.empty((t, n))
    width = math.log(SWITCH)
    for k in range(t):
        run_now = run.state[k] == RUN
        s = stride[k]
        ok = np.isfinite(s) & (s > 0)
        ls = np.log(np.where(ok, s, 1.0))
        # nearest cycle of the agent's gait (walk or run)
        cost = np.abs(ls[:, None] - log_s[None, :]) + 1e3 * (table.run[None, :] != run_now[:, None])
        best = np.argmin(cost, axis=1)
        keep = known & (table.run[chosen] == run_now) & \
            (np.abs(ls - log_s[chosen]) < np.abs(ls - log_s[best]) + width)
        chosen = np.where(ok & ~keep, best, chosen)
        known |= ok
        out[k] = table.start[chosen] + np.clip(run.phase[k], 0, 1 - 1e-6) * table.frames
    return out, idle_fade(~stepping, fps)


def idle_fade(standing: np.ndarray, fps: float) -> np.ndarray:
    """(T, N) in [0, 1]: 1 standing (idle, turn, inactive), 0 stepping, fading over BLEND_S."""
    target = standing.astype(float)
    step = 1.0 / max(BLEND_S * fps, 1.0)
    weight = np.empty_like(target)
    weight[0] = target[0]
    for k in range(1, len(target)):
        weight[k] = weight[k - 1] + np.clip(target[k] - weight[k - 1], -step, step)
    return weight


def walker_pose(run: Run, yaw: np.ndarray, arm_data) -> dict:
    """((path, index) -> (T, N) values of the built-in walker's pose channels with its feet
    planted (footlock.pose), in the F-curves' units; the ankles' world targets (T, N, 2, 3))."""
    standing = (run.state != WALK) & (run.state != RUN)
    rest = {b.name: np.array(b.matrix_local.to_3x3()) for b in arm_data.bones}
    got = footlock.pose(run.position, yaw, run.contact_left, run.contact_right, standing,
                        idle_fade(standing, run.fps), rest)
    axes = walker_rig.bone_axes(arm_data)
    path, index, sign = axes["hips"]
    out = {(path, index): sign * got["hips"]}
    for side in ("L", "R"):
        for bone in walker_rig.LEG_BONES:
            euler = got[f"{bone}.{side}"]
            for k in range(1 if bone == "shin" else 3):  # the knee bends about its own X alone
                out[(f'pose.bones["{bone}.{side}"].rotation_euler', k)] = euler[..., k]
    for arm, leg in (("arm.L", "R"), ("arm.R", "L")):  # each arm swings with the other leg
        path, index, sign = axes[arm]
        out[(path, index)] = sign * 0.6 * got[f"swing.{leg}"]
    return out, got["ankle"]


def _changes(values: np.ndarray) -> np.ndarray:
    """Indices where a column's value differs from the one before (and 0)."""
    keep = np.ones(len(values), bool)
    keep[1:] = values[1:] != values[:-1]
    return np.flatnonzero(keep)


def bind(run: Run, scene=None, character=None, collection_name: str = "crowdmotion") -> dict:
    """A walking character per agent of ``run`` (see the module docstring); returns the
    seconds each stage took. ``character``: None for the built-in walker, or a
    ``(armature object, walk action, stride m, idle action or None)`` of the user's own."""
    scene = scene or bpy.context.scene
    times = {}
    t0 = time.perf_counter()
    coll = bpy.data.collections.new(collection_name)
    scene.collection.children.link(coll)
    # the bodies in a collection of their own: each body's hiding is keyed (it is shown only
    # while its agent is in the scene), so hiding them all for a quick playback is the
    # collection's switch, not the objects'
    body_coll = bpy.data.collections.new(f"{collection_name} bodies")
    coll.children.link(body_coll)
    groups = sorted(run.colour)
    if character is None:
        arm = walker_rig.build_armature()
        protos = {}
        for g in groups:
            mesh, owner = walker_rig.build_mesh(f"crowdmotion_body_{g}", run.colour[g])
            holder = bpy.data.objects.new("skin", mesh)  # vertex groups are the mesh's: skin it once
            walker_rig.skin(holder, owner)
            bpy.data.objects.remove(holder)
            protos[g] = (arm, [(mesh, owner)])
        pose_bones = list(walker_rig.BONES)
        table = None
    else:
        rig, walk, stride, idle = character
        table = walker_rig.CycleTable([stride, stride], [False, True], [walk.frame_range[0]] * 2,
                                      walk.frame_range[1] - walk.frame_range[0])
        children = [(c.data, None) for c in rig.children if c.type == "MESH"]
        protos = {g: (rig.data, children) for g in groups}
        pose_bones = None
        if idle is None:
            idle = _rest_action(walk)
    times["rig"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    n = run.position.shape[1]
    rigs = []
    for i in range(n):
        g = int(run.group[i])
        arm_data, meshes = protos[g]
        ob = bpy.data.objects.new(f"agent_{i:05d}", arm_data)
        coll.objects.link(ob)
        rigs.append(ob)
        for mesh, owner in meshes:
            body = bpy.data.objects.new(f"agent_{i:05d}_body", mesh)
            body.parent = ob
            body_coll.objects.link(body)
            body.modifiers.new("walk", "ARMATURE").object = ob
    # the rigs' poses exist once evaluated: an armature object without one crashes Blender
    # (5.0.1) when its action slot is assigned
    bpy.context.view_layer.update()
    if pose_bones is not None:  # the walker's legs key Euler angles: each rig's pose bones rotate in XYZ
        for ob in rigs:
            for pb in ob.pose.bones:
                pb.rotation_mode = "XYZ"
    times["objects"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    fps = run.fps
    frames = run.frame_start + np.arange(run.position.shape[0], dtype=np.float32)
    yaw = heading(run.forward)
    legs, ankle = walker_pose(run, yaw, arm) if character is None else (None, None)
    times["leg poses"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    for i, ob in enumerate(rigs):
        action = bpy.data.actions.new(f"agent_{i:05d}_path")
        slot = action.slots.new(id_type="OBJECT", name=ob.name)
        bag = action.layers.new("path").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
        walker_rig.write_fcurve(bag.fcurves.new("location", index=0), frames, run.position[:, i, 0], "LINEAR")
        walker_rig.write_fcurve(bag.fcurves.new("location", index=1), frames, run.position[:, i, 1], "LINEAR")
        walker_rig.write_fcurve(bag.fcurves.new("location", index=2), frames, run.position[:, i, 2], "LINEAR")
        walker_rig.write_fcurve(bag.fcurves.new("rotation_euler", index=2), frames, yaw[:, i], "LINEAR")
        hidden = (~run.active[:, i]).astype(np.float32)
        at = _changes(hidden)
        for path in ("hide_viewport", "hide_render"):
            walker_rig.write_fcurve(bag.fcurves.new(path), frames[at], hidden[at], "CONSTANT")
        for body in ob.children:  # a child does not inherit its parent's hiding: the mesh gets its own keys
            shown = walker_rig.new_action(f"{body.name}_shown", {(path, 0): (frames[at], hidden[at])
                                                                  for path in ("hide_viewport", "hide_render")},
                                          body.name, "CONSTANT", "shown")
            body_ad = body.animation_data_create()
            body_ad.action = shown
            body_ad.action_slot = shown.slots[0]
        if legs is not None:
            for (path, index), values in legs.items():
                walker_rig.write_fcurve(bag.fcurves.new(path, index=index), frames, values[:, i], "LINEAR")
        ad = ob.animation_data_create()
        ad.action = action
        ad.action_slot = slot
    times["root paths" if legs is None else "root paths and legs"] = time.perf_counter() - t0
    if legs is not None:
        return {"times": times, "rigs": rigs, "ankle": ankle}

    t0 = time.perf_counter()
    strip_time, weight = cycle_time(run, table, fps)
    walk_slot, idle_slot = walk.slots[0], idle.slots[0]
    span = float(run.position.shape[0] + 1)
    for i, ob in enumerate(rigs):
        ad = ob.animation_data
        for k, (action, slot) in enumerate(((walk, walk_slot), (idle, idle_slot))):
            track = ad.nla_tracks.new()
            strip = track.strips.new(action.name, int(run.frame_start), action)
            strip.action_slot = slot
            strip.extrapolation = "HOLD"
            strip.blend_type = "REPLACE"
            # the strip spans the whole run; what it shows is its animated time
            length = strip.frame_end - strip.frame_start
            strip.scale = max(span / max(length, 1e-3), 1.0)
            if k == 0:
                strip.use_animated_time = True
                fc = strip.fcurves.find("strip_time")
                fc.keyframe_points.clear()
                walker_rig.write_fcurve(fc, frames, strip_time[:, i], "CONSTANT")
            else:
                strip.use_animated_influence = True
                fc = strip.fcurves.find("influence")
                fc.keyframe_points.clear()
                w = weight[:, i]
                at = np.union1d(_changes(w), np.flatnonzero(np.r_[w[1:] != w[:-1], False]))
                walker_rig.write_fcurve(fc, frames[at], w[at], "LINEAR")
    times["gait cycles"] = time.perf_counter() - t0
    return {"times": times, "rigs": rigs, "table": table, "strip_time": strip_time, "idle_weight": weight}


def _rest_action(walk) -> bpy.types.Action:
    """An idle pose for a user's rig that has none: every channel the walk keys, at rest."""
    keys = {}
    for layer in walk.layers:
        for strip in layer.strips:
            for bag in strip.channelbags:
                for fc in bag.fcurves:
                    rest = 1.0 if fc.data_path.endswith(("rotation_quaternion", "scale")) and \
                        (fc.array_index == 0 or fc.data_path.endswith("scale")) else 0.0
                    keys[(fc.data_path, fc.array_index)] = (np.zeros(1), np.full(1, rest))
    return walker_rig.new_action(walk.name + "_rest", keys)


def import_run(filepath: str, character=None, obstacles: bool = True) -> dict:
    """Read ``filepath`` and bind the characters: stage times, the run and the rigs."""
    t0 = time.perf_counter()
    run = read_run(filepath, obstacles=obstacles)
    read_s = time.perf_counter() - t0
    done = bind(run, character=character)
    done["times"] = {"read": read_s, **done["times"]}
    done["run"] = run
    LAST_TIMES.clear()
    LAST_TIMES.update(done["times"])
    return done
