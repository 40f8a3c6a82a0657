"""Run inside Blender's Python (the ``bpy`` package): build a tiny character of one's own (an
armature, Z up facing −Y, feet at its origin, with a box body skinned to it and a walk
action of one stride), install the crowdmotion add-on from its zip, import a run with
*Own character*, and print as JSON what the characters do on every frame.

    python tests/io/blender_own_rig_check.py ADDON.zip FILE.usdc

The walk action keys the left thigh's X rotation as AMPLITUDE · sin(2π (frame − 1) / 24)
over frames 1-25 (one stride, a key on every frame) and the right thigh's as its
opposite. Printed per frame and character: the root (world), the left thigh's angle, the
body's lowest point (world z). tests/io/test_blender.py runs it with
CROWDMOTION_BLENDER_PYTHON (and BLENDER_USER_RESOURCES set to a temporary folder).
"""

import json
import math
import sys

import bpy  # before addon_utils, which bpy puts on the path
import addon_utils  # noqa: I001
import numpy as np

AMPLITUDE = 0.5  # rad
CYCLE = 24  # action frames per stride


def own_character():
    """An armature with hips and two thighs, a box body on each thigh, and its walk action."""
    arm = bpy.data.armatures.new("my_rig")
    rig = bpy.data.objects.new("my_rig", arm)
    bpy.context.scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    hips = arm.edit_bones.new("hips")
    hips.head, hips.tail = (0, 0, 0.9), (0, 0, 1.2)
    for side, x in (("L", 0.1), ("R", -0.1)):
        b = arm.edit_bones.new(f"thigh.{side}")
        b.head, b.tail, b.parent = (x, 0, 0.9), (x, 0, 0.05), hips
    bpy.ops.object.mode_set(mode="OBJECT")
    verts, faces, groups = [], [], {"hips": [], "thigh.L": [], "thigh.R": []}
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    for bone, (x0, x1, z0, z1) in (("hips", (-0.18, 0.18, 0.9, 1.5)), ("thigh.L", (0.05, 0.15, 0.0, 0.9)),
                                   ("thigh.R", (-0.15, -0.05, 0.0, 0.9))):
        base = len(verts)
        verts += [(x, y, z) for x in (x0, x1) for y in (-0.08, 0.08) for z in (z0, z1)]
        faces += [tuple(base + i for i in q) for q in quads]
        groups[bone] += list(range(base, base + 8))
    mesh = bpy.data.meshes.new("my_body")
    mesh.from_pydata(verts, [], faces)
    body = bpy.data.objects.new("my_body", mesh)
    bpy.context.scene.collection.objects.link(body)
    body.parent = rig
    for bone, idx in groups.items():
        body.vertex_groups.new(name=bone).add(idx, 1.0, "REPLACE")
    body.modifiers.new("rig", "ARMATURE").object = rig
    for pb in rig.pose.bones:
        pb.rotation_mode = "XYZ"
    # the walk: keyed as an animator would, frame by frame, on the rig's own action
    for f in range(1, CYCLE + 2):
        a = AMPLITUDE * math.sin(2 * math.pi * (f - 1) / CYCLE)
        for side, sign in (("L", 1.0), ("R", -1.0)):
            pb = rig.pose.bones[f"thigh.{side}"]
            pb.rotation_euler = (sign * a, 0.0, 0.0)
            pb.keyframe_insert("rotation_euler", index=0, frame=f)
    walk = rig.animation_data.action
    walk.name = "my_walk"
    for bag in (cb for layer in walk.layers for strip in layer.strips for cb in strip.channelbags):
        for fc in bag.fcurves:
            for k in fc.keyframe_points:
                k.interpolation = "LINEAR"
    rig.animation_data.action = None  # the character stands in its rest pose where it was made
    for pb in rig.pose.bones:
        pb.rotation_euler = (0.0, 0.0, 0.0)
    return rig, walk


def main() -> dict:
    addon, usd = sys.argv[1:3]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.preferences.addon_install(filepath=addon, overwrite=True)
    addon_utils.enable("crowdmotion_blender", default_set=True)
    rig, walk = own_character()
    result = bpy.ops.crowdmotion.import_run(filepath=usd, use_own=True, rig=rig.name, walk=walk.name, stride=1.4)
    scene = bpy.context.scene
    rigs = sorted((o for o in scene.objects if o.type == "ARMATURE" and o.name.startswith("agent_")),
                  key=lambda o: o.name)
    graph = bpy.context.evaluated_depsgraph_get()
    frames = []
    for f in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(f)
        row = []
        for ob in rigs:
            body = ob.children[0].evaluated_get(graph)
            low = min((body.matrix_world @ v.co).z for v in body.data.vertices)
            row.append({"root": list(ob.matrix_world.translation), "thigh": ob.pose.bones["thigh.L"].rotation_euler.x,
                        "low": low})
        frames.append(row)
    return {"result": sorted(result), "agents": len(rigs), "bodies": [len(o.children) for o in rigs],
            "walk_range": list(walk.frame_range), "fps": scene.render.fps / scene.render.fps_base,
            "frame_start": scene.frame_start, "frames": frames, "amplitude": AMPLITUDE}


if __name__ == "__main__":
    print("CROWDMOTION_JSON " + json.dumps(main()))
