"""The walker the add-on builds itself: an armature with hips, spine, legs and arms, a
low-poly body skinned rigidly to it, and the F-curves that pose it (its legs are posed per
agent and frame with planted feet: see footlock.py). A user's own character keeps its walk
cycle: ``CycleTable`` says where it lies in its action. Runs inside Blender: bpy and numpy
only.
"""

from __future__ import annotations

import bpy
import numpy as np

from .footlock import ANKLE, HIP, HIP_WIDTH, THIGH  # the body's measures

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
    """Where each cycle lies in a character's walk action (a user's own: one cycle, used
    for walking and running): ``start[k]`` is the first action frame of cycle k, which
    covers ``stride[k]`` metres in ``frames`` action frames; ``run[k]`` says whether it
    is a run cycle."""

    def __init__(self, stride, run, start, frames):
        self.stride = np.asarray(stride, float)
        self.run = np.asarray(run, bool)
        self.start = np.asarray(start, float)
        self.frames = float(frames)


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


def new_action(name: str, keys: dict, slot_name: str = "walker", interpolation: str = "LINEAR",
               layer: str = "cycles") -> bpy.types.Action:
    """An action of one object slot with an F-curve per (path, index): frames and values,
    written in bulk, keyed ``interpolation`` ("LINEAR" or "CONSTANT")."""
    action = bpy.data.actions.new(name)
    slot = action.slots.new(id_type="OBJECT", name=slot_name)
    bag = action.layers.new(layer).strips.new(type="KEYFRAME").channelbag(slot, ensure=True)
    for (path, index), (frames, values) in keys.items():
        write_fcurve(bag.fcurves.new(path, index=index), frames, values, interpolation)
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
