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
from mathutils import Euler, Vector  # noqa: E402

from conftest import ROOT, read_tracks  # noqa: E402

sys.path.insert(0, str(ROOT))
import blender_addon  # noqa: E402
from blender_addon import binary, importer, props, runner, shot_builder  # noqa: E402

TOL = 1e-4  # metres


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
    s.count = 40
    s.seed = 1
    s.spawn_center = (0.0, 0.0, 1.0)
    s.spawn_size = (0.8, 0.8, 0.8)
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
    scene.beeswarm.spawn_object = spawn
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
    s = scene.beeswarm
    assert names(props.model_items(s, bpy.context)) == ["bee", "curl", "brownian", "boids"]
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
    s = scene.beeswarm
    s.model = "curl"
    assert s.preset == "default"
    shot, _ = shot_builder.build_shot(scene, s)
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
    assert names(props.model_items(scene.beeswarm, bpy.context)) and doc is binary.FALLBACK_MODELS
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
        assert reason == "" and len(doc["models"]) == 4
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
    scene.beeswarm.count = 0
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
    p = runner.BakeProcess([beeswarm_bin, "bake", str(shot), "--out", str(out), "--progress", "json"])
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


def usd_instances(name, frame):
    """{bee id: (Blender world position, instance velocity attr)} at a frame."""
    sc = bpy.context.scene
    sc.frame_set(frame)
    dg = bpy.context.evaluated_depsgraph_get()
    inst = usd_instancer(name)
    geometry_set = inst.evaluated_get(dg).evaluated_geometry()  # keeps geo alive
    geo = geometry_set.instances_pointcloud()
    n = len(geo.points)
    ids = np.zeros(n, np.int32)
    geo.attributes["id"].data.foreach_get("value", ids)
    vel = np.zeros(n * 3, np.float32)
    geo.attributes["velocity"].data.foreach_get("vector", vel)
    vel = vel.reshape(n, 3)
    # Instance positions from the depsgraph (the instances' own "position" attribute is a
    # virtual one that reads back unreliably): the prototype's root object (no parent) once
    # per instance. Its persistent id is the instance's `id` attribute: the bee's id.
    positions = {}
    for i in dg.object_instances:
        if i.is_instance and i.parent and i.parent.original == inst and \
                i.object.original.parent is None:
            positions[i.persistent_id[1]] = i.matrix_world.translation.copy()
    assert sorted(positions) == sorted(int(b) for b in ids)
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
    assert (tmp_path / "bltest.shot.toml").is_file()
    cache_dir = tmp_path / "beeswarm_cache" / "bltest"
    assert (cache_dir / "bltest.usda").is_file()
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


def gltf_bodies(name):
    """{bee id: object} for the imported glTF bees. The writer makes one node per bee,
    `bee_<id>` (the path), with a child `bee_<id>_body` whose world transform is the
    simulated pose: its world position is the tracks CSV position."""
    out = {}
    for o in bpy.data.collections[name].all_objects:
        m = GLTF_BODY.match(o.name)
        if m:
            out[int(m.group(1))] = o
    return out


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
    assert {"count", "preset", "seed", "obstacles", "targets", "format"} <= props_shown
    assert ("operator", "beeswarm.bake") in log
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
    assert manifest["blender_version_min"] == "4.2.0"


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
                gs = ob.evaluated_geometry()
                ip = gs.instances_pointcloud()
                n = len(ip.points)
                v = np.zeros(n * 3, np.float32)
                ip.attributes["velocity"].data.foreach_get("vector", v)
                ids = np.zeros(n, np.int32)
                ip.attributes["id"].data.foreach_get("value", ids)
                # The prototype's root object, once per bee, by persistent id (= bee id).
                pos = {i.persistent_id[1]: tuple(i.matrix_world.translation)
                       for i in depsgraph.object_instances
                       if i.is_instance and i.parent and i.parent.name == ob.name
                       and i.object.original.parent is None}
                ProbeEngine.seen[key] = (ids, v.reshape(n, 3), pos)

    def render(self, depsgraph):
        f = depsgraph.scene.frame_current
        self._look(depsgraph, float(f))
        self.frame_set(f, 0.5)
        self._look(depsgraph, f + 0.5)
        self.frame_set(f, 0.0)
        r = self.begin_result(0, 0, 4, 4)
        self.end_result(r)


def test_render_depsgraph_has_ids_and_velocities_at_subframes(scene, fake_bin):
    scene.beeswarm.count = 12
    assert bake("USD", fake_bin) == {"FINISHED"}
    tracks = read_tracks(pathlib.Path(bpy.path.abspath("//beeswarm_cache/bltest/bltest.tracks.csv")))
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(cam)
    scene.camera = cam
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
    mine = tmp_path / "bltest.shot.toml"
    mine.write_text("# my hand-made shot\n[scene]\nname = \"bltest\"\n")
    with pytest.raises(RuntimeError, match="not written by the add-on"):
        bake("USD", fake_bin)
    assert mine.read_text().startswith("# my hand-made shot")
    mine.unlink()
    assert bake("USD", fake_bin) == {"FINISHED"}
    assert bake("USD", fake_bin) == {"FINISHED"}  # its own file: rewritten
    assert mine.read_text().startswith(shot_builder.HEADER_MARK)


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
    props = type("Props", (), {"format": fmt, "binary_path": binary_path, "shot_path": shot_path})()
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
    cached = cache.read_bytes()
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
    assert cache.read_bytes() == cached


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
    scene.frame_set(12)
    dg = bpy.context.evaluated_depsgraph_get()
    seen = {}
    for name, ob in instancers.items():
        gs = ob.evaluated_get(dg).evaluated_geometry()
        ip = gs.instances_pointcloud()
        n = len(ip.points)
        ids = np.zeros(n, np.int32)
        ip.attributes["id"].data.foreach_get("value", ids)
        vel = np.zeros(n * 3, np.float32)
        ip.attributes["velocity"].data.foreach_get("vector", vel)
        seen[name] = n
        for bee, v in zip(ids, vel.reshape(n, 3)):
            row = tracks[int(bee)][12]
            assert np.allclose(v, [row["vx"], row["vy"], row["vz"]], atol=1e-5)
    assert seen == {"near": 15, "far": 25}


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
