#!/usr/bin/env python3
"""beeswarm against Blender's built-in boids: the same agent count and frame range, whole
processes, runs alternated so that both see the same machine load.

    ~/.cache/beeswarm/venv/bin/python scripts/bench_vs_blender_boids.py \
        --agents 10000 --frames 240 --runs 5 [--beeswarm target/release/beeswarm]

Blender side: a fresh bpy process (from the test venv's `bpy`) adds an emitter whose
particle system uses boids physics (Blender's defaults: separate, flock, goal rules),
emits every particle on frame 1 and steps the scene frame by frame to the end, which is
what evaluating (or baking) the particle cache does. beeswarm side: `beeswarm bake` of a
shot holding one swarm of the same count and frame range (`--model`: the bee model by
default, or beeswarm's own boids; 4 substeps per frame, the
default spawn box at 500 bees per m³), writing one cache (`--format`): binary glTF by
default, the lightest to write (10,000 bees × 240 frames: 1.88 s against 2.52 s for the
tracks CSV and 2.9 s for USDA, medians of 5, 2026-11-26). Each time is the whole
process, start-up included. Prints one line per run and the medians.
This is a benchmark, not a test: nothing asserts on it.
"""

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BLENDER_SIDE = r"""
import sys
import bpy
agents, frames = int(sys.argv[1]), int(sys.argv[2])
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, frames
bpy.ops.mesh.primitive_plane_add(size=2)
emitter = bpy.context.active_object
emitter.modifiers.new("boids", "PARTICLE_SYSTEM")
settings = emitter.particle_systems[0].settings
settings.count = agents
settings.frame_start = settings.frame_end = 1
settings.lifetime = frames + 1
settings.physics_type = "BOIDS"
emitter.particle_systems[0].point_cache.frame_end = frames
for f in range(1, frames + 1):
    scene.frame_set(f)
depsgraph = bpy.context.evaluated_depsgraph_get()
alive = sum(1 for p in emitter.evaluated_get(depsgraph).particle_systems[0].particles
            if p.alive_state == "ALIVE")
print("alive", alive)
"""


def run(cmd):
    t = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True)
    elapsed = time.perf_counter() - t
    if out.returncode != 0:
        sys.exit(f"{cmd[0]} failed ({out.returncode}):\n{out.stderr[-2000:]}")
    return elapsed, out.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--agents", type=int, default=10_000)
    ap.add_argument("--frames", type=int, default=240)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--beeswarm", default="target/release/beeswarm")
    ap.add_argument("--threads", type=int, default=0, help="beeswarm threads (0: all cores)")
    ap.add_argument("--format", default="glb", choices=["glb", "gltf", "usda", "csv"],
                    help="the cache beeswarm writes (glb, the lightest, by default)")
    ap.add_argument("--model", default="bee",
                    help="beeswarm's model: bee (paper 000, the default) or boids (its Reynolds "
                         "baseline, the same kind of model as Blender's)")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        shot = tmp / "bench.toml"
        shot.write_text(
            f'[scene]\nname = "bench"\nframes = [1, {a.frames}]\n'
            f"[[swarm]]\ncount = {a.agents}\nmodel = \"{a.model}\"\n"
        )
        times = {"blender": [], "beeswarm": []}
        for k in range(a.runs):
            # Alternate which goes first, so that neither always follows the other.
            order = ["blender", "beeswarm"] if k % 2 == 0 else ["beeswarm", "blender"]
            for who in order:
                if who == "blender":
                    t, out = run([sys.executable, "-c", BLENDER_SIDE, str(a.agents), str(a.frames)])
                    if f"alive {a.agents}" not in out:
                        sys.exit(f"Blender's boids did not all live: {out[-300:]}")
                else:
                    t, _ = run([a.beeswarm, "bake", str(shot), "--format", a.format, "--progress",
                                "none", "--threads", str(a.threads), "--out", str(tmp / "out")])
                times[who].append(t)
                print(f"run {k + 1}: {who:8} {t:7.2f} s", flush=True)
        b, s = statistics.median(times["blender"]), statistics.median(times["beeswarm"])
        print(f"{a.agents} agents x {a.frames} frames, beeswarm model {a.model} writing "
              f"{a.format}, medians of {a.runs}: "
              f"Blender boids {b:.2f} s ({min(times['blender']):.2f}-{max(times['blender']):.2f}), "
              f"beeswarm {s:.2f} s ({min(times['beeswarm']):.2f}-{max(times['beeswarm']):.2f}): "
              f"beeswarm {b / s:.1f}x faster per frame")


if __name__ == "__main__":
    main()
