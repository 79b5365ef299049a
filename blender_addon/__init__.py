"""beeswarm for Blender: bake honeybee swarms with the beeswarm binary and import the cache.

A Blender extension (blender_manifest.toml). The 3D viewport's sidebar has a "Beeswarm"
tab; the operator `beeswarm.bake` does the work and can be scripted:

    bpy.ops.beeswarm.bake(shot_path="", format='USD', binary_path="")
"""
from . import motion, operators, panel, props, swarm_list
# Blender's glTF importer looks up this name in every enabled add-on's module; the hooks act
# only while the add-on imports a cache (gltf_hooks.py).
from .gltf_hooks import GltfImportHooks as glTF2ImportUserExtension  # noqa: F401

_modules = (props, swarm_list, operators, panel, motion)


def register():
    for m in _modules:
        m.register()


def unregister():
    for m in reversed(_modules):
        m.unregister()
