"""The sidebar panel (3D viewport, N panel, tab "Beeswarm")."""
import bpy

from . import binary, operators, props, swarm_list


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
            _draw_shot(context, layout, s, path)
        layout.prop(s, "cache_dir")
        col = layout.column(align=True)
        row = col.row(align=True)
        row.prop(s, "formats", expand=True)
        if len(s.formats) > 1:
            col.row(align=True).prop(s, "format", expand=True)
        imported = s.format if len(s.formats) != 1 else next(iter(s.formats))
        if imported == "USD":
            col.prop(s, "instance_motion")
            col.prop(s, "asset")
            col.prop(s, "viewport_points")
        col.prop(s, "display_percent", slider=True)
        row = layout.row()
        row.scale_y = 1.4
        busy = operators._active["job"] is not None
        row.enabled = path is not None and not busy and len(s.formats) > 0
        op = row.operator("beeswarm.bake", text="Baking… (Esc cancels)" if busy else "Bake Swarm",
                          icon="PLAY")
        op.format = imported
        op.also_formats = set(s.formats) - {imported}
        op.shot_path = s.shot_file if s.source == "FILE" else ""
        row = layout.row(align=True)
        if s.source == "SCENE":
            row.operator("beeswarm.write_shot", icon="FILE_TEXT")
        wedge = row.row(align=True)
        wedge.enabled = path is not None
        wedge.operator("beeswarm.write_wedge", icon="MOD_ARRAY")
        hint = motion_blur_hint(context.scene, swarm_list.active_swarm(s), props.models_doc(context)[0])
        if hint:
            box = layout.box()
            for line in _wrap(hint, 40):
                box.label(text=line, icon="NONE")
        if s.last_message:
            col = layout.column(align=True)
            col.alert = s.last_message.startswith("Error")
            for line in _wrap(s.last_message, 40):
                col.label(text=line)

def _draw_shot(context, layout, s, path):
    col = layout.column(align=True)
    col.prop(s, "shot_name")
    col.prop(s, "seed")
    col.prop(s, "substeps")
    col = layout.column(align=True)
    col.prop(s, "use_scene_frames")
    if s.use_scene_frames:
        col.label(text=f"Frames {context.scene.frame_start}–{context.scene.frame_end} at "
                       f"{context.scene.render.fps / context.scene.render.fps_base:g} fps")
    else:
        row = col.row(align=True)
        row.prop(s, "frame_start")
        row.prop(s, "frame_end")

    layout.label(text="Swarms")
    row = layout.row()
    row.template_list("BEESWARM_UL_swarms", "", s, "swarms", s, "swarm_index", rows=2)
    col = row.column(align=True)
    col.operator("beeswarm.swarm_add", icon="ADD", text="")
    col.operator("beeswarm.swarm_remove", icon="REMOVE", text="")
    sw = swarm_list.active_swarm(s)
    if sw is None:
        layout.label(text="No swarm yet: + adds one (Bake adds the default)", icon="INFO")
    else:
        _draw_swarm(context, layout.box(), sw, path)

    layout.prop(s, "obstacles")
    layout.prop(s, "targets")
    layout.prop(s, "ground")
    layout.prop(s, "wind")
    layout.prop(s, "wings")
    if s.wings == "FLAP":
        layout.prop(s, "wing_flap_hz")
    if "GLTF" in s.formats:
        layout.prop(s, "gltf_layout")

def _draw_swarm(context, box, sw, path):
    col = box.column(align=True)
    col.prop(sw, "name")
    col.prop(sw, "count")
    col.prop(sw, "model")
    doc, reason = props.models_doc(context)
    info = binary.model_info(doc, sw.model)
    if reason and path is not None:
        for line in _wrap(reason, 40):
            col.label(text=line, icon="INFO")
    elif info:
        for line in _wrap(info["summary"], 40):
            col.label(text=line)
    col.prop(sw, "preset")
    if sw.preset == "FILE":
        col.prop(sw, "preset_file")
    col = box.column(align=True)
    col.prop(sw, "bee_length")
    col.prop(sw, "size_variation")
    col.prop(sw, "speed_variation")
    if (sw.model or "bee") == "bee":
        col.prop(sw, "start_inside")
    box.prop(sw, "spawn_object")
    if sw.spawn_object is None:
        col = box.column(align=True)
        col.prop(sw, "spawn_center")
        col.prop(sw, "spawn_size")
    box.prop(sw, "bounds_object")
    box.label(text="Parameter overrides")
    row = box.row()
    row.template_list("BEESWARM_UL_overrides", "", sw, "overrides", sw, "override_index",
                      rows=2)
    col = row.column(align=True)
    col.operator("beeswarm.override_add", icon="ADD", text="")
    col.operator("beeswarm.override_remove", icon="REMOVE", text="")


def motion_blur_hint(scene, swarm, doc):
    """What real-scale motion blur does to a bee at the swarm's speed, and how to tame it,
    or "" without a swarm. Blur length = speed × shutter / fps (shutter in frames)."""
    if swarm is None:
        return ""
    speed = props.preset_values(doc, swarm).get("speed")
    speed = next((o.value for o in swarm.overrides if o.param == "speed"), speed)
    if speed is None:
        speed = 1.0  # the bee model's default
    fps = scene.render.fps / (scene.render.fps_base or 1.0)
    shutter = scene.render.motion_blur_shutter
    smear = speed * shutter / fps
    lengths = smear / max(swarm.bee_length, 1e-6)
    state = "on" if scene.render.use_motion_blur else "off"
    return (f"Motion blur ({state}, shutter {shutter:g}): at {speed:g} m/s a bee smears "
            f"{smear * 100:.1f} cm, {lengths:.1f} body lengths, per exposure. For crisper "
            f"bees lower Render > Motion Blur > Shutter (0.1 gives {speed * 0.1 / fps * 100:.1f} cm).")


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
