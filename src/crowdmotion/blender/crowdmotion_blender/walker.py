"""The walker the add-on builds itself: an armature with hips, spine, legs and arms, a
low-poly body skinned rigidly to it, and its walk and run cycles keyed by analytic leg IK.

One action holds a table of cycles: a walk cycle (each foot down for ``WALK_DUTY`` of the
cycle) for each stride length of a geometric ladder from 0.4 to 2.0 m, and run cycles
(``RUN_DUTY``) from 1.4 to 3.0 m. A stride is a full cycle of two steps, the ground the
body covers in one cycle. In each cycle the planted foot moves back under the hips at
exactly the body's speed (the stride over the cycle), so a character whose cycle time
follows its gait phase and whose stride matches the ladder's nearest keeps its planted
foot in place. Left heel strike at phase 0, right at 0.5, as crowdmotion's channels say.
Runs inside Blender: bpy and numpy only.
"""

from __future__ import annotations

import math

import bpy
import numpy as np

ANKLE = 0.09  # m: ankle height over the ground with the foot flat
THIGH = SHIN = 0.43  # m
HIP = ANKLE + THIGH + SHIN  # m: hip height standing
HIP_WIDTH = 0.1  # m: each hip joint's distance from the middle
WALK_DUTY, RUN_DUTY = 0.6, 0.35  # share of the cycle each foot is down
CYCLE_FRAMES = 32  # action frames per cycle
GAP = 4  # action frames between two cycles of the table
RATIO = 1.02  # stride ratio between neighbouring cycles
WALK_STRIDES = (0.4, 2.0)
RUN_STRIDES = (1.4, 3.0)
LEG_BONES = ("thigh", "shin", "foot")
BONES = {  # name: (head, tail, parent) in the armature's space, Z up, facing -Y
    "hips": ((0, 0, HIP), (0, 0, HIP + 0.2), None),
    "spine": ((0, 0, HIP + 0.2), (0, 0, HIP + 0.55), "hips"),
    "thigh.L": ((HIP_WIDTH, 0, HIP), (HIP_WIDTH, 0, HIP - THIGH), "hips"),
    "shin.L": ((HIP_WIDTH, 0, HIP - THIGH), (HIP_WIDTH, 0, ANKLE), "thigh.L"),
    "foot.L": ((HIP_WIDTH, 0, ANKLE), (HIP_WIDTH, -0.17, 0.0), "shin.L"),
    "thigh.R": ((-HIP_WIDTH, 0, HIP), (-HIP_WIDTH, 0, HIP - THIGH), "hips"),
    "shin.R": ((-HIP_WIDTH, 0, HIP - THIGH), (-HIP_WIDTH, 0, ANKLE), "thigh.R"),
    "foot.R": ((-HIP_WIDTH, 0, ANKLE), (-HIP_WIDTH, -0.17, 0.0), "shin.R"),
    "arm.L": ((0.245, 0, HIP + 0.5), (0.245, 0, HIP - 0.05), "spine"),
    "arm.R": ((-0.245, 0, HIP + 0.5), (-0.245, 0, HIP - 0.05), "spine"),
}
BOXES = {  # bone: (x0, x1, y0, y1, z0, z1), its part of the body
    "hips": (-0.17, 0.17, -0.1, 0.1, HIP - 0.08, HIP + 0.2),
    "spine": (-0.19, 0.19, -0.11, 0.11, HIP + 0.2, HIP + 0.55),
    "thigh.L": (0.03, 0.17, -0.07, 0.07, HIP - THIGH, HIP - 0.05),
    "shin.L": (0.05, 0.15, -0.05, 0.05, ANKLE, HIP - THIGH),
    "foot.L": (0.05, 0.15, -0.19, 0.05, 0.0, ANKLE + 0.02),
    "thigh.R": (-0.17, -0.03, -0.07, 0.07, HIP - THIGH, HIP - 0.05),
    "shin.R": (-0.15, -0.05, -0.05, 0.05, ANKLE, HIP - THIGH),
    "foot.R": (-0.15, -0.05, -0.19, 0.05, 0.0, ANKLE + 0.02),
    "arm.L": (0.2, 0.29, -0.05, 0.05, HIP - 0.05, HIP + 0.5),
    "arm.R": (-0.29, -0.2, -0.05, 0.05, HIP - 0.05, HIP + 0.5),
}
HEAD = (-0.1, 0.1, -0.11, 0.1, HIP + 0.57, HIP + 0.8)  # on the spine
NOSE = (-0.03, 0.03, -0.16, -0.1, HIP + 0.66, HIP + 0.71)


class CycleTable:
    """Where each stride's cycle lies in the walker's action: ``start[k]`` is the first
    action frame of cycle k, which covers ``stride[k]`` metres in ``frames`` action
    frames; ``run[k]`` says whether it is a run cycle."""

    def __init__(self, stride, run, start, frames):
        self.stride = np.asarray(stride, float)
        self.run = np.asarray(run, bool)
        self.start = np.asarray(start, float)
        self.frames = float(frames)


def ladder(lo: float, hi: float) -> np.ndarray:
    n = int(math.ceil(math.log(hi / lo) / math.log(RATIO))) + 1
    return lo * RATIO ** np.arange(n)


def foot_path(u: np.ndarray, stride: float, duty: float) -> tuple[np.ndarray, np.ndarray]:
    """(forward offset from the hip, ankle height) of a foot at cycle fraction ``u`` (0 at
    its heel strike): planted for ``duty`` of the cycle, sliding back under the body at the
    body's speed, then swung forward, lifted, to land a stride ahead of where it rose."""
    u = np.mod(u, 1.0)
    half = stride * duty / 2
    stance = u < duty
    s = np.clip((u - duty) / (1 - duty), 0, 1)
    x = np.where(stance, half - stride * u, -half + 2 * half * (1 - np.cos(np.pi * s)) / 2)
    lift = 0.06 + 0.03 * stride
    y = np.where(stance, ANKLE, ANKLE + lift * np.sin(np.pi * s))
    return x, y


def leg_angles(x: np.ndarray, y: np.ndarray, hip: float) -> tuple[np.ndarray, np.ndarray]:
    """Thigh and shin angles from straight down (forward positive) putting the ankle at
    (x forward, y up) from a hip at height ``hip``, knee forward (two-bone IK)."""
    dx, dy = x, y - hip
    r = np.minimum(np.hypot(dx, dy), 0.999 * (THIGH + SHIN))
    phi = np.arctan2(dx, -dy)
    alpha = np.arccos(np.clip((THIGH ** 2 + r ** 2 - SHIN ** 2) / (2 * THIGH * r), -1, 1))
    a1 = phi + alpha
    kx, ky = THIGH * np.sin(a1), hip - THIGH * np.cos(a1)
    # the ankle on the reachable circle in the leg's direction (where the foot would be)
    ax, ay = r * np.sin(phi), hip - r * np.cos(phi)
    a2 = np.arctan2(ax - kx, ky - ay)
    return a1, a2


def hip_height(stride: float, duty: float) -> float:
    """The hips drop for long strides so the leg reaches the foot at both ends of its stance."""
    reach = stride * duty / 2
    return min(HIP, ANKLE + math.sqrt(max((0.985 * (THIGH + SHIN)) ** 2 - reach ** 2, 0.2)))


def cycle_pose(stride: float, duty: float, frames: int) -> dict:
    """channel -> values over ``frames + 1`` cycle frames (the last equals the first):
    angles forward-positive about the armature's X axis in radians, relative to the parent
    bone; ``hips`` the hips' drop in metres."""
    u = np.arange(frames + 1) / frames
    hip = hip_height(stride, duty)
    out = {"hips": np.full(u.shape, hip - HIP)}
    thigh = {}
    for side, shift in (("L", 0.0), ("R", 0.5)):
        x, y = foot_path(u - shift, stride, duty)
        a1, a2 = leg_angles(x, y, hip)
        out[f"thigh.{side}"], out[f"shin.{side}"], out[f"foot.{side}"] = a1, a2 - a1, -a2
        thigh[side] = a1
    out["arm.L"], out["arm.R"] = 0.6 * thigh["R"], 0.6 * thigh["L"]  # each arm swings with the other leg
    return out


def bone_axes(arm_data) -> dict:
    """bone -> (channel path, index, sign): a forward-positive angle about the armature's X
    axis is ``sign`` times that bone's local Euler X; the hips' rise is its local Y."""
    out = {}
    for bone in arm_data.bones:
        rest = np.array(bone.matrix_local.to_3x3())
        if bone.name == "hips":
            local = rest.T @ np.array([0.0, 0.0, 1.0])
            k = int(np.argmax(np.abs(local)))
            out[bone.name] = (f'pose.bones["{bone.name}"].location', k, float(np.sign(local[k])))
        else:
            local = rest.T @ np.array([-1.0, 0.0, 0.0])  # forward (-Y) positive: about -X
            assert abs(abs(local[0]) - 1) < 1e-6, bone.name
            out[bone.name] = (f'pose.bones["{bone.name}"].rotation_euler', 0, float(np.sign(local[0])))
    return out


def new_action(name: str, keys: dict, slot_name: str = "walker") -> bpy.types.Action:
    """An action of one object slot with a linear F-curve per (path, index): frames and
    values, written in bulk."""
    action = bpy.data.actions.new(name)
    slot = action.slots.new(id_type="OBJECT", name=slot_name)
    bag = action.layers.new("cycles").strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    for (path, index), (frames, values) in keys.items():
        write_fcurve(bag.fcurves.new(path, index=index), frames, values, "LINEAR")
    return action


INTERPOLATION = {"CONSTANT": 0, "LINEAR": 1}


def write_fcurve(fc, frames, values, interpolation: str) -> None:
    """Keys (frames, values) on F-curve ``fc`` in bulk (foreach_set), not one by one."""
    frames = np.asarray(frames, np.float32)
    co = np.empty(2 * len(frames), np.float32)
    co[0::2], co[1::2] = frames, values
    fc.keyframe_points.add(len(frames))
    fc.keyframe_points.foreach_set("co", co)
    fc.keyframe_points.foreach_set("interpolation", np.full(len(frames), INTERPOLATION[interpolation], np.int32))
    fc.update()


def build_armature(name: str = "crowdmotion_walker") -> bpy.types.Armature:
    """The walker's bones (see BONES), made without edit mode's operators."""
    arm = bpy.data.armatures.new(name)
    ob = bpy.data.objects.new(name + "_rig", arm)
    bpy.context.scene.collection.objects.link(ob)
    view = bpy.context.view_layer
    view.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    made = {}
    for bone, (head, tail, parent) in BONES.items():
        eb = arm.edit_bones.new(bone)
        eb.head, eb.tail, eb.roll = head, tail, 0.0
        if parent:
            eb.parent = made[parent]
            eb.use_connect = tuple(BONES[parent][1]) == tuple(head)
        made[bone] = eb
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.data.objects.remove(ob)
    return arm


def build_mesh(name: str, colour) -> bpy.types.Mesh:
    """The body: a box per bone and a head, each vertex weighted wholly to its bone, in a
    material of ``colour``."""
    verts, faces, owner = [], [], []
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    parts = [(b, box) for b, box in BOXES.items()] + [("spine", HEAD), ("spine", NOSE)]
    for bone, (x0, x1, y0, y1, z0, z1) in parts:
        base = len(verts)
        verts += [(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)]
        faces += [tuple(base + i for i in q) for q in quads]
        owner += [bone] * 8
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    mat = bpy.data.materials.new(name)
    mat.diffuse_color = (*colour[:3], 1.0)
    mat.use_nodes = True
    bsdf = next((n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    if bsdf is not None:
        bsdf.inputs["Base Color"].default_value = (*colour[:3], 1.0)
    mesh.materials.append(mat)
    return mesh, owner


def skin(ob, owner) -> None:
    """Vertex groups on the body object: each vertex wholly to the bone that owns it."""
    for bone in dict.fromkeys(owner):
        idx = [i for i, b in enumerate(owner) if b == bone]
        ob.vertex_groups.new(name=bone).add(idx, 1.0, "REPLACE")


def build_cycles(arm_data) -> tuple[bpy.types.Action, bpy.types.Action, CycleTable]:
    """(walk-and-run action, idle action, its cycle table) for the walker's armature."""
    axes = bone_axes(arm_data)
    strides, runs = [], []
    for lo_hi, run in ((WALK_STRIDES, False), (RUN_STRIDES, True)):
        s = ladder(*lo_hi)
        strides += s.tolist()
        runs += [run] * len(s)
    start = np.arange(len(strides)) * (CYCLE_FRAMES + GAP)
    keys = {}
    for k, (stride, run) in enumerate(zip(strides, runs)):
        pose = cycle_pose(stride, RUN_DUTY if run else WALK_DUTY, CYCLE_FRAMES)
        frames = start[k] + np.arange(CYCLE_FRAMES + 1)
        for bone, values in pose.items():
            path, index, sign = axes[bone]
            f, v = keys.setdefault((path, index), ([], []))
            f.append(frames)
            v.append(sign * values)
    walk = new_action("crowdmotion_walk", {k: (np.concatenate(f), np.concatenate(v)) for k, (f, v) in keys.items()})
    idle = new_action("crowdmotion_idle", {k: (np.zeros(1), np.zeros(1)) for k in keys})
    return walk, idle, CycleTable(strides, runs, start, CYCLE_FRAMES)
