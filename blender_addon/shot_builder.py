"""Scene → shot: reads the panel's settings, the obstacle collection and the target
collection, and writes a shot TOML in the shot's Y-up frame.

Axes: Blender is Z-up, the shot is Y-up, both right-handed. A Blender point (x, y, z) is
the shot point (x, z, −y): the matrix C below. A rotation R in Blender is C·R·Cᵀ in the
shot; shapes' local axes map the same way, so a Blender box's local size (sx, sy, sz)
becomes the shot box's (sx, sz, sy) and a Blender cylinder's local +Z axis becomes the
shot cylinder's local +Y axis. The shot's `rotation` is Euler XYZ in degrees applied X,
then Y, then Z about world axes (R = Rz·Ry·Rx), which is Blender's own 'XYZ' convention.
"""
import math
import re

import bpy
import numpy as np
from mathutils import Matrix, Vector

from . import glb_writer, toml_writer

C = Matrix(((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0)))
C_INV = C.transposed()

OBSTACLE_TYPES = ("sphere", "box", "cylinder", "capsule", "plane", "mesh")
# Objects that can be evaluated to a mesh, and so exported as mesh obstacles.
MESH_LIKE = {"MESH", "CURVE", "SURFACE", "META", "FONT"}
# Key of the shot dict holding the mesh files to write beside the shot ({name: bytes}):
# one .glb of every mesh obstacle; not part of the TOML (see shot_toml, write_mesh_files).
MESH_FILES = "_mesh_files"
TARGET_TYPES = ("nest", "flower", "attractor")
TYPE_PROP = "beeswarm_type"


class ShotBuildError(Exception):
    """The scene cannot make a valid shot; the message is for the artist."""


class UnsupportedShape(Exception):
    """An obstacle whose shape the shot format has no type for (an ellipsoid, an elliptic
    cylinder, a sheared box): reported, never approximated."""


def to_shot(v):
    """Blender point or direction (Z-up) → shot (Y-up) as a list of floats."""
    return [float(v[0]), float(v[2]), -float(v[1])]


def from_shot(v):
    """Shot point (Y-up) → Blender (Z-up)."""
    return Vector((v[0], -v[2], v[1]))


def rotation_to_shot_euler(rot3):
    """A Blender world rotation (3x3) → the shot's Euler XYZ degrees."""
    r = C @ rot3 @ C_INV
    e = r.to_euler("XYZ")
    return [_clean(math.degrees(a), 1e-6) for a in e]


def _clean(x, eps=1e-9):
    x = float(x)
    return 0.0 if abs(x) < eps else x


def safe_name(text, fallback="beeswarm", identifier=False):
    """A file-safe (shot) or identifier-safe (swarm) name from any Blender name."""
    allowed = "_" if identifier else "_-."
    out = "".join(c if (c.isascii() and c.isalnum()) or c in allowed else "_" for c in text)
    out = out.strip(".")
    if identifier and out and out[0].isdigit():
        out = "_" + out
    return out or fallback


# ---------------------------------------------------------------------------------------
# Obstacles

def _custom_type(obj, allowed):
    for holder in (obj, getattr(obj, "data", None)):
        if holder is None:
            continue
        try:
            val = holder.get(TYPE_PROP)
        except TypeError:
            val = None
        if isinstance(val, str) and val.strip().lower() in allowed:
            return val.strip().lower()
    return None


def _name_type(name, table):
    low = name.lower()
    for word, kind in table:
        if re.search(word, low):
            return kind
    return None


_OBSTACLE_WORDS = (
    (r"cyl", "cylinder"), (r"capsule", "capsule"), (r"sphere|ball|icosphere", "sphere"),
    (r"plane|ground|floor", "plane"), (r"cube|box", "box"),
)


def _local_points(obj):
    """The object's own vertex coordinates (unevaluated mesh), or None."""
    if obj.type != "MESH" or not obj.data.vertices:
        return None
    return [v.co.copy() for v in obj.data.vertices]


def guess_mesh_shape(points, tol=0.02):
    """'box', 'sphere', 'cylinder' or 'plane' from a mesh's local vertices, or None.

    Box: every vertex on a corner of the bounding box. Sphere: every vertex at one distance
    from the box centre. Cylinder: every vertex either on the axis (cap centres) or at one
    radial distance from the local Z axis, on two Z levels. Plane: a flat rectangle."""
    if not points:
        return None
    lo = Vector((min(p.x for p in points), min(p.y for p in points), min(p.z for p in points)))
    hi = Vector((max(p.x for p in points), max(p.y for p in points), max(p.z for p in points)))
    c = (lo + hi) / 2
    h = (hi - lo) / 2
    size = max(h) or 1.0
    eps = tol * size
    if min(h) < 1e-9 * size or (h.z < eps and h.x > eps and h.y > eps):
        return "plane" if h.z <= eps else None
    if all(all(abs(abs(p[i] - c[i]) - h[i]) <= eps for i in range(3)) for p in points):
        return "box"
    radial = [math.hypot(p.x - c.x, p.y - c.y) for p in points]
    rim = [(r, p.z > c.z) for r, p in zip(radial, points) if r > eps]
    # A rim at both ends: a cone (one rim and an apex) is not a cylinder.
    if (rim and max(r for r, _ in rim) - min(r for r, _ in rim) <= eps
            and abs(h.x - h.y) <= eps and {top for _, top in rim} == {True, False}
            and all(abs(abs(p.z - c.z) - h.z) <= eps for p in points)):
        return "cylinder"
    radii = [(p - c).length for p in points]
    if max(radii) - min(radii) <= eps and min(h) >= 0.7 * max(h):
        return "sphere"
    return None


def _local_bounds(obj):
    """(centre, half extents) of the object's shape in its local space."""
    pts = _local_points(obj)
    if pts:
        lo = Vector((min(p.x for p in pts), min(p.y for p in pts), min(p.z for p in pts)))
        hi = Vector((max(p.x for p in pts), max(p.y for p in pts), max(p.z for p in pts)))
        return (lo + hi) / 2, (hi - lo) / 2
    if obj.type == "EMPTY":
        s = obj.empty_display_size
        return Vector((0, 0, 0)), Vector((s, s, s))
    bb = [Vector(c) for c in obj.bound_box]
    lo = Vector((min(p.x for p in bb), min(p.y for p in bb), min(p.z for p in bb)))
    hi = Vector((max(p.x for p in bb), max(p.y for p in bb), max(p.z for p in bb)))
    return (lo + hi) / 2, (hi - lo) / 2


def obstacle_kind(obj):
    """The obstacle type of an object, or None when it cannot be told. Order: custom
    property `beeswarm_type` (object or data), empty display type, mesh shape, name."""
    kind = _custom_type(obj, OBSTACLE_TYPES)
    if kind:
        return kind
    if obj.type == "EMPTY":
        return {"SPHERE": "sphere", "CUBE": "box", "CIRCLE": None}.get(obj.empty_display_type) \
            or _name_type(obj.name, _OBSTACLE_WORDS)
    kind = guess_mesh_shape(_local_points(obj))
    if kind:
        return kind
    return _name_type(obj.name, _OBSTACLE_WORDS)


def _decompose(obj):
    """World matrix → (rotation 3x3 orthonormal, scale Vector). Shear (a rotated child of a
    non-uniformly scaled parent) has no shot equivalent: UnsupportedShape."""
    mw = obj.matrix_world
    loc, quat, scale = mw.decompose()
    rebuilt = Matrix.LocRotScale(loc, quat, scale)
    size = max(max(abs(x) for x in scale), 1e-12)
    if max(abs(rebuilt[i][j] - mw[i][j]) for i in range(3) for j in range(3)) > 1e-5 * size:
        raise UnsupportedShape(f"'{obj.name}' is sheared (a rotated child of a non-uniformly "
                               f"scaled parent); apply the parent's scale")
    return quat.to_matrix(), scale


def mesh_obstacle(obj, depsgraph, file_name, node, scene=None, frames=None):
    """(obstacle entry, (node, positions, triangles)) of any object that evaluates to a
    mesh: its evaluated geometry (modifiers applied) in world space, Y-up, metres,
    triangulated, for the node `node` of the shot's obstacle .glb `file_name`. A closed
    mesh (every edge shared by two triangles) is a solid; any other is avoided as a shell.

    An object whose transform is animated (keyframes, drivers, constraints, an animated
    parent), given the `scene` and its `frames`, moves: the .glb holds its mesh in its rest
    pose (scaled, unrotated, at the origin) and the entry its `keys`, one per frame, from
    `motion_keys`."""
    ev = obj.evaluated_get(depsgraph)
    try:
        me = ev.to_mesh()
    except RuntimeError:
        me = None
    if me is None:
        raise UnsupportedShape(f"'{obj.name}' has no mesh to avoid")
    try:
        me.calc_loop_triangles()
        n, t = len(me.vertices), len(me.loop_triangles)
        if t == 0:
            raise UnsupportedShape(f"'{obj.name}' has no faces to avoid (only vertices or "
                                   f"edges); give it faces or take it out of the obstacle "
                                   f"collection")
        co = np.empty(n * 3, dtype=np.float32)
        me.vertices.foreach_get("co", co)
        tri = np.empty(t * 3, dtype=np.int64)
        me.loop_triangles.foreach_get("vertices", tri)
    finally:
        ev.to_mesh_clear()
    keys = None
    if scene is not None and frames is not None and _is_animated(obj):
        keys, scale = motion_keys(obj, scene, frames)
        # The rest pose: the object's scale only; the keys turn and place it.
        mw = np.diag([scale[0], scale[1], scale[2], 1.0])
    else:
        mw = np.array(obj.matrix_world, dtype=np.float64)
    world = co.reshape(n, 3).astype(np.float64) @ mw[:3, :3].T + mw[:3, 3]
    shot = np.stack([world[:, 0], world[:, 2], -world[:, 1]], axis=1).astype(np.float32)
    if not np.all(np.isfinite(shot)):
        raise UnsupportedShape(f"'{obj.name}' has vertices that are not finite numbers")
    tri = tri.reshape(t, 3)
    edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    _, uses = np.unique(edges, axis=0, return_counts=True)
    closed = bool(np.all(uses == 2))
    entry = {"type": "mesh", "name": obj.name, "file": file_name, "node": node}
    if not closed:
        entry["mode"] = "shell"
    if keys is not None:
        entry["keys"] = keys
    return entry, (node, shot, tri)


def _sample_frames(scene, frames, sample):
    """[(frame, sample())] for every frame of `frames`, the scene evaluated at each once
    (keyframes, drivers, constraints and parents all count); the scene's frame and subframe
    are restored afterwards, whatever happens."""
    current, sub = scene.frame_current, scene.frame_subframe
    out = []
    try:
        for f in range(frames[0], frames[1] + 1):
            scene.frame_set(f)
            out.append((f, sample()))
    finally:
        scene.frame_set(current, subframe=sub)
    return out


def motion_keys(obj, scene, frames):
    """(keys, scale) of an animated object: one shot key {frame, position, rotation} per
    frame of `frames` (sampled from the evaluated scene, so keyframes, drivers, constraints
    and parents all count), and its world scale, which must not change (a moving mesh
    obstacle is rigid: UnsupportedShape otherwise). Euler angles are kept continuous from
    frame to frame (a turn past 180° goes on to 190°, not back to −170°), so the shot's
    linear interpolation between keys turns the way Blender did."""
    poses = _sample_frames(scene, frames,
                           lambda: (*_decompose(obj), obj.matrix_world.translation.copy()))
    keys, scale, prev = [], None, None
    for f, (rot, s, position) in poses:
        if scale is None:
            scale = s.copy()
        elif max(abs(a - b) for a, b in zip(s, scale)) > 1e-5 * max(max(scale), 1e-12):
            raise UnsupportedShape(
                f"'{obj.name}' changes scale at frame {f}; a moving mesh obstacle keeps "
                f"one scale: animate its location and rotation only")
        r = C @ rot @ C_INV
        e = r.to_euler("XYZ") if prev is None else r.to_euler("XYZ", prev)
        prev = e
        keys.append({"frame": f, "position": to_shot(position),
                     "rotation": [_clean(math.degrees(a), 1e-6) for a in e]})
    return keys, scale


def obstacle_entry(obj, kind, warnings):
    mw = obj.matrix_world
    rot, scale = _decompose(obj)
    c_local, h_local = _local_bounds(obj)
    center = mw @ c_local
    name = obj.name
    if kind == "sphere":
        if obj.type == "EMPTY":
            h_local = Vector([obj.empty_display_size] * 3)
        hw = Vector((abs(h_local.x * scale.x), abs(h_local.y * scale.y), abs(h_local.z * scale.z)))
        if max(hw) - min(hw) > 1e-4 * max(hw):
            raise UnsupportedShape(f"'{name}' is a non-uniformly scaled sphere (an ellipsoid: "
                                   f"radii {hw.x:.3g}, {hw.y:.3g}, {hw.z:.3g} m); scale it "
                                   f"uniformly")
        return {"type": "sphere", "name": name, "center": to_shot(center), "radius": max(hw)}
    if kind == "box":
        if obj.type == "EMPTY":
            h_local = Vector([obj.empty_display_size] * 3)
        size_b = [2 * h_local[i] * scale[i] for i in range(3)]
        return {"type": "box", "name": name, "center": to_shot(center),
                "size": [size_b[0], size_b[2], size_b[1]],
                "rotation": rotation_to_shot_euler(rot)}
    if kind == "cylinder":
        rx, ry = abs(h_local.x * scale.x), abs(h_local.y * scale.y)
        if abs(rx - ry) > 1e-4 * max(rx, ry):
            raise UnsupportedShape(f"'{name}' is an elliptic cylinder (radii {rx:.3g} and "
                                   f"{ry:.3g} m); give X and Y the same scale")
        return {"type": "cylinder", "name": name, "center": to_shot(center),
                "radius": max(rx, ry), "height": 2 * h_local.z * scale.z,
                "rotation": rotation_to_shot_euler(rot)}
    if kind == "capsule":
        # Along the local Z axis; radius from X/Y, the ends' spheres included in Z.
        rx, ry = abs(h_local.x * scale.x), abs(h_local.y * scale.y)
        if abs(rx - ry) > 1e-4 * max(rx, ry):
            raise UnsupportedShape(f"'{name}' is an elliptic capsule (radii {rx:.3g} and "
                                   f"{ry:.3g} m); give X and Y the same scale")
        r = rx
        half = max(h_local.z * scale.z - r, 0.0)
        axis = rot @ Vector((0, 0, 1))
        return {"type": "capsule", "name": name, "a": to_shot(center - axis * half),
                "b": to_shot(center + axis * half), "radius": r}
    if kind == "plane":
        normal = (rot @ Vector((0, 0, 1))).normalized()
        return {"type": "plane", "name": name, "point": to_shot(center), "normal": to_shot(normal)}
    raise ShotBuildError(f"unknown obstacle type {kind!r}")


def _objects(coll):
    return sorted(coll.all_objects, key=lambda o: o.name) if coll else []


# ---------------------------------------------------------------------------------------
# Targets

_TARGET_WORDS = ((r"nest|hive", "nest"), (r"flower", "flower"), (r"attract", "attractor"))


def target_kind(obj):
    return _custom_type(obj, TARGET_TYPES) or _name_type(obj.name, _TARGET_WORDS)


def _is_animated(obj):
    o = obj
    while o is not None:
        ad = o.animation_data
        if ad and (ad.action or ad.drivers or (ad.nla_tracks and len(ad.nla_tracks))):
            return True
        if o.constraints and len(o.constraints):
            return True
        o = o.parent
    return False


def _seconds_range(obj, key):
    """A custom property `beeswarm_<key>` holding [min, max] seconds, or None if unset."""
    val = obj.get("beeswarm_" + key)
    if val is None:
        return None
    try:
        pair = [float(x) for x in val]
    except (TypeError, ValueError):
        pair = []
    if len(pair) != 2:
        raise ShotBuildError(f"{obj.name}: the custom property beeswarm_{key} must be two "
                             f"numbers, [min, max] seconds (found {val!r})")
    return pair


def target_entry(obj, kind, scene, frames):
    entry = {"type": kind, "name": obj.name}
    for key in ("radius", "strength", "reach"):
        val = obj.get("beeswarm_" + key)
        if isinstance(val, (int, float)):
            entry[key] = float(val)
    # Landing and hive traffic (docs/shot-format.md): bees land on it, stay, and at a
    # nest with `inside` go in and come out. The binary checks the values and says which
    # key is wrong; the shot names the target after this object.
    land = obj.get("beeswarm_land")
    if land is not None:
        entry["land"] = bool(land)
    for key in ("stay", "inside"):
        pair = _seconds_range(obj, key)
        if pair is not None:
            entry[key] = pair
    if _is_animated(obj):
        positions = _sample_frames(scene, frames, lambda: obj.matrix_world.translation.copy())
        entry["keys"] = [{"frame": f, "position": to_shot(p)} for f, p in positions]
    else:
        entry["position"] = to_shot(obj.matrix_world.translation)
    return entry


# ---------------------------------------------------------------------------------------

def scene_frames(scene, settings=None):
    """The frame range to bake: the scene's, or the panel's own when it says so."""
    if settings is not None and not settings.use_scene_frames:
        return [int(settings.frame_start), int(settings.frame_end)]
    return [int(scene.frame_start), int(scene.frame_end)]


def scene_fps(scene):
    return scene.render.fps / (scene.render.fps_base or 1.0)


def _world_box(obj):
    """(centre, size) of an object's world-space bounding box (an empty: its display cube)."""
    if obj.type == "EMPTY":
        size = Vector([2 * obj.empty_display_size * abs(s) for s in obj.matrix_world.to_scale()])
        return obj.matrix_world.translation.copy(), size
    corners = [obj.matrix_world @ Vector(c) for c in obj.bound_box]
    lo = Vector((min(p.x for p in corners), min(p.y for p in corners), min(p.z for p in corners)))
    hi = Vector((max(p.x for p in corners), max(p.y for p in corners), max(p.z for p in corners)))
    return (lo + hi) / 2, hi - lo


def _box_size_to_shot(size):
    return [abs(size.x), abs(size.z), abs(size.y)]


def swarm_entry(sw):
    """One `[[swarm]]` from a panel swarm. Errors name the swarm."""
    label = f"Swarm '{sw.name}'"
    if sw.count < 1:
        raise ShotBuildError(f"{label} needs at least 1 bee (count is {sw.count})")
    # A menu whose stored choice no longer exists (another binary) reads as "".
    model = sw.model or "bee"
    preset = sw.preset
    if preset == "FILE":
        if not sw.preset_file:
            raise ShotBuildError(f"{label}: choose a preset file, or a built-in preset")
        # Absolute: the shot is written into the cache folder, and the binary reads a
        # relative preset path from the shot file's folder, not the .blend's.
        preset = bpy.path.abspath(sw.preset_file)
    elif not preset:
        raise ShotBuildError(f"{label}: choose a preset of the {model} model")
    entry = {
        "name": safe_name(sw.name or "bees", "bees", identifier=True),
        "count": int(sw.count),
        "model": model,
        "preset": preset,
    }
    # Spawn region: an object's world bounds, else the panel's centre and size.
    sp = sw.spawn_object
    if sp is not None:
        if sp.type == "EMPTY" and sp.empty_display_type == "SPHERE":
            radius = sp.empty_display_size * max(abs(x) for x in sp.matrix_world.to_scale())
            entry["spawn"] = {"shape": "sphere", "center": to_shot(sp.matrix_world.translation),
                              "radius": radius}
        else:
            centre, size = _world_box(sp)
            entry["spawn"] = {"shape": "box", "center": to_shot(centre),
                              "size": _box_size_to_shot(size)}
        where = f"the spawn object '{sp.name}'"
    else:
        size = sw.spawn_size
        entry["spawn"] = {"shape": "box", "center": to_shot(sw.spawn_center),
                          "size": [size[0], size[2], size[1]]}
        where = "its spawn size"
    if min(entry["spawn"].get("size", [1.0])) <= 0 or entry["spawn"].get("radius", 1.0) <= 0:
        raise ShotBuildError(f"{label}: the spawn region has no volume ({where} is flat)")
    if sw.bounds_object is not None:
        centre, size = _world_box(sw.bounds_object)
        if min(abs(size.x), abs(size.y), abs(size.z)) <= 0:
            raise ShotBuildError(f"{label}: the bounds object '{sw.bounds_object.name}' is flat")
        entry["bounds"] = {"center": to_shot(centre), "size": _box_size_to_shot(size)}
    entry["variation"] = {"size": float(sw.size_variation), "speed": float(sw.speed_variation)}
    if sw.start_inside > 0:
        entry["start_inside"] = float(sw.start_inside)
    entry["bee"] = {"length": float(sw.bee_length), "radius": float(sw.bee_length) / 6.0}
    params = {}
    for o in sw.overrides:
        if not o.param:
            raise ShotBuildError(f"{label}: an override names no parameter of the {model} model")
        if o.param in params:
            raise ShotBuildError(f"{label}: the parameter {o.param} is overridden twice")
        params[o.param] = float(o.value)
    if params:
        entry["params"] = params
    return entry


def build_shot(scene, settings, name=None):
    """Returns (shot dict, warnings). Raises ShotBuildError for a scene that cannot bake;
    its message names the Blender object or swarm at fault."""
    warnings = []
    frames = scene_frames(scene, settings)
    if frames[1] < frames[0]:
        raise ShotBuildError(f"The frame range is reversed ({frames[0]}–{frames[1]})")
    if not len(settings.swarms):
        raise ShotBuildError("The shot has no swarm: add one with + beside the Swarms list")
    shot_name = safe_name(name or settings.shot_name or "beeswarm")
    swarms = [swarm_entry(sw) for sw in settings.swarms]
    names = [sw["name"] for sw in swarms]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise ShotBuildError(f"Two swarms are named {dupes[0]}: give each its own name")

    obstacles, problems, meshes = [], [], []
    # Every mesh obstacle is one node of this file, beside the shot (not `<shot>.glb`,
    # which is the glTF cache's name).
    mesh_file = f"{shot_name}.obstacles.glb"
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for obj in _objects(settings.obstacles):
        if obj.type not in MESH_LIKE | {"EMPTY"}:
            continue
        kind = obstacle_kind(obj)
        if kind is None and obj.type == "EMPTY":
            problems.append(f"'{obj.name}' is an empty of no obstacle shape (set its custom "
                            f"property {TYPE_PROP}, or take it out of the obstacle collection)")
            continue
        try:
            if kind is None or kind == "mesh":
                # Any other shape: its mesh, a node of the shot's obstacle .glb. Object
                # names are unique but for linked libraries' objects: keep nodes apart.
                node, k = obj.name, 1
                while any(m[0] == node for m in meshes):
                    k += 1
                    node = f"{obj.name}_{k}"
                entry, mesh = mesh_obstacle(obj, depsgraph, mesh_file, node, scene, frames)
                meshes.append(mesh)
                obstacles.append(entry)
            else:
                obstacles.append(obstacle_entry(obj, kind, warnings))
        except UnsupportedShape as e:
            problems.append(str(e))
    if problems:
        raise ShotBuildError("Obstacles the shot format cannot describe: " + "; ".join(problems))
    if settings.ground:
        obstacles.append({"type": "plane", "name": "ground", "point": [0.0, 0.0, 0.0],
                          "normal": [0.0, 1.0, 0.0]})

    targets = []
    for obj in _objects(settings.targets):
        if obj.type != "EMPTY" and not _custom_type(obj, TARGET_TYPES):
            continue
        kind = target_kind(obj)
        if kind is None:
            warnings.append(f"{obj.name}: not a nest, flower or attractor; treated as an attractor")
            kind = "attractor"
        targets.append(target_entry(obj, kind, scene, frames))

    fps = float(scene_fps(scene))
    shot = {
        "scene": {
            "name": shot_name,
            "fps": fps,
            "frames": frames,
            "substeps": int(settings.substeps),
            "seed": int(settings.seed),
        },
        "swarm": swarms,
    }
    if obstacles:
        shot["obstacle"] = obstacles
    if meshes:
        shot[MESH_FILES] = {mesh_file: glb_writer.glb_bytes(meshes)}
    if targets:
        shot["target"] = targets
    if any(abs(x) > 0 for x in settings.wind):
        shot["wind"] = {"velocity": to_shot(settings.wind)}
    shot["output"] = {"wings": settings.wings.lower(),
                      "gltf_layout": settings.gltf_layout.lower()}
    if settings.wings == "FLAP" and settings.wing_flap_hz > 0:
        if settings.wing_flap_hz > fps / 2:
            raise ShotBuildError(f"Wing Flap {settings.wing_flap_hz:g} Hz is above half the "
                                 f"frame rate ({fps / 2:g} Hz) and would alias")
        shot["output"]["wing_flap_hz"] = float(settings.wing_flap_hz)
    return shot, warnings


HEADER_MARK = "# Written by the beeswarm Blender add-on"


def shot_toml(shot, source=""):
    header = (HEADER_MARK[2:] + (f" from {source}" if source else "")
              + ".\nY-up, metres, seconds: Blender (x, y, z) is (x, z, -y) here.")
    return toml_writer.dumps({k: v for k, v in shot.items() if k != MESH_FILES}, header=header)


def write_mesh_files(shot, folder):
    """Writes the shot's mesh obstacles' files into `folder` (where the shot goes)."""
    for name, data in shot.get(MESH_FILES, {}).items():
        (folder / name).write_bytes(data)
