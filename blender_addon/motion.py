"""Per-instance `id` and `velocity` for the imported swarm.

What Blender's USD import does (bpy 5.0.1, checked with a hand-written animated
PointInstancer, see docs/blender.md): the PointInstancer becomes a point cloud object read
by a Mesh Sequence Cache modifier, plus a Geometry Nodes modifier that instances the
prototypes. The point cloud carries `position`, `orientation`, `scale`, `proto_index` and
`mask` only: the PointInstancer's `ids` and `velocities` (and custom primvars) are dropped.
Sub-frame times are interpolated from the time samples, so transform motion blur works,
and instances are told apart by their index (the order of the bees never changes).

What this module adds: the tracks CSV (always baked beside the cache) is turned into a
sidecar `.velocity.npy` (velocities per frame, in the shot's Y-up axes, which is the
imported point cloud's local space). A hidden helper mesh `<shot>.motion` has one vertex per
bee with `id` and `velocity` attributes; a persistent frame-change handler writes the
current frame's velocities into it (linear between frames for sub-frames), and a Geometry
Nodes modifier appended to each imported instancer stores them on its instances
(`Store Named Attribute`, Instance domain). `id` makes the instance ids (persistent ids,
used by Cycles and EEVEE to match instances across motion steps) the bees' own ids.
"""
import os
import pathlib

import bpy
import numpy as np
from bpy.app.handlers import persistent

HELPER_TAG = "beeswarm_motion"  # on the helper object: the sidecar path
START_TAG = "beeswarm_frame_start"  # on the helper object: the sidecar's first frame
MODIFIER = "beeswarm motion"

_cache = {}  # absolute sidecar path → (mtime, memory-mapped velocities [F, N, 3])


# ---------------------------------------------------------------------------------------
# Tracks CSV → sidecar

def read_tracks_csv(path, chunk_rows=500_000):
    """(ids[N], frames[F], first-frame positions[N,3], velocities[F,N,3]) from a tracks CSV,
    in the file's order (the bees' order is the same in every frame). Only the columns
    needed are parsed, in chunks, into float32."""
    chunks = []
    ids = first_pos = None
    f0 = None
    with open(path, "r", encoding="utf-8") as f:
        header = f.readline().strip().split(",")
        cols = [header.index(c) for c in ("id", "frame", "x", "y", "z", "vx", "vy", "vz")]
        while True:
            block = np.loadtxt(f, delimiter=",", usecols=cols, max_rows=chunk_rows, ndmin=2,
                               dtype=np.float64)
            if block.size == 0:
                break
            if f0 is None:
                f0 = int(block[0, 1])
                rest = np.flatnonzero(block[:, 1] != f0)
                if not len(rest) and len(block) == chunk_rows:
                    return read_tracks_csv(path, chunk_rows * 8)  # more bees than a chunk
                n = int(rest[0]) if len(rest) else len(block)
                ids = block[:n, 0].astype(np.int64)
                first_pos = block[:n, 2:5].astype(np.float32)
            chunks.append(block[:, 5:8].astype(np.float32))
            if len(block) < chunk_rows:
                break
    if f0 is None:
        raise ValueError(f"{os.path.basename(path)} has no rows")
    vel = np.concatenate(chunks)
    n = len(ids)
    if len(vel) % n:
        raise ValueError(f"{os.path.basename(path)}: the number of bees changes between frames")
    vel = vel.reshape(len(vel) // n, n, 3)
    return ids, np.arange(len(vel), dtype=np.int64) + f0, first_pos, vel


def write_sidecar(path, velocities):
    """Velocities [F, N, 3] float32 as a .npy (memory-mapped when read), atomically."""
    path = pathlib.Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        np.save(f, np.ascontiguousarray(velocities, dtype=np.float32))
    os.replace(tmp, path)
    _cache.pop(str(path), None)


def load_sidecar(path):
    path = bpy.path.abspath(path)
    try:
        mtime = os.path.getmtime(path)
    except OSError:
        return None
    hit = _cache.get(path)
    if hit and hit[0] == mtime:
        return hit[1]
    vel = np.load(path, mmap_mode="r")
    _cache[path] = (mtime, vel)
    return vel


def velocity_at(vel, frame_start, frame):
    """Velocities at a (fractional) frame: linear between baked frames, held at the ends."""
    f = frame - frame_start
    last = vel.shape[0] - 1
    if f <= 0:
        return np.asarray(vel[0])
    if f >= last:
        return np.asarray(vel[last])
    i = int(np.floor(f))
    t = np.float32(f - i)
    if not t:
        return np.asarray(vel[i])
    return vel[i] * (1 - t) + vel[i + 1] * t


# ---------------------------------------------------------------------------------------
# Helper mesh and node group

def _node_group(name):
    """A node group per import (removed with it): instances get `id` and `velocity`
    sampled by index from the Motion object's points."""
    ng = bpy.data.node_groups.new(name, "GeometryNodeTree")
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Motion", in_out="INPUT", socket_type="NodeSocketObject")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    n = ng.nodes
    gin = n.new("NodeGroupInput")
    gout = n.new("NodeGroupOutput")
    info = n.new("GeometryNodeObjectInfo")
    info.transform_space = "ORIGINAL"
    index = n.new("GeometryNodeInputIndex")
    link = ng.links.new
    link(gin.outputs["Motion"], info.inputs["Object"])
    geo = gin.outputs["Geometry"]
    x = -200
    for name, dtype in (("id", "INT"), ("velocity", "FLOAT_VECTOR")):
        attr = n.new("GeometryNodeInputNamedAttribute")
        attr.data_type = dtype
        attr.inputs["Name"].default_value = name
        sample = n.new("GeometryNodeSampleIndex")
        sample.data_type = dtype
        sample.domain = "POINT"
        store = n.new("GeometryNodeStoreNamedAttribute")
        store.data_type = dtype
        store.domain = "INSTANCE"
        store.inputs["Name"].default_value = name
        link(info.outputs["Geometry"], sample.inputs["Geometry"])
        link(attr.outputs["Attribute"], sample.inputs["Value"])
        link(index.outputs["Index"], sample.inputs["Index"])
        link(geo, store.inputs["Geometry"])
        link(sample.outputs["Value"], store.inputs["Value"])
        geo = store.outputs["Geometry"]
        x += 200
    link(geo, gout.inputs["Geometry"])
    return ng


def _helper(name, ids, collection):
    me = bpy.data.meshes.new(name)
    me.vertices.add(len(ids))
    me.attributes.new("id", "INT", "POINT").data.foreach_set("value", ids.astype(np.int32))
    me.attributes.new("velocity", "FLOAT_VECTOR", "POINT")
    ob = bpy.data.objects.new(name, me)
    collection.objects.link(ob)
    ob.hide_render = True
    ob.hide_select = True
    ob.display_type = "BOUNDS"
    ob.hide_set(True) if bpy.context.view_layer.objects.get(ob.name) else None
    return ob


def update_helper(ob, frame):
    vel = load_sidecar(ob.get(HELPER_TAG, ""))
    if vel is None:
        return False
    start = int(ob.get(START_TAG, 0))
    me = ob.data
    if len(me.vertices) != vel.shape[1]:
        return False
    v = np.ascontiguousarray(velocity_at(vel, start, frame), dtype=np.float32)
    me.attributes["velocity"].data.foreach_set("vector", v.ravel())
    me.update()
    return True


@persistent
def on_frame_change(scene, depsgraph=None):
    frame = scene.frame_current + scene.frame_subframe
    for ob in scene.objects:
        if ob.get(HELPER_TAG) and ob.type == "MESH":
            try:
                update_helper(ob, frame)
            except Exception as e:  # never break playback
                print(f"beeswarm: cannot update {ob.name}: {e}")


# ---------------------------------------------------------------------------------------

def safe(name):
    return "".join(c if c.isalnum() or c in "_-" else "_" for c in name)


def _instancers(objects):
    return [o for o in objects if o.type == "POINTCLOUD"
            and any(m.type == "MESH_SEQUENCE_CACHE" for m in o.modifiers)]


def _point_positions(ob, scene, frame):
    """The cache-read points of an instancer (its Geometry Nodes modifier bypassed)."""
    scene.frame_set(frame)
    gn = [m for m in ob.modifiers if m.type == "NODES"]
    states = [m.show_viewport for m in gn]
    for m in gn:
        m.show_viewport = False
    try:
        dg = bpy.context.evaluated_depsgraph_get()
        dg.update()
        pc = ob.evaluated_get(dg).data
        pos = np.zeros(len(pc.points) * 3, dtype=np.float32)
        pc.attributes["position"].data.foreach_get("vector", pos)
    finally:
        for m, s in zip(gn, states):
            m.show_viewport = s
    return pos.reshape(-1, 3)


def set_modifier_input(mod, identifier, value):
    """Sets a Geometry Nodes modifier's input: `mod.properties.inputs.<identifier>.value` in
    Blender 5.3, which refuses the ID property on the modifier that 4.4–5.0 use."""
    props = getattr(mod, "properties", None)
    if props is not None and hasattr(props, "inputs"):
        getattr(props.inputs, identifier).value = value
    else:
        mod[identifier] = value


def attach(context, shot_name, fmt, objects, csv_path, frames, collection):
    """Adds id/velocity to every imported USD instancer. glTF imports are left as they are
    (each bee is an animated object there; Blender blurs object motion by itself)."""
    if fmt != "USD":
        return
    instancers = _instancers(objects)
    if not instancers:
        return
    csv_path = pathlib.Path(csv_path)
    if not csv_path.is_file():
        print(f"beeswarm: no tracks CSV at {csv_path}; instances keep index ids, no velocity")
        return
    scene = context.scene
    ids, csv_frames, pos, vel = read_tracks_csv(csv_path)
    current = scene.frame_current
    ng = _node_group(f"{shot_name}.motion")
    for k, ob in enumerate(instancers):
        pts = _point_positions(ob, scene, int(csv_frames[0]))
        n = len(pts)
        # The CSV lists every swarm's bees in shot order: find this instancer's block.
        offset = 0
        if n != len(ids):
            d = np.linalg.norm(pos - pts[0], axis=1)
            offset = int(np.argmin(d))
            if offset + n > len(ids):
                raise ValueError(f"{ob.name}: {n} instances do not match the tracks CSV")
        block = slice(offset, offset + n)
        if n and float(np.abs(pos[block] - pts).max()) > 1e-3:
            raise ValueError(f"{ob.name}: the instances do not match the tracks CSV")
        stem = csv_path.name[: -len(".tracks.csv")]
        sidecar = csv_path.with_name(f"{stem}.{safe(ob.name)}.velocity.npy")
        write_sidecar(sidecar, vel[:, block])
        helper = _helper(f"{shot_name}.{ob.name}.motion", ids[block], collection)
        helper[START_TAG] = int(csv_frames[0])
        try:
            helper[HELPER_TAG] = bpy.path.relpath(str(sidecar)) if bpy.data.filepath else str(sidecar)
        except ValueError:  # another drive
            helper[HELPER_TAG] = str(sidecar)
        mod = ob.modifiers.new(MODIFIER, "NODES")
        mod.node_group = ng
        key = next(i.identifier for i in ng.interface.items_tree
                   if getattr(i, "in_out", "") == "INPUT" and i.name == "Motion")
        set_modifier_input(mod, key, helper)
        update_helper(helper, current)
    scene.frame_set(current)


def register():
    if on_frame_change not in bpy.app.handlers.frame_change_pre:
        bpy.app.handlers.frame_change_pre.append(on_frame_change)


def unregister():
    while on_frame_change in bpy.app.handlers.frame_change_pre:
        bpy.app.handlers.frame_change_pre.remove(on_frame_change)
