#!/usr/bin/env python3
"""Blender import time of beeswarm caches: the stock importers alone, and the add-on's bake
button from start to an animated swarm. glTF (agent and parts layouts) and USD.

Not a test (tests never assert on time): a measurement for docs/blender.md. For each bee
count it bakes one shot (240 frames at 24 fps by default) to `.glb` twice
(gltf_layout = "agent" and "parts") and to `.usda`, then, each case in a fresh Blender
(bpy, one subprocess per case):

- raw: `bpy.ops.import_scene.gltf` / `bpy.ops.wm.usd_import` into an empty scene;
- add-on: the add-on enabled as an extension (a link in a temporary user folder), then
  `bpy.ops.beeswarm.bake(shot_path=…)`: the binary's bake, the cache moved into place and
  the add-on's import (`import`: its `importer.import_cache`, hooks and passes included);
  then the same bake again (the re-bake replaces the swarm).

Every case runs `--runs` times, alternated (all cases once, then again), and the table
gives medians with the range, since other work on the machine moves single runs.

    ~/.cache/beeswarm/venv/bin/python scripts/bench_blender_import.py \\
        --bin target/release/beeswarm --counts 1000,2000,4000 --frames 240 --runs 3

`--cases` picks some of: raw-agent, raw-parts, raw-usd, addon-agent, addon-parts,
addon-usd (the raw parts-layout import of 4,000 bees takes minutes).
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

# The add-on as a user has it: an extension, enabled, the binary in its preferences; the
# bake button's operator on a shot file, timed whole and for its import step.
ADDON = r"""
import json, os, sys, time
import bpy

addon_dir, binary, shot, fmt = sys.argv[-4:]
bpy.ops.wm.read_factory_settings(use_empty=True)
ext = bpy.utils.user_resource("EXTENSIONS", path="user_default", create=True)
os.symlink(addon_dir, os.path.join(ext, "beeswarm"))
module = "bl_ext.user_default.beeswarm"
assert bpy.ops.preferences.addon_enable(module=module) == {"FINISHED"}
bpy.context.preferences.addons[module].preferences.binary_path = binary
importer = sys.modules[module + ".importer"]
spent = []
real = importer.import_cache
def timed(*a, **k):
    t = time.perf_counter()
    try:
        return real(*a, **k)
    finally:
        spent.append(time.perf_counter() - t)
importer.import_cache = timed
scene = bpy.context.scene
out = {}
for run in ("bake", "rebake"):
    t = time.perf_counter()
    assert bpy.ops.beeswarm.bake(shot_path=shot, format=fmt) == {"FINISHED"}
    out[run + "_s"] = time.perf_counter() - t
    out[run + "_import_s"] = spent[-1]
t = time.perf_counter()
scene.frame_set(100)
out["frame_s"] = time.perf_counter() - t
out["objects"] = len(bpy.data.objects)
print("RESULT " + json.dumps(out))
"""

CASES = {  # name: (label, gltf_layout, file format, what runs)
    "raw-agent": ("glTF agent, importer", "agent", "glb", "gltf"),
    "raw-parts": ("glTF parts, importer", "parts", "glb", "gltf"),
    "raw-usd": ("USD, importer", "parts", "usda", "usd"),
    "addon-agent": ("glTF agent, add-on", "agent", "glb", "GLTF"),
    "addon-parts": ("glTF parts, add-on", "parts", "glb", "GLTF"),
    "addon-usd": ("USD, add-on", "parts", "usda", "USD"),
}


def write_shot(count, frames, layout, wings, out):
    out.mkdir(parents=True, exist_ok=True)
    shot = out / "bench.toml"
    shot.write_text(SHOT.format(count=count, frames=frames, layout=layout, wings=wings))
    return shot


def bake(binary, count, frames, layout, fmt, wings, out):
    shot = write_shot(count, frames, layout, wings, out)
    subprocess.run([binary, "bake", str(shot), "--out", str(out), "--format", fmt, "--progress", "none"],
                   check=True, capture_output=True)
    return out / f"bench.{fmt}"


def run_blender(args, env=None):
    run = subprocess.run([sys.executable, "-c", *args], capture_output=True, text=True, env=env)
    if run.returncode != 0:
        raise SystemExit(run.stdout[-2000:] + run.stderr[-3000:])
    line = next(l for l in run.stdout.splitlines() if l.startswith("RESULT "))
    return json.loads(line[len("RESULT "):])


def measure_raw(path, kind):
    r = run_blender([IMPORT, str(path), kind])
    r["total_s"] = r["import_s"]
    return r


def measure_addon(binary, shot, fmt, scratch):
    addon = pathlib.Path(__file__).resolve().parent.parent / "blender_addon"
    res = tempfile.mkdtemp(prefix="res-", dir=scratch)
    tmp = tempfile.mkdtemp(prefix="tmp-", dir=scratch)
    env = {**__import__("os").environ, "BLENDER_USER_RESOURCES": res, "TMPDIR": tmp}
    r = run_blender([ADDON, str(addon), str(pathlib.Path(binary).resolve()), str(shot), fmt], env)
    r["total_s"], r["import_s"] = r["bake_s"], r["bake_import_s"]
    return r


def median(xs):
    xs = sorted(xs)
    n = len(xs)
    return xs[n // 2] if n % 2 else 0.5 * (xs[n // 2 - 1] + xs[n // 2])


def cell(xs, fmt="{:.1f}"):
    m = fmt.format(median(xs))
    if len(xs) == 1 or fmt.format(min(xs)) == fmt.format(max(xs)):
        return f"{m} s"
    return f"{m} s ({fmt.format(min(xs))}–{fmt.format(max(xs))})"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="target/release/beeswarm")
    ap.add_argument("--counts", default="1000,2000,4000")
    ap.add_argument("--frames", type=int, default=240)
    ap.add_argument("--wings", default="blur", choices=["still", "blur", "flap"])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--cases", default=",".join(CASES), help="comma-separated, of: " + ", ".join(CASES))
    ap.add_argument("--out", default=None, help="where to bake (default: a temporary folder)")
    args = ap.parse_args()
    counts = [int(c) for c in args.counts.split(",")]
    cases = [c.strip() for c in args.cases.split(",")]
    for c in cases:
        if c not in CASES:
            ap.error(f"--cases: unknown case {c!r} (known: {', '.join(CASES)})")
    root = pathlib.Path(args.out or tempfile.mkdtemp(prefix="beeswarm-bench-"))
    inputs = {}
    for c in cases:
        _, layout, fmt, kind = CASES[c]
        for n in counts:
            out = root / f"{c}-{n}"
            if kind in ("gltf", "usd"):
                inputs[(c, n)] = bake(args.bin, n, args.frames, layout, fmt, args.wings, out)
            else:
                inputs[(c, n)] = write_shot(n, args.frames, layout, args.wings, out)
    rows = {}
    for run in range(args.runs):  # alternated: every case once per round
        for c in cases:
            label, layout, fmt, kind = CASES[c]
            for n in counts:
                if kind in ("gltf", "usd"):
                    r = measure_raw(inputs[(c, n)], kind)
                else:
                    r = measure_addon(args.bin, inputs[(c, n)], kind, root)
                rows.setdefault((c, n), []).append(r)
                extra = (f", re-bake {r['rebake_s']:.2f} s (import {r['rebake_import_s']:.2f} s)"
                         if "rebake_s" in r else "")
                print(f"run {run + 1}: {label:22} {n:6} bees: total {r['total_s']:7.2f} s, "
                      f"import {r['import_s']:7.2f} s{extra}, one frame {r['frame_s']:.2f} s, "
                      f"{r['objects']} objects", file=sys.stderr, flush=True)
    print(f"\n{args.frames} frames, wings = \"{args.wings}\", {args.runs} alternated runs: "
          f"median (range).\n")
    head = " | ".join(f"{n:,} bees" for n in counts)

    def table(title, key, which):
        sel = [c for c in cases if c.startswith(which)]
        if not sel:
            return
        print(f"{title}\n")
        print(f"| case | {head} | {counts[-1]:,}/{counts[0]:,} |")
        print("|---|" + "---|" * (len(counts) + 1))
        for c in sel:
            cells = " | ".join(cell([r[key] for r in rows[(c, n)]]) for n in counts)
            ratio = median([r[key] for r in rows[(c, counts[-1])]]) / median([r[key] for r in rows[(c, counts[0])]])
            print(f"| {CASES[c][0]} | {cells} | {ratio:.1f} |")
        print()

    table("Importer alone (`import_scene.gltf` / `usd_import`):", "import_s", "raw")
    table("Add-on, bake button to animated swarm (binary's bake + import):", "bake_s", "addon")
    table("Add-on, its import step alone (`importer.import_cache`):", "bake_import_s", "addon")
    table("Add-on, re-bake replacing the swarm (whole button):", "rebake_s", "addon")
    table("Add-on, re-bake's import step (new swarm in, old one removed):", "rebake_import_s", "addon")
    print("One frame evaluated afterwards (`scene.frame_set`):\n")
    print(f"| case | {head} |")
    print("|---|" + "---|" * len(counts))
    for c in cases:
        print(f"| {CASES[c][0]} | " + " | ".join(cell([r['frame_s'] for r in rows[(c, n)]], "{:.2f}")
                                                  for n in counts) + " |")
    print("\nObjects: " + ", ".join(f"{CASES[c][0]} {rows[(c, counts[-1])][0]['objects']:,}" for c in cases)
          + f" at {counts[-1]:,} bees.")


if __name__ == "__main__":
    main()
