"""Paper 004's butterflies in the caches: a real bake of one butterfly checked by the Khronos
glTF validator and usd-core's validators, and imported into Blender, where the wings must
turn between frames by the recorded angles.

glTF keys start at 0 s, so shot frame f is Blender frame f - start.
"""
import json
import math
import os
import subprocess
import sys
import textwrap

import pytest

from conftest import bake, read_tracks
from test_gltf import VALIDATE, _missing

SHOT = textwrap.dedent(
    """\
    [scene]
    name = "butterfly_test"
    fps = 30
    frames = [1, 31]
    substeps = 8
    seed = 4

    [[swarm]]
    name = "monarchs"
    count = 2
    model = "butterfly"
    spawn = { shape = "box", center = [0, 1.5, 0], size = [0.3, 0.3, 0.3] }
    bee = { length = 0.025, radius = 0.005 }

    [[target]]
    type = "attractor"
    position = [1, 2, 0]

    [output]
    formats = ["gltf", "usda", "csv"]
    """
)


@pytest.fixture(scope="module")
def baked(beeswarm_bin, tmp_path_factory):
    out = tmp_path_factory.mktemp("butterfly")
    bake(beeswarm_bin, SHOT, out)
    return {
        "gltf": out / "butterfly_test.gltf",
        "usda": out / "butterfly_test.usda",
        "csv": out / "butterfly_test.tracks.csv",
    }


def test_khronos_validator_finds_nothing(baked, node_modules):
    env = dict(os.environ, BEESWARM_NODE_MODULES=node_modules, NODE_PATH=node_modules)
    run = subprocess.run(["node", str(VALIDATE), str(baked["gltf"])], capture_output=True,
                         text=True, env=env)
    assert run.returncode == 0, run.stderr
    issues = json.loads(run.stdout)["issues"]
    summary = json.dumps(issues["messages"][:20], indent=1)
    assert (issues["numErrors"], issues["numWarnings"], issues["numInfos"]) == (0, 0, 0), summary


def test_usd_validators_pass_and_every_angle_is_a_primvar(baked):
    pxr = pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom, UsdValidation

    stage = Usd.Stage.Open(str(baked["usda"]))
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    assert UsdValidation.ValidationContext(validators).Validate(stage) == []
    inst = next(p for p in stage.Traverse() if p.IsA(UsdGeom.PointInstancer))
    api = UsdGeom.PrimvarsAPI(inst)
    tracks = read_tracks(baked["csv"])
    for name in ["thorax_pitch", "flap", "feather", "sweep", "abdomen", "flap_hz"]:
        pv = api.GetPrimvar(name)
        assert pv, name
        got = pv.Get(11)
        assert got[0] == pytest.approx(tracks[0][11][name], abs=1e-3), name


def test_usd_prototype_per_frame_is_the_flap_bin_and_extent_holds_the_wings(baked):
    """protoIndices is time-sampled: at every frame each butterfly's index is the bin of its
    flap primvar, and the bin's prototype poses the wings there; the instancer's extent
    holds every butterfly with its posed wings (what USD computes from the prototypes)."""
    pytest.importorskip("pxr")
    import numpy as np
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(baked["usda"]))
    inst = next(p for p in stage.Traverse() if p.IsA(UsdGeom.PointInstancer))
    pi = UsdGeom.PointInstancer(inst)
    assert pi.GetProtoIndicesAttr().GetNumTimeSamples() == 31
    targets = pi.GetPrototypesRel().GetTargets()
    assert [t.name for t in targets] == [f"butterfly_{k}" for k in range(19)]
    flap = UsdGeom.PrimvarsAPI(inst).GetPrimvar("flap")
    abdomen = UsdGeom.PrimvarsAPI(inst).GetPrimvar("abdomen")
    seen = set()
    in_bin = {}
    for t in range(1, 32):
        indices = list(pi.GetProtoIndicesAttr().Get(t))
        assert indices == [flap_bin(a) for a in flap.Get(t)], t
        seen.update(indices)
        for k, a in zip(indices, abdomen.Get(t)):
            in_bin.setdefault(k, []).append(a)
        lo, hi = (np.array(v) for v in pi.GetExtentAttr().Get(t))
        exact_lo, exact_hi = (np.array(v) for v in pi.ComputeExtentAtTime(t, t))
        assert np.all(lo <= exact_lo + 1e-6) and np.all(hi >= exact_hi - 1e-6), t
    assert len(seen) >= 4, seen
    # Bin k turns the right forewing by -(k*10 - 90) degrees about X (tip up), the left by +.
    for k in (0, 7, 18):
        proto = stage.GetPrimAtPath(targets[k])
        right = proto.GetChild("forewing_r").GetAttribute("xformOp:rotateX").Get()
        left = proto.GetChild("forewing_l").GetAttribute("xformOp:rotateX").Get()
        assert (left, right) == (k * 10 - 90, 90 - k * 10), k
    # The abdomen (turned about -Z) in each bin's prototype: the mean of the recorded
    # abdomen angle over every (butterfly, frame) of the bin.
    for k in range(19):
        turn = stage.GetPrimAtPath(targets[k]).GetChild("abdomen").GetAttribute("xformOp:rotateZ").Get()
        values = in_bin.get(k, [0.0])
        assert -turn == pytest.approx(sum(values) / len(values), abs=1e-4), k


BLENDER = r"""
import json, math, sys
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
# The shot's 30 fps, so that Blender's frames are the shot's (the importer keys seconds).
bpy.context.scene.render.fps = 30
bpy.ops.import_scene.gltf(filepath=sys.argv[1])
out = {}
for f in json.loads(sys.argv[2]):
    bpy.context.scene.frame_set(f)
    row = {}
    for o in bpy.data.objects:
        if o.name.startswith("butterfly_000000_"):
            part = o.name[len("butterfly_000000_"):]
            q = o.matrix_local.to_quaternion()
            row[part] = [q.w, q.x, q.y, q.z]
            row[part + "_world"] = [list(r) for r in o.matrix_world]
    out[f] = row
print("RESULT " + json.dumps(out))
"""


def angle_deg(q):
    return math.degrees(2.0 * math.acos(min(1.0, abs(q[0]))))


def test_blender_turns_the_wings_by_the_recorded_angles(baked):
    import importlib.util

    if importlib.util.find_spec("bpy") is None:
        _missing("bpy (Blender as a Python module)")
    frames = list(range(0, 31, 3))
    run = subprocess.run([sys.executable, "-c", BLENDER, str(baked["gltf"]), json.dumps(frames)],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-4000:]
    line = next(l for l in run.stdout.splitlines() if l.startswith("RESULT "))
    got = json.loads(line[len("RESULT "):])
    tracks = read_tracks(baked["csv"])
    for f in frames:
        row, rec = got[str(f)], tracks[0][f + 1]
        # Each joint turns by its channel's angle about its axis (the angle of the node's
        # local rotation is the channel's magnitude).
        for part, channel in [("forewing_r_flap", "flap"), ("forewing_l_flap", "flap"),
                              ("hindwing_r", "flap"), ("forewing_r", "feather"),
                              ("forewing_r_sweep", "sweep"), ("abdomen", "abdomen")]:
            assert angle_deg(row[part]) == pytest.approx(abs(rec[channel]), abs=0.05), (f, part)
    # The wings move between frames in the world too.
    worlds = [got[str(f)]["forewing_r_world"] for f in frames]
    moved = [max(abs(a - b) for ra, rb in zip(w0, w1) for a, b in zip(ra[:3], rb[:3]))
             for w0, w1 in zip(worlds, worlds[1:])]
    assert min(moved) > 0.01, moved
    flaps = [tracks[0][f + 1]["flap"] for f in frames]
    assert max(flaps) - min(flaps) > 20.0, flaps


BLENDER_USD = r"""
import json, math, sys
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.context.scene.render.fps = 30
bpy.ops.wm.usd_import(filepath=sys.argv[1])
out = {}
for f in json.loads(sys.argv[2]):
    bpy.context.scene.frame_set(f)
    dg = bpy.context.evaluated_depsgraph_get()
    row = {}
    for i in dg.object_instances:
        if not i.is_instance:
            continue
        bee = str(i.persistent_id[1])
        name = i.object.original.name.split(".")[0]
        entry = row.setdefault(bee, {})
        if name.startswith("butterfly_"):
            entry["prototype"] = name
        elif name in ("body", "forewing_r"):
            entry[name] = i.matrix_world.copy()
    for entry in row.values():
        # The right forewing's turn relative to the body, degrees.
        rel = entry.pop("body").inverted() @ entry.pop("forewing_r")
        entry["turn"] = math.degrees(rel.to_3x3().normalized().to_quaternion().angle)
    out[f] = row
print("RESULT " + json.dumps(out))
"""


def flap_bin(deg):
    """The prototype bin of a flap angle: 10° bins from -90° (src/export/wings.rs)."""
    return min(18, max(0, math.floor((deg + 90.0) / 10.0 + 0.5)))


def test_blender_usd_import_flaps_the_wings_by_the_recorded_angle(baked):
    """The USD PointInstancer picks, per butterfly and frame, the prototype posed at its
    recorded flap angle (time-sampled protoIndices): in Blender the drawn prototype and the
    forewing's turn relative to the body follow the CSV's flap channel."""
    import importlib.util

    if importlib.util.find_spec("bpy") is None:
        _missing("bpy (Blender as a Python module)")
    frames = list(range(1, 32, 2))
    run = subprocess.run([sys.executable, "-c", BLENDER_USD, str(baked["usda"]),
                          json.dumps(frames)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-4000:]
    line = next(l for l in run.stdout.splitlines() if l.startswith("RESULT "))
    got = json.loads(line[len("RESULT "):])
    tracks = read_tracks(baked["csv"])
    turns = []
    for f in frames:
        for bee in (0, 1):
            drawn, rec = got[str(f)][str(bee)], tracks[bee][f]
            # USD time codes are the shot's frames: Blender frame f is shot frame f.
            assert drawn["prototype"] == f"butterfly_{flap_bin(rec['flap'])}", (f, bee, rec["flap"])
        # The right forewing's turn relative to the body is the bin's flap angle.
        turn = got[str(f)]["0"]["turn"]
        assert turn == pytest.approx(abs(flap_bin(tracks[0][f]["flap"]) * 10.0 - 90.0), abs=0.1)
        turns.append(turn)
    # The wings really move between frames of the imported scene.
    assert max(turns) - min(turns) > 20.0, turns
    assert len({got[str(f)]["0"]["prototype"] for f in frames}) >= 4

