"""Preferences and the scene's bake settings."""
import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty,
                       FloatVectorProperty, IntProperty, PointerProperty, StringProperty)

from . import binary

PRESET_FILE = ("FILE", "Preset File", "A preset .toml written by `beeswarm calibrate`")

# Blender keeps only pointers to the strings of dynamic enum items: the lists must stay
# referenced from Python, or the menu shows garbage.
_items = {}


def _title(name):
    return name.replace("_", " ").title()


def models_doc(context):
    """The models document of the binary in use (see binary.models) and the reason when it
    is the built-in fallback."""
    return binary.models(preference_binary(context))


def model_items(self, context):
    doc, _ = models_doc(context)
    items = [(m["name"], _title(m["name"]), m["summary"]) for m in doc["models"]]
    _items["models"] = items
    return items


def preset_items(self, context):
    doc, _ = models_doc(context)
    m = binary.model_info(doc, self.model) or doc["models"][0]
    items = [(p["name"], _title(p["name"]), p["doc"]) for p in m["presets"]] + [PRESET_FILE]
    _items[("presets", m["name"])] = items
    return items


def preset_values(doc, swarm):
    """{parameter: value} of the swarm's chosen built-in preset ({} for a preset file or a
    binary that does not list values)."""
    info = binary.model_info(doc, swarm.model) or {}
    preset = next((p for p in info.get("presets", []) if p["name"] == swarm.preset), {})
    return preset.get("values", {})


def _owner_swarm(item):
    """The swarm an override item belongs to (from its RNA path, `beeswarm.swarms[i]...`)."""
    path = item.path_from_id()
    i = int(path.split("swarms[", 1)[1].split("]", 1)[0])
    return item.id_data.beeswarm.swarms[i]


def param_items(self, context):
    doc, _ = models_doc(context)
    swarm = _owner_swarm(self)
    m = binary.model_info(doc, swarm.model) or doc["models"][0]
    items = [(q["name"], q["name"], f"{q['doc']} ({q['unit']}, {q['min']:g} – {q['max']:g}, "
                                    f"default {q['default']:g})") for q in m.get("params", [])]
    if not items:  # the fallback list knows no parameters
        items = [("speed", "speed", "Preferred speed, m/s")]
    _items[("params", m["name"])] = items
    return items


def _model_changed(self, context):
    # A new model starts from its own default preset (its first), whichever was chosen.
    doc, _ = models_doc(context)
    m = binary.model_info(doc, self.model)
    if m:
        self.preset = m["presets"][0]["name"]

FORMATS = [
    ("USD", "USD", "Bake a USDA PointInstancer and import it"),
    ("GLTF", "glTF", "Bake a binary glTF (.glb) and import it"),
]


def _display_changed(self, context):
    from . import display
    display.apply(self.id_data)


WINGS = [
    ("BLUR", "Blur", "A faint fan of wings over the whole stroke, static: what a camera sees of "
                     "a real 230 Hz beat"),
    ("STILL", "Still", "Wings held at mid-stroke, a clear membrane"),
    ("FLAP", "Flap", "A stylised flap at Wing Flap Hz, in 8 phase groups so the swarm does not "
                     "beat in lockstep"),
]
GLTF_LAYOUTS = [
    ("AGENT", "One Object per Bee", "One animated object per bee holding its pose (flapping "
                                    "wings add two): Blender imports it several times faster"),
    ("PARTS", "Path, Body, Wings", "Per bee a path object, a body object and wing objects "
                                   "(2–4 animated objects per bee), for animators who edit them"),
]


class BeeswarmPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    binary_path: StringProperty(
        name="beeswarm Binary",
        description="Path to the beeswarm executable; empty = found on PATH or in the "
                    "repository's target/release",
        subtype="FILE_PATH",
        default="",
    )

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "binary_path")
        path, msg = binary.resolve(bpy.path.abspath(self.binary_path) if self.binary_path else "")
        row = layout.row()
        row.label(text=msg, icon="CHECKMARK" if path else "ERROR")


def preferences(context=None):
    context = context or bpy.context
    addon = context.preferences.addons.get(__package__)
    return addon.preferences if addon else None


def preference_binary(context=None):
    prefs = preferences(context)
    if prefs and prefs.binary_path:
        return bpy.path.abspath(prefs.binary_path)
    return ""


class BeeswarmOverride(bpy.types.PropertyGroup):
    """One model parameter set for one swarm, over its preset (`[swarm.params]`)."""
    param: EnumProperty(name="Parameter", items=param_items,
                        description="A parameter of the swarm's model (`beeswarm models`)")
    value: FloatProperty(name="Value", default=1.0, precision=4)


class BeeswarmSwarm(bpy.types.PropertyGroup):
    """One `[[swarm]]` of the shot."""
    name: StringProperty(name="Name", default="bees",
                         description="The swarm's name in the caches (letters, digits, _)")
    count: IntProperty(name="Count", default=200, min=0, soft_max=20000,
                       description="Number of bees")
    model: EnumProperty(name="Model", items=model_items, update=_model_changed,
                        description="How the swarm flies (the binary's `beeswarm models`)")
    preset: EnumProperty(name="Preset", items=preset_items,
                         description="The model's parameters to start from")
    preset_file: StringProperty(name="Preset File", subtype="FILE_PATH", default="")
    spawn_object: PointerProperty(
        name="Spawn", type=bpy.types.Object,
        description="The bees start inside this object's bounds (a sphere empty: a sphere); "
                    "empty = the centre and size below")
    spawn_center: FloatVectorProperty(name="Spawn Centre", subtype="TRANSLATION", size=3,
                                      default=(0.0, 0.0, 1.0))
    spawn_size: FloatVectorProperty(name="Spawn Size", subtype="XYZ", size=3,
                                    default=(1.0, 1.0, 1.0), min=0.0)
    bounds_object: PointerProperty(
        name="Bounds", type=bpy.types.Object,
        description="A soft box the swarm stays in: this object's world bounding box; "
                    "empty = the spawn region grown by 1.5 m")
    bee_length: FloatProperty(name="Bee Length", default=0.012, min=0.0001, max=1.0,
                              subtype="DISTANCE", precision=4, unit="LENGTH",
                              description="Body length (the contact radius is a sixth of it)")
    size_variation: FloatProperty(name="Size Variation", default=0.1, min=0.0, max=0.9,
                                  description="Each bee's size factor is drawn from "
                                              "[1 − v, 1 + v]")
    speed_variation: FloatProperty(name="Speed Variation", default=0.15, min=0.0, max=0.9,
                                   description="Each bee's speed factor is drawn from "
                                               "[1 − v, 1 + v]")
    start_inside: FloatProperty(name="Start Inside", default=0.0, min=0.0, max=1.0,
                                subtype="FACTOR",
                                description="Share of the bees inside the hive at the first "
                                            "frame (bee model; needs a nest empty with "
                                            "beeswarm_land and beeswarm_inside)")
    overrides: CollectionProperty(type=BeeswarmOverride)
    override_index: IntProperty(default=0)


class BeeswarmSettings(bpy.types.PropertyGroup):
    source: EnumProperty(
        name="Shot",
        items=[("SCENE", "From Scene", "Build the shot from this scene and the settings below"),
               ("FILE", "Shot File", "Bake an existing shot .toml")],
        default="SCENE",
    )
    shot_file: StringProperty(name="Shot File", subtype="FILE_PATH", default="")
    shot_name: StringProperty(name="Name", default="beeswarm",
                              description="The shot's name: the cache's file names and the "
                                          "imported collection")
    swarms: CollectionProperty(type=BeeswarmSwarm)
    swarm_index: IntProperty(name="Swarm", default=0)
    seed: IntProperty(name="Seed", default=1, min=0,
                      description="The shot's seed: spawn positions, variation, noise")
    substeps: IntProperty(name="Substeps", default=4, min=1, max=64)
    use_scene_frames: BoolProperty(name="Scene Frame Range", default=True,
                                   description="Bake the scene's frame range; off = the "
                                               "range below (the scene's own is left alone)")
    frame_start: IntProperty(name="Start", default=1)
    frame_end: IntProperty(name="End", default=120)
    obstacles: PointerProperty(
        name="Obstacles", type=bpy.types.Collection,
        description="Spheres, boxes, cylinders, capsules and planes (told by the custom "
                    "property beeswarm_type, the mesh's shape or the name)")
    targets: PointerProperty(
        name="Targets", type=bpy.types.Collection,
        description="Empties: nest, flower or attractor (custom property beeswarm_type or "
                    "the name)")
    ground: BoolProperty(name="Ground Plane", default=False,
                         description="Add a ground plane at Z = 0")
    wind: FloatVectorProperty(name="Wind", subtype="VELOCITY", size=3, default=(0.0, 0.0, 0.0))
    wings: EnumProperty(
        name="Wings", items=WINGS, default="BLUR",
        description="How the wings are drawn, the same in glTF and USD")
    wing_flap_hz: FloatProperty(
        name="Wing Flap", default=0.0, min=0.0, soft_max=12.0, unit="NONE",
        description="Flap rate of Wings = Flap, Hz (the real 230 Hz beat would alias); 0 = the "
                    "default, 6 Hz or a sixth of the frame rate if less")
    gltf_layout: EnumProperty(
        name="glTF Layout", items=GLTF_LAYOUTS, default="AGENT",
        description="How each bee is laid out in a glTF cache")
    formats: EnumProperty(name="Formats", items=FORMATS, options={"ENUM_FLAG"}, default={"USD"},
                          description="Caches to bake (the tracks CSV always comes too)")
    format: EnumProperty(name="Import", items=FORMATS, default="USD",
                         description="Which baked cache to import")
    cache_dir: StringProperty(
        name="Cache Folder", subtype="DIR_PATH", default="//beeswarm_cache/",
        description="Where caches are written (// = next to the .blend; an unsaved file "
                    "uses Blender's temporary folder)")
    instance_motion: BoolProperty(
        name="Instance id & velocity", default=True,
        description="USD: give the imported instances the bees' ids and velocities from the "
                    "tracks CSV (Blender's USD import drops them)")
    display_percent: IntProperty(
        name="Display", default=100, min=1, max=100, subtype="PERCENTAGE",
        update=_display_changed,
        description="Share of the bees drawn in the viewport (renders draw every bee)")
    viewport_points: BoolProperty(
        name="Points in Viewport", default=False, update=_display_changed,
        description="USD: draw each bee as a point in the viewport (light for big swarms); "
                    "renders draw the bees")
    asset: PointerProperty(
        name="Insect Asset", type=bpy.types.Object,
        description="USD: draw this object on every bee instead of the cache's bee (model it "
                    "facing +X with +Z up, at bee scale: 1 unit = 1 m)")
    last_message: StringProperty(name="Last Bake", default="")


def add_swarm(settings):
    """A new swarm with the defaults and a name not yet used; it becomes the active one."""
    used = {s.name for s in settings.swarms}
    name, k = "bees", 2
    while name in used:
        name, k = f"bees_{k}", k + 1
    sw = settings.swarms.add()
    sw.name = name
    settings.swarm_index = len(settings.swarms) - 1
    return sw


classes = (BeeswarmPreferences, BeeswarmOverride, BeeswarmSwarm, BeeswarmSettings)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.beeswarm = PointerProperty(type=BeeswarmSettings)


def unregister():
    del bpy.types.Scene.beeswarm
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
