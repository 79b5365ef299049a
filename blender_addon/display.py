"""What the viewport shows of an imported swarm: a share of the bees (Display %, viewport
only, renders draw every bee), for USD each bee as a point (Points in Viewport), and for
USD a scene object drawn on every bee instead of the cache's prototype (Insect Asset)."""
import math
import re

import bpy

from . import importer

DISPLAY_MODIFIER = "beeswarm display"
_BEE_OBJECT = re.compile(r"^bee_(\d+)(?:_|$)")  # glTF: bee_<id>, bee_<id>_body, wings


def shown(bee_id, percent):
    """Whether bee `bee_id` is drawn at `percent` (a fixed hash of the id, so the same bees
    stay as the percentage changes and between formats)."""
    h = (int(bee_id) * 2654435761) % 4294967296
    return h < percent / 100.0 * 4294967296


def _display_group():
    """Viewport-only Geometry Nodes: deletes a random share of the instances, chosen by their
    `id` (Random Value's ID input is the `id` attribute when present), so the same bees stay;
    with Points in Viewport, the points of hidden bees (inside a hive) too."""
    # One per instancer, not shared: each import's data-blocks go with that import.
    ng = bpy.data.node_groups.new(DISPLAY_MODIFIER, "GeometryNodeTree")
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    share = ng.interface.new_socket("Share", in_out="INPUT", socket_type="NodeSocketFloat")
    share.default_value, share.min_value, share.max_value = 1.0, 0.0, 1.0
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    gin, gout = ng.nodes.new("NodeGroupInput"), ng.nodes.new("NodeGroupOutput")
    rnd = ng.nodes.new("FunctionNodeRandomValue")
    rnd.data_type = "BOOLEAN"
    invert = ng.nodes.new("FunctionNodeBooleanMath")
    invert.operation = "NOT"
    ng.links.new(gin.outputs["Share"], rnd.inputs["Probability"])
    # The boolean output: one of four sockets up to 5.0, the only one (typed) in 5.3.
    ng.links.new(next(o for o in rnd.outputs if o.type == "BOOLEAN"), invert.inputs[0])
    # Instances, or points when the instancing is off in the viewport (Points in Viewport),
    # each from its own component: a point-domain delete on instances would reach into the
    # instanced prototypes.
    parts = ng.nodes.new("GeometryNodeSeparateComponents")
    join = ng.nodes.new("GeometryNodeJoinGeometry")
    ng.links.new(gin.outputs["Geometry"], parts.inputs[0])
    # The points also lose those the instancer's mask hides (bees inside a hive: USD
    # invisibleIds, which Blender's importer reads into a `mask` point attribute and the
    # instancing skips): hidden = the attribute exists and is false.
    mask = ng.nodes.new("GeometryNodeInputNamedAttribute")
    mask.data_type = "BOOLEAN"
    mask.inputs["Name"].default_value = "mask"
    hidden = ng.nodes.new("FunctionNodeBooleanMath")
    hidden.operation = "NIMPLY"  # A and not B
    ng.links.new(mask.outputs["Exists"], hidden.inputs[0])
    ng.links.new(mask.outputs["Attribute"], hidden.inputs[1])
    either = ng.nodes.new("FunctionNodeBooleanMath")
    either.operation = "OR"
    ng.links.new(invert.outputs[0], either.inputs[0])
    ng.links.new(hidden.outputs[0], either.inputs[1])
    for component, domain, drop in (("Instances", "INSTANCE", invert), ("Point Cloud", "POINT", either)):
        delete = ng.nodes.new("GeometryNodeDeleteGeometry")
        delete.domain = domain
        ng.links.new(parts.outputs[component], delete.inputs["Geometry"])
        ng.links.new(drop.outputs[0], delete.inputs["Selection"])
        ng.links.new(delete.outputs["Geometry"], join.inputs[0])
    ng.links.new(join.outputs[0], gout.inputs["Geometry"])
    return ng


def _instancing_modifier(ob):
    """The USD importer's own Geometry Nodes modifier (Instance on Points), or None."""
    for mod in ob.modifiers:
        ng = getattr(mod, "node_group", None)
        if mod.type == "NODES" and ng is not None and any(
                n.bl_idname == "GeometryNodeInstanceOnPoints" for n in ng.nodes):
            return mod
    return None


def _share_input(ng):
    return next(i.identifier for i in ng.interface.items_tree
                if getattr(i, "in_out", "") == "INPUT" and i.name == "Share")


def apply(scene, objects=None):
    """Applies the scene's Display % and Points in Viewport to its imported swarms (or to
    `objects`)."""
    from . import motion
    percent = scene.beeswarm.display_percent
    points = scene.beeswarm.viewport_points
    if objects is None:
        objects = [o for o in scene.objects if o.get(importer.SHOT_TAG) is not None]
    for ob in objects:
        if ob.type == "POINTCLOUD" and any(m.type == "MESH_SEQUENCE_CACHE" for m in ob.modifiers):
            mod = ob.modifiers.get(DISPLAY_MODIFIER)
            if mod is None:
                mod = ob.modifiers.new(DISPLAY_MODIFIER, "NODES")
                mod.node_group = _display_group()
                mod.show_render = False  # renders draw every bee
            motion.set_modifier_input(mod, _share_input(mod.node_group), percent / 100.0)
            instancing = _instancing_modifier(ob)
            if instancing is not None and instancing.show_viewport == points:
                instancing.show_viewport = not points  # renders keep instancing
            ob.update_tag()
            continue
        m = _BEE_OBJECT.match(ob.name)
        if m:
            hide = not shown(int(m.group(1)), percent)
            if ob.hide_viewport != hide:
                ob.hide_viewport = hide


def use_asset(objects, asset):
    """Draws `asset` on every bee of each imported USD instancer instead of the cache's
    prototype, in the importer's own node group (made for this import). The asset is
    modelled in Blender's axes, facing +X with +Z up; the instancer's space is the shot's
    Y-up, so it is turned −90° about X first (+Z up → +Y up, +Y left → −Z: the bee's
    body frame, X forward, Y up, Z right)."""
    done = 0
    for ob in objects:
        if ob.type != "POINTCLOUD":
            continue
        for mod in ob.modifiers:
            ng = getattr(mod, "node_group", None)
            if mod.type != "NODES" or ng is None:
                continue
            iop = next((n for n in ng.nodes if n.bl_idname == "GeometryNodeInstanceOnPoints"), None)
            if iop is None:
                continue
            info = ng.nodes.new("GeometryNodeObjectInfo")
            info.transform_space = "ORIGINAL"
            info.inputs["Object"].default_value = asset
            info.inputs["As Instance"].default_value = True
            turn = ng.nodes.new("GeometryNodeTransform")
            turn.inputs["Rotation"].default_value = (-math.pi / 2, 0.0, 0.0)
            ng.links.new(info.outputs["Geometry"], turn.inputs["Geometry"])
            ng.links.new(turn.outputs["Geometry"], iop.inputs["Instance"])
            iop.inputs["Pick Instance"].default_value = False
            done += 1
            break
    return done
