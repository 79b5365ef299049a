"""The Swarms list and each swarm's parameter overrides: UI lists and their + / − operators."""
import bpy

from . import props


class BEESWARM_UL_swarms(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        row = layout.row(align=True)
        row.prop(item, "name", text="", emboss=False, icon="FORCE_BOID")
        row.label(text=f"{item.count} · {item.model or '?'}")


class BEESWARM_UL_overrides(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        row = layout.row(align=True)
        row.prop(item, "param", text="")
        row.prop(item, "value", text="")


class BEESWARM_OT_swarm_add(bpy.types.Operator):
    """Add a swarm to the shot"""
    bl_idname = "beeswarm.swarm_add"
    bl_label = "Add Swarm"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        props.add_swarm(context.scene.beeswarm)
        return {"FINISHED"}


class BEESWARM_OT_swarm_remove(bpy.types.Operator):
    """Remove the selected swarm"""
    bl_idname = "beeswarm.swarm_remove"
    bl_label = "Remove Swarm"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return len(context.scene.beeswarm.swarms) > 0

    def execute(self, context):
        s = context.scene.beeswarm
        s.swarms.remove(s.swarm_index)
        s.swarm_index = max(0, min(s.swarm_index, len(s.swarms) - 1))
        return {"FINISHED"}


def active_swarm(settings):
    if not len(settings.swarms):
        return None
    return settings.swarms[max(0, min(settings.swarm_index, len(settings.swarms) - 1))]


class BEESWARM_OT_override_add(bpy.types.Operator):
    """Override one of the model's parameters for the selected swarm"""
    bl_idname = "beeswarm.override_add"
    bl_label = "Add Parameter Override"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return active_swarm(context.scene.beeswarm) is not None

    def execute(self, context):
        sw = active_swarm(context.scene.beeswarm)
        o = sw.overrides.add()
        # Start at the first parameter not yet overridden, at its preset value.
        doc, _ = props.models_doc(context)
        info = props.binary.model_info(doc, sw.model) or {}
        taken = {x.param for x in sw.overrides if x != o}
        free = [q for q in info.get("params", []) if q["name"] not in taken]
        if free:
            o.param = free[0]["name"]
            preset = next((p for p in info.get("presets", []) if p["name"] == sw.preset), {})
            o.value = preset.get("values", {}).get(free[0]["name"], free[0]["default"])
        sw.override_index = len(sw.overrides) - 1
        return {"FINISHED"}


class BEESWARM_OT_override_remove(bpy.types.Operator):
    """Remove the selected parameter override"""
    bl_idname = "beeswarm.override_remove"
    bl_label = "Remove Parameter Override"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        sw = active_swarm(context.scene.beeswarm)
        return sw is not None and len(sw.overrides) > 0

    def execute(self, context):
        sw = active_swarm(context.scene.beeswarm)
        sw.overrides.remove(sw.override_index)
        sw.override_index = max(0, min(sw.override_index, len(sw.overrides) - 1))
        return {"FINISHED"}


classes = (BEESWARM_UL_swarms, BEESWARM_UL_overrides, BEESWARM_OT_swarm_add,
           BEESWARM_OT_swarm_remove, BEESWARM_OT_override_add, BEESWARM_OT_override_remove)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
