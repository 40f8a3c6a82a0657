"""Run inside Blender's Python (the ``bpy`` package): install the crowdmotion add-on from
its zip, import a run with it, and print as JSON what the characters do.

    python tests/io/blender_addon_check.py ADDON.zip FILE.usdc OUT_DIR [--times T1,T2,T3]
        [--feet FIRST:LAST] [--play FIRST:LAST] [--render]

Prints the add-on's stage times; at each time, each character's root, up and forward
axes, whether it shows its idle pose; with --feet, each character's ankles (world, m) on
every frame of FIRST:LAST, into OUT_DIR/feet.npy (frames, agents, 2 feet, 3) with the
frame and evaluation time; with --play, the median and largest seconds of a frame change
(``scene.frame_set`` alone) over frames FIRST:LAST played in order; with --render, a small Cycles frame of the characters and one
of the same scene without them (OUT_DIR/crowd.png, empty.png) and each character's box on
screen. tests/io/test_blender.py runs it with CROWDMOTION_BLENDER_PYTHON (and the
environment variable BLENDER_USER_RESOURCES set to a temporary folder, so the add-on is
installed there and not into the user's Blender).
"""

import argparse
import json
import math
import time

import bpy  # before addon_utils, which bpy puts on the path
import addon_utils  # noqa: I001
import mathutils
import numpy as np


def pose_of(ob) -> dict:
    m = ob.matrix_world
    rot = m.to_3x3().normalized()
    pb = ob.pose.bones
    idle = all(abs(b.rotation_euler.x) < 1e-6 for b in pb if b.name.startswith(("thigh", "shin", "foot")))
    return {"root": list(m.translation), "up": list(rot @ mathutils.Vector((0, 0, 1))),
            "forward": list(rot @ mathutils.Vector((0, -1, 0))), "idle": idle,
            "visible": not ob.hide_render, "body_visible": [not c.hide_render and c.visible_get() for c in ob.children]}


def render(out: str, rigs, focus=None, size=(320, 180)) -> dict:
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 8
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    world = bpy.data.worlds.new("sky")
    world.color = (0.6, 0.65, 0.7)
    scene.world = world
    bpy.ops.mesh.primitive_plane_add(size=200, location=(0, 0, 0))
    floor = bpy.context.active_object
    mat = bpy.data.materials.new("floor")
    mat.diffuse_color = (0.35, 0.35, 0.33, 1)
    floor.data.materials.append(mat)
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (math.radians(40), math.radians(10), math.radians(30))
    scene.collection.objects.link(sun)
    live = [ob for ob in rigs if not ob.hide_render]
    if focus is not None:  # frame only the characters within focus[2] m of (focus[0], focus[1])
        live = [ob for ob in live if math.dist(ob.matrix_world.translation[:2], focus[:2]) < focus[2]]
    pts = np.array([list(ob.matrix_world.translation) for ob in live])
    centre = pts.mean(axis=0) + np.array([0, 0, 0.9])
    span = max(np.ptp(pts[:, 0]), np.ptp(pts[:, 1]) * 16 / 9, 4.0)
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    cam.data.lens = 35
    look = mathutils.Vector((0, -1.0, 0.6)).normalized()
    cam.location = mathutils.Vector(centre) + look * span * 1.2
    cam.rotation_euler = (-look).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(cam)
    scene.camera = cam
    from bpy_extras.object_utils import world_to_camera_view

    boxes = []
    graph = bpy.context.evaluated_depsgraph_get()
    for ob in live:
        body = ob.children[0].evaluated_get(graph)
        mw = body.matrix_world
        co = [world_to_camera_view(scene, cam, mw @ v.co) for v in body.data.vertices]
        xs, ys = [c.x for c in co], [c.y for c in co]
        boxes.append([min(xs), min(ys), max(xs), max(ys)])
    t0 = time.perf_counter()
    scene.render.filepath = f"{out}/crowd.png"
    bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - t0
    for coll in bpy.data.collections:  # the bodies' own hiding is keyed: their collection's switch hides them
        if coll.name.endswith(" bodies"):
            coll.hide_render = True
    scene.render.filepath = f"{out}/empty.png"
    bpy.ops.render.render(write_still=True)
    return {"boxes": boxes, "render_s": seconds, "pointclouds": [o.name for o in scene.objects
                                                                 if o.type == "POINTCLOUD"]}


def main() -> dict:
    ap = argparse.ArgumentParser()
    ap.add_argument("addon")
    ap.add_argument("usd")
    ap.add_argument("out")
    ap.add_argument("--times", default="")
    ap.add_argument("--feet", default="")
    ap.add_argument("--play", default="")
    ap.add_argument("--render", action="store_true")
    ap.add_argument("--focus", default="", help="X,Y,R: frame the characters within R m of (X, Y)")
    ap.add_argument("--size", default="320,180", help="render width,height in pixels")
    args = ap.parse_args()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.preferences.addon_install(filepath=args.addon, overwrite=True)
    addon_utils.enable("crowdmotion_blender", default_set=True)
    t0 = time.perf_counter()
    result = bpy.ops.crowdmotion.import_run(filepath=args.usd)  # as the menu entry runs it
    total = time.perf_counter() - t0
    from crowdmotion_blender import crowd

    scene = bpy.context.scene
    rigs = sorted((o for o in scene.objects if o.type == "ARMATURE" and o.name.startswith("agent_")),
                  key=lambda o: o.name)
    out = {"version": bpy.app.version_string, "result": sorted(result), "import_s": total,
           "times": crowd.LAST_TIMES, "fps": scene.render.fps / scene.render.fps_base,
           "frame_start": scene.frame_start, "frame_end": scene.frame_end, "agents": len(rigs), "frames": []}
    for t in [float(x) for x in args.times.split(",") if x]:
        scene.frame_set(int(round(t * out["fps"])))
        out["frames"].append({"t": t, "rigs": [pose_of(ob) for ob in rigs]})
    if args.feet:
        first, last = map(int, args.feet.split(":"))
        feet = np.empty((last - first, len(rigs), 2, 3), np.float32)
        t0 = time.perf_counter()
        for k, f in enumerate(range(first, last)):
            scene.frame_set(f)
            for i, ob in enumerate(rigs):
                m = ob.matrix_world
                feet[k, i, 0] = m @ ob.pose.bones["foot.L"].head
                feet[k, i, 1] = m @ ob.pose.bones["foot.R"].head
        out["feet_s_per_frame"] = (time.perf_counter() - t0) / max(last - first, 1)
        np.save(f"{args.out}/feet.npy", feet)
        t0 = time.perf_counter()
        scene.frame_set(first + 1)
        out["frame_change_s"] = time.perf_counter() - t0
    if args.play:
        first, last = map(int, args.play.split(":"))
        spent = []
        for f in range(first, last):
            t0 = time.perf_counter()
            scene.frame_set(f)
            spent.append(time.perf_counter() - t0)
        out["play_s"] = {"median": float(np.median(spent)), "max": float(np.max(spent))}
    if args.render:
        scene.frame_set(int(round(float(args.times.split(",")[-1] or 0) * out["fps"])))
        focus = [float(v) for v in args.focus.split(",")] if args.focus else None
        out["render"] = render(args.out, rigs, focus, tuple(int(v) for v in args.size.split(",")))
    return out


if __name__ == "__main__":
    print("CROWDMOTION_JSON " + json.dumps(main()))
