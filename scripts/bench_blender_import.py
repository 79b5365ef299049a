#!/usr/bin/env python3
"""Blender import time of beeswarm caches: glTF (parts and agent layouts) and USD.

Not a test (tests never assert on time): a measurement for docs/blender.md. For each bee
count it bakes one shot (240 frames at 24 fps by default) to `.glb` twice (gltf_layout =
"parts" and "agent") and to `.usda`, then imports each file into a fresh, empty Blender
(bpy, one subprocess per import) and reports the importer's wall time, the objects it
made, and the time to evaluate one frame afterwards (a proxy for playback).

    ~/.cache/beeswarm/venv/bin/python scripts/bench_blender_import.py \\
        --bin target/release/beeswarm --counts 1000,2000,4000 --frames 240

Prints a Markdown table; the 4,000-bee parts-layout glTF import takes minutes.
"""
import argparse
import json
import pathlib
import subprocess
import sys
import tempfile
import time

SHOT = """
[scene]
name = "bench"
fps = 24
frames = [1, {frames}]
seed = 5

[[swarm]]
name = "bees"
count = {count}
preset = "nest"
spawn = {{ shape = "box", center = [0.0, 1.0, 0.6], size = [1.2, 0.6, 0.6] }}

[[target]]
type = "nest"
name = "hive"
position = [0.0, 1.0, 0.0]

[output]
wings = "{wings}"
gltf_layout = "{layout}"
"""

IMPORT = r"""
import json, sys, time
import bpy

path, kind = sys.argv[1], sys.argv[2]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.fps = 24
t0 = time.perf_counter()
if kind == "usd":
    bpy.ops.wm.usd_import(filepath=path)
else:
    bpy.ops.import_scene.gltf(filepath=path)
t1 = time.perf_counter()
scene.frame_set(100)
t2 = time.perf_counter()
print("RESULT " + json.dumps({"import_s": t1 - t0, "frame_s": t2 - t1, "objects": len(bpy.data.objects)}))
"""


def bake(binary, count, frames, layout, fmt, wings, out):
    out.mkdir(parents=True, exist_ok=True)
    shot = out / "bench.toml"
    shot.write_text(SHOT.format(count=count, frames=frames, layout=layout, wings=wings))
    subprocess.run([binary, "bake", str(shot), "--out", str(out), "--format", fmt, "--progress", "none"],
                   check=True, capture_output=True)
    return out / f"bench.{fmt}"


def measure(path, kind):
    run = subprocess.run([sys.executable, "-c", IMPORT, str(path), kind], capture_output=True, text=True)
    if run.returncode != 0:
        raise SystemExit(run.stderr[-3000:])
    line = next(l for l in run.stdout.splitlines() if l.startswith("RESULT "))
    return json.loads(line[len("RESULT "):])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="target/release/beeswarm")
    ap.add_argument("--counts", default="1000,2000,4000")
    ap.add_argument("--frames", type=int, default=240)
    ap.add_argument("--wings", default="blur", choices=["still", "blur", "flap"])
    ap.add_argument("--out", default=None, help="where to bake (default: a temporary folder)")
    args = ap.parse_args()
    counts = [int(c) for c in args.counts.split(",")]
    root = pathlib.Path(args.out or tempfile.mkdtemp(prefix="beeswarm-bench-"))
    cases = [("glTF, parts layout", "parts", "glb", "gltf"),
             ("glTF, agent layout", "agent", "glb", "gltf"),
             ("USD", "parts", "usda", "usd")]
    rows = {}
    for name, layout, fmt, kind in cases:
        for n in counts:
            path = bake(args.bin, n, args.frames, layout, fmt, args.wings, root / f"{layout}-{fmt}-{n}")
            t = time.perf_counter()
            r = measure(path, kind)
            r["wall_s"] = time.perf_counter() - t
            r["mb"] = path.stat().st_size / 1e6
            rows[(name, n)] = r
            print(f"{name:20} {n:6} bees: import {r['import_s']:7.2f} s, one frame {r['frame_s']:6.2f} s, "
                  f"{r['objects']} objects, {r['mb']:.1f} MB", file=sys.stderr, flush=True)
    print(f"\n{args.frames} frames, wings = \"{args.wings}\"; import = the importer call alone.\n")
    head = " | ".join(f"{n:,} bees" for n in counts)
    print(f"| cache | {head} | {counts[-1]:,}/{counts[0]:,} |")
    print("|---|" + "---|" * (len(counts) + 1))
    for name, *_ in cases:
        cells = " | ".join(f"{rows[(name, n)]['import_s']:.1f} s ({rows[(name, n)]['objects']:,} objects)" for n in counts)
        ratio = rows[(name, counts[-1])]["import_s"] / rows[(name, counts[0])]["import_s"]
        print(f"| {name} | {cells} | {ratio:.1f} |")
    print("\nOne frame evaluated after import (`scene.frame_set`):\n")
    print(f"| cache | {head} |")
    print("|---|" + "---|" * len(counts))
    for name, *_ in cases:
        cells = " | ".join(f"{rows[(name, n)]['frame_s']:.2f} s" for n in counts)
        print(f"| {name} | {cells} |")


if __name__ == "__main__":
    main()
