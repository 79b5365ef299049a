#!/usr/bin/env python3
"""Renders one butterfly of paper 004's model from its glTF cache at four frames, side by side,
with Blender's Workbench engine (no GPU needed): docs/img/butterfly_phases.png, 4 × 320×320.

Bakes `examples/butterfly_path.toml` (glTF and tracks CSV), picks four frames whose flapping
phases are spread over a wing beat (wings high, going down, low, going up), imports the
glTF with Blender's stock importer, aims a camera at the butterfly at each of those frames
from the same side, and writes the four renders as one strip.

    ~/.cache/beeswarm/venv/bin/python scripts/render_butterfly.py --bin target/release/beeswarm

glTF keys start at 0 s: shot frame f is Blender frame f − start. Blender is Z-up: shot
(x, y, z) is (x, −z, y).
"""
import argparse
import csv
import json
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]

RENDER = r"""
import json, math, sys
import bpy
import numpy as np
from mathutils import Vector

args = json.loads(sys.argv[1])
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.fps = args["fps"]
bpy.ops.import_scene.gltf(filepath=args["path"])
cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
scene.collection.objects.link(cam)
cam.data.lens = 50
cam.data.clip_start = 0.001
scene.camera = cam
scene.render.engine = "BLENDER_WORKBENCH"
shading = scene.display.shading
shading.light = "STUDIO"
shading.color_type = "MATERIAL"
shading.show_shadows = True
shading.show_cavity = True
scene.world = bpy.data.worlds.new("world")
scene.world.color = (0.75, 0.82, 0.9)
scene.view_settings.view_transform = "Standard"
w, h = args["size"]
scene.render.resolution_x, scene.render.resolution_y = w, h
scene.render.resolution_percentage = 100
strips = []
for k, f in enumerate(args["frames"]):
    scene.frame_set(f)
    body = bpy.data.objects["butterfly_000000_body"]
    target = body.matrix_world.translation.copy()
    # From the front-left, a little above, at a fixed distance.
    heading = body.matrix_world.to_3x3() @ Vector((1.0, 0.0, 0.0))
    heading.z = 0.0
    heading.normalize()
    side = Vector((-heading.y, heading.x, 0.0))
    cam.location = target + heading * 0.07 + side * 0.06 + Vector((0.0, 0.0, 0.045))
    cam.rotation_euler = (target - cam.location).to_track_quat("-Z", "Y").to_euler()
    path = f"{args['work']}/frame_{k}.png"
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    strips.append(px.reshape(h, w, 4))
row = np.concatenate(strips, axis=1)
out = bpy.data.images.new("strip", width=row.shape[1], height=h, alpha=True)
out.pixels.foreach_set(row.ravel())
out.filepath_raw = args["out"]
out.file_format = "PNG"
out.save()
print("RESULT ok")
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "beeswarm"))
    ap.add_argument("--out", default=str(ROOT / "docs" / "img" / "butterfly_phases.png"))
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as work:
        work = pathlib.Path(work)
        shot = ROOT / "examples" / "butterfly_path.toml"
        subprocess.run([args.bin, "bake", str(shot), "--out", str(work), "--format", "gltf,csv",
                        "--progress", "none"], check=True)
        with open(work / "butterfly_path.tracks.csv", newline="") as f:
            rows = [r for r in csv.DictReader(f) if r["id"] == "0"]
        # Four frames after the first few seconds whose phases are nearest 0, ¼, ½, ¾ of a beat
        # while the butterfly flaps with a large amplitude.
        start = int(rows[0]["frame"])
        late = [r for r in rows if int(r["frame"]) > start + 90 and float(r["flap_hz"]) > 8.0]
        frames = []
        for want in (0.0, 0.25, 0.5, 0.75):
            best = min(late, key=lambda r: min(abs(float(r["flap_phase"]) - want),
                                               1 - abs(float(r["flap_phase"]) - want)))
            late = [r for r in late if r is not best]
            frames.append(int(best["frame"]) - start)
            print(f"frame {best['frame']}: phase {float(best['flap_phase']):.2f}, "
                  f"flap {float(best['flap']):.0f} deg, abdomen {float(best['abdomen']):.0f} deg",
                  file=sys.stderr)
        job = dict(path=str(work / "butterfly_path.gltf"), fps=30, frames=frames, size=[320, 320],
                   out=str(pathlib.Path(args.out).resolve()), work=str(work))
        run = subprocess.run([sys.executable, "-c", RENDER, json.dumps(job)], capture_output=True, text=True)
        if run.returncode != 0 or "RESULT ok" not in run.stdout:
            raise SystemExit(run.stderr[-3000:])
        print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
