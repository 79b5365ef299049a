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
from mathutils import Matrix, Vector

from . import toml_writer

C = Matrix(((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0)))
C_INV = C.transposed()

OBSTACLE_TYPES = ("sphere", "box", "cylinder", "capsule", "plane")
TARGET_TYPES = ("nest", "flower", "attractor")
TYPE_PROP = "beeswarm_type"


class ShotBuildError(Exception):
    """The scene cannot make a valid shot; the message is for the artist."""


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
    rim = [r for r in radial if r > eps]
    if (rim and max(rim) - min(rim) <= eps and abs(h.x - h.y) <= eps
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


def _decompose(mw):
    """World matrix → (rotation 3x3 orthonormal, scale Vector). Shear (a non-uniformly
    scaled parent of a rotated child) has no exact shot equivalent; the nearest rotation and
    the column lengths are used."""
    loc, quat, scale = mw.decompose()
    return quat.to_matrix(), scale


def obstacle_entry(obj, kind, warnings):
    mw = obj.matrix_world
    rot, scale = _decompose(mw)
    c_local, h_local = _local_bounds(obj)
    center = mw @ c_local
    name = obj.name
    if kind == "sphere":
        if obj.type == "EMPTY":
            h_local = Vector([obj.empty_display_size] * 3)
        hw = Vector((h_local.x * scale.x, h_local.y * scale.y, h_local.z * scale.z))
        if max(hw) - min(hw) > 1e-4 * max(hw):
            warnings.append(f"{name}: a non-uniformly scaled sphere is approximated by its "
                            f"largest radius")
        return {"type": "sphere", "name": name, "center": to_shot(center), "radius": max(hw)}
    if kind == "box":
        if obj.type == "EMPTY":
            h_local = Vector([obj.empty_display_size] * 3)
        size_b = [2 * h_local[i] * scale[i] for i in range(3)]
        return {"type": "box", "name": name, "center": to_shot(center),
                "size": [size_b[0], size_b[2], size_b[1]],
                "rotation": rotation_to_shot_euler(rot)}
    if kind == "cylinder":
        rx, ry = h_local.x * scale.x, h_local.y * scale.y
        if abs(rx - ry) > 1e-4 * max(rx, ry):
            warnings.append(f"{name}: an elliptic cylinder is approximated by its larger radius")
        return {"type": "cylinder", "name": name, "center": to_shot(center),
                "radius": max(rx, ry), "height": 2 * h_local.z * scale.z,
                "rotation": rotation_to_shot_euler(rot)}
    if kind == "capsule":
        # Along the local Z axis; radius from X/Y, the ends' spheres included in Z.
        r = max(h_local.x * scale.x, h_local.y * scale.y)
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


def target_entry(obj, kind, scene, frames, depsgraph_frame):
    entry = {"type": kind, "name": obj.name}
    for key in ("radius", "strength", "reach"):
        val = obj.get("beeswarm_" + key)
        if isinstance(val, (int, float)):
            entry[key] = float(val)
    if _is_animated(obj) and depsgraph_frame is not None:
        keys = []
        for f in range(frames[0], frames[1] + 1):
            keys.append({"frame": f, "position": to_shot(depsgraph_frame(obj, f))})
        entry["keys"] = keys
    else:
        entry["position"] = to_shot(obj.matrix_world.translation)
    return entry


# ---------------------------------------------------------------------------------------

def scene_frames(scene):
    return [int(scene.frame_start), int(scene.frame_end)]


def scene_fps(scene):
    return scene.render.fps / (scene.render.fps_base or 1.0)


def build_shot(scene, settings, name=None):
    """Returns (shot dict, warnings). Raises ShotBuildError for a scene that cannot bake."""
    warnings = []
    if settings.count < 1:
        raise ShotBuildError(f"The swarm needs at least 1 bee (count is {settings.count})")
    frames = scene_frames(scene)
    if frames[1] < frames[0]:
        raise ShotBuildError(f"The scene's frame range is reversed ({frames[0]}–{frames[1]})")
    shot_name = safe_name(name or settings.shot_name or "beeswarm")
    # A menu whose stored choice no longer exists (another binary) reads as "".
    model = settings.model or "bee"
    preset = settings.preset
    if preset == "FILE":
        if not settings.preset_file:
            raise ShotBuildError("Choose a preset file, or a built-in preset")
        # Absolute: the shot is written into the cache folder, and the binary reads a
        # relative preset path from the shot file's folder, not the .blend's.
        preset = bpy.path.abspath(settings.preset_file)
    elif not preset:
        raise ShotBuildError(f"Choose a preset of the {model} model")
    swarm = {
        "name": safe_name(settings.swarm_name or "bees", "bees", identifier=True),
        "count": int(settings.count),
        "model": model,
        "preset": preset,
    }
    # Spawn region: an object's world bounds, else the panel's centre and size.
    sp = settings.spawn_object
    if sp is not None:
        corners = [sp.matrix_world @ Vector(c) for c in sp.bound_box]
        lo = Vector((min(p.x for p in corners), min(p.y for p in corners), min(p.z for p in corners)))
        hi = Vector((max(p.x for p in corners), max(p.y for p in corners), max(p.z for p in corners)))
        centre, size = (lo + hi) / 2, hi - lo
        if sp.type == "EMPTY" and sp.empty_display_type == "SPHERE":
            radius = sp.empty_display_size * max(sp.matrix_world.to_scale())
            swarm["spawn"] = {"shape": "sphere", "center": to_shot(sp.matrix_world.translation),
                              "radius": radius}
        else:
            if sp.type == "EMPTY":
                size = Vector([2 * sp.empty_display_size * s for s in sp.matrix_world.to_scale()])
                centre = sp.matrix_world.translation
            swarm["spawn"] = {"shape": "box", "center": to_shot(centre),
                              "size": [abs(size.x), abs(size.z), abs(size.y)]}
    else:
        s = settings.spawn_size
        swarm["spawn"] = {"shape": "box", "center": to_shot(settings.spawn_center),
                          "size": [s[0], s[2], s[1]]}
    if min(swarm["spawn"].get("size", [1.0])) <= 0 or swarm["spawn"].get("radius", 1.0) <= 0:
        raise ShotBuildError("The spawn region has no volume")

    obstacles = []
    for obj in _objects(settings.obstacles):
        if obj.type not in {"MESH", "EMPTY", "CURVE", "SURFACE", "META"}:
            continue
        kind = obstacle_kind(obj)
        if kind is None:
            warnings.append(f"{obj.name}: not recognised as a sphere, box or cylinder; skipped "
                            f"(set the custom property {TYPE_PROP})")
            continue
        obstacles.append(obstacle_entry(obj, kind, warnings))
    if settings.ground:
        obstacles.append({"type": "plane", "name": "ground", "point": [0.0, 0.0, 0.0],
                          "normal": [0.0, 1.0, 0.0]})

    def position_at(obj, frame):
        current = scene.frame_current
        scene.frame_set(frame)
        p = obj.matrix_world.translation.copy()
        scene.frame_set(current)
        return p

    targets = []
    for obj in _objects(settings.targets):
        if obj.type != "EMPTY" and not _custom_type(obj, TARGET_TYPES):
            continue
        kind = target_kind(obj)
        if kind is None:
            warnings.append(f"{obj.name}: not a nest, flower or attractor; treated as an attractor")
            kind = "attractor"
        targets.append(target_entry(obj, kind, scene, frames, position_at))

    shot = {
        "scene": {
            "name": shot_name,
            "fps": float(scene_fps(scene)),
            "frames": frames,
            "substeps": int(settings.substeps),
            "seed": int(settings.seed),
        },
        "swarm": [swarm],
    }
    if obstacles:
        shot["obstacle"] = obstacles
    if targets:
        shot["target"] = targets
    if any(abs(x) > 0 for x in settings.wind):
        shot["wind"] = {"velocity": to_shot(settings.wind)}
    return shot, warnings


HEADER_MARK = "# Written by the beeswarm Blender add-on"


def shot_toml(shot, source=""):
    header = (HEADER_MARK[2:] + (f" from {source}" if source else "")
              + ".\nY-up, metres, seconds: Blender (x, y, z) is (x, z, -y) here.")
    return toml_writer.dumps(shot, header=header)
