"""The sidebar panel (3D viewport, N panel, tab "Beeswarm")."""
import bpy

from . import binary, operators, props


class BEESWARM_PT_panel(bpy.types.Panel):
    bl_label = "Beeswarm"
    bl_idname = "BEESWARM_PT_panel"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Beeswarm"

    def draw(self, context):
        layout = self.layout
        s = context.scene.beeswarm
        path, msg = binary.resolve(props.preference_binary(context))
        box = layout.box()
        if path is None:
            col = box.column(align=True)
            col.alert = True
            for line in _wrap(msg, 36):
                col.label(text=line, icon="NONE")
            col.operator("preferences.addon_show", text="Set Binary Path",
                         icon="PREFERENCES").module = __package__
        else:
            where = "bundled" if path == binary.bundled() else str(path.parent)
            box.label(text=f"beeswarm: {path.name} ({where})", icon="CHECKMARK")

        layout.prop(s, "source", expand=True)
        if s.source == "FILE":
            layout.prop(s, "shot_file")
        else:
            col = layout.column(align=True)
            col.prop(s, "shot_name")
            col.prop(s, "swarm_name")
            col = layout.column(align=True)
            col.prop(s, "count")
            col.prop(s, "model")
            doc, reason = props.models_doc(context)
            info = binary.model_info(doc, s.model)
            if reason and path is not None:
                for line in _wrap(reason, 40):
                    col.label(text=line, icon="INFO")
            elif info:
                for line in _wrap(info["summary"], 40):
                    col.label(text=line)
            col.prop(s, "preset")
            if s.preset == "FILE":
                col.prop(s, "preset_file")
            col.prop(s, "seed")
            col.prop(s, "substeps")
            row = layout.row()
            row.label(text=f"Frames {context.scene.frame_start}–{context.scene.frame_end} at "
                           f"{context.scene.render.fps / context.scene.render.fps_base:g} fps "
                           f"(from the scene)")
            layout.prop(s, "spawn_object")
            if s.spawn_object is None:
                col = layout.column(align=True)
                col.prop(s, "spawn_center")
                col.prop(s, "spawn_size")
            layout.prop(s, "obstacles")
            layout.prop(s, "targets")
            layout.prop(s, "ground")
            layout.prop(s, "wind")
        layout.prop(s, "cache_dir")
        layout.prop(s, "format", expand=True)
        if s.format == "USD":
            layout.prop(s, "instance_motion")
        row = layout.row()
        row.scale_y = 1.4
        busy = operators._active["job"] is not None
        row.enabled = path is not None and not busy
        op = row.operator("beeswarm.bake", text="Baking… (Esc cancels)" if busy else "Bake Swarm",
                          icon="PLAY")
        op.format = s.format
        op.shot_path = s.shot_file if s.source == "FILE" else ""
        if s.source == "SCENE":
            layout.operator("beeswarm.write_shot", icon="FILE_TEXT")
        if s.last_message:
            col = layout.column(align=True)
            col.alert = s.last_message.startswith("Error")
            for line in _wrap(s.last_message, 40):
                col.label(text=line)


def _wrap(text, width):
    words, line, out = text.split(), "", []
    for w in words:
        if line and len(line) + 1 + len(w) > width:
            out.append(line)
            line = w
        else:
            line = f"{line} {w}" if line else w
    if line:
        out.append(line)
    return out or [""]


classes = (BEESWARM_PT_panel,)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
