"""Run inside Blender's Python (the ``bpy`` package): import a crowdmotion USD with the
default options, put a character modelled as Blender models one (Z up, facing −Y, feet
at the origin) in place of the prototypes by both documented routes, and print as JSON
where each character's root is and which ways its up and forward axes point.

    python tests/io/blender_character.py FILE.usdc BLEND_DIR T1 T2 ...

Routes: (1) the ``/World/Crowd`` instancer, the prototype's mesh swapped for the
character's; (2) Geometry Nodes *Instance on Points* on ``/World/Agents`` (imported with
the *Guide* purpose option) rotated by its ``orient`` attribute. Then the scene is saved
into BLEND_DIR, reopened, and route (1) is read again at the last time (the file must
still be found). tests/io/test_blender.py runs it with CROWDMOTION_BLENDER_PYTHON.
"""

import json
import sys

import bpy
import mathutils


def character_mesh() -> bpy.types.Mesh:
    """A 1.7 m block with a nose on its −Y side, standing on the origin."""
    mesh = bpy.data.meshes.new("character")
    v = [(-0.2, -0.1, 0), (0.2, -0.1, 0), (0.2, 0.1, 0), (-0.2, 0.1, 0),
         (-0.2, -0.1, 1.7), (0.2, -0.1, 1.7), (0.2, 0.1, 1.7), (-0.2, 0.1, 1.7), (0, -0.4, 1.5)]
    f = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    mesh.from_pydata(v, [], f)
    return mesh


def poses(times: list[float], name_filter) -> list[dict]:
    scene = bpy.context.scene
    fps = scene.render.fps / scene.render.fps_base
    out = []
    for t in times:
        frame = t * fps
        whole = int(frame)
        scene.frame_set(whole, subframe=frame - whole)
        graph = bpy.context.evaluated_depsgraph_get()
        rows = []
        for inst in graph.object_instances:
            if not inst.is_instance or not name_filter(inst):
                continue
            m = inst.matrix_world
            rot = m.to_3x3().normalized()
            rows.append({"root": list(m.translation), "up": list(rot @ mathutils.Vector((0, 0, 1))),
                         "forward": list(rot @ mathutils.Vector((0, -1, 0)))})
        out.append({"t": t, "instances": rows})
    return out


def main(path: str, folder: str, times: list[float]) -> dict:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.usd_import(filepath=path)
    out = {"version": bpy.app.version_string, "objects": sorted(o.name for o in bpy.data.objects)}
    mesh = character_mesh()
    protos = [o for o in bpy.data.objects if o.type == "MESH" and o.users_collection
              and o.users_collection[0].name.startswith("proto")]
    for o in protos:
        o.data = mesh
    names = {o.name for o in protos}
    out["instancer"] = poses(times, lambda inst: inst.object.original.name in names)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.usd_import(filepath=path, import_guide=True)
    agents = bpy.data.objects["Agents"]
    char = bpy.data.objects.new("character", character_mesh())
    bpy.context.scene.collection.objects.link(char)
    char.hide_render = char.hide_viewport = True
    tree = bpy.data.node_groups.new("walkers", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    group_in, group_out = tree.nodes.new("NodeGroupInput"), tree.nodes.new("NodeGroupOutput")
    on_points = tree.nodes.new("GeometryNodeInstanceOnPoints")
    info = tree.nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = char
    orient = tree.nodes.new("GeometryNodeInputNamedAttribute")
    orient.data_type = "QUATERNION"
    orient.inputs["Name"].default_value = "orient"
    tree.links.new(group_in.outputs[0], on_points.inputs["Points"])
    tree.links.new(info.outputs["Geometry"], on_points.inputs["Instance"])
    tree.links.new(orient.outputs["Attribute"], on_points.inputs["Rotation"])
    tree.links.new(on_points.outputs["Instances"], group_out.inputs[0])
    agents.modifiers.new("walkers", "NODES").node_group = tree
    out["on_points"] = poses(times, lambda inst: inst.parent is not None and inst.parent.original == agents)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.usd_import(filepath=path)
    blend = f"{folder}/saved.blend"
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    bpy.ops.wm.open_mainfile(filepath=blend)
    out["reopened"] = poses(times[-1:], lambda inst: True)
    return out


if __name__ == "__main__":
    result = main(sys.argv[1], sys.argv[2], [float(t) for t in sys.argv[3:]])
    print("CROWDMOTION_JSON " + json.dumps(result))
