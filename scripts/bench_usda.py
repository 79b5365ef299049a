#!/usr/bin/env python3
"""Benchmark: beeswarm's USDA writer against usd-core writing the same arrays.

    /root/.cache/beeswarm/venv/bin/python scripts/bench_usda.py [--bees 10000] [--frames 240]

Generates one swarm's per-frame arrays with numpy (deterministic), then times:
  * usd-core, positions only: a PointInstancer with time-sampled positions, Save() to
    .usda (the reference workload: 10,000 x 240 is about 87 MB of text);
  * usd-core, full: every attribute beeswarm writes (positions, orientations as quath,
    scales, velocities, angularVelocities, extent, primvars pitch/roll/sway);
  * beeswarm, full: the Rust writer (benches/usda_writer.rs) on the same arrays, from
    opening the writer to the committed, fsynced file.
Compares throughput per byte written (MB/s), checks that both full files read back the
same values at a few frames, and prints one JSON object. Not a test: timings vary.
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

ROOT = pathlib.Path(__file__).resolve().parents[1]
BOUND_RADIUS = 0.012  # about the prototype's bound; only sizes the extent here


def make_arrays(n, f, seed=1):
    """Per-frame arrays of a plausible swarm: smooth paths, unit quaternions."""
    rng = np.random.default_rng(seed)
    start = rng.uniform(-5, 5, (n, 3)).astype(np.float32)
    vel = rng.normal(0, 1, (f, n, 3)).astype(np.float32)
    pos = (start + np.cumsum(vel, axis=0) / 24.0).astype(np.float32)
    q = rng.normal(0, 1, (f, n, 4)).astype(np.float32)
    q /= np.linalg.norm(q, axis=2, keepdims=True)
    ang = rng.normal(0, 90, (f, n, 3)).astype(np.float32)
    scale = np.broadcast_to(rng.uniform(0.9, 1.1, n).astype(np.float32), (f, n)).copy()
    pitch = rng.normal(0, 15, (f, n)).astype(np.float32)
    roll = rng.normal(0, 15, (f, n)).astype(np.float32)
    sway = rng.normal(0, 0.01, (f, n)).astype(np.float32)
    return dict(pos=pos, vel=vel, q=q, ang=ang, scale=scale, pitch=pitch, roll=roll, sway=sway)


def write_raw(a, path):
    """The layout benches/usda_writer.rs reads: per frame, block after block."""
    f = a["pos"].shape[0]
    with open(path, "wb") as out:
        for i in range(f):
            for k in ("pos", "vel", "q", "ang", "scale", "pitch", "roll", "sway"):
                out.write(np.ascontiguousarray(a[k][i], dtype="<f4").tobytes())


def usd_core(a, path, full):
    f, n = a["pos"].shape[:2]
    t0 = time.perf_counter()
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(f)
    stage.SetTimeCodesPerSecond(24)
    stage.SetFramesPerSecond(24)
    root = UsdGeom.Xform.Define(stage, "/bench")
    stage.SetDefaultPrim(root.GetPrim())
    pi = UsdGeom.PointInstancer.Define(stage, "/bench/bees")
    pi.CreateIdsAttr(Vt.Int64Array.FromNumpy(np.arange(n, dtype=np.int64)))
    pi.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(np.zeros(n, dtype=np.int32)))
    pos = pi.CreatePositionsAttr()
    if full:
        ori, scl = pi.CreateOrientationsAttr(), pi.CreateScalesAttr()
        vel, ang, ext = pi.CreateVelocitiesAttr(), pi.CreateAngularVelocitiesAttr(), pi.CreateExtentAttr()
        pv = UsdGeom.PrimvarsAPI(pi)
        prim = {k: pv.CreatePrimvar(k, Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex)
                for k in ("pitch", "roll", "sway")}
    for i in range(f):
        t = i + 1
        pos.Set(Vt.Vec3fArray.FromNumpy(a["pos"][i]), t)
        if full:
            # Gf.Quath's memory order is (i, j, k, real), as glam's (x, y, z, w).
            ori.Set(Vt.QuathArray.FromNumpy(a["q"][i].astype(np.float16)), t)
            scl.Set(Vt.Vec3fArray.FromNumpy(np.repeat(a["scale"][i][:, None], 3, axis=1)), t)
            vel.Set(Vt.Vec3fArray.FromNumpy(a["vel"][i]), t)
            ang.Set(Vt.Vec3fArray.FromNumpy(a["ang"][i]), t)
            reach = (BOUND_RADIUS * a["scale"][i])[:, None]
            lo, hi = (a["pos"][i] - reach).min(0), (a["pos"][i] + reach).max(0)
            ext.Set(Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))]), t)
            for k in ("pitch", "roll", "sway"):
                prim[k].Set(Vt.FloatArray.FromNumpy(a[k][i]), t)
    stage.Save()
    seconds = time.perf_counter() - t0
    return {"seconds": round(seconds, 4), "bytes": path.stat().st_size}


def ours(raw, out_dir, n, f):
    build = subprocess.run(["cargo", "bench", "--bench", "usda_writer", "--no-run"], cwd=ROOT,
                           capture_output=True, text=True)
    if build.returncode != 0:
        sys.exit(build.stderr)
    run = subprocess.run(["cargo", "bench", "-q", "--bench", "usda_writer", "--", str(raw), str(out_dir),
                          str(n), str(f)], cwd=ROOT, capture_output=True, text=True, check=True)
    return json.loads(run.stdout.strip().splitlines()[-1])


def same_values(a_path, b_path, frames):
    a, b = Usd.Stage.Open(str(a_path)), Usd.Stage.Open(str(b_path))
    pa, pb = (s.GetPrimAtPath("/bench/bees") for s in (a, b))
    names = ["positions", "orientations", "scales", "velocities", "angularVelocities",
             "primvars:pitch", "primvars:roll", "primvars:sway"]
    for t in frames:
        for k in names:
            va, vb = pa.GetAttribute(k).Get(t), pb.GetAttribute(k).Get(t)
            if k == "orientations":
                va, vb = ([(q.GetReal(), *q.GetImaginary()) for q in v] for v in (va, vb))
            if list(va) != list(vb):
                return f"{k} differs at frame {t}"
    return "equal"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bees", type=int, default=10000)
    ap.add_argument("--frames", type=int, default=240)
    ap.add_argument("--repeat", type=int, default=3, help="runs of each writer; the fastest counts")
    ap.add_argument("--keep", action="store_true", help="keep the files written")
    args = ap.parse_args()
    n, f = args.bees, args.frames
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="bench_usda."))
    try:
        a = make_arrays(n, f)
        raw = tmp / "arrays.f32"
        write_raw(a, raw)
        result = {"bees": n, "frames": f, "cpus": os.cpu_count()}
        best = lambda runs: min(runs, key=lambda r: r["seconds"])
        # Interleaved, so that a burst of load on a shared machine hits every writer alike.
        core_pos, core_full, ours_runs = [], [], []
        for _ in range(args.repeat):
            core_pos.append(usd_core(a, tmp / "core_positions.usda", full=False))
            core_full.append(usd_core(a, tmp / "core_full.usda", full=True))
            ours_runs.append(ours(raw, tmp / "ours", n, f))
        result["usd_core_positions"] = best(core_pos)
        result["usd_core_full"] = best(core_full)
        ours_out = best(ours_runs)
        result["beeswarm_full"] = {k: ours_out[k] for k in
                                   ("seconds", "frames_seconds", "finish_seconds", "bytes", "threads")}
        for k in ("usd_core_positions", "usd_core_full", "beeswarm_full"):
            r = result[k]
            r["mb_per_s"] = round(r["bytes"] / 1e6 / r["seconds"], 1)
        mb = result["beeswarm_full"]["mb_per_s"]
        result["speedup_per_byte_vs_full"] = round(mb / result["usd_core_full"]["mb_per_s"], 2)
        result["speedup_per_byte_vs_positions"] = round(mb / result["usd_core_positions"]["mb_per_s"], 2)
        result["speedup_same_data"] = round(result["usd_core_full"]["seconds"] / result["beeswarm_full"]["seconds"], 2)
        result["load_average"] = os.getloadavg()[0]
        result["values"] = same_values(tmp / "core_full.usda", ours_out["path"], [1, f // 2, f])
        print(json.dumps(result, indent=1))
    finally:
        if args.keep:
            print(f"files kept in {tmp}", file=sys.stderr)
        else:
            import shutil
            shutil.rmtree(tmp)


if __name__ == "__main__":
    main()
