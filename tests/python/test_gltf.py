"""glTF cache: a real bake checked by the Khronos validator and by Blender's importer.

The bake writes glb, gltf(+bin) and the tracks CSV from one simulation, so the CSV is the
ground truth the glTF is compared against.
"""
import json
import os
import pathlib
import re
import struct
import subprocess
import sys
import textwrap

import pytest

from conftest import bake, read_tracks

ROOT = pathlib.Path(__file__).resolve().parents[2]
VALIDATE = ROOT / "tests" / "node" / "validate_gltf.mjs"

FPS = 24
FRAMES = (1, 48)
BEES = 12

SHOT = textwrap.dedent(
    f"""\
    [scene]
    name = "gltf_test"
    fps = {FPS}
    frames = [{FRAMES[0]}, {FRAMES[1]}]
    substeps = 4
    seed = 7

    [[swarm]]
    name = "bees"
    count = {BEES}
    preset = "nest"
    spawn = {{ shape = "box", center = [0.0, 1.0, 0.6], size = [0.6, 0.4, 0.4] }}

    [[target]]
    type = "nest"
    name = "hive_entrance"
    position = [0.0, 1.0, 0.0]

    [output]
    formats = ["glb"]
    wing_flap_hz = @FLAP@
    gltf_layout = "@LAYOUT@"
    """
)

BEE_NODE = re.compile(r"bee_\d+")


def _missing(what):
    if os.environ.get("BEESWARM_REQUIRE_TOOLS") == "1":
        pytest.fail(f"{what} is required here (BEESWARM_REQUIRE_TOOLS=1) but missing")
    pytest.skip(f"{what} is not available")


def shot_text(flap, layout="parts"):
    return SHOT.replace("@FLAP@", str(flap)).replace("@LAYOUT@", layout)


@pytest.fixture(scope="module", params=[(6, "parts"), (0, "parts"), (6, "agent"), (0, "agent")],
                ids=["flap6hz", "blurred", "agent-flap6hz", "agent-blurred"])
def baked(request, beeswarm_bin, tmp_path_factory):
    """One bake per wing mode and layout: {format: path}."""
    flap, layout = request.param
    out = tmp_path_factory.mktemp(f"gltf_flap{flap}_{layout}")
    bake(beeswarm_bin, shot_text(flap, layout), out, "--format", "glb,gltf,csv")
    files = {
        "glb": out / "gltf_test.glb",
        "gltf": out / "gltf_test.gltf",
        "bin": out / "gltf_test.bin",
        "csv": out / "gltf_test.tracks.csv",
    }
    files["dir"] = out
    files["flap"] = flap
    files["layout"] = layout
    return files


def load_json(path):
    """The glTF JSON of a .gltf or .glb file."""
    data = pathlib.Path(path).read_bytes()
    if data[:4] == b"glTF":
        magic, version, length, json_len, kind = struct.unpack_from("<4sIII4s", data)
        assert (version, length, kind) == (2, len(data), b"JSON")
        return json.loads(data[20 : 20 + json_len])
    return json.loads(data)


def test_bake_writes_the_files_and_nothing_else(baked):
    for key in ("glb", "gltf", "bin", "csv"):
        assert baked[key].is_file(), key
    leftovers = [p.name for p in baked["dir"].iterdir() if p.name.startswith(".")]
    assert leftovers == [], "temporary or scratch files left behind"


@pytest.mark.parametrize("fmt", ["glb", "gltf"])
def test_khronos_validator_finds_no_errors_or_warnings(baked, fmt, node_modules):
    env = dict(os.environ, BEESWARM_NODE_MODULES=node_modules, NODE_PATH=node_modules)
    run = subprocess.run(
        ["node", str(VALIDATE), str(baked[fmt])], capture_output=True, text=True, env=env
    )
    assert run.returncode == 0, run.stderr
    report = json.loads(run.stdout)
    issues = report["issues"]
    summary = json.dumps(issues["messages"][:20], indent=1)
    assert issues["numErrors"] == 0, summary
    assert issues["numWarnings"] == 0, summary
    # Infos are allowed by the brief; this writer produces none, keep it that way.
    assert issues["numInfos"] == 0, summary
    assert report["info"]["animationCount"] == 1


def test_document_matches_the_tracks(baked):
    doc = load_json(baked["glb"])
    tracks = read_tracks(baked["csv"])
    bees = [n for n in doc["nodes"] if BEE_NODE.fullmatch(n.get("name", ""))]
    assert len(bees) == len(tracks) == BEES
    assert sorted(int(n["name"][4:]) for n in bees) == sorted(tracks)
    assert [doc["nodes"][i]["name"] for i in doc["scenes"][0]["nodes"]] == ["bees"]
    extras = doc["asset"]["extras"]
    assert extras["fps"] == FPS
    assert (extras["frame_start"], extras["frame_end"]) == FRAMES
    assert extras["shot_name"] == "gltf_test"
    assert extras["seed"] == 7
    assert doc["asset"]["generator"] == f"beeswarm {extras['tool_version']}"
    assert doc["scenes"][0]["extras"] == extras
    anim = doc["animations"][0]
    inputs = {s["input"] for s in anim["samplers"]}
    assert len(inputs) == 1, "one shared time accessor"
    time = doc["accessors"][inputs.pop()]
    assert time["count"] == FRAMES[1] - FRAMES[0] + 1
    assert time["min"] == [0.0]
    assert abs(time["max"][0] - (FRAMES[1] - FRAMES[0]) / FPS) < 1e-6
    wing_tracks = sum(
        1 for c in anim["channels"] if doc["nodes"][c["target"]["node"]]["name"].endswith(("_wing_l", "_wing_r"))
    )
    assert wing_tracks == (2 * BEES if baked["flap"] else 0)
    animated = {c["target"]["node"] for c in anim["channels"]}
    per_bee = 1 + (2 if baked["flap"] else 0) if baked["layout"] == "agent" else (4 if baked["flap"] else 2)
    assert len(animated) == per_bee * BEES
    # The .gltf is the same document with an external buffer.
    gltf = load_json(baked["gltf"])
    assert gltf["buffers"][0]["uri"] == "gltf_test.bin"
    assert gltf["buffers"][0]["byteLength"] == baked["bin"].stat().st_size
    del gltf["buffers"][0]["uri"]
    assert gltf == doc


BLENDER_SCRIPT = r"""
import json, re, sys
import bpy

path, fps, frames = sys.argv[1], float(sys.argv[2]), json.loads(sys.argv[3])
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
# glTF has no frame rate: the importer converts key times with the scene's, so set it from
# the file's extras first (an integer rate here; fps_base covers 23.976 and the like).
scene.render.fps = round(fps)
scene.render.fps_base = round(fps) / fps
bpy.ops.import_scene.gltf(filepath=path)
out = {
    "fps": scene.render.fps / scene.render.fps_base,
    "scene_extras": {k: scene[k] for k in ("fps", "frame_start", "frame_end") if k in scene},
    "bees": sorted(o.name for o in bpy.data.objects if re.fullmatch(r"bee_\d+", o.name)),
}
key_frames = sorted({round(k.co.x, 6) for a in bpy.data.actions for fc in a.fcurves for k in fc.keyframe_points}) \
    if hasattr(bpy.types.Action, "fcurves") else None
if key_frames is None:
    # Blender 4.4+ keeps F-curves in slotted channel bags.
    key_frames = sorted({
        round(k.co.x, 6)
        for a in bpy.data.actions for layer in a.layers for strip in layer.strips
        for bag in strip.channelbags for fc in bag.fcurves for k in fc.keyframe_points
    })
out["key_range"] = [key_frames[0], key_frames[-1]]
# Shot frame f is Blender frame f - start (key times start at 0 s).
scene.frame_start = 0
scene.frame_end = frames[1] - frames[0]
out["scene_range"] = [scene.frame_start, scene.frame_end]
bee = bpy.data.objects[out["bees"][0]]
# The agent layout has no body node: the bee node is the body.
body = bpy.data.objects.get(out["bees"][0] + "_body", bee)
out["body_parent"] = body.parent.name
out["objects"] = len(bpy.data.objects)
poses = {}
for f in (frames[0], (frames[0] + frames[1]) // 2, frames[1]):
    scene.frame_set(f - frames[0])
    m = body.matrix_world
    q = m.to_quaternion()
    poses[f] = {"p": list(m.translation), "q": [q.w, q.x, q.y, q.z], "path": list(bee.matrix_world.translation)}
out["poses"] = poses
print("RESULT " + json.dumps(out))
"""


def quat_mul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


@pytest.mark.parametrize("fmt", ["glb", "gltf"])
def test_blender_import_reproduces_the_tracks(baked, fmt):
    import importlib.util

    if importlib.util.find_spec("bpy") is None:
        _missing("bpy (Blender as a Python module)")
    extras = load_json(baked[fmt])["asset"]["extras"]
    run = subprocess.run(
        [sys.executable, "-c", BLENDER_SCRIPT, str(baked[fmt]), str(extras["fps"]),
         json.dumps([extras["frame_start"], extras["frame_end"]])],
        capture_output=True, text=True, timeout=600,
    )
    assert run.returncode == 0, run.stderr[-4000:]
    line = next(l for l in run.stdout.splitlines() if l.startswith("RESULT "))
    got = json.loads(line[len("RESULT "):])
    tracks = read_tracks(baked["csv"])

    assert len(got["bees"]) == BEES
    assert got["fps"] == pytest.approx(FPS)
    assert got["scene_extras"] == {"fps": FPS, "frame_start": FRAMES[0], "frame_end": FRAMES[1]}
    # Keys land on whole Blender frames 0 .. (end - start).
    assert got["key_range"] == [0.0, float(FRAMES[1] - FRAMES[0])]
    assert got["scene_range"] == [0, FRAMES[1] - FRAMES[0]]

    bee = int(got["bees"][0][4:])
    agent = baked["layout"] == "agent"
    # parts: swarm root + 4 objects per bee; agent: 1 per bee (+2 wings when they flap).
    per_bee = (3 if baked["flap"] else 1) if agent else 4
    assert got["objects"] == 1 + per_bee * BEES
    assert got["body_parent"] == ("bees" if agent else got["bees"][0])
    # Y-up → Z-up on import: (x, y, z) → (x, -z, y), which is c = +90° about X; points and
    # body axes both turn, so a world rotation q becomes c·q·c⁻¹.
    c = (0.5 ** 0.5, 0.5 ** 0.5, 0.0, 0.0)
    c_inv = (c[0], -c[1], 0.0, 0.0)
    for f, pose in got["poses"].items():
        row = tracks[bee][int(f)]
        expect = (row["x"], -row["z"], row["y"])
        assert pose["p"] == pytest.approx(expect, abs=1e-5), f"frame {f}"
        q = quat_mul(quat_mul(c, (row["qw"], row["qx"], row["qy"], row["qz"])), c_inv)
        dot = abs(sum(a * b for a, b in zip(q, pose["q"])))
        assert dot == pytest.approx(1.0, abs=1e-5), f"frame {f}: {pose['q']} vs {q}"
        # The bee (path) node sits off the body by exactly the sway.
        off = sum((a - b) ** 2 for a, b in zip(pose["p"], pose["path"])) ** 0.5
        assert off == pytest.approx(0.0 if agent else abs(row["sway"]), abs=1e-5), f"frame {f}"
    assert any(abs(tracks[bee][int(f)]["sway"]) > 1e-3 for f in got["poses"]), "sway untested"


def test_interrupted_bake_keeps_the_previous_glb(beeswarm_bin, tmp_path):
    """SIGINT mid-bake: the previous .glb/.gltf/.bin stay byte-identical, nothing is left behind."""
    import signal

    out = tmp_path
    bake(beeswarm_bin, shot_text(0), out, "--format", "glb,gltf")
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.suffix in (".glb", ".gltf", ".bin")}
    assert len(before) == 3
    # A longer, bigger bake of the same shot name, stopped after its first frame.
    shot = out / "long.toml"
    shot.write_text(
        shot_text(0)
        .replace(f"count = {BEES}", "count = 3000")
        .replace(f"frames = [{FRAMES[0]}, {FRAMES[1]}]", "frames = [1, 2400]")
    )
    proc = subprocess.Popen(
        [beeswarm_bin, "bake", str(shot), "--out", str(out), "--progress", "json",
         "--format", "glb,gltf"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    for line in proc.stdout:
        if '"progress"' in line:
            break
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 1, err  # a clean, reported stop, not a kill
    assert "interrupted" in err
    after = {p.name: p.read_bytes() for p in out.iterdir() if p.suffix in (".glb", ".gltf", ".bin")}
    assert after == before
    assert [p.name for p in out.iterdir() if p.name.startswith(".")] == []


def test_identical_bakes_are_byte_identical(baked, beeswarm_bin, tmp_path):
    bake(beeswarm_bin, shot_text(baked["flap"], baked["layout"]), tmp_path, "--format", "glb,gltf")
    for name in ("gltf_test.glb", "gltf_test.gltf", "gltf_test.bin"):
        assert (tmp_path / name).read_bytes() == (baked["dir"] / name).read_bytes(), name
