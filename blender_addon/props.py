"""Preferences and the scene's bake settings."""
import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatVectorProperty, IntProperty,
                       PointerProperty, StringProperty)

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
    swarm_name: StringProperty(name="Swarm", default="bees")
    count: IntProperty(name="Count", default=200, min=0, soft_max=20000,
                       description="Number of bees")
    model: EnumProperty(name="Model", items=model_items, update=_model_changed,
                        description="How the swarm flies (the binary's `beeswarm models`)")
    preset: EnumProperty(name="Preset", items=preset_items,
                         description="The model's parameters to start from")
    preset_file: StringProperty(name="Preset File", subtype="FILE_PATH", default="")
    seed: IntProperty(name="Seed", default=1, min=0)
    substeps: IntProperty(name="Substeps", default=4, min=1, max=64)
    spawn_object: PointerProperty(
        name="Spawn", type=bpy.types.Object,
        description="The bees start inside this object's bounds (a sphere empty: a sphere); "
                    "empty = the centre and size below")
    spawn_center: FloatVectorProperty(name="Spawn Centre", subtype="TRANSLATION", size=3,
                                      default=(0.0, 0.0, 1.0))
    spawn_size: FloatVectorProperty(name="Spawn Size", subtype="XYZ", size=3,
                                    default=(1.0, 1.0, 1.0), min=0.0)
    obstacles: PointerProperty(
        name="Obstacles", type=bpy.types.Collection,
        description="Spheres, boxes and cylinders (told by the custom property beeswarm_type, "
                    "the mesh's shape or the name)")
    targets: PointerProperty(
        name="Targets", type=bpy.types.Collection,
        description="Empties: nest, flower or attractor (custom property beeswarm_type or "
                    "the name)")
    ground: BoolProperty(name="Ground Plane", default=False,
                         description="Add a ground plane at Z = 0")
    wind: FloatVectorProperty(name="Wind", subtype="VELOCITY", size=3, default=(0.0, 0.0, 0.0))
    format: EnumProperty(name="Format", items=FORMATS, default="USD")
    cache_dir: StringProperty(
        name="Cache Folder", subtype="DIR_PATH", default="//beeswarm_cache/",
        description="Where caches are written (// = next to the .blend; an unsaved file "
                    "uses a temporary folder)")
    instance_motion: BoolProperty(
        name="Instance id & velocity", default=True,
        description="USD: give the imported instances the bees' ids and velocities from the "
                    "tracks CSV (Blender's USD import drops them)")
    last_message: StringProperty(name="Last Bake", default="")


classes = (BeeswarmPreferences, BeeswarmSettings)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.beeswarm = PointerProperty(type=BeeswarmSettings)


def unregister():
    del bpy.types.Scene.beeswarm
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
