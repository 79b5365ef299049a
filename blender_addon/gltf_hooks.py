"""What the add-on changes in Blender's glTF importer while it imports a cache, through the
importer's public hook API (an add-on module's `glTF2ImportUserExtension` class), so the
import takes time linear in the bee count and the bees play at the shot's frames without a
pass over their F-curves.

Blender's glTF importer (4.4–5.3) puts every animated object of a glTF animation into one
action, one slot per object, then "stashes" it per object on an NLA track: `strips.new()`
and `action.frame_range` each walk the whole action unless the action has a manual frame
range, which makes the import quadratic in the bee count (docs/blender.md, *Import times*).
While the add-on imports (`importing()`), the hooks:

- give each new action a manual frame range as soon as it exists: its keys' range, read
  from the animation's sampler inputs (glTF requires their `min`/`max`), so stashing is
  constant time per object;
- keep the importer from making the first animation each object's active action: the
  bees play from the NLA strip the importer made, which starts at the scene's first frame,
  so time 0 of the cache lands on the shot's first frame without moving any key;
- once the file has been read and checked, and before anything is created, call
  `parsed()`: the add-on removes the previous swarm there. Freeing an ID walks Blender's
  whole queue of pending notifiers, which an import of N bees fills with O(N) entries, so
  removing the old swarm after the new import is quadratic (4,000 bees: 11 s against 1 s).

Outside the add-on's own imports the hooks do nothing.
"""
import contextlib
import sys

import bpy

_state = {"on": False, "actions": 0, "parsed": None}


class GltfImportHooks:
    """Exposed as the package's `glTF2ImportUserExtension`; the importer makes one per
    import and calls the hooks by name with the importer's `gltf` object last."""

    def __init__(self):
        self.ranged = set()

    def gather_import_gltf_before_hook(self, gltf):
        parsed, _state["parsed"] = _state["parsed"], None
        if _state["on"] and parsed is not None:
            parsed()

    def gather_import_animations(self, animations, options, gltf):
        if _state["on"]:
            options.restore_first_anim = False

    def gather_import_animation_channel_after_hook(self, animation, vnode, path, channel,
                                                   action, gltf):
        if not _state["on"] or action is None or action.name in self.ranged:
            return
        self.ranged.add(action.name)
        end = 0.0
        for sampler in animation.samplers:
            hi = gltf.data.accessors[sampler.input].max
            if not hi:
                return  # no max (invalid glTF): the importer computes the range itself
            end = max(end, float(hi[0]))
        scene = bpy.context.scene
        end *= scene.render.fps * scene.render.fps_base  # the importer's own conversion
        if end <= 0.0:
            return  # one key: nothing to range
        action.use_frame_range = True
        action.frame_start, action.frame_end = 0.0, end
        _state["actions"] += 1


def _discoverable(package):
    """Whether the importer finds `package`: it looks for the hooks in the modules of the
    enabled add-ons (an installed extension is one; a script that imported the package and
    called register() is not)."""
    return any(sys.modules.get(name) is package
               for name in bpy.context.preferences.addons.keys())


@contextlib.contextmanager
def importing(scene, fps, frame_start, parsed=None):
    """Around `bpy.ops.import_scene.gltf`: the hooks act, the importer converts glTF time
    with the shot's true rate (it multiplies fps by fps_base, where Blender divides) and
    stashes at the shot's first frame; `parsed()` runs once the file is read, before any
    data-block is made (the importer reports an exception in a hook and goes on). Restores
    the scene's timing afterwards. Yields a dict whose `actions` counts the actions given
    a frame range."""
    package = sys.modules[__package__]
    prefs = bpy.context.preferences
    entry = None
    if not _discoverable(package):
        dirty = prefs.is_dirty
        entry = prefs.addons.new()
        entry.module = __package__
    saved = (scene.render.fps_base, scene.frame_start, scene.frame_end)
    scene.render.fps_base = fps / scene.render.fps
    scene.frame_start = int(frame_start)
    _state.update(on=True, actions=0, parsed=parsed)
    try:
        yield _state
    finally:
        _state.update(on=False, parsed=None)
        scene.render.fps_base = saved[0]
        scene.frame_start, scene.frame_end = saved[1], saved[2]
        if entry is not None:
            prefs.addons.remove(entry)
            prefs.is_dirty = dirty


def play_from_strips(objects):
    """Each imported animated object plays its NLA strip (the importer leaves the track
    muted and locked). Assigning `action` (to None) also makes the depsgraph rebuild the
    object's animation relations, which unmuting alone does not."""
    for ob in objects:
        ad = ob.animation_data
        if ad is None or not len(ad.nla_tracks):
            continue
        ad.action = None
        for track in ad.nla_tracks:
            track.mute = False
            track.lock = False
