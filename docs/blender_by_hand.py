"""Run inside Blender's Python (the ``bpy`` package), by docs/make_blender_figures.py: the
*by hand* route of docs/exporting.md. Imports a crowdmotion USD with Blender's own
importer and its default options, gives each ``/World/Crowd`` prototype a character's
mesh (the add-on walker's body in its rest pose, Z up, facing −Y, feet at its origin:
Object Data of the prototype object), and renders one Cycles frame.

    python docs/blender_by_hand.py FILE.usdc OUT.png T X,Y,R W,H
"""

import math
import pathlib
import sys

import bpy
import mathutils
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "src" / "crowdmotion" / "blender"))
from crowdmotion_blender import walker  # noqa: E402  the add-on's body mesh, nothing registered


def main(path: str, out: str, t: float, focus: str, size: str) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.usd_import(filepath=str(pathlib.Path(path).resolve()))  # File > Import > USD, the defaults
    scene = bpy.context.scene
    colours = [(0.2, 0.55, 0.8), (0.9, 0.55, 0.15), (0.4, 0.7, 0.3)]
    protos = sorted((o for o in bpy.data.objects if o.type == "MESH" and o.users_collection
                     and o.users_collection[0].name.startswith("proto")), key=lambda o: o.users_collection[0].name)
    for k, ob in enumerate(protos):
        ob.data = walker.build_mesh(f"character_{k}", colours[k % len(colours)])[0]
    scene.frame_set(int(round(float(t) * scene.render.fps / scene.render.fps_base)))
    graph = bpy.context.evaluated_depsgraph_get()
    fx, fy, fr = (float(v) for v in focus.split(","))
    pts = np.array([list(i.matrix_world.translation) for i in graph.object_instances if i.is_instance])
    pts = pts[np.hypot(pts[:, 0] - fx, pts[:, 1] - fy) < fr]

    scene.render.engine = "CYCLES"
    scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", 8, False
    scene.render.resolution_x, scene.render.resolution_y = (int(v) for v in size.split(","))
    scene.render.resolution_percentage = 100
    world = bpy.data.worlds.new("sky")
    world.color = (0.6, 0.65, 0.7)
    scene.world = world
    bpy.ops.mesh.primitive_plane_add(size=200, location=(0, 0, 0))
    floor = bpy.context.active_object
    floor.data.materials.append(bpy.data.materials.new("floor"))
    floor.data.materials[0].diffuse_color = (0.35, 0.35, 0.33, 1)
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (math.radians(40), math.radians(10), math.radians(30))
    scene.collection.objects.link(sun)
    centre = pts.mean(axis=0) + np.array([0, 0, 0.9])
    span = max(np.ptp(pts[:, 0]), np.ptp(pts[:, 1]) * 16 / 9, 4.0)
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    cam.data.lens = 35
    look = mathutils.Vector((0, -1.0, 0.6)).normalized()
    cam.location = mathutils.Vector(centre) + look * span * 1.2
    cam.rotation_euler = (-look).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.filepath = out
    bpy.ops.render.render(write_still=True)
    print(f"CROWDMOTION_DONE {len(pts)} characters framed")


if __name__ == "__main__":
    main(*sys.argv[1:6])
