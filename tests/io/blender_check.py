"""Run inside Blender's Python (the ``bpy`` package): import a crowdmotion USD and print,
as JSON, where Blender puts the agents and the obstacles at given times.

    python tests/io/blender_check.py FILE.usdc T1 T2 ...

tests/io/test_blender.py runs it with the interpreter named by CROWDMOTION_BLENDER_PYTHON.
"""

import json
import sys

import bpy
import mathutils


def main(path: str, times: list[float]) -> dict:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.usd_import(filepath=path)
    scene = bpy.context.scene
    out = {"version": bpy.app.version_string, "fps": scene.render.fps / scene.render.fps_base,
           "frame_end": scene.frame_end, "frames": [], "obstacles": {}}
    for t in times:
        frame = t * out["fps"]
        whole = int(frame)
        scene.frame_set(whole, subframe=frame - whole)
        graph = bpy.context.evaluated_depsgraph_get()
        points = [list(i.matrix_world.translation) for i in graph.object_instances if i.is_instance]
        out["frames"].append({"t": t, "instances": points})
    scene.frame_set(0)
    for ob in scene.objects:
        if ob.name.startswith("obstacle_"):
            corners = [list(ob.matrix_world @ mathutils.Vector(c)) for c in ob.bound_box]
            out["obstacles"][ob.name] = corners
    return out


if __name__ == "__main__":
    print("CROWDMOTION_JSON " + json.dumps(main(sys.argv[1], [float(t) for t in sys.argv[2:]])))
