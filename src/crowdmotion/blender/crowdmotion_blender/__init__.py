"""crowdmotion for Blender: import a crowd run (the USD file crowdmotion writes) as
walking characters.

File > Import > crowdmotion run (.usd/.usdc/.usda): sets the scene's frame rate and range
from the file, keeps its obstacles, and binds a character to every agent, either the
walker this add-on builds (an armature with legs, hips, spine and arms, whose legs are
posed on every frame with each foot planted through its contact, whichever way the body
moves) or your own armature with a walk action, whose cycle runs at the agent's own gait
phase and fades to its idle pose while the agent stands. Needs nothing but Blender (4.4
or later: its animation uses the slotted, layered actions Blender 4.4 brought).
"""

bl_info = {
    "name": "crowdmotion",
    "author": "crowdmotion",
    "version": (0, 1, 0),
    "blender": (4, 4, 0),
    "location": "File > Import > crowdmotion run",
    "description": "Import a crowdmotion run as walking characters",
    "category": "Import-Export",
}

import bpy  # noqa: E402
from bpy.props import BoolProperty, FloatProperty, StringProperty  # noqa: E402
from bpy_extras.io_utils import ImportHelper  # noqa: E402

from . import crowd  # noqa: E402


class CROWDMOTION_OT_import_run(bpy.types.Operator, ImportHelper):
    """Import a crowdmotion run (USD) with a walking character per agent"""

    bl_idname = "crowdmotion.import_run"
    bl_label = "Import crowdmotion run"
    bl_options = {"REGISTER", "UNDO"}

    filter_glob: StringProperty(default="*.usd;*.usdc;*.usda", options={"HIDDEN"})
    obstacles: BoolProperty(name="Obstacles", default=True, description="Keep the scene's obstacles")
    use_own: BoolProperty(name="Own character", default=False,
                          description="Bind your own armature and walk action instead of the built-in walker")
    rig: StringProperty(name="Armature",
                        description="Your character's armature (its meshes are its children), Z up, facing -Y, "
                                    "feet at its origin")
    walk: StringProperty(name="Walk cycle",
                         description="One stride (two steps) of walking in place, left heel strike first")
    idle: StringProperty(name="Idle pose", description="Pose while the agent stands (default: the rest pose)")
    stride: FloatProperty(name="Stride (m)", default=1.4, min=0.1,
                          description="Ground the walk cycle covers in one cycle (two steps)")

    def draw(self, context):
        col = self.layout.column()
        col.prop(self, "obstacles")
        col.prop(self, "use_own")
        if self.use_own:
            col.prop_search(self, "rig", bpy.data, "objects")
            col.prop_search(self, "walk", bpy.data, "actions")
            col.prop_search(self, "idle", bpy.data, "actions")
            col.prop(self, "stride")

    def execute(self, context):
        character = None
        if self.use_own:
            rig, walk = bpy.data.objects.get(self.rig), bpy.data.actions.get(self.walk)
            if rig is None or rig.type != "ARMATURE" or walk is None:
                self.report({"ERROR"}, "Own character: choose an armature and its walk action")
                return {"CANCELLED"}
            character = (rig, walk, self.stride, bpy.data.actions.get(self.idle))
        try:
            done = crowd.import_run(self.filepath, character=character, obstacles=self.obstacles)
        except ValueError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        times = ", ".join(f"{k} {v:.1f} s" for k, v in done["times"].items())
        self.report({"INFO"}, f"{len(done['rigs'])} characters ({times})")
        return {"FINISHED"}


def _menu(self, context):
    self.layout.operator(CROWDMOTION_OT_import_run.bl_idname, text="crowdmotion run (.usd)")


def register():
    bpy.utils.register_class(CROWDMOTION_OT_import_run)
    bpy.types.TOPBAR_MT_file_import.append(_menu)


def unregister():
    bpy.types.TOPBAR_MT_file_import.remove(_menu)
    bpy.utils.unregister_class(CROWDMOTION_OT_import_run)
