"""A stand-in for `beeswarm bake` used by the Blender add-on tests for what the real binary
cannot be made to do on purpose: fail after a good start, write a cache Blender cannot
read, or write a USDA PointInstancer with exactly known content.

    python blender_fake_beeswarm.py bake SHOT --out DIR --format usda,csv --progress json

BEESWARM_FAKE_MODE: "ok" (default: bees circling the spawn centre), "fail" (progress, then
an error on stderr and exit 1), "corrupt" (exit 0, but the cache is not USD or glTF),
"slow" (progress, then a minute of nothing: for cancelling), "partial" (writes the tracks
CSV, then fails: a bake that dies between two outputs).
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
    if mode == "partial":
        print(f"error: {shot}: out of memory after writing {p.name}", file=sys.stderr)
        return 1
    for fmt in fmts:
        if fmt == "csv":
            continue
        p = out / f"{name}.{fmt}"
        if mode == "corrupt" or fmt not in ("usda", "glb"):
            p.write_bytes(b"\x00\x01 not a cache \xff" * 10)
        elif fmt == "usda":
            p.write_text(usda(name, sw.get("name", "bees"), fps, f0, f1, n, frames))
        else:
            p.write_bytes(glb(sw.get("name", "bees"), fps, f0, f1, n, frames))
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
        f"        rel prototypes = [</{name}/{swarm}/Prototypes/honeybee>]",
        "        int[] protoIndices = [" + ", ".join("0" * 1 for _ in range(n)) + "]",
        "        int64[] ids = [" + ", ".join(str(i) for i in range(n)) + "]",
        "        point3f[] positions.timeSamples = {",
    ]
    lines += [f"            {f}: {arr(p for p, _ in rows)}," for f, rows in frames.items()]
    lines += ["        }", "        vector3f[] velocities.timeSamples = {"]
    lines += [f"            {f}: {arr(v for _, v in rows)}," for f, rows in frames.items()]
    lines += ["        }",
              "        quath[] orientations = [" + ", ".join("(1, 0, 0, 0)" for _ in range(n)) + "]",
              '        def Scope "Prototypes"', "        {", '            def Cube "honeybee"',
              "            {", "                double size = 0.012", "            }", "        }",
              "    }", "}", ""]
    return "\n".join(lines)


def glb(swarm, fps, f0, f1, n, frames):
    """The real writer's layout, reduced: a root node per swarm, `bee_<id>` nodes moved by
    LINEAR translation tracks on a shared time accessor (frame − start) / fps, each with a
    `bee_<id>_body` child holding a one-triangle mesh."""
    import struct
    bin_ = bytearray()
    views, accessors = [], []

    def add(data, fmt, count, type_, extra=None):
        while len(bin_) % 4:
            bin_.append(0)
        views.append({"buffer": 0, "byteOffset": len(bin_), "byteLength": len(data)})
        bin_.extend(data)
        acc = {"bufferView": len(views) - 1, "componentType": 5126, "count": count, "type": type_}
        acc.update(extra or {})
        accessors.append(acc)
        return len(accessors) - 1

    tri = [0, 0, 0, 0.01, 0, 0, 0, 0.01, 0]
    pos_acc = add(struct.pack("<9f", *tri), "f", 3, "VEC3", {"min": [0, 0, 0], "max": [0.01, 0.01, 0]})
    times = [(f - f0) / fps for f in frames]
    t_acc = add(struct.pack(f"<{len(times)}f", *times), "f", len(times), "SCALAR",
                {"min": [min(times)], "max": [max(times)]})
    nodes = [{"name": swarm, "children": []}]
    channels, samplers = [], []
    for i in range(n):
        vals = [c for f in frames for c in frames[f][i][0]]
        acc = add(struct.pack(f"<{len(vals)}f", *vals), "f", len(frames), "VEC3")
        bee = len(nodes)
        nodes[0]["children"].append(bee)
        nodes.append({"name": f"bee_{i:06d}", "children": [bee + 1],
                      "translation": list(frames[f0][i][0])})
        nodes.append({"name": f"bee_{i:06d}_body", "mesh": 0})
        samplers.append({"input": t_acc, "output": acc, "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": bee, "path": "translation"}})
    doc = {"asset": {"version": "2.0", "generator": "blender_fake_beeswarm"},
           "scene": 0, "scenes": [{"nodes": [0]}], "nodes": nodes,
           "meshes": [{"primitives": [{"attributes": {"POSITION": pos_acc}}]}],
           "animations": [{"name": "swarm", "channels": channels, "samplers": samplers}],
           "buffers": [{"byteLength": len(bin_)}], "bufferViews": views, "accessors": accessors}
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    bin_ += b"\0" * (-len(bin_) % 4)
    total = 12 + 8 + len(js) + 8 + len(bin_)
    return (struct.pack("<III", 0x46546C67, 2, total) + struct.pack("<II", len(js), 0x4E4F534A)
            + js + struct.pack("<II", len(bin_), 0x004E4942) + bytes(bin_))


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
