"""The Blender add-on (blender_addon/), headless with `bpy` (Blender as a Python module).

Run with the venv that has bpy 5.0.1:
    BEESWARM_BIN=target/release/beeswarm python -m pytest tests/python/test_blender_addon.py
"""
import json
import math
import os
import pathlib
import re
import stat
import subprocess
import sys
import time
import tomllib

import pytest

bpy = pytest.importorskip("bpy", reason="bpy (Blender as a module) is not installed")
import numpy as np  # noqa: E402  (bpy brings numpy)
from mathutils import Euler, Quaternion, Vector  # noqa: E402

from conftest import ROOT, read_tracks  # noqa: E402

sys.path.insert(0, str(ROOT))
import blender_addon  # noqa: E402
from blender_addon import binary, display, importer, props, runner, shot_builder  # noqa: E402

TOL = 1e-4  # metres
# Blender's name for this machine's platform (extension manifests' `platforms`).
PLATFORM = {"linux": "linux", "darwin": "macos", "win32": "windows"}.get(sys.platform, sys.platform) \
    + "-" + {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64", "arm64": "arm64"}.get(
        __import__("platform").machine().lower(), __import__("platform").machine().lower())


@pytest.fixture(scope="module", autouse=True)
def addon():
    blender_addon.register()
    yield blender_addon
    blender_addon.unregister()


@pytest.fixture
def scene(tmp_path):
    """An empty scene with Obstacles and Targets collections, saved in tmp_path (so the
    shot TOML and the cache go there, not to a shared temporary folder)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.fps, sc.render.fps_base = 24, 1.0
    sc.frame_start, sc.frame_end = 1, 36
    for name in ("Obstacles", "Targets"):
        sc.collection.children.link(bpy.data.collections.new(name))
    s = sc.beeswarm
    s.obstacles = bpy.data.collections["Obstacles"]
    s.targets = bpy.data.collections["Targets"]
    s.shot_name = "bltest"
    s.seed = 1
    sw = props.add_swarm(s)
    sw.count = 40
    sw.spawn_center = (0.0, 0.0, 1.0)
    sw.spawn_size = (0.8, 0.8, 0.8)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "scene.blend"))
    return sc


def add_primitive(kind, collection, **kw):
    op = {"cylinder": bpy.ops.mesh.primitive_cylinder_add, "cube": bpy.ops.mesh.primitive_cube_add,
          "uv_sphere": bpy.ops.mesh.primitive_uv_sphere_add,
          "ico_sphere": bpy.ops.mesh.primitive_ico_sphere_add,
          "plane": bpy.ops.mesh.primitive_plane_add}[kind]
    op(**kw)
    obj = bpy.context.active_object
    for c in list(obj.users_collection):
        c.objects.unlink(obj)
    bpy.data.collections[collection].objects.link(obj)
    return obj


def add_empty(name, location, collection="Targets", **props):
    e = bpy.data.objects.new(name, None)
    e.location = location
    for k, v in props.items():
        e[k] = v
    bpy.data.collections[collection].objects.link(e)
    return e


def shot_cylinder_scene(sc):
    """A nest and a tilted cylinder through the spawn region."""
    add_empty("Nest", (0.0, 0.3, 1.1))
    cyl = add_primitive("cylinder", "Obstacles", radius=0.08, depth=1.6, location=(0.15, 0.0, 1.0),
                        rotation=(math.radians(20), 0.0, math.radians(35)))
    cyl.name = "post"
    return cyl


def bake(fmt="USD", binary_path=None, **kw):
    return bpy.ops.beeswarm.bake(format=fmt, binary_path=binary_path or "", **kw)


def run_bake(beeswarm_bin, fmt="USD", **kw):
    """Bakes; a build without the writer for `fmt` (the writers land on main separately)
    skips: it is a feature of the build, not a tool to install."""
    try:
        return bake(fmt, beeswarm_bin, **kw)
    except RuntimeError as e:
        if "not available in this build" in str(e):
            pytest.skip(f"{beeswarm_bin} has no {fmt} writer yet: {e}")
        raise


def shot_collections(name):
    return [c for c in bpy.data.collections if c.get(importer.SHOT_TAG) == name
            and c.name.startswith(name) and c.name in bpy.context.scene.collection.children]


def blender_from_shot(p):
    return Vector((p[0], -p[2], p[1]))


# ---------------------------------------------------------------------------------------
# Shot building (no binary needed)

def shot_points_on_cylinder(entry, points):
    """Max deviation of shot-space points from the shot cylinder's side or caps."""
    rot = Euler([math.radians(a) for a in entry["rotation"]], "XYZ").to_matrix()
    axis = rot @ Vector((0, 1, 0))
    c = Vector(entry["center"])
    worst = 0.0
    for p in points:
        d = Vector(p) - c
        along = d.dot(axis)
        radial = (d - along * axis).length
        on_side = abs(radial - entry["radius"]) if abs(along) <= entry["height"] / 2 + 1e-6 else 1.0
        on_cap = abs(abs(along) - entry["height"] / 2) if radial <= entry["radius"] + 1e-6 else 1.0
        worst = max(worst, min(on_side, on_cap))
    return worst


def test_rotated_scaled_cylinder_and_box_convert_to_shot_axes(scene):
    cyl = add_primitive("cylinder", "Obstacles", radius=0.5, depth=2.0, location=(1.0, 2.0, 3.0),
                        rotation=(math.radians(30), math.radians(-50), math.radians(70)))
    cyl.scale = (0.4, 0.4, 1.5)
    box = add_primitive("cube", "Obstacles", size=2.0, location=(-1.0, 0.5, 0.25),
                        rotation=(math.radians(10), math.radians(80), math.radians(-120)))
    box.scale = (0.3, 1.2, 0.7)
    add_primitive("uv_sphere", "Obstacles", radius=0.25, location=(0.0, -2.0, 0.5))
    bpy.context.view_layer.update()
    shot, warnings = shot_builder.build_shot(scene, scene.beeswarm)
    doc = tomllib.loads(shot_builder.shot_toml(shot))
    obstacles = {o["name"]: o for o in doc["obstacle"]}
    assert obstacles["Cylinder"]["type"] == "cylinder"
    assert obstacles["Cube"]["type"] == "box"
    assert obstacles["Sphere"]["type"] == "sphere"

    def shot_verts(obj):
        return [shot_builder.to_shot(obj.matrix_world @ v.co) for v in obj.data.vertices]

    c = obstacles["Cylinder"]
    assert c["radius"] == pytest.approx(0.2, abs=1e-6)
    assert c["height"] == pytest.approx(3.0, abs=1e-6)
    assert shot_points_on_cylinder(c, shot_verts(cyl)) < 1e-5

    b = obstacles["Cube"]
    rot = Euler([math.radians(a) for a in b["rotation"]], "XYZ").to_matrix()
    half = Vector(b["size"]) / 2
    corners = [Vector(b["center"]) + rot @ Vector((sx * half.x, sy * half.y, sz * half.z))
               for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    verts = [Vector(p) for p in shot_verts(box)]
    assert len(verts) == 8
    assert max(min((c - v).length for c in corners) for v in verts) < 1e-5
    assert max(min((c - v).length for v in verts) for c in corners) < 1e-5

    s = obstacles["Sphere"]
    assert s["center"] == pytest.approx([0.0, 0.5, 2.0], abs=1e-6)
    assert s["radius"] == pytest.approx(0.25, abs=1e-3)
    assert not warnings


def test_targets_and_spawn_from_scene(scene):
    add_empty("Nest", (0.5, 1.0, 2.0))
    add_empty("food", (1.0, -1.0, 0.5), beeswarm_type="flower", beeswarm_radius=0.1)
    moving = add_empty("Attractor.001", (0.0, 0.0, 1.0))
    moving.keyframe_insert("location", frame=1)
    moving.location = (0.0, 2.0, 1.0)
    moving.keyframe_insert("location", frame=36)
    spawn = bpy.data.objects.new("spawn", None)
    spawn.empty_display_type = "CUBE"
    spawn.location = (0.0, 0.0, 1.5)
    spawn.scale = (0.5, 1.0, 0.25)
    scene.collection.objects.link(spawn)
    scene.beeswarm.swarms[0].spawn_object = spawn
    scene.beeswarm.wind = (1.0, 2.0, 0.0)
    bpy.context.view_layer.update()
    shot, _ = shot_builder.build_shot(scene, scene.beeswarm)
    doc = tomllib.loads(shot_builder.shot_toml(shot))
    t = {x["name"]: x for x in doc["target"]}
    assert t["Nest"]["type"] == "nest" and t["Nest"]["position"] == pytest.approx([0.5, 2.0, -1.0])
    assert t["food"]["type"] == "flower" and t["food"]["radius"] == pytest.approx(0.1)
    assert t["food"]["position"] == pytest.approx([1.0, 0.5, 1.0])
    keys = t["Attractor.001"]["keys"]
    assert len(keys) == 36 and keys[0]["frame"] == 1
    assert keys[-1]["position"] == pytest.approx([0.0, 1.0, -2.0])
    assert doc["swarm"][0]["spawn"] == {"shape": "box", "center": pytest.approx([0.0, 1.5, 0.0]),
                                        "size": pytest.approx([1.0, 0.5, 2.0])}
    assert doc["wind"]["velocity"] == pytest.approx([1.0, 0.0, -2.0])
    assert doc["scene"]["frames"] == [1, 36] and doc["scene"]["fps"] == 24


@pytest.mark.parametrize("kind,kw,expected", [
    ("cube", {}, "box"),
    ("uv_sphere", {}, "sphere"),
    ("ico_sphere", {"subdivisions": 2}, "sphere"),
    ("cylinder", {"vertices": 16}, "cylinder"),
    ("cylinder", {"vertices": 32, "end_fill_type": "TRIFAN"}, "cylinder"),
    ("plane", {}, "plane"),
])
def test_mesh_shape_heuristics(scene, kind, kw, expected):
    obj = add_primitive(kind, "Obstacles", **kw)
    obj.name = "thing"  # the name must not decide
    assert shot_builder.obstacle_kind(obj) == expected


def test_custom_property_and_name_decide_the_type(scene):
    blob = add_primitive("ico_sphere", "Obstacles")
    blob["beeswarm_type"] = "box"
    assert shot_builder.obstacle_kind(blob) == "box"
    # An irregular mesh: told by its name.
    me = bpy.data.meshes.new("irregular")
    me.from_pydata([(0, 0, 0), (1, 0, 0), (0, 2, 0), (0, 0, 0.3), (0.5, 0.5, 0.1)], [], [])
    ob = bpy.data.objects.new("column_cylinder", me)
    bpy.data.collections["Obstacles"].objects.link(ob)
    assert shot_builder.obstacle_kind(ob) == "cylinder"
    ob.name = "rock"
    assert shot_builder.obstacle_kind(ob) is None


def test_built_shot_passes_beeswarm_check(scene, beeswarm_bin, tmp_path):
    shot_cylinder_scene(scene)
    add_primitive("cube", "Obstacles", size=0.2, location=(-0.6, 0.0, 0.3))
    scene.beeswarm.ground = True
    bpy.context.view_layer.update()
    shot, _ = shot_builder.build_shot(scene, scene.beeswarm)
    path = tmp_path / "built.shot.toml"
    path.write_text(shot_builder.shot_toml(shot, "test"))
    r = subprocess.run([beeswarm_bin, "check", str(path)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "3 obstacle(s)" in r.stdout and "1 target(s)" in r.stdout


def test_hive_traffic_from_custom_properties(scene, beeswarm_bin, tmp_path):
    """A nest empty's beeswarm_land / _stay / _inside and a swarm's Start Inside become the
    shot's hive traffic, which the binary accepts; a malformed range names the object."""
    hive = add_empty("Hive", (0.0, 0.3, 1.0), beeswarm_type="nest", beeswarm_land=True,
                     beeswarm_stay=[0.3, 1.0], beeswarm_inside=[4.0, 12.0])
    scene.beeswarm.swarms[0].start_inside = 0.25
    bpy.context.view_layer.update()
    shot, _ = shot_builder.build_shot(scene, scene.beeswarm)
    doc = tomllib.loads(shot_builder.shot_toml(shot))
    t = doc["target"][0]
    assert t["land"] is True
    assert t["stay"] == pytest.approx([0.3, 1.0]) and t["inside"] == pytest.approx([4.0, 12.0])
    assert doc["swarm"][0]["start_inside"] == pytest.approx(0.25)
    path = tmp_path / "hive.shot.toml"
    path.write_text(shot_builder.shot_toml(shot, "test"))
    r = subprocess.run([beeswarm_bin, "check", str(path)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    hive["beeswarm_inside"] = [4.0]
    with pytest.raises(shot_builder.ShotBuildError, match="Hive: the custom property beeswarm_inside"):
        shot_builder.build_shot(scene, scene.beeswarm)


def test_toml_writer_escapes_and_round_trips():
    from blender_addon import toml_writer
    doc = {"scene": {"name": 'a "quoted"\\name', "fps": 23.976, "frames": [1, 2]},
           "swarm": [{"name": "s", "count": 3, "spawn": {"shape": "box", "size": [1.0, 2.0, 3.0]},
                      "params": {"speed": 1.5}}],
           "target": [{"type": "nest", "keys": [{"frame": 1, "position": [0.0, 1.0, 2.0]}]}]}
    back = tomllib.loads(toml_writer.dumps(doc, header="x\ny"))
    assert back == doc


def test_binary_discovery(tmp_path, monkeypatch):
    repo = tmp_path / "repo"
    exe = repo / "target" / "release" / binary.EXE
    exe.parent.mkdir(parents=True)
    exe.write_text("#!/bin/sh\n")
    exe.chmod(exe.stat().st_mode | stat.S_IXUSR)
    addon_dir = repo / "blender_addon"
    addon_dir.mkdir()
    monkeypatch.setenv("PATH", str(tmp_path / "nowhere"))
    assert binary.discover(addon_dir, use_cache=False) == exe
    assert binary.search_upwards(tmp_path) is None
    on_path = tmp_path / "bin" / binary.EXE
    on_path.parent.mkdir()
    on_path.write_text("#!/bin/sh\n")
    on_path.chmod(0o755)
    monkeypatch.setenv("PATH", str(on_path.parent))
    assert binary.discover(addon_dir, use_cache=False) == on_path
    assert binary.resolve(str(tmp_path / "missing"))[0] is None
    assert binary.resolve(str(exe))[0] == exe
    # A binary bundled in the extension (bin/ beside the add-on) comes before PATH; the
    # installer drops file modes, so it is made executable on first use.
    packed = addon_dir / "bin" / binary.EXE
    packed.parent.mkdir()
    packed.write_text("#!/bin/sh\n")
    packed.chmod(0o644)
    assert binary.discover(addon_dir, use_cache=False) == packed
    assert os.access(packed, os.X_OK)
    # An explicit path (the operator's or the preference) still wins.
    assert binary.resolve(str(on_path))[0] == on_path


# ---------------------------------------------------------------------------------------
# The whole shot from the panel: several swarms, overrides, bounds, frames, formats

def test_two_swarms_with_overrides_bounds_and_own_frames(scene, with_binary, tmp_path):
    s = scene.beeswarm
    first = s.swarms[0]
    first.bee_length = 0.015
    first.size_variation = 0.3
    first.speed_variation = 0.05
    assert bpy.ops.beeswarm.override_add() == {"FINISHED"}
    first.overrides[0].param = "speed"
    first.overrides[0].value = 1.5
    box = add_empty("Roam", (0.0, 0.0, 1.0), collection="Obstacles")
    bpy.data.collections["Obstacles"].objects.unlink(box)
    scene.collection.objects.link(box)
    box.empty_display_type = "CUBE"
    box.scale = (3.0, 2.0, 1.5)
    first.bounds_object = box
    assert bpy.ops.beeswarm.swarm_add() == {"FINISHED"}
    second = s.swarms[1]
    assert second.name == "bees_2" and s.swarm_index == 1
    second.count = 15
    second.model = "boids"
    second.spawn_center = (2.0, 0.0, 1.0)
    s.use_scene_frames = False
    s.frame_start, s.frame_end = 10, 30
    bpy.context.view_layer.update()
    shot, _ = shot_builder.build_shot(scene, s)
    doc = tomllib.loads(shot_builder.shot_toml(shot))
    a, b = doc["swarm"]
    assert (a["name"], a["count"], b["name"], b["count"], b["model"]) == \
        ("bees", 40, "bees_2", 15, "boids")
    assert a["params"] == {"speed": 1.5} and "params" not in b
    assert a["bee"] == pytest.approx({"length": 0.015, "radius": 0.0025})
    assert a["variation"] == pytest.approx({"size": 0.3, "speed": 0.05})
    assert a["bounds"] == {"center": pytest.approx([0.0, 1.0, 0.0]),
                           "size": pytest.approx([6.0, 3.0, 4.0])}
    assert "bounds" not in b
    assert doc["scene"]["frames"] == [10, 30]
    path = tmp_path / "two.shot.toml"
    path.write_text(shot_builder.shot_toml(shot, "test"))
    r = subprocess.run([with_binary, "check", str(path)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr

    assert run_bake(with_binary, "USD") == {"FINISHED"}
    clouds = sorted(o.name for o in bpy.data.collections["bltest"].all_objects
                    if o.type == "POINTCLOUD")
    assert clouds == ["bees", "bees_2"]
    tracks = read_tracks(tmp_path / "beeswarm_cache" / "bltest" / "bltest.tracks.csv")
    assert len(tracks) == 55 and sorted(next(iter(tracks.values()))) == list(range(10, 31))
    # The panel's own range is baked; the scene keeps its range.
    assert (scene.frame_start, scene.frame_end) == (1, 36)


def test_swarm_and_override_lists_add_and_remove(scene, with_binary):
    s = scene.beeswarm
    for _ in range(2):
        assert bpy.ops.beeswarm.swarm_add() == {"FINISHED"}
    assert [w.name for w in s.swarms] == ["bees", "bees_2", "bees_3"] and s.swarm_index == 2
    s.swarm_index = 1
    assert bpy.ops.beeswarm.override_add() == {"FINISHED"}
    assert bpy.ops.beeswarm.override_add() == {"FINISHED"}
    first, second = s.swarms[1].overrides
    # Each starts at another parameter, at the preset's value.
    assert first.param == "kappa1" and second.param == "kappa2"
    assert (first.value, second.value) == pytest.approx((1.0, 2.5))  # nest
    s.swarms[1].override_index = 0
    assert bpy.ops.beeswarm.override_remove() == {"FINISHED"}
    assert [o.param for o in s.swarms[1].overrides] == ["kappa2"]
    assert bpy.ops.beeswarm.swarm_remove() == {"FINISHED"}
    assert [w.name for w in s.swarms] == ["bees", "bees_3"] and s.swarm_index == 1
    assert bpy.ops.beeswarm.swarm_remove() == {"FINISHED"}
    assert bpy.ops.beeswarm.swarm_remove() == {"FINISHED"}
    assert not s.swarms and not bpy.ops.beeswarm.swarm_remove.poll()
    with pytest.raises(shot_builder.ShotBuildError, match="no swarm"):
        shot_builder.build_shot(scene, s)


def test_both_formats_in_one_bake(scene, with_binary, tmp_path):
    s = scene.beeswarm
    s.formats = {"USD", "GLTF"}
    s.format = "GLTF"
    log = draw_panel(bpy.context)
    assert ("prop", "format") in log  # which one to import, once both are chosen
    assert run_bake(with_binary, "GLTF", also_formats={"USD"}) == {"FINISHED"}
    folder = tmp_path / "beeswarm_cache" / "bltest"
    assert {"bltest.glb", "bltest.usda", "bltest.tracks.csv"} <= {p.name for p in folder.iterdir()}
    assert len(gltf_bodies("bltest")) == 40  # the glTF is the one imported


def test_unsupported_obstacle_shapes_are_errors_naming_the_objects(scene, beeswarm_bin):
    egg = add_primitive("uv_sphere", "Obstacles", radius=0.2, location=(1.0, 0.0, 1.0))
    egg.name = "egg"
    egg.scale = (1.0, 1.0, 1.6)
    oval = add_primitive("cylinder", "Obstacles", radius=0.1, depth=1.0, location=(-1.0, 0.0, 0.5))
    oval.name = "oval_post"
    oval.scale = (1.0, 2.0, 1.0)
    parent = bpy.data.objects.new("squash", None)
    parent.scale = (1.0, 3.0, 1.0)
    scene.collection.objects.link(parent)
    leaning = add_primitive("cube", "Obstacles", size=0.2, location=(0.0, 1.0, 0.2),
                            rotation=(0.0, 0.0, math.radians(30)))
    leaning.name = "leaning_box"
    leaning.parent = parent
    me = bpy.data.meshes.new("rock")
    me.from_pydata([(0, 0, 0), (1, 0, 0), (0, 2, 0), (0, 0, 0.3), (0.5, 0.5, 0.1)], [], [])
    bpy.data.collections["Obstacles"].objects.link(bpy.data.objects.new("rock", me))
    add_primitive("cube", "Obstacles", size=0.2, location=(0.0, -1.0, 0.2))  # fine
    bpy.context.view_layer.update()
    with pytest.raises(shot_builder.ShotBuildError) as err:
        shot_builder.build_shot(scene, scene.beeswarm)
    msg = str(err.value)
    for name, why in (("egg", "ellipsoid"), ("oval_post", "elliptic cylinder"),
                      ("leaning_box", "sheared"), ("rock", "has no faces")):
        assert f"'{name}'" in msg and why in msg, (name, msg)
    assert "'Cube'" not in msg
    with pytest.raises(RuntimeError, match="egg"):
        bake("USD", beeswarm_bin)
    assert not shot_collections("bltest")


def read_glb(data):
    """(glTF JSON, {node name: (float32 positions (n, 3), triangles (t, 3))}) of a .glb of
    one buffer, every node holding one indexed triangle mesh (what the add-on writes)."""
    import struct
    magic, version, length = struct.unpack_from("<4sII", data)
    assert (magic, version, length) == (b"glTF", 2, len(data))
    jlen, jtype = struct.unpack_from("<I4s", data, 12)
    assert jtype == b"JSON"
    doc = json.loads(data[20:20 + jlen])
    blen, btype = struct.unpack_from("<I4s", data, 20 + jlen)
    assert btype == b"BIN\0"
    blob = data[28 + jlen:28 + jlen + blen]

    def accessor(i, dtype, width):
        a = doc["accessors"][i]
        v = doc["bufferViews"][a["bufferView"]]
        raw = blob[v["byteOffset"]:v["byteOffset"] + v["byteLength"]]
        return np.frombuffer(raw, dtype=dtype).reshape(a["count"] // (3 // width), 3)

    out = {}
    for node in doc["nodes"]:
        assert set(node) == {"name", "mesh"}  # identity transform: vertices are in the world
        (prim,) = doc["meshes"][node["mesh"]]["primitives"]
        out[node["name"]] = (accessor(prim["attributes"]["POSITION"], "<f4", 3),
                             accessor(prim["indices"], "<u4", 1))
    return doc, out


def test_any_mesh_is_an_obstacle_written_beside_the_shot_and_avoided(scene, beeswarm_bin,
                                                                     tmp_path, node_modules):
    """A monkey head (open: avoided as a shell) and a cone (closed: a solid, not the
    cylinder it used to become) are written as two nodes of one .glb beside the shot, in
    world space, Y-up, with their modifiers; the file passes the Khronos validator and the
    bake keeps every bee out of them."""
    from mathutils.bvhtree import BVHTree
    from mathutils.kdtree import KDTree
    bpy.ops.mesh.primitive_monkey_add(size=0.8, location=(0.0, 0.0, 1.0),
                                      rotation=(0.0, 0.0, math.radians(30)))
    monkey = bpy.context.active_object
    monkey.name = "Suzanne"
    monkey.modifiers.new("sub", "SUBSURF").levels = 1
    for c in list(monkey.users_collection):
        c.objects.unlink(monkey)
    bpy.data.collections["Obstacles"].objects.link(monkey)
    bpy.ops.mesh.primitive_cone_add(radius1=0.15, depth=0.5, location=(0.6, 0.3, 0.25))
    cone = bpy.context.active_object
    cone.name = "cone"
    for c in list(cone.users_collection):
        c.objects.unlink(cone)
    bpy.data.collections["Obstacles"].objects.link(cone)
    add_empty("Nest", (0.0, 0.9, 1.0))
    sw = scene.beeswarm.swarms[0]
    sw.spawn_center = (0.0, -0.9, 1.0)
    sw.spawn_size = (0.6, 0.4, 0.6)
    bpy.context.view_layer.update()

    shot, _ = shot_builder.build_shot(scene, scene.beeswarm)
    entries = {o["name"]: o for o in shot["obstacle"]}
    assert entries["Suzanne"] == {"type": "mesh", "name": "Suzanne", "mode": "shell",
                                  "file": "bltest.obstacles.glb", "node": "Suzanne"}
    assert entries["cone"] == {"type": "mesh", "name": "cone", "file": "bltest.obstacles.glb",
                               "node": "cone"}
    assert "_mesh_files" not in tomllib.loads(shot_builder.shot_toml(shot))
    data = shot[shot_builder.MESH_FILES]["bltest.obstacles.glb"]
    # The same scene writes the same bytes.
    assert shot_builder.build_shot(scene, scene.beeswarm)[0][shot_builder.MESH_FILES] == \
        {"bltest.obstacles.glb": data}
    _, nodes = read_glb(data)
    assert set(nodes) == {"Suzanne", "cone"}
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for obj in (monkey, cone):
        verts, faces = nodes[obj.name]
        ev = obj.evaluated_get(depsgraph)
        assert len(verts) == len(ev.data.vertices)
        assert len(faces) == len(ev.data.loop_triangles)
        world = [obj.matrix_world @ v.co for v in ev.data.vertices]
        assert max((blender_from_shot(a) - b).length for a, b in zip(verts, world)) < 1e-5
    assert len(nodes["Suzanne"][0]) > 500  # subdivided: the evaluated mesh
    glb = tmp_path / "obstacles.glb"
    glb.write_bytes(data)
    env = dict(os.environ, BEESWARM_NODE_MODULES=node_modules, NODE_PATH=node_modules)
    run = subprocess.run(["node", str(ROOT / "tests" / "node" / "validate_gltf.mjs"), str(glb)],
                         capture_output=True, text=True, env=env)
    assert run.returncode == 0, run.stderr
    issues = json.loads(run.stdout)["issues"]
    assert issues["numErrors"] == issues["numWarnings"] == 0, issues["messages"][:10]

    assert run_bake(beeswarm_bin, "USD") == {"FINISHED"}
    folder = tmp_path / "beeswarm_cache" / "bltest"
    assert {"bltest.obstacles.glb", "bltest.shot.toml"} <= {p.name for p in folder.iterdir()}
    tracks = read_tracks(folder / "bltest.tracks.csv")
    trees = {o.name: BVHTree.FromObject(o, depsgraph) for o in (monkey, cone)}
    gaps = {name: [] for name in trees}
    for bee in tracks.values():
        for row in bee.values():
            p = blender_from_shot((row["x"], row["y"], row["z"]))
            for name, tree in trees.items():
                # BVHTree works in the object's local space.
                obj = bpy.data.objects[name]
                local = obj.matrix_world.inverted() @ p
                hit = tree.find_nearest(local)
                near = obj.matrix_world @ hit[0]
                # The cone is convex: inside is behind every face.
                inside = name == "cone" and all(
                    (local - f.center).dot(f.normal) < 0 for f in cone.data.polygons)
                gaps[name].append(-(p - near).length if inside else (p - near).length)
    # The monkey is a 1 cm shell: centres stay half of it away; nobody inside the cone.
    assert min(gaps["Suzanne"]) > 0.005 - 1e-4, min(gaps["Suzanne"])
    assert min(gaps["cone"]) > 0.0, min(gaps["cone"])
    # The swarm met the monkey on its way to the nest.
    assert sum(g < 0.1 for g in gaps["Suzanne"]) > 20, sorted(gaps["Suzanne"])[:5]

    # Blender's own glTF importer reads the file back where the objects are.
    bpy.ops.import_scene.gltf(filepath=str(folder / "bltest.obstacles.glb"))
    for obj in (monkey, cone):
        back = bpy.data.objects[obj.name + ".001"]
        ev = obj.evaluated_get(depsgraph)
        assert len(back.data.vertices) == len(ev.data.vertices)
        tree = KDTree(len(ev.data.vertices))
        for k, v in enumerate(ev.data.vertices):
            tree.insert(obj.matrix_world @ v.co, k)
        tree.balance()
        hits = [tree.find(back.matrix_world @ v.co) for v in back.data.vertices]
        assert max(d for _, _, d in hits) < 1e-5
        assert len({k for _, k, _ in hits}) == len(hits)  # one to one


def test_an_animated_mesh_obstacle_moves_in_the_shot_and_is_avoided(scene, beeswarm_bin,
                                                                   tmp_path):
    """A cone keyframed to sweep through the swarm while turning 300° exports its mesh in
    its rest pose (scaled only) and one key per frame; the keys' pose put on the .glb's
    vertices is where Blender has the cone at every frame; and no bee is ever inside it."""
    bpy.ops.mesh.primitive_cone_add(radius1=0.25, depth=0.7, location=(-1.2, 0.0, 1.0))
    cone = bpy.context.active_object
    cone.name = "sweeper"
    for c in list(cone.users_collection):
        c.objects.unlink(cone)
    bpy.data.collections["Obstacles"].objects.link(cone)
    cone.scale = (1.0, 1.5, 1.0)
    cone.keyframe_insert("location", frame=1)
    cone.keyframe_insert("rotation_euler", frame=1)
    cone.location = (1.2, 0.2, 1.1)
    cone.rotation_euler = (math.radians(40), 0.0, math.radians(300))
    cone.keyframe_insert("location", frame=36)
    cone.keyframe_insert("rotation_euler", frame=36)
    scene.frame_set(1)
    sw = scene.beeswarm.swarms[0]
    sw.spawn_center = (0.0, 0.0, 1.0)
    sw.spawn_size = (0.8, 0.8, 0.6)
    add_empty("Nest", (0.0, 0.0, 1.0))
    bpy.context.view_layer.update()

    shot, _ = shot_builder.build_shot(scene, scene.beeswarm)
    entry = {o["name"]: o for o in shot["obstacle"]}["sweeper"]
    assert "position" not in entry and "rotation" not in entry
    keys = entry["keys"]
    assert [k["frame"] for k in keys] == list(range(1, 37))
    # Continuous angles: 300° about Blender's Z (the shot's −Y) is reached going on, not
    # by jumping back through ±180°.
    steps = [max(abs(a - b) for a, b in zip(k0["rotation"], k1["rotation"]))
             for k0, k1 in zip(keys, keys[1:])]
    assert max(steps) < 30.0, steps
    assert abs(keys[-1]["rotation"][1] - (-300.0)) < 1e-3 or \
        abs(keys[-1]["rotation"][1] - 300.0) < 1e-3, keys[-1]
    _, nodes = read_glb(shot[shot_builder.MESH_FILES]["bltest.obstacles.glb"])
    rest, faces = nodes["sweeper"]
    depsgraph = bpy.context.evaluated_depsgraph_get()
    ev = cone.evaluated_get(depsgraph)
    local = [v.co.copy() for v in ev.data.vertices]
    # The rest pose: the local mesh scaled, in the shot's axes.
    scaled = [Vector((v.x * 1.0, v.y * 1.5, v.z * 1.0)) for v in local]
    assert max((blender_from_shot(a) - b).length for a, b in zip(rest, scaled)) < 1e-5
    # The shot's pose at every frame (rotation, Euler XYZ degrees, then position) puts the
    # rest mesh where Blender has the cone.
    for k in keys:
        scene.frame_set(k["frame"])
        rot = Euler([math.radians(a) for a in k["rotation"]], "XYZ").to_matrix()
        worst = max((blender_from_shot(rot @ Vector(a) + Vector(k["position"]))
                     - cone.matrix_world @ v).length for a, v in zip(rest, local))
        assert worst < 1e-4, (k, worst)
    scene.frame_set(1)

    # The shot bakes: the binary takes the keys; no bee is inside the cone at any frame.
    assert run_bake(beeswarm_bin, "USD") == {"FINISHED"}
    folder = tmp_path / "beeswarm_cache" / "bltest"
    written = tomllib.loads((folder / "bltest.shot.toml").read_text())
    back = {o["name"]: o for o in written["obstacle"]}["sweeper"]["keys"]
    assert [k["frame"] for k in back] == [k["frame"] for k in keys]
    assert max(abs(a - b) for k0, k1 in zip(back, keys) for field in ("position", "rotation")
               for a, b in zip(k0[field], k1[field])) < 1e-4
    tracks = read_tracks(folder / "bltest.tracks.csv")
    gaps, met = [], 0
    for f in range(1, 37):
        scene.frame_set(f)
        inv = cone.matrix_world.inverted()
        for bee in tracks.values():
            row = bee[f]
            p = inv @ blender_from_shot((row["x"], row["y"], row["z"]))
            # The cone is convex: inside is behind every face (in its local space, where
            # the sign tells inside from outside).
            worst = max((p - poly.center).dot(poly.normal) for poly in cone.data.polygons)
            gaps.append(worst)
            met += worst < 0.05
    scene.frame_set(1)
    print(f"smallest gap {min(gaps):.4f}, {met} bee-frames within 0.05 of the moving cone")
    assert min(gaps) > 0.0, min(gaps)
    # The cone swept through the swarm: bees were near it.
    assert met > 20, met


def test_binary_errors_name_the_blender_object(scene, beeswarm_bin):
    """A flat sphere passes the add-on but not the binary: its message names the Blender
    object beside the shot key."""
    ball = add_primitive("uv_sphere", "Obstacles", radius=0.2, location=(1.0, 0.0, 1.0))
    ball.name = "ball"
    ball.scale = (0.0, 0.0, 0.0)
    shot_cylinder_scene(scene)
    bpy.context.view_layer.update()
    with pytest.raises(RuntimeError) as err:
        bake("USD", beeswarm_bin)
    msg = str(err.value)
    index = [o["name"] for o in shot_builder.build_shot(scene, scene.beeswarm)[0]["obstacle"]]
    assert f"obstacle[{index.index('ball')}] (Blender object 'ball').radius" in msg, msg
    assert "bltest.shot.toml:" in msg and "Y-up: its [x, y, z] is Blender's (x, −z, y)" in msg
    # The failing shot is kept where the message says (Blender's temp folder), not beside
    # the cache it did not make.
    kept = pathlib.Path(bpy.app.tempdir) / "beeswarm_failed" / "bltest.shot.toml"
    assert f"{kept}:" in msg and 'name = "ball"' in kept.read_text()
    assert not (pathlib.Path(bpy.path.abspath("//beeswarm_cache")) / "bltest").exists()
    from blender_addon import operators
    shot = {"swarm": [{"name": "bees"}], "obstacle": [{"name": "post"}]}
    assert operators.name_blender_objects("key `swarm[0].params.speed`, `obstacle[0].a`, "
                                          "`obstacle[3].b`", shot) == \
        "key `swarm[0] (swarm 'bees').params.speed`, `obstacle[0] (Blender object 'post').a`, " \
        "`obstacle[3].b`"


def test_wing_display_gltf_layout_flap_and_its_limit(scene):
    s = scene.beeswarm
    shot, _ = shot_builder.build_shot(scene, s)
    assert tomllib.loads(shot_builder.shot_toml(shot))["output"] == {
        "wings": "blur", "gltf_layout": "agent"}
    s.wings, s.gltf_layout, s.wing_flap_hz = "FLAP", "PARTS", 6.0
    shot, _ = shot_builder.build_shot(scene, s)
    assert tomllib.loads(shot_builder.shot_toml(shot))["output"] == {
        "wings": "flap", "gltf_layout": "parts", "wing_flap_hz": 6.0}
    s.wing_flap_hz = 13.0  # 24 fps: above 12 Hz it would alias
    with pytest.raises(shot_builder.ShotBuildError, match="above half the frame rate"):
        shot_builder.build_shot(scene, s)


def test_motion_blur_hint_from_the_swarms_speed(scene, with_binary):
    from blender_addon import panel
    sw = scene.beeswarm.swarms[0]
    scene.render.motion_blur_shutter = 0.5
    doc, _ = props.models_doc(bpy.context)
    hint = panel.motion_blur_hint(scene, sw, doc)
    # nest preset: 1 m/s; 0.5 frame at 24 fps: 2.1 cm, 1.7 lengths of a 12 mm bee
    assert "at 1 m/s a bee smears 2.1 cm, 1.7 body lengths" in hint, hint
    assert "0.1 gives 0.4 cm" in hint
    sw.overrides.add().param = "speed"
    sw.overrides[0].value = 2.0
    assert "at 2 m/s a bee smears 4.2 cm" in panel.motion_blur_hint(scene, sw, doc)
    text = " ".join(t for kind, t in draw_panel(bpy.context) if kind == "label")
    assert "Motion blur" in text and "Shutter" in text


def test_undo_restores_the_swarm_before_a_bake(scene, beeswarm_bin):
    """The bake is one undo step (as a button press makes it; a script asks with undo=True).
    glTF keeps its animation in the .blend, so undo brings the previous swarm back whole."""
    shot_cylinder_scene(scene)
    bpy.ops.ed.undo_push(message="before the first bake")

    def bake_with_undo():
        return bpy.ops.beeswarm.bake("EXEC_DEFAULT", True, format="GLTF", binary_path=beeswarm_bin)
    assert bake_with_undo() == {"FINISHED"}
    first = gltf_positions("bltest", 20)
    scene.beeswarm.seed = 7
    assert bake_with_undo() == {"FINISHED"}
    second = gltf_positions("bltest", 20)
    assert max((first[b] - second[b]).length for b in first) > 1e-3
    assert bpy.ops.ed.undo() == {"FINISHED"}  # the second bake
    assert len(shot_collections("bltest")) == 1
    back = gltf_positions("bltest", 20)
    assert max((first[b] - back[b]).length for b in first) < 1e-6
    assert bpy.context.scene.beeswarm.seed == 1
    assert bpy.ops.ed.undo() == {"FINISHED"}  # the first bake
    assert not shot_collections("bltest")
    assert bpy.ops.ed.redo() == {"FINISHED"}
    assert len(shot_collections("bltest")) == 1


def drawn_instances(ob, frame=None):
    """{persistent id: DepsgraphObjectInstance matrix, object name} of the prototype roots
    the viewport depsgraph draws for an instancer."""
    if frame is not None:
        bpy.context.scene.frame_set(frame)
    dg = bpy.context.evaluated_depsgraph_get()
    return {i.persistent_id[1]: (i.matrix_world.copy(), i.object.original.name)
            for i in dg.object_instances
            if i.is_instance and i.parent and i.parent.original == ob
            and i.object.original.parent is None}


def test_display_percentage_in_the_viewport_only(scene, beeswarm_bin):
    s = scene.beeswarm
    s.swarms[0].count = 200
    assert run_bake(beeswarm_bin, "USD") == {"FINISHED"}
    inst = usd_instancer("bltest")
    assert len(drawn_instances(inst, 5)) == 200
    s.display_percent = 25
    drawn = drawn_instances(inst, 5)
    assert 25 <= len(drawn) <= 75, len(drawn)  # a random quarter of 200
    assert drawn.keys() == drawn_instances(inst, 20).keys()  # the same bees all along
    mod = inst.modifiers[display.DISPLAY_MODIFIER]
    assert mod.show_viewport and not mod.show_render  # renders draw every bee
    s.display_percent = 100
    assert len(drawn_instances(inst, 5)) == 200
    # Points in Viewport: no instances drawn, a point per bee; renders keep the bees.
    s.viewport_points = True
    assert not drawn_instances(inst, 5)
    dg = bpy.context.evaluated_depsgraph_get()
    assert len(inst.evaluated_get(dg).data.points) == 200
    s.display_percent = 50
    assert 60 <= len(inst.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.points) <= 140
    assert all(m.show_render for m in inst.modifiers if m.name != display.DISPLAY_MODIFIER)
    s.viewport_points = False
    s.display_percent = 100
    assert len(drawn_instances(inst, 5)) == 200

    s.display_percent = 30
    scene.beeswarm.seed = 3
    assert run_bake(beeswarm_bin, "GLTF") == {"FINISHED"}  # a new import takes the setting
    bodies = gltf_bodies("bltest")
    hidden = {b for b, o in bodies.items() if o.hide_viewport}
    assert hidden == {b for b in bodies if not display.shown(b, 30)}
    assert 0 < len(hidden) < len(bodies) and not any(o.hide_render for o in bodies.values())


def test_points_in_viewport_leave_out_the_bees_inside_a_hive(scene, beeswarm_bin, tmp_path):
    """A USD hive cache (examples/hive_traffic.toml): Blender's instancing skips the bees
    inside (invisibleIds → its `mask` attribute), and so do the viewport's points."""
    subprocess.run([beeswarm_bin, "bake", str(ROOT / "examples" / "hive_traffic.toml"), "--out",
                    str(tmp_path), "--format", "usda,csv", "--frames", "1:48", "--progress", "none"],
                   check=True, capture_output=True)
    importer.import_cache(bpy.context, "hive_traffic", str(tmp_path / "hive_traffic.usda"), "USD",
                          24, (1, 48))
    inst = usd_instancer("hive_traffic")
    display.apply(scene, [inst])
    tracks = read_tracks(tmp_path / "hive_traffic.tracks.csv")
    outside = {f: sum(1 for rows in tracks.values() if rows[f]["state"] != 3.0) for f in (1, 24, 48)}
    assert len(set(outside.values())) > 1 and max(outside.values()) < len(tracks)
    for f, n in outside.items():
        assert len(drawn_instances(inst, f)) == n, f"frame {f}"
    scene.beeswarm.viewport_points = True
    for f, n in outside.items():
        scene.frame_set(f)
        dg = bpy.context.evaluated_depsgraph_get()
        assert len(inst.evaluated_get(dg).data.points) == n, f"frame {f}"
    scene.beeswarm.viewport_points = False


def test_a_scene_object_as_the_insect_asset(scene, beeswarm_bin, tmp_path):
    """The asset (modelled facing +X, +Z up) is drawn on every bee, turned into the bee's
    body frame: its +X along the body's forward axis, its +Z along the body's up."""
    bpy.ops.mesh.primitive_cone_add(radius1=0.003, depth=0.012, location=(5.0, 5.0, 5.0))
    wasp = bpy.context.active_object
    wasp.name = "wasp"
    scene.beeswarm.asset = wasp
    assert run_bake(beeswarm_bin, "USD") == {"FINISHED"}
    inst = usd_instancer("bltest")
    drawn = drawn_instances(inst, 12)
    assert len(drawn) == 40 and {name for _, name in drawn.values()} == {"wasp"}
    tracks = read_tracks(tmp_path / "beeswarm_cache" / "bltest" / "bltest.tracks.csv")
    for bee, (m, _) in drawn.items():
        row = tracks[bee][12]
        q = Quaternion((row["qw"], row["qx"], row["qy"], row["qz"]))  # body → world, shot axes
        assert (m.translation - blender_from_shot([row["x"], row["y"], row["z"]])).length < TOL
        rot = m.to_3x3().normalized()
        forward = blender_from_shot(q @ Vector((1, 0, 0)))
        up = blender_from_shot(q @ Vector((0, 1, 0)))
        assert (rot @ Vector((1, 0, 0)) - forward).length < 1e-3, bee
        assert (rot @ Vector((0, 0, 1)) - up).length < 1e-3, bee
    # glTF keeps its own bees, and says so.
    r = bake("GLTF", beeswarm_bin)
    assert r == {"FINISHED"} and gltf_bodies("bltest")


# ---------------------------------------------------------------------------------------
# Model and preset menus, from `beeswarm models --json`

@pytest.fixture
def with_binary(monkeypatch, beeswarm_bin):
    """The add-on finds the real binary (as on PATH), with a fresh models cache."""
    monkeypatch.setattr(binary, "discover", lambda *a, **k: pathlib.Path(beeswarm_bin))
    monkeypatch.setattr(binary, "_models_cache", {})
    return beeswarm_bin


def names(items):
    return [i[0] for i in items]


def test_model_and_preset_menus_come_from_the_binary(scene, with_binary):
    s = scene.beeswarm.swarms[0]
    assert names(props.model_items(s, bpy.context)) == \
        ["bee", "curl", "brownian", "boids", "field", "fastswarm", "zonal",
         "butterfly"]
    expected = json.loads(subprocess.run([with_binary, "models", "--json"], capture_output=True,
                                         text=True, check=True).stdout)
    for m in expected["models"]:
        s.model = m["name"]
        # Each model's own presets, then a preset file; switching starts at its default.
        assert names(props.preset_items(s, bpy.context)) == \
            [p["name"] for p in m["presets"]] + ["FILE"]
        assert s.preset == m["presets"][0]["name"]
    s.model = "bee"
    s.preset = "grassland"
    log = draw_panel(bpy.context)
    assert ("prop", "model") in log and ("prop", "preset") in log
    text = " ".join(t for kind, t in log if kind == "label")
    assert "Paper 000" in text, text


def test_a_curl_swarm_built_from_the_scene_passes_check_and_bakes(scene, with_binary, tmp_path):
    shot_cylinder_scene(scene)
    s = scene.beeswarm.swarms[0]
    s.model = "curl"
    assert s.preset == "default"
    shot, _ = shot_builder.build_shot(scene, scene.beeswarm)
    assert (shot["swarm"][0]["model"], shot["swarm"][0]["preset"]) == ("curl", "default")
    path = tmp_path / "curl.shot.toml"
    path.write_text(shot_builder.shot_toml(shot, "test"))
    r = subprocess.run([with_binary, "check", str(path)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "model curl, preset default" in r.stdout
    assert run_bake(with_binary, "USD") == {"FINISHED"}
    assert len(shot_collections("bltest")) == 1


def test_model_menu_falls_back_to_the_bee_model_and_says_why(scene, tmp_path, monkeypatch):
    monkeypatch.setattr(binary, "_models_cache", {})
    doc, reason = binary.models(str(tmp_path / "missing" / "beeswarm"))
    assert names(props.model_items(scene.beeswarm.swarms[0], bpy.context)) and doc is binary.FALLBACK_MODELS
    assert "No beeswarm binary" in reason
    # A binary without the `models` subcommand (an older build): the bee model, and why.
    old = tmp_path / "old" / binary.EXE
    old.parent.mkdir()
    old.write_text("#!/bin/sh\necho \"error: unrecognized subcommand 'models'\" >&2\nexit 2\n")
    old.chmod(0o755)
    doc, reason = binary.models(str(old))
    assert [m["name"] for m in doc["models"]] == ["bee"]
    assert "could not list its models" in reason and "unrecognized subcommand" in reason


def test_models_are_asked_once_per_binary(with_binary, monkeypatch):
    calls = []
    real = subprocess.run
    monkeypatch.setattr(binary.subprocess, "run", lambda *a, **k: calls.append(a) or real(*a, **k))
    for _ in range(5):
        doc, reason = binary.models(with_binary)
        assert reason == "" and len(doc["models"]) == 8
    assert len(calls) == 1, "the menu callbacks run on every redraw: one query per binary"


# ---------------------------------------------------------------------------------------
# Failures: an error in Blender's UI, nothing imported

def previous_swarm_intact(name, before):
    after = sorted(o.name for o in bpy.data.objects if o.get(importer.SHOT_TAG) == name)
    assert after == before
    assert not [c for c in bpy.data.collections if c.name.endswith(".importing")]


def test_missing_binary_reports_and_imports_nothing(scene, tmp_path):
    shot_cylinder_scene(scene)
    with pytest.raises(RuntimeError, match="No beeswarm binary"):
        bake("USD", str(tmp_path / "no" / "beeswarm"))
    assert not shot_collections("bltest")
    assert not [o for o in bpy.data.objects if o.get(importer.SHOT_TAG)]


def test_count_zero_is_an_error(scene, beeswarm_bin):
    shot_cylinder_scene(scene)
    scene.beeswarm.swarms[0].count = 0
    with pytest.raises(RuntimeError, match="at least 1 bee"):
        bake("USD", beeswarm_bin)
    assert not shot_collections("bltest")
    assert scene.beeswarm.last_message.startswith("Error")


def test_failing_bake_shows_the_binarys_message(scene, beeswarm_bin, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[scene]\nname = "bad"\n\n[[swarm]]\ncount = 10\nspeling = 3\n')
    frames = (scene.frame_start, scene.frame_end, scene.render.fps)
    with pytest.raises(RuntimeError) as err:
        bake("USD", beeswarm_bin, shot_path=str(bad))
    msg = str(err.value)
    assert "Bake failed" in msg and "bad.toml:6" in msg and "speling" in msg
    assert not shot_collections("bad")
    assert (scene.frame_start, scene.frame_end, scene.render.fps) == frames


def test_cancel_kills_the_bake_and_keeps_the_previous_cache(beeswarm_bin, tmp_path):
    shot = tmp_path / "long.shot.toml"
    shot.write_text('[scene]\nname = "long"\nframes = [1, 100000]\n\n[[swarm]]\ncount = 2000\n'
                    '\n[output]\nformats = ["csv"]\n')
    out = tmp_path / "out"
    first = runner.BakeProcess([beeswarm_bin, "bake", str(shot), "--out", str(out),
                                "--progress", "json", "--frames", "1:3"])
    while first.wait_event(30)[0] != "exit":
        pass
    assert first.returncode == 0, first.stderr
    cache = out / "long.tracks.csv"
    before = cache.read_bytes()
    # A long bake, cancelled after its first progress line: --allow-large, because the
    # disk check would otherwise refuse it on a machine with under ~33 GB free.
    p = runner.BakeProcess([beeswarm_bin, "bake", str(shot), "--out", str(out), "--progress", "json",
                            "--allow-large"])
    ev = p.wait_event(30)
    assert ev and ev[0] == "progress", (ev, p.stderr)
    assert 0.0 <= runner.fraction(ev[1]) < 1.0
    t = time.monotonic()
    p.cancel()
    assert time.monotonic() - t < 5
    assert p.returncode != 0 and p.cancelled
    assert cache.read_bytes() == before
    assert sorted(x.name for x in out.iterdir() if not x.name.startswith(".")) == [
        "long.beeswarm.json", "long.tracks.csv"]


# ---------------------------------------------------------------------------------------
# Bake and import

def usd_instancer(name):
    coll = bpy.data.collections[name]
    pcs = [o for o in coll.all_objects if o.type == "POINTCLOUD"]
    assert len(pcs) == 1, [o.name for o in coll.all_objects]
    return pcs[0]


# Blender 4.4 (the oldest the manifest claims) has no Python access to instance attributes
# (Object.evaluated_geometry() is newer). There a last, temporary modifier turns the
# instances into points (Instances to Points carries their attributes over) whose evaluated
# point cloud Python can read.
HAS_GEOMETRY_SET = hasattr(bpy.types.Object, "evaluated_geometry")
PROBE_MODIFIER = "beeswarm test: instances to points"


def expose_instances(obs):
    if HAS_GEOMETRY_SET:
        return
    ng = bpy.data.node_groups.get(PROBE_MODIFIER)
    if ng is None:
        ng = bpy.data.node_groups.new(PROBE_MODIFIER, "GeometryNodeTree")
        ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
        gin, gout = ng.nodes.new("NodeGroupInput"), ng.nodes.new("NodeGroupOutput")
        to_points = ng.nodes.new("GeometryNodeInstancesToPoints")
        ng.links.new(gin.outputs[0], to_points.inputs["Instances"])
        ng.links.new(to_points.outputs["Points"], gout.inputs[0])
    for ob in obs:
        if PROBE_MODIFIER not in ob.modifiers:
            ob.modifiers.new(PROBE_MODIFIER, "NODES").node_group = ng


def read_instances(ob_eval, depsgraph):
    """(ids, velocities [n, 3], {id: Blender world position}) of an evaluated instancer
    (after expose_instances)."""
    if HAS_GEOMETRY_SET:
        geometry_set = ob_eval.evaluated_geometry()  # keeps the geometry alive
        geo = geometry_set.instances_pointcloud()
    else:
        geo = ob_eval.data
    n = len(geo.points)
    ids = np.zeros(n, np.int32)
    geo.attributes["id"].data.foreach_get("value", ids)
    vel = np.zeros(n * 3, np.float32)
    geo.attributes["velocity"].data.foreach_get("vector", vel)
    positions = {}
    if HAS_GEOMETRY_SET:
        # From the depsgraph (the instances' own "position" attribute is a virtual one that
        # reads back unreliably): the prototype's root object (no parent) once per
        # instance. Its persistent id is the instance's `id` attribute: the bee's id.
        for i in depsgraph.object_instances:
            if i.is_instance and i.parent and i.parent.original == ob_eval.original and \
                    i.object.original.parent is None:
                positions[i.persistent_id[1]] = i.matrix_world.translation.copy()
    else:
        pos = np.zeros(n * 3, np.float32)
        geo.attributes["position"].data.foreach_get("vector", pos)
        for bee, p in zip(ids, pos.reshape(n, 3)):
            positions[int(bee)] = ob_eval.matrix_world @ Vector(p)
    assert sorted(positions) == sorted(int(b) for b in ids)
    return ids, vel.reshape(n, 3), positions


def usd_instances(name, frame):
    """{bee id: (Blender world position, instance velocity attr)} at a frame."""
    inst = usd_instancer(name)
    expose_instances([inst])
    sc = bpy.context.scene
    sc.frame_set(frame)
    dg = bpy.context.evaluated_depsgraph_get()
    ids, vel, positions = read_instances(inst.evaluated_get(dg), dg)
    return {int(b): (positions[int(b)], v) for b, v in zip(ids, vel)}


def check_swarm_against_csv(name, count, get_positions, tracks, frames):
    bee = sorted(tracks)[count // 2]
    for f in frames:
        pos = get_positions(f)
        assert len(pos) == count
        want = blender_from_shot([tracks[bee][f][k] for k in ("x", "y", "z")])
        got = pos[bee][0] if isinstance(pos[bee], tuple) else pos[bee]
        assert (got - want).length < TOL, (f, bee, got, want)


def no_bee_inside(cyl, tracks, radius=0.08, depth=1.6):
    inv = cyl.matrix_world.inverted()
    worst = math.inf
    for rows in tracks.values():
        for r in rows.values():
            local = inv @ blender_from_shot((r["x"], r["y"], r["z"]))
            radial = math.hypot(local.x, local.y)
            depth_in = min(radius - radial, depth / 2 - abs(local.z))
            worst = min(worst, -depth_in)  # >0: outside
    return worst


def test_usd_bake_imports_the_swarm_once_and_rebakes_in_place(scene, beeswarm_bin, tmp_path):
    cyl = shot_cylinder_scene(scene)
    scene.render.fps = 30
    scene.frame_start, scene.frame_end = 5, 40
    t0 = time.monotonic()
    assert run_bake(beeswarm_bin, "USD") == {"FINISHED"}
    print(f"USD bake + import: {time.monotonic() - t0:.2f} s")
    cache_dir = tmp_path / "beeswarm_cache" / "bltest"
    assert (cache_dir / "bltest.shot.toml").is_file() and (cache_dir / "bltest.usda").is_file()
    assert not (tmp_path / "bltest.shot.toml").exists()
    assert sorted(p.name for p in cache_dir.parent.iterdir()) == ["bltest"]  # no staging left
    assert len(shot_collections("bltest")) == 1 and "bltest" in bpy.data.collections
    assert (scene.render.fps, scene.render.fps_base) == (30, 1.0)
    assert (scene.frame_start, scene.frame_end) == (5, 40)
    tracks = read_tracks(cache_dir / "bltest.tracks.csv")
    assert len(tracks) == 40
    check_swarm_against_csv("bltest", 40, lambda f: usd_instances("bltest", f), tracks, (5, 22, 40))
    assert no_bee_inside(cyl, tracks) > 0.0

    # id and velocity on the instances equal the tracks (instancer-local = shot axes).
    at = usd_instances("bltest", 22)
    assert sorted(at) == sorted(tracks)
    for bee, (_, v) in at.items():
        row = tracks[bee][22]
        assert np.allclose(v, [row["vx"], row["vy"], row["vz"]], atol=1e-5)

    first = {b: p.copy() for b, (p, _) in usd_instances("bltest", 30).items()}
    n_objects = len(bpy.data.objects)
    scene.beeswarm.seed = 2
    assert run_bake(beeswarm_bin, "USD") == {"FINISHED"}
    assert len(shot_collections("bltest")) == 1 and "bltest" in bpy.data.collections
    assert len(bpy.data.objects) == n_objects
    assert not [o for o in bpy.data.objects if o.name.startswith("~old")]
    tracks2 = read_tracks(cache_dir / "bltest.tracks.csv")
    second = usd_instances("bltest", 30)
    assert max((first[b] - second[b][0]).length for b in first) > 1e-3
    check_swarm_against_csv("bltest", 40, lambda f: usd_instances("bltest", f), tracks2, (5, 30))
    assert no_bee_inside(cyl, tracks2) > 0.0


GLTF_BODY = re.compile(r"^bee_(\d+)_body$")
GLTF_AGENT = re.compile(r"^bee_(\d+)$")


def gltf_bodies(name):
    """{bee id: object} for the imported glTF bees: the object whose world transform is the
    simulated pose (its world position is the tracks CSV position). In the parts layout that
    is `bee_<id>_body`, the child of the path node `bee_<id>`; in the agent layout (the
    add-on's default) the one node `bee_<id>`."""
    objects = bpy.data.collections[name].all_objects
    for pattern in (GLTF_BODY, GLTF_AGENT):
        out = {int(m.group(1)): o for o in objects if (m := pattern.match(o.name))}
        if out:
            return out
    return {}


def gltf_positions(name, frame):
    bpy.context.scene.frame_set(frame)
    return {bee: o.matrix_world.translation.copy() for bee, o in gltf_bodies(name).items()}


def test_gltf_bake_imports_the_swarm_once(scene, beeswarm_bin, tmp_path):
    cyl = shot_cylinder_scene(scene)
    scene.frame_start, scene.frame_end = 3, 30
    t0 = time.monotonic()
    assert run_bake(beeswarm_bin, "GLTF") == {"FINISHED"}
    print(f"glTF bake + import: {time.monotonic() - t0:.2f} s")
    cache_dir = tmp_path / "beeswarm_cache" / "bltest"
    assert (cache_dir / "bltest.glb").is_file()
    assert len(shot_collections("bltest")) == 1
    assert (scene.render.fps, scene.frame_start, scene.frame_end) == (24, 3, 30)
    tracks = read_tracks(cache_dir / "bltest.tracks.csv")
    assert sorted(gltf_bodies("bltest")) == sorted(tracks)
    check_swarm_against_csv("bltest", 40, lambda f: gltf_positions("bltest", f), tracks, (3, 17, 30))
    assert no_bee_inside(cyl, tracks) > 0.0

    first = gltf_positions("bltest", 20)
    n_objects = len(bpy.data.objects)
    scene.beeswarm.seed = 5
    assert run_bake(beeswarm_bin, "GLTF") == {"FINISHED"}
    assert len(shot_collections("bltest")) == 1 and len(bpy.data.objects) == n_objects
    assert not [o for o in bpy.data.objects if o.name.startswith("~old") or ".00" in o.name]
    tracks2 = read_tracks(cache_dir / "bltest.tracks.csv")
    second = gltf_positions("bltest", 20)
    assert max((first[b] - second[b]).length for b in first) > 1e-3
    check_swarm_against_csv("bltest", 40, lambda f: gltf_positions("bltest", f), tracks2, (3, 30))


NTSC_GLTF = """
[scene]
name = "ntsc"
fps = 23.976
frames = [7, 30]
seed = 3

[[swarm]]
name = "bees"
count = 12
preset = "nest"
spawn = { shape = "box", center = [0.0, 1.0, 0.0], size = [0.4, 0.4, 0.4] }

[output]
gltf_layout = "parts"
"""


def test_gltf_import_plays_strips_at_the_shots_frames_and_rate(scene, beeswarm_bin, tmp_path):
    """A shot at 23.976 fps starting at frame 7, parts layout: every bee plays the NLA strip
    the importer made (no active action, no key moved), starting at the shot's first frame
    at the shot's rate, and the hooks gave the action its frame range (constant-time
    stashing). A glTF imported by hand afterwards is the importer's own business."""
    shot = tmp_path / "shots" / "ntsc.toml"
    shot.parent.mkdir()
    shot.write_text(NTSC_GLTF)
    assert run_bake(beeswarm_bin, "GLTF", shot_path=str(shot)) == {"FINISHED"}
    assert (scene.render.fps, scene.frame_start, scene.frame_end) == (24, 7, 30)
    assert abs(scene.render.fps / scene.render.fps_base - 23.976) < 1e-6
    cache = tmp_path / "beeswarm_cache" / "ntsc"
    tracks = read_tracks(cache / "ntsc.tracks.csv")
    check_swarm_against_csv("ntsc", 12, lambda f: gltf_positions("ntsc", f), tracks, (7, 8, 19, 30))
    animated = [o for o in bpy.data.collections["ntsc"].all_objects if o.animation_data]
    assert len(animated) >= 12
    for o in animated:
        ad = o.animation_data
        assert ad.action is None and len(ad.nla_tracks) == 1
        track = ad.nla_tracks[0]
        assert not track.mute and len(track.strips) == 1
        assert track.strips[0].frame_start == 7.0
    actions = [a for a in bpy.data.actions if a.get(importer.SHOT_TAG) == "ntsc"]
    assert len(actions) == 1 and actions[0].use_frame_range
    assert tuple(actions[0].frame_range) == pytest.approx((0.0, 23.0), abs=1e-3)
    # Keys stay where the importer put them (glTF time x rate), none moved by the add-on.
    keys = {round(k.co.x, 3) for layer in actions[0].layers for strip in layer.strips
            for bag in strip.channelbags for fc in bag.fcurves for k in fc.keyframe_points}
    assert min(keys) == 0.0 and max(keys) == pytest.approx(23.0, abs=1e-3)

    # The user's own glTF import, the add-on enabled: an active action as usual, no range.
    bpy.ops.import_scene.gltf(filepath=str(cache / "ntsc.glb"))
    mine = bpy.context.selected_objects
    assert mine and all(o.get(importer.SHOT_TAG) is None for o in mine)
    own = [o for o in mine if o.animation_data]
    assert own and all(o.animation_data.action is not None for o in own)
    assert not own[0].animation_data.action.use_frame_range


# ---------------------------------------------------------------------------------------
# The panel (drawn into a recording stand-in for UILayout: headless Blender has no UI)

class RecordingLayout:
    def __init__(self, log):
        self.log = log
        self.alert = False
        self.enabled = True
        self.scale_y = 1.0

    def _child(self, *a, **k):
        return RecordingLayout(self.log)

    row = column = box = split = _child

    def label(self, text="", icon="NONE"):
        self.log.append(("label", text))

    def prop(self, data, prop, **kw):
        assert prop in data.bl_rna.properties, prop
        self.log.append(("prop", prop))

    def template_list(self, list_type, list_id, data, prop, active_data, active_prop, **kw):
        assert prop in data.bl_rna.properties and active_prop in active_data.bl_rna.properties
        self.log.append(("list", list_type))

    def operator(self, idname, **kw):
        self.log.append(("operator", idname))

        class Props:
            pass
        return Props()


def draw_panel(context):
    from blender_addon import panel
    log = []
    holder = type("Holder", (), {"layout": RecordingLayout(log)})()
    panel.BEESWARM_PT_panel.draw(holder, context)
    return log


def test_panel_draws_settings_and_says_when_no_binary(scene, monkeypatch, beeswarm_bin):
    monkeypatch.setattr(binary, "discover", lambda *a, **k: None)
    log = draw_panel(bpy.context)
    text = " ".join(t for kind, t in log if kind == "label")
    assert "No beeswarm binary found" in text
    props_shown = {t for kind, t in log if kind == "prop"}
    assert {"count", "preset", "seed", "obstacles", "targets", "formats"} <= props_shown
    assert ("operator", "beeswarm.bake") in log
    assert ("operator", "beeswarm.write_wedge") in log
    monkeypatch.setattr(binary, "discover", lambda *a, **k: pathlib.Path(beeswarm_bin))
    scene.beeswarm.source = "FILE"
    log = draw_panel(bpy.context)
    assert "No beeswarm binary" not in " ".join(t for kind, t in log if kind == "label")
    assert ("prop", "shot_file") in log and ("prop", "count") not in log


# ---------------------------------------------------------------------------------------
# As an installed extension

def test_manifest_validates_with_blenders_extension_tool():
    tool = pathlib.Path(bpy.utils.system_resource("SCRIPTS")) / "addons_core" / "bl_pkg" / \
        "cli" / "blender_ext.py"
    if not tool.is_file():
        pytest.skip(f"{tool} is not in this bpy build")
    r = subprocess.run([sys.executable, str(tool), "validate", str(ROOT / "blender_addon")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    manifest = tomllib.loads((ROOT / "blender_addon" / "blender_manifest.toml").read_text())
    assert manifest["id"] == "beeswarm" and manifest["schema_version"] == "1.0.0"
    # 4.4: Blender 4.2 and 4.3 import a PointInstancer without its animation (docs/blender.md).
    assert manifest["blender_version_min"] == "4.4.0"


ENABLE_AS_EXTENSION = r'''
import os, sys, bpy
ext = bpy.utils.user_resource("EXTENSIONS", path="user_default", create=True)
os.symlink(sys.argv[-2], os.path.join(ext, "beeswarm"))
assert bpy.ops.preferences.addon_enable(module="bl_ext.user_default.beeswarm") == {"FINISHED"}
prefs = bpy.context.preferences.addons["bl_ext.user_default.beeswarm"].preferences
prefs.binary_path = sys.argv[-1]
try:
    bpy.ops.beeswarm.bake()
except RuntimeError as e:
    print("REPORTED:", e)
'''


def test_enables_as_an_extension_and_reads_its_preference(tmp_path):
    missing = tmp_path / "not-here" / "beeswarm"
    r = subprocess.run(
        [sys.executable, "-c", ENABLE_AS_EXTENSION, str(ROOT / "blender_addon"), str(missing)],
        capture_output=True, text=True, timeout=120,
        env={**os.environ, "BLENDER_USER_RESOURCES": str(tmp_path / "res")})
    assert r.returncode == 0, r.stdout + r.stderr
    assert f"REPORTED: Error: No beeswarm binary at {missing}" in r.stdout


INSTALL_ZIP_AND_BAKE = r'''
import os, pathlib, shutil, sys, bpy
zip_path, workdir = sys.argv[-2:]
assert shutil.which("beeswarm") is None, "the test needs a PATH without beeswarm"
assert bpy.ops.extensions.package_install_files(
    filepath=zip_path, repo="user_default", enable_on_install=True) == {"FINISHED"}
module = "bl_ext.user_default.beeswarm"
assert module in bpy.context.preferences.addons, list(bpy.context.preferences.addons.keys())
binary = sys.modules[module + ".binary"]
print("BINARY:", binary.resolve("")[0])
sc = bpy.context.scene
sc.frame_start, sc.frame_end = 1, 12
sc.beeswarm.shot_name = "installed"
assert bpy.ops.beeswarm.swarm_add() == {"FINISHED"}
sc.beeswarm.swarms[0].count = 20
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(workdir, "scene.blend"))
assert bpy.ops.beeswarm.bake(format="USD") == {"FINISHED"}
sc.frame_set(6)
dg = bpy.context.evaluated_depsgraph_get()
clouds = [o for o in bpy.data.collections["installed"].all_objects if o.type == "POINTCLOUD"]
# One prototype root (no parent) per drawn bee.
print("POINTS:", [len({tuple(i.persistent_id) for i in dg.object_instances
                       if i.is_instance and i.parent and i.parent.original == o
                       and i.object.original.parent is None}) for o in clouds])
print("MESSAGE:", sc.beeswarm.last_message)
'''


@pytest.fixture(scope="module")
def extension_zip(beeswarm_bin, tmp_path_factory):
    """The extension zip scripts/build-extension makes from the binary under test, packed
    with this bpy's own extension tool."""
    out = tmp_path_factory.mktemp("extension")
    r = subprocess.run([str(ROOT / "scripts" / "build-extension"), "--binary", beeswarm_bin,
                        "--out", str(out)], capture_output=True, text=True, timeout=300,
                       env={**os.environ, "BEESWARM_BPY_PYTHON": sys.executable, "BLENDER": ""})
    assert r.returncode == 0, r.stdout + r.stderr
    zips = list(out.glob("*.zip"))
    assert [z.name for z in zips] == [r.stdout.strip().splitlines()[-1].rsplit("/", 1)[-1]]
    return zips[0]


def test_extension_zip_holds_the_binary_for_this_platform(extension_zip):
    import zipfile
    with zipfile.ZipFile(extension_zip) as z:
        manifest = tomllib.loads(z.read("blender_manifest.toml").decode())
        names = set(z.namelist())
    assert manifest["platforms"] == [PLATFORM] and extension_zip.name.endswith(
        PLATFORM.replace("-", "_") + ".zip")
    assert f"bin/{binary.EXE}" in names and "__init__.py" in names
    assert not [n for n in names if "__pycache__" in n]


def test_installed_zip_bakes_with_its_bundled_binary(extension_zip, tmp_path):
    """Install from Disk, as a user would (extensions.package_install_files), in a Blender
    whose PATH has no beeswarm: the first bake works with the binary inside the zip."""
    work = tmp_path / "work"
    work.mkdir()
    r = subprocess.run(
        [sys.executable, "-c", INSTALL_ZIP_AND_BAKE, str(extension_zip), str(work)],
        capture_output=True, text=True, timeout=300,
        env={**os.environ, "BLENDER_USER_RESOURCES": str(tmp_path / "res"),
             "PATH": "/usr/bin:/bin"})
    assert r.returncode == 0, r.stdout + r.stderr
    installed = tmp_path / "res" / "extensions" / "user_default" / "beeswarm" / "bin" / binary.EXE
    assert f"BINARY: {installed}" in r.stdout, r.stdout
    assert "POINTS: [20]" in r.stdout, r.stdout + r.stderr
    assert "MESSAGE: Baked installed" in r.stdout
    assert (work / "beeswarm_cache" / "installed" / "installed.usda").is_file()


# ---------------------------------------------------------------------------------------
# Failures after a good start (a stand-in binary: tests/python/blender_fake_beeswarm.py)

@pytest.fixture
def fake_bin(tmp_path):
    script = pathlib.Path(__file__).with_name("blender_fake_beeswarm.py")
    wrapper = tmp_path / "fakebin" / "beeswarm"
    wrapper.parent.mkdir()
    wrapper.write_text(f'#!/bin/sh\nexec "{sys.executable}" "{script}" "$@"\n')
    wrapper.chmod(0o755)
    return str(wrapper)


def test_failed_or_unreadable_rebake_keeps_the_previous_swarm(scene, fake_bin, monkeypatch):
    shot_cylinder_scene(scene)
    monkeypatch.setenv("BEESWARM_FAKE_MODE", "ok")
    assert bake("USD", fake_bin) == {"FINISHED"}
    before = sorted(o.name for o in bpy.data.objects if o.get(importer.SHOT_TAG) == "bltest")
    assert before and len(shot_collections("bltest")) == 1
    n_ids = {a: len(getattr(bpy.data, a)) for a in ("objects", "meshes", "node_groups",
                                                    "collections", "cache_files", "pointclouds")}
    scene.beeswarm.seed = 9
    monkeypatch.setenv("BEESWARM_FAKE_MODE", "fail")
    with pytest.raises(RuntimeError, match="simulation diverged"):
        bake("USD", fake_bin)
    previous_swarm_intact("bltest", before)

    # A bake that exits 0 with a file Blender cannot read: the import is rolled back.
    scene.frame_end = 20
    monkeypatch.setenv("BEESWARM_FAKE_MODE", "corrupt")
    for fmt in ("USD", "GLTF"):
        with pytest.raises(RuntimeError, match="Import of bltest"):
            bake(fmt, fake_bin)
        previous_swarm_intact("bltest", before)
        assert {a: len(getattr(bpy.data, a)) for a in n_ids} == n_ids
        assert len(shot_collections("bltest")) == 1
        assert (scene.frame_start, scene.frame_end) == (1, 20)  # the scene's own, restored


class ProbeEngine(bpy.types.RenderEngine):
    """A render engine that renders nothing and records what a renderer would see of the
    swarm: the render depsgraph's instances at the frame and at the motion-blur sub-frame
    (the way Cycles steps through the shutter)."""
    bl_idname = "BEESWARM_PROBE"
    bl_label = "beeswarm probe"
    seen = {}

    def _look(self, depsgraph, key):
        for ob in depsgraph.objects:
            if ob.type == "POINTCLOUD":
                ids, v, pos = read_instances(ob, depsgraph)
                ProbeEngine.seen[key] = (ids, v, {b: tuple(p) for b, p in pos.items()})

    def render(self, depsgraph):
        f = depsgraph.scene.frame_current
        self._look(depsgraph, float(f))
        self.frame_set(f, 0.5)
        self._look(depsgraph, f + 0.5)
        self.frame_set(f, 0.0)
        r = self.begin_result(0, 0, 4, 4)
        self.end_result(r)


def test_render_depsgraph_has_ids_and_velocities_at_subframes(scene, fake_bin):
    scene.beeswarm.swarms[0].count = 12
    assert bake("USD", fake_bin) == {"FINISHED"}
    tracks = read_tracks(pathlib.Path(bpy.path.abspath("//beeswarm_cache/bltest/bltest.tracks.csv")))
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    expose_instances([o for o in bpy.data.collections["bltest"].all_objects
                      if o.type == "POINTCLOUD"])
    bpy.utils.register_class(ProbeEngine)
    try:
        scene.render.engine = ProbeEngine.bl_idname
        scene.render.resolution_x = scene.render.resolution_y = 4
        ProbeEngine.seen.clear()
        scene.frame_set(7)
        bpy.ops.render.render()
    finally:
        bpy.utils.unregister_class(ProbeEngine)
    for key in (7.0, 7.5):
        ids, vel, pos = ProbeEngine.seen[key]
        assert sorted(ids) == sorted(tracks) == sorted(pos)
        for k, bee in enumerate(ids):
            a, b = tracks[int(bee)][7], tracks[int(bee)][8]
            t = key - 7
            want_v = [(1 - t) * a[c] + t * b[c] for c in ("vx", "vy", "vz")]
            want_p = blender_from_shot([(1 - t) * a[c] + t * b[c] for c in ("x", "y", "z")])
            assert np.allclose(vel[k], want_v, atol=1e-5)
            assert (Vector(pos[int(bee)]) - want_p).length < TOL


def test_never_overwrites_a_shot_file_it_did_not_write(scene, fake_bin, tmp_path):
    mine = tmp_path / "beeswarm_cache" / "bltest" / "bltest.shot.toml"
    mine.parent.mkdir(parents=True)
    mine.write_text("# my hand-made shot\n[scene]\nname = \"bltest\"\n")
    with pytest.raises(RuntimeError, match="not written by the add-on"):
        bake("USD", fake_bin)
    assert mine.read_text().startswith("# my hand-made shot")
    mine.unlink()
    assert bake("USD", fake_bin) == {"FINISHED"}
    assert bake("USD", fake_bin) == {"FINISHED"}  # its own file: rewritten
    assert mine.read_text().startswith(shot_builder.HEADER_MARK)


def cache_state(folder):
    """{file name: bytes} of a cache folder and whatever sits beside it."""
    return {str(p.relative_to(folder.parent)): p.read_bytes()
            for p in sorted(folder.parent.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("mode", ["fail", "partial"])
def test_failed_bake_leaves_the_shot_and_the_cache_as_they_were(scene, fake_bin, tmp_path,
                                                                monkeypatch, mode):
    """The shot TOML lives in the cache folder and is replaced with the cache, only when a
    bake succeeds: a failing bake (even one that wrote an output first) changes neither."""
    shot_cylinder_scene(scene)
    assert bake("USD", fake_bin) == {"FINISHED"}
    folder = tmp_path / "beeswarm_cache" / "bltest"
    before = cache_state(folder)
    assert "count = 40" in (folder / "bltest.shot.toml").read_text()
    scene.beeswarm.swarms[0].count = 900
    monkeypatch.setenv("BEESWARM_FAKE_MODE", mode)
    with pytest.raises(RuntimeError, match="Bake failed"):
        bake("USD", fake_bin)
    assert cache_state(folder) == before
    monkeypatch.setenv("BEESWARM_FAKE_MODE", "ok")
    scene.beeswarm.swarms[0].count = 12
    assert bake("USD", fake_bin) == {"FINISHED"}
    assert "count = 12" in (folder / "bltest.shot.toml").read_text()
    assert len(read_tracks(folder / "bltest.tracks.csv")) == 12


def test_unsaved_file_bakes_into_blenders_temp_directory(fake_bin, tmp_path):
    """An unsaved file has no folder: its shot and cache go to a folder in Blender's own
    temporary directory for this session, not a /tmp folder every Blender shares."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert not bpy.data.filepath
    sc = bpy.context.scene
    sc.frame_start, sc.frame_end = 1, 12
    sc.beeswarm.shot_name = "unsaved"
    props.add_swarm(sc.beeswarm).count = 5
    assert bake("USD", fake_bin) == {"FINISHED"}
    folder = pathlib.Path(bpy.app.tempdir) / "beeswarm_unsaved" / "beeswarm_cache" / "unsaved"
    assert sorted(p.name for p in folder.iterdir()) == [
        "unsaved.bees.velocity.npy", "unsaved.shot.toml", "unsaved.tracks.csv", "unsaved.usda"]
    assert str(folder / "unsaved.usda") in sc.beeswarm.last_message


# ---------------------------------------------------------------------------------------
# The modal path, driven by hand: headless Blender has no event loop, so the operator's
# own invoke-side state is set up here and its modal() fed timer and Esc events.

class FakeWM:
    def __init__(self):
        self.progress = []
        self.timers = 0

    def progress_begin(self, a, b):
        self.progress.append(("begin", a, b))

    def progress_update(self, v):
        self.progress.append(v)

    def progress_end(self):
        self.progress.append("end")

    def event_timer_remove(self, timer):
        self.timers -= 1


class FakeWorkspace:
    def __init__(self):
        self.status = []

    def status_text_set(self, text):
        self.status.append(text)


def modal_operator(job):
    from blender_addon import operators
    op_type = operators.BEESWARM_OT_bake
    reports = []

    class Op:
        _job = job
        _timer = object()
        modal = op_type.modal
        _end_modal = op_type._end_modal
        _complete = op_type._complete
        _status = op_type._status
        _fail = op_type._fail

        def report(self, kind, msg):
            reports.append((set(kind), msg))
    return Op(), reports


def start_modal(context, binary_path, fmt="USD", shot_path=""):
    from blender_addon import operators
    props = type("Props", (), {"format": fmt, "binary_path": binary_path, "shot_path": shot_path,
                               "also_formats": set()})()
    job = operators.Job(context, props)
    job.start()
    operators._active["job"] = job
    return job


def Event(kind, value="NOTHING"):
    return type("Event", (), {"type": kind, "value": value})()


def drive(op, ctx, until, limit=60.0):
    t = time.monotonic()
    while time.monotonic() - t < limit:
        r = op.modal(ctx, Event("TIMER"))
        if r != {"RUNNING_MODAL"} or until():
            return r
        time.sleep(0.05)
    raise AssertionError("the modal bake did not finish")


def test_modal_bake_reports_progress_and_imports(scene, fake_bin):
    wm, ws = FakeWM(), FakeWorkspace()
    ctx = type("Ctx", (), {"scene": scene, "window_manager": wm, "workspace": ws,
                           "view_layer": bpy.context.view_layer})()
    job = start_modal(bpy.context, fake_bin)
    op, reports = modal_operator(job)
    assert op.modal(ctx, Event("MOUSEMOVE")) == {"PASS_THROUGH"}
    assert drive(op, ctx, until=lambda: False) == {"FINISHED"}
    assert any(isinstance(p, float) and 0 < p <= 100 for p in wm.progress)
    assert wm.progress[-1] == "end" and ws.status[-1] is None
    assert any(s and "frame" in s and "Esc" in s for s in ws.status)
    assert len(shot_collections("bltest")) == 1
    assert reports[-1][0] == {"INFO"}


def test_esc_cancels_the_modal_bake_imports_nothing(scene, fake_bin, monkeypatch):
    from blender_addon import operators
    assert bake("USD", fake_bin) == {"FINISHED"}
    before = sorted(o.name for o in bpy.data.objects if o.get(importer.SHOT_TAG) == "bltest")
    cache = pathlib.Path(bpy.path.abspath("//beeswarm_cache/bltest/bltest.usda"))
    before_files = cache_state(cache.parent)
    monkeypatch.setenv("BEESWARM_FAKE_MODE", "slow")
    scene.beeswarm.seed = 4
    wm, ws = FakeWM(), FakeWorkspace()
    ctx = type("Ctx", (), {"scene": scene, "window_manager": wm, "workspace": ws,
                           "view_layer": bpy.context.view_layer})()
    job = start_modal(bpy.context, fake_bin, "USD")
    op, reports = modal_operator(job)
    assert drive(op, ctx, until=lambda: any(isinstance(p, float) for p in wm.progress)) \
        == {"RUNNING_MODAL"}, job.process.stderr
    t = time.monotonic()
    assert op.modal(ctx, Event("ESC", "PRESS")) == {"CANCELLED"}
    assert time.monotonic() - t < 5
    assert job.process.returncode is not None and job.process.returncode != 0
    assert operators._active["job"] is None and wm.progress[-1] == "end"
    assert reports[-1][0] == {"WARNING"} and "cancelled" in reports[-1][1]
    previous_swarm_intact("bltest", before)
    assert cache_state(cache.parent) == before_files  # the shot (seed 1) and the cache


TWO_SWARMS = """
[scene]
name = "two"
fps = 25
frames = [1, 30]

[[swarm]]
name = "near"
count = 15
spawn = { shape = "box", center = [0.0, 1.0, 0.0], size = [0.5, 0.5, 0.5] }

[[swarm]]
name = "far"
count = 25
preset = "grassland"
spawn = { shape = "sphere", center = [3.0, 1.0, 0.0], radius = 0.4 }

[[obstacle]]
type = "box"
center = [1.5, 1.0, 0.0]
size = [0.2, 2.0, 0.2]
rotation = [0, 45, 0]
"""


def test_shot_file_with_two_swarms(scene, beeswarm_bin, tmp_path):
    """A shot file (not the scene) with two swarms: its fps and range win, and each
    instancer gets its own bees' ids and velocities."""
    shot = tmp_path / "shots" / "two.toml"
    shot.parent.mkdir()
    shot.write_text(TWO_SWARMS)
    assert run_bake(beeswarm_bin, "USD", shot_path=str(shot)) == {"FINISHED"}
    assert (scene.render.fps, scene.frame_start, scene.frame_end) == (25, 1, 30)
    tracks = read_tracks(tmp_path / "beeswarm_cache" / "two" / "two.tracks.csv")
    coll = bpy.data.collections["two"]
    instancers = {o.name: o for o in coll.all_objects if o.type == "POINTCLOUD"}
    assert sorted(instancers) == ["far", "near"]
    expose_instances(instancers.values())
    scene.frame_set(12)
    dg = bpy.context.evaluated_depsgraph_get()
    seen = {}
    for name, ob in instancers.items():
        ids, vel, _ = read_instances(ob.evaluated_get(dg), dg)
        seen[name] = len(ids)
        for bee, v in zip(ids, vel):
            row = tracks[int(bee)][12]
            assert np.allclose(v, [row["vx"], row["vy"], row["vz"]], atol=1e-5)
    assert seen == {"near": 15, "far": 25}


def test_wedge_operator_writes_the_scenes_wedge_and_a_variant_bakes(scene, with_binary, tmp_path):
    """Wedge…: the scene's shot as a wedge (variants, OpenJD job); any variant then bakes
    and imports like any shot file."""
    out = tmp_path / "wedge"
    assert bpy.ops.beeswarm.write_wedge(vary="seed=1..2 swarm.0.count=10,20",
                                        out_dir=str(out)) == {"FINISHED"}
    assert (tmp_path / "bltest.shot.toml").is_file()
    variants = sorted(p.name for p in (out / "variants").iterdir())
    assert variants == [f"bltest_{k}.toml" for k in range(1, 5)]
    assert "jobtemplate-2023-09" in (out / "job.yaml").read_text()
    assert "count = 20" in (out / "variants" / "bltest_4.toml").read_text()
    assert "openjd run" in scene.beeswarm.last_message
    assert run_bake(with_binary, "USD", shot_path=str(out / "variants" / "bltest_4.toml")) == {"FINISHED"}
    tracks = read_tracks(tmp_path / "beeswarm_cache" / "bltest_4" / "bltest_4.tracks.csv")
    assert len(tracks) == 20
    # A bad variant is refused with the binary's located message; nothing new is written.
    with pytest.raises(RuntimeError, match="swarm"):
        bpy.ops.beeswarm.write_wedge(vary="swarm.nobody.count=3", out_dir=str(tmp_path / "bad"))
    assert scene.beeswarm.last_message.startswith("Error")
    assert not (tmp_path / "bad").exists()


def test_write_shot_file_operator(scene, beeswarm_bin, tmp_path):
    shot_cylinder_scene(scene)
    assert bpy.ops.beeswarm.write_shot() == {"FINISHED"}
    path = tmp_path / "bltest.shot.toml"
    r = subprocess.run([beeswarm_bin, "check", str(path)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert 'shot "bltest": ok' in r.stdout and "40 bees" in r.stdout
    other = tmp_path / "theirs.toml"
    other.write_text("[scene]\n")
    with pytest.raises(RuntimeError, match="not written by the add-on"):
        bpy.ops.beeswarm.write_shot(filepath=str(other))
    assert other.read_text() == "[scene]\n"


def test_no_obstacles_and_no_collections_is_fine(scene, beeswarm_bin, tmp_path):
    scene.beeswarm.obstacles = None
    scene.beeswarm.targets = None
    shot, warnings = shot_builder.build_shot(scene, scene.beeswarm)
    assert "obstacle" not in shot and "target" not in shot and not warnings
    path = tmp_path / "bare.shot.toml"
    path.write_text(shot_builder.shot_toml(shot))
    r = subprocess.run([beeswarm_bin, "check", str(path)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
