"""Run by tests/io/test_blender.py under a Python with bpy: import a crowdmotion USD with the
add-on's reader and print, as one JSON line, each obstacle's visibility at the frames given.

    python blender_visibility_check.py ADDON_FOLDER RUN.usdc FRAME [FRAME ...]
"""

import json
import sys

import bpy

sys.path.insert(0, sys.argv[1])
from crowdmotion_blender import crowd  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
crowd.read_run(sys.argv[2])
scene = bpy.context.scene
obstacles = sorted(o.name for o in bpy.data.objects if o.name.startswith("obstacle_"))
seen = {}
for frame in map(int, sys.argv[3:]):
    scene.frame_set(frame)
    seen[frame] = {name: bpy.data.objects[name].visible_get() and not bpy.data.objects[name].hide_render
                   for name in obstacles}
print("CROWDMOTION_JSON " + json.dumps(seen))
