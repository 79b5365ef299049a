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
        remove_active(context.scene.beeswarm, "swarms", "swarm_index")
        return {"FINISHED"}


def _clamped(owner, items, index):
    return max(0, min(getattr(owner, index), len(getattr(owner, items)) - 1))


def remove_active(owner, items, index):
    """Removes the list's selected item; the selection stays on a neighbour."""
    getattr(owner, items).remove(_clamped(owner, items, index))
    setattr(owner, index, _clamped(owner, items, index))


def active_swarm(settings):
    if not len(settings.swarms):
        return None
    return settings.swarms[_clamped(settings, "swarms", "swarm_index")]


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
            o.value = props.preset_values(doc, sw).get(free[0]["name"], free[0]["default"])
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
        remove_active(active_swarm(context.scene.beeswarm), "overrides", "override_index")
        return {"FINISHED"}


classes = (BEESWARM_UL_swarms, BEESWARM_UL_overrides, BEESWARM_OT_swarm_add,
           BEESWARM_OT_swarm_remove, BEESWARM_OT_override_add, BEESWARM_OT_override_remove)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
