"""Importing a baked cache into a collection named after the shot, replacing the previous
import of the same shot, and never leaving a half-imported swarm behind."""
import os
import tomllib

import bpy

from . import gltf_hooks

SHOT_TAG = "beeswarm_shot"  # ID property on every data-block an import created

# Defaults of the shot format (src/shot/defaults.rs).
DEFAULT_FPS = 24.0
DEFAULT_FRAMES = (1, 120)

_ID_COLLECTIONS = (
    "objects", "meshes", "pointclouds", "curves", "materials", "node_groups", "cache_files",
    "actions", "collections", "images", "textures", "cameras", "lights", "armatures",
    "shape_keys", "worlds", "hair_curves", "volumes",
)


class ImportFailed(Exception):
    pass


def shot_info(shot_path):
    """(name, fps, (start, end)) of a shot file, with the format's defaults."""
    with open(shot_path, "rb") as f:
        doc = tomllib.load(f)
    scene = doc.get("scene", {}) or {}
    stem = os.path.basename(shot_path)
    stem = stem[: -len(".toml")] if stem.endswith(".toml") else os.path.splitext(stem)[0]
    if stem.endswith(".shot"):
        stem = stem[: -len(".shot")]
    name = scene.get("name") or stem or "beeswarm"
    fps = float(scene.get("fps", DEFAULT_FPS))
    frames = tuple(int(x) for x in scene.get("frames", DEFAULT_FRAMES))
    return name, fps, frames


def set_scene_timing(scene, fps, frames, set_range=True):
    """Sets the scene's frame rate (fps / fps_base for a non-integer rate) and range."""
    whole = round(fps)
    if abs(whole - fps) < 1e-6:
        scene.render.fps, scene.render.fps_base = int(whole), 1.0
    else:
        base = 1001.0 / 1000.0 if abs(fps * 1.001 - round(fps * 1.001)) < 1e-3 else 1.0
        scene.render.fps = int(round(fps * base))
        scene.render.fps_base = scene.render.fps / fps
    if not set_range:
        return
    scene.frame_start, scene.frame_end = int(frames[0]), int(frames[1])
    if not frames[0] <= scene.frame_current <= frames[1]:
        scene.frame_current = int(frames[0])


def _snapshot():
    snap = {}
    for attr in _ID_COLLECTIONS:
        coll = getattr(bpy.data, attr, None)
        if coll is not None:
            snap[attr] = set(coll)
    return snap


def _new_ids(before):
    new = []
    for attr, old in before.items():
        new.extend(x for x in getattr(bpy.data, attr) if x not in old)
    return new


def tagged(shot_name):
    """Every data-block a previous import of `shot_name` created."""
    out = []
    for attr in _ID_COLLECTIONS:
        coll = getattr(bpy.data, attr, None)
        if coll is None:
            continue
        out.extend(x for x in coll if x.get(SHOT_TAG) == shot_name)
    return out


def remove_ids(ids):
    ids = [i for i in ids if i is not None]
    if not ids:
        return
    try:
        bpy.data.batch_remove(ids)
        return
    except Exception:
        pass
    for attr in _ID_COLLECTIONS:
        coll = getattr(bpy.data, attr, None)
        if coll is None:
            continue
        for i in ids:
            try:
                if i in set(coll):
                    coll.remove(i)
            except (ReferenceError, RuntimeError):
                pass


def remove_shot(shot_name):
    """Removes the previous import of a shot: its collection, objects and their data."""
    remove_ids(tagged(shot_name))
    old = bpy.data.collections.get(shot_name)
    if old is not None and old.get(SHOT_TAG) is None and len(old.all_objects) == 0:
        bpy.data.collections.remove(old)


def _find_layer_collection(layer_coll, coll):
    if layer_coll.collection == coll:
        return layer_coll
    for child in layer_coll.children:
        found = _find_layer_collection(child, coll)
        if found:
            return found
    return None


def _supported(op, **kwargs):
    """Only the options this Blender's importer has (older ones lack some of 5.0's)."""
    props = op.get_rna_type().properties
    return {k: v for k, v in kwargs.items() if k in props}


def _import_file(path, fmt, scene, fps, frame_start, parsed=None):
    if fmt == "USD":
        op = bpy.ops.wm.usd_import
        kwargs = _supported(op, set_frame_range=False, import_cameras=False,
                            import_lights=False, create_collection=False, relative_path=True,
                            create_world_material=False)
    else:
        op = bpy.ops.import_scene.gltf
        kwargs = _supported(op, import_scene_as_collection=False, import_scene_extras=True)
        with gltf_hooks.importing(scene, fps, frame_start, parsed):
            result = op(filepath=path, **kwargs)
        if "FINISHED" not in result:
            raise ImportFailed(f"Blender could not import {os.path.basename(path)}")
        return
    result = op(filepath=path, **kwargs)
    if "FINISHED" not in result:
        raise ImportFailed(f"Blender could not import {os.path.basename(path)}")


def _stash_names(ids):
    """Renames the previous import out of the way so the new one gets clean names; returns
    the originals to restore on failure."""
    names = {}
    for i, id_ in enumerate(ids):
        names[id_] = id_.name
        id_.name = f"~old{i}.{id_.name}"[:60]
    return names


def _restore_names(names):
    for id_, name in names.items():
        try:
            id_.name = name
        except ReferenceError:
            pass


def _adopt_stray_collections(staging, new_ids, view_layer):
    """The USD importer links its prototypes collection to the scene's collection; it
    belongs to the shot, so it moves under the shot's collection, still excluded."""
    root = bpy.context.scene.collection
    for coll in [i for i in new_ids if isinstance(i, bpy.types.Collection)]:
        if coll is staging or coll.name not in root.children:
            continue
        lc = _find_layer_collection(view_layer.layer_collection, coll)
        excluded = lc.exclude if lc else False
        root.children.unlink(coll)
        staging.children.link(coll)
        lc = _find_layer_collection(view_layer.layer_collection, coll)
        if lc is not None:
            lc.exclude = excluded
    # Name lookups in a collection are linear: one set each, not one walk per object.
    in_root = set(root.objects)
    in_staging = set(staging.objects)
    for obj in [i for i in new_ids if isinstance(i, bpy.types.Object)]:
        if obj in in_root:
            root.objects.unlink(obj)
            if obj not in in_staging:
                staging.objects.link(obj)


def import_cache(context, shot_name, path, fmt, fps, frames, after=None, set_range=True):
    """Imports `path` into a new collection `shot_name` under the scene's collection.

    The scene's fps and range are set first (glTF animation is converted with them). The
    previous import of the shot is removed once the new one is in (USD), or once the glTF
    file has been read and checked, before its data-blocks are made (removing it after
    them costs time quadratic in the bee count, see gltf_hooks.py). On failure everything
    this import created is removed, the scene's timing is restored and so is the previous
    import if it is still there, and the error is raised. `after(collection, objects)` runs
    inside the guarded section. `set_range=False` leaves the scene's frame range alone (a
    bake of another range)."""
    scene = context.scene
    saved = (scene.render.fps, scene.render.fps_base, scene.frame_start, scene.frame_end,
             scene.frame_current)
    view_layer = context.view_layer
    saved_active = view_layer.active_layer_collection
    previous = tagged(shot_name)
    old_names = _stash_names(previous)
    before = _snapshot()
    staging = None
    dropped = []

    def drop_previous():
        remove_ids(previous)
        dropped.append(True)
        # Freed IDs' addresses may be reused by new ones: what existed is taken again.
        before.clear()
        before.update(_snapshot())
        before["collections"].discard(staging)

    try:
        set_scene_timing(scene, fps, frames, set_range)
        staging = bpy.data.collections.new(shot_name)
        scene.collection.children.link(staging)
        layer = _find_layer_collection(view_layer.layer_collection, staging)
        view_layer.active_layer_collection = layer
        _import_file(path, fmt, scene, fps, frames[0], drop_previous if previous else None)
        new = _new_ids(before)
        imported_objects = [o for o in new if isinstance(o, bpy.types.Object)]
        if not imported_objects:
            raise ImportFailed(f"{os.path.basename(path)} holds nothing to import")
        _adopt_stray_collections(staging, new, view_layer)
        if fmt != "USD":
            gltf_hooks.play_from_strips(imported_objects)
        if after is not None:
            after(staging, imported_objects)
        for id_ in _new_ids(before):
            id_[SHOT_TAG] = shot_name
    except BaseException as e:
        remove_ids(_new_ids(before))
        _restore_names(old_names)
        (scene.render.fps, scene.render.fps_base, scene.frame_start, scene.frame_end,
         scene.frame_current) = saved
        try:
            view_layer.active_layer_collection = saved_active
        except Exception:
            pass
        if dropped and isinstance(e, Exception):
            raise ImportFailed(f"{e} (the previous swarm had already been removed)") from e
        raise
    try:
        view_layer.active_layer_collection = saved_active
    except Exception:
        pass
    if not dropped:
        remove_ids(previous)
    staging.name = shot_name
    return staging
