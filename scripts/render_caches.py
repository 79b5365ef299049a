#!/usr/bin/env python3
"""Renders the same frame of one bake from its glTF and its USD cache, with Blender (bpy).

Bakes a 200-bee shot once to `.glb` and `.usda` (and the tracks CSV, to aim the camera),
imports each cache into a fresh Blender scene with the stock importers, and renders the
same shot frame from the same camera with Cycles on the CPU (no GPU needed):

    docs/img/render_gltf.png    960×540, from <name>.glb
    docs/img/render_usd.png     960×540, from <name>.usda

and, for docs/caches.md, one bee close up under each wing display:

    docs/img/wings_still.png, wings_blur.png, wings_flap.png    480×270, from USD

    ~/.cache/beeswarm/venv/bin/python scripts/render_caches.py --bin target/release/beeswarm

Blender frames: glTF keys start at 0 s, so shot frame f is Blender frame f − start; USD
time codes are the shot's frame numbers. Blender is Z-up: shot (x, y, z) is (x, −z, y).
"""
import argparse
import csv
import json
import math
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]

SHOT = """
[scene]
name = "render"
fps = 24
frames = [1, {last}]
seed = {seed}

[[swarm]]
name = "bees"
count = {count}
preset = "nest"
spawn = {{ shape = "box", center = [0.0, 1.0, 0.3], size = [{size}, {size}, {size}] }}

[[target]]
type = "nest"
name = "hive"
position = [0.0, 1.0, 0.0]

[output]
wings = "{wings}"
gltf_layout = "agent"
"""

RENDER = r"""
import json, math, sys
import bpy
from mathutils import Vector

args = json.loads(sys.argv[1])
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.fps = 24
if args["kind"] == "usd":
    bpy.ops.wm.usd_import(filepath=args["path"])
else:
    bpy.ops.import_scene.gltf(filepath=args["path"])
scene.frame_set(args["blender_frame"])

target = Vector(args["target"])
cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
scene.collection.objects.link(cam)
cam.data.lens = 50
cam.data.clip_start = 0.001
cam.location = target + Vector(args["offset"])
cam.rotation_euler = (target - cam.location).to_track_quat("-Z", "Y").to_euler()
scene.camera = cam
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sun.data.energy = 3.0
sun.rotation_euler = (math.radians(40), math.radians(10), math.radians(30))
scene.collection.objects.link(sun)
world = bpy.data.worlds.new("world")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.45, 0.55, 0.65, 1.0)
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.8
scene.world = world
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = args["samples"]
scene.cycles.use_denoising = False
scene.view_settings.view_transform = "Standard"
scene.render.resolution_x, scene.render.resolution_y = args["size"]
scene.render.resolution_percentage = 100
scene.render.filepath = args["out"]
bpy.ops.render.render(write_still=True)
print("RESULT ok")
"""


def bake(binary, out, fmts, **shot):
    out.mkdir(parents=True, exist_ok=True)
    (out / "render.toml").write_text(SHOT.format(**shot))
    subprocess.run([binary, "bake", str(out / "render.toml"), "--out", str(out), "--format", fmts,
                    "--progress", "none"], check=True, capture_output=True)


def positions(tracks, frame):
    """Blender-space (Z-up) bee positions at a shot frame."""
    with open(tracks, newline="") as f:
        return [(float(r["x"]), -float(r["z"]), float(r["y"])) for r in csv.DictReader(f)
                if int(r["frame"]) == frame]


def render(kind, path, blender_frame, target, offset, size, samples, out):
    args = dict(kind=kind, path=str(path), blender_frame=blender_frame, target=target, offset=offset,
                size=size, samples=samples, out=str(out))
    run = subprocess.run([sys.executable, "-c", RENDER, json.dumps(args)], capture_output=True, text=True)
    if run.returncode != 0 or "RESULT ok" not in run.stdout:
        raise SystemExit(run.stderr[-3000:])
    print(f"wrote {out}", file=sys.stderr)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "beeswarm"))
    ap.add_argument("--out", default=str(ROOT / "docs" / "img"))
    ap.add_argument("--samples", type=int, default=32)
    ap.add_argument("--frame", type=int, default=12, help="the shot frame to render")
    ap.add_argument("--only", choices=["swarm", "wings"], help="only the swarm or the wing renders")
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    work = pathlib.Path(tempfile.mkdtemp(prefix="beeswarm-render-"))

    if args.only != "wings":
        swarm(args, out, work)
    if args.only != "swarm":
        wing_closeups(args, out, work)


def swarm(args, out, work):
    """The swarm, from both caches."""
    bake(args.bin, work / "swarm", "glb,usda,csv", last=48, seed=3, count=200, size=0.3, wings="blur")
    pts = positions(work / "swarm" / "render.tracks.csv", args.frame)
    centre = [sum(p[k] for p in pts) / len(pts) for k in range(3)]
    spread = sorted(math.dist(p, centre) for p in pts)[int(0.8 * len(pts))]
    # 50 mm lens, 36 mm sensor: the frame is 0.72 × distance wide. Close enough to see the
    # bees' bands: the frame holds the swarm's core, not every straggler.
    dist = 1.0 * spread / 0.72
    look = [0.25, -1.0, 0.35]
    norm = math.sqrt(sum(v * v for v in look))
    offset = [dist * v / norm for v in look]
    for kind, name, blender_frame in (("gltf", "render.glb", args.frame - 1),
                                      ("usd", "render.usda", args.frame)):
        render(kind, work / "swarm" / name, blender_frame, centre, offset, (960, 540), args.samples,
               out / f"render_{kind}.png")


def wing_closeups(args, out, work):
    """One bee close up under each wing display (USD), seen from the side and above."""
    for wings in ("still", "blur", "flap"):
        d = work / wings
        bake(args.bin, d, "usda,csv", last=12, seed=9, count=1, size=0.01, wings=wings)
        (bee,) = positions(d / "render.tracks.csv", 6)
        render("usd", d / "render.usda", 6, list(bee), [0.012, -0.03, 0.035], (480, 270), args.samples,
               out / f"wings_{wings}.png")


if __name__ == "__main__":
    main()
