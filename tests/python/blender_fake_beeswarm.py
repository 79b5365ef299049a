"""A stand-in for `beeswarm bake` used by the Blender add-on tests for what the real binary
cannot be made to do on purpose: fail after a good start, write a cache Blender cannot
read, or write a USDA PointInstancer with exactly known content.

    python blender_fake_beeswarm.py bake SHOT --out DIR --format usda,csv --progress json

BEESWARM_FAKE_MODE: "ok" (default: bees circling the spawn centre), "fail" (progress, then
an error on stderr and exit 1), "corrupt" (exit 0, but the cache is not USD or glTF),
"slow" (progress, then a minute of nothing: for cancelling).
"""
import json
import math
import os
import pathlib
import random
import sys
import tomllib


def main(argv):
    if not argv or argv[0] != "bake":
        print("error: only `bake` is faked", file=sys.stderr)
        return 2
    shot = argv[1]
    out = pathlib.Path(argv[argv.index("--out") + 1])
    fmts = argv[argv.index("--format") + 1].split(",")
    doc = tomllib.load(open(shot, "rb"))
    sc = doc.get("scene", {})
    name = sc.get("name", pathlib.Path(shot).name.split(".")[0])
    fps = float(sc.get("fps", 24))
    f0, f1 = sc.get("frames", [1, 120])
    sw = doc["swarm"][0]
    n = sw["count"]
    mode = os.environ.get("BEESWARM_FAKE_MODE", "ok")
    out.mkdir(parents=True, exist_ok=True)
    print(json.dumps({"event": "progress", "frame": f0, "done": 1, "total": f1 - f0 + 1,
                      "elapsed_s": 0.0}), flush=True)
    if mode == "slow":
        import time
        time.sleep(60)
    if mode == "fail":
        print(f"error: {shot}: the simulation diverged at frame {f0 + 1}", file=sys.stderr)
        return 1
    c = sw.get("spawn", {}).get("center", [0, 1, 0])
    rnd = random.Random(sc.get("seed", 1))
    bees = [(rnd.uniform(0, 6.28), rnd.uniform(0.2, 0.5), rnd.uniform(-0.2, 0.2)) for _ in range(n)]
    frames = {}
    for f in range(f0, f1 + 1):
        t = (f - f0) / fps
        frames[f] = [((c[0] + r * math.cos(p + 2 * t), c[1] + h, c[2] + r * math.sin(p + 2 * t)),
                      (-2 * r * math.sin(p + 2 * t), 0.0, 2 * r * math.cos(p + 2 * t)))
                     for p, r, h in bees]
    outputs = []
    if "csv" in fmts:
        p = out / f"{name}.tracks.csv"
        with open(p, "w") as fh:
            fh.write("id,frame,time,x,y,z,vx,vy,vz,qx,qy,qz,qw,pitch,roll,sway\n")
            for f, rows in frames.items():
                for i, (pos, vel) in enumerate(rows):
                    fh.write(f"{i},{f},{(f - f0) / fps},{pos[0]},{pos[1]},{pos[2]},"
                             f"{vel[0]},{vel[1]},{vel[2]},0,0,0,1,0,0,0\n")
        outputs.append(str(p.resolve()))
    for fmt in fmts:
        if fmt == "csv":
            continue
        p = out / f"{name}.{fmt}"
        if mode == "corrupt" or fmt != "usda":
            p.write_bytes(b"\x00\x01 not a cache \xff" * 10)
        else:
            p.write_text(usda(name, sw.get("name", "bees"), fps, f0, f1, n, frames))
        outputs.append(str(p.resolve()))
    print(json.dumps({"event": "done", "outputs": outputs}), flush=True)
    return 0


def usda(name, swarm, fps, f0, f1, n, frames):
    def arr(vals):
        return "[" + ", ".join("(%r, %r, %r)" % v for v in vals) + "]"
    lines = [
        "#usda 1.0", "(", f'    defaultPrim = "{name}"', "    metersPerUnit = 1",
        '    upAxis = "Y"', f"    timeCodesPerSecond = {fps}", f"    framesPerSecond = {fps}",
        f"    startTimeCode = {f0}", f"    endTimeCode = {f1}", ")", "",
        f'def Xform "{name}"', "{", f'    def PointInstancer "{swarm}"', "    {",
        f"        rel prototypes = [</{name}/{swarm}/Prototypes/bee>]",
        "        int[] protoIndices = [" + ", ".join("0" * 1 for _ in range(n)) + "]",
        "        int64[] ids = [" + ", ".join(str(i) for i in range(n)) + "]",
        "        point3f[] positions.timeSamples = {",
    ]
    lines += [f"            {f}: {arr(p for p, _ in rows)}," for f, rows in frames.items()]
    lines += ["        }", "        vector3f[] velocities.timeSamples = {"]
    lines += [f"            {f}: {arr(v for _, v in rows)}," for f, rows in frames.items()]
    lines += ["        }",
              "        quath[] orientations = [" + ", ".join("(1, 0, 0, 0)" for _ in range(n)) + "]",
              '        def Scope "Prototypes"', "        {", '            def Cube "bee"',
              "            {", "                double size = 0.012", "            }", "        }",
              "    }", "}", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
