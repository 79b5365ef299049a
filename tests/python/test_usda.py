"""The USDA PointInstancer cache, read back through usd-core (pxr).

Bakes one small two-swarm shot with the release binary, once as a single layer and once
split into value clips, then checks: every registered UsdValidation validator passes,
the stage metadata, and that positions, orientations, velocities, pitch, roll and sway
read through pxr equal the tracks CSV of the same bake.
"""
import filecmp
import subprocess

import pytest

from conftest import bake, read_tracks

pxr = pytest.importorskip("pxr", reason="usd-core is not installed")
np = pytest.importorskip("numpy")
from pxr import Usd, UsdGeom, UsdValidation  # noqa: E402

FPS = 24
FIRST, LAST = 3, 31
CLIP_FRAMES = 7  # does not divide the 29 frames: the last clip is short


def bake_usda(beeswarm_bin, clip_frames, out_dir):
    bake(beeswarm_bin, shot_text(clip_frames), out_dir, "--format", "usda,csv")


def shot_text(clip_frames):
    return f"""
[scene]
name = "usda_test"
fps = {FPS}
frames = [{FIRST}, {LAST}]
seed = 11

[[swarm]]
name = "workers"
count = 23
preset = "nest"
spawn = {{ shape = "box", center = [0.0, 1.0, 0.6], size = [1.2, 0.6, 0.6] }}

[[swarm]]
name = "scouts"
count = 5
spawn = {{ shape = "box", center = [0.5, 1.5, 0.0], size = [0.4, 0.4, 0.4] }}

[[target]]
type = "nest"
name = "hive"
position = [0.0, 1.0, 0.0]

[output]
usda_clip_frames = {clip_frames}
"""


@pytest.fixture(scope="module")
def baked(beeswarm_bin, tmp_path_factory):
    """{"single": dir, "clips": dir}, each holding usda_test.usda and the tracks CSV."""
    out = {}
    for mode, clip_frames in (("single", 0), ("clips", CLIP_FRAMES)):
        d = tmp_path_factory.mktemp(mode)
        bake_usda(beeswarm_bin, clip_frames, d)
        out[mode] = d
    return out


def open_stage(d):
    return Usd.Stage.Open(str(d / "usda_test.usda"))


def instancers(stage):
    return [UsdGeom.PointInstancer(p) for p in stage.Traverse() if p.IsA(UsdGeom.PointInstancer)]


def run_validators(stage):
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    assert len(validators) > 10, "usd-core registered fewer validators than expected"
    errors = UsdValidation.ValidationContext(validators).Validate(stage)
    return [f"{e.GetName()}: {e.GetMessage()}" for e in errors if not e.HasNoError()]


@pytest.mark.parametrize("mode", ["single", "clips"])
def test_all_validators_pass(baked, mode):
    stage = open_stage(baked[mode])
    assert run_validators(stage) == []


@pytest.mark.parametrize("mode", ["single", "clips"])
def test_stage_metadata(baked, mode, beeswarm_bin):
    stage = open_stage(baked[mode])
    assert stage.GetDefaultPrim().GetPath() == "/usda_test"
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert stage.GetStartTimeCode() == FIRST
    assert stage.GetEndTimeCode() == LAST
    assert stage.GetTimeCodesPerSecond() == FPS
    assert stage.GetFramesPerSecond() == FPS
    data = stage.GetRootLayer().customLayerData
    assert data["shotName"] == "usda_test"
    assert data["seed"] == 11
    version = subprocess.run([beeswarm_bin, "--version"], capture_output=True, text=True).stdout
    assert data["toolVersion"] in version


@pytest.mark.parametrize("mode", ["single", "clips"])
def test_one_instancer_per_swarm_with_constant_instances(baked, mode):
    stage = open_stage(baked[mode])
    pis = {pi.GetPath().name: pi for pi in instancers(stage)}
    assert sorted(pis) == ["scouts", "workers"]
    for name, count in (("workers", 23), ("scouts", 5)):
        pi = pis[name]
        assert pi.GetPath().GetParentPath() == "/usda_test"
        ids = list(pi.GetIdsAttr().Get())
        assert len(ids) == count and len(set(ids)) == count
        assert pi.GetIdsAttr().GetTypeName() == "int64[]"
        assert list(pi.GetProtoIndicesAttr().Get()) == [0] * count
        (proto,) = pi.GetPrototypesRel().GetTargets()
        assert proto.HasPrefix(pi.GetPath())
        assert proto == pi.GetPath().AppendPath("Prototypes/honeybee")
        for attr in (pi.GetPositionsAttr(), pi.GetOrientationsAttr(),
                     pi.GetVelocitiesAttr(), pi.GetAngularVelocitiesAttr()):
            assert attr.GetTimeSamples() == list(range(FIRST, LAST + 1)), attr.GetName()
            for t in (FIRST, 17, LAST):
                assert len(attr.Get(t)) == count
        # Each bee's scale is constant through the shot: one static value, the same at
        # every time, uniform on the three axes.
        scales = pi.GetScalesAttr()
        assert scales.GetTimeSamples() == []
        assert len(scales.Get()) == count
        assert list(scales.Get(FIRST)) == list(scales.Get(LAST))
        assert all(s[0] == s[1] == s[2] and 0.5 < s[0] < 1.5 for s in scales.Get())
        assert pi.GetOrientationsAttr().GetTypeName() == "quath[]"
        for pv_name in ("pitch", "roll", "sway"):
            pv = UsdGeom.PrimvarsAPI(pi).GetPrimvar(pv_name)
            assert pv.GetInterpolation() == UsdGeom.Tokens.vertex
            assert len(pv.Get(10)) == count


def test_prototype_is_a_bee_at_real_scale(baked):
    stage = open_stage(baked["single"])
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath("/usda_test/workers"))
    (proto,) = pi.GetPrototypesRel().GetTargets()
    assert proto.name == "honeybee"
    assert [c.GetName() for c in stage.GetPrimAtPath(proto).GetChildren()] == ["body", "wing_l", "wing_r"]
    body = UsdGeom.Mesh(stage.GetPrimAtPath(proto.AppendChild("body")))
    wing_l = UsdGeom.Mesh(stage.GetPrimAtPath(proto.AppendChild("wing_l")))
    wing_r = UsdGeom.Mesh(stage.GetPrimAtPath(proto.AppendChild("wing_r")))
    lo, hi = (np.array(v) for v in body.GetExtentAttr().Get())
    size = hi - lo
    assert size[0] == pytest.approx(0.012, rel=1e-4), "12 mm long, along +X"
    assert size[1] < 0.005 and size[2] < 0.005
    lo, hi = (np.array(v) for v in wing_r.GetExtentAttr().Get())
    assert hi[2] > 0.008 and lo[2] > 0, "the right wing spans +Z"
    lo, hi = (np.array(v) for v in wing_l.GetExtentAttr().Get())
    assert lo[2] < -0.008 and hi[2] < 0, "the left wing spans -Z"
    for mesh in (body, wing_l, wing_r):
        pts = np.array(mesh.GetPointsAttr().Get())
        assert np.allclose(UsdGeom.Boundable.ComputeExtentFromPlugins(mesh, 0), mesh.GetExtentAttr().Get())
        assert pts.shape[0] == max(mesh.GetFaceVertexIndicesAttr().Get()) + 1


@pytest.mark.parametrize("mode", ["single", "clips"])
def test_values_equal_tracks_csv(baked, mode):
    stage = open_stage(baked[mode])
    tracks = read_tracks(baked[mode] / "usda_test.tracks.csv")
    checked = 0
    for pi in instancers(stage):
        ids = list(pi.GetIdsAttr().Get())
        pvs = UsdGeom.PrimvarsAPI(pi)
        for frame in (FIRST, 9, 10, 18, LAST):
            rows = [tracks[i][frame] for i in ids]
            col = lambda *keys: np.array([[r[k] for k in keys] for r in rows], dtype=np.float32)
            # Floats are written shortest round-trip: equal to the float32 in the CSV.
            np.testing.assert_array_equal(np.array(pi.GetPositionsAttr().Get(frame)), col("x", "y", "z"))
            np.testing.assert_array_equal(np.array(pi.GetVelocitiesAttr().Get(frame)), col("vx", "vy", "vz"))
            for name in ("pitch", "roll", "sway"):
                np.testing.assert_array_equal(np.array(pvs.GetPrimvar(name).Get(frame)), col(name)[:, 0])
            # quath: (real, i, j, k), the nearest halves of the CSV's float quaternion.
            got = np.array([[q.GetReal(), *q.GetImaginary()] for q in pi.GetOrientationsAttr().Get(frame)])
            want = col("qw", "qx", "qy", "qz")
            np.testing.assert_array_equal(got.astype(np.float16), want.astype(np.float16))
            np.testing.assert_allclose(got, want, rtol=2.0**-11, atol=2.0**-25)
            checked += len(ids)
    assert checked == 5 * (23 + 5)


@pytest.mark.parametrize("mode", ["single", "clips"])
def test_extent_bounds_every_instance(baked, mode):
    stage = open_stage(baked[mode])
    for pi in instancers(stage):
        for t in (FIRST, 12, LAST):
            lo, hi = (np.array(v) for v in pi.GetExtentAttr().Get(t))
            exact_lo, exact_hi = (np.array(v) for v in pi.ComputeExtentAtTime(t, t))
            assert np.all(lo <= exact_lo + 1e-6) and np.all(hi >= exact_hi - 1e-6)
            assert np.all(hi - lo <= exact_hi - exact_lo + 0.05), "conservative, but not loose"


def test_clips_read_back_like_the_single_file(baked):
    single, clips = open_stage(baked["single"]), open_stage(baked["clips"])
    main = (baked["clips"] / "usda_test.usda").read_text()
    assert "timeSamples" not in main, "the main layer holds no samples in clips mode"
    clip_dir = baked["clips"] / "usda_test.clips"
    n_clips = -(-(LAST - FIRST + 1) // CLIP_FRAMES)
    assert sorted(p.name for p in clip_dir.iterdir()) == sorted(
        [f"usda_test.{i:04d}.usda" for i in range(1, n_clips + 1)] + ["usda_test.manifest.usda"])
    assert not list(baked["clips"].glob(".*")), "no temporary file left"
    # Integer frames, and sub-frame times on both sides of every clip boundary (motion blur).
    times = list(range(FIRST, LAST + 1)) + [FIRST + k * CLIP_FRAMES + d for k in range(n_clips) for d in (-0.5, 0.25)]
    for pi in instancers(single):
        other = clips.GetPrimAtPath(pi.GetPath())
        for attr in pi.GetPrim().GetAttributes():
            twin = other.GetAttribute(attr.GetName())
            assert twin.GetTypeName() == attr.GetTypeName()
            assert twin.GetMetadata("interpolation") == attr.GetMetadata("interpolation")
            for t in times:
                assert twin.Get(t) == attr.Get(t), f"{attr.GetPath()} at {t}"


def test_bakes_are_byte_identical(beeswarm_bin, baked, tmp_path):
    for mode, clip_frames in (("single", 0), ("clips", CLIP_FRAMES)):
        d = tmp_path / mode
        bake_usda(beeswarm_bin, clip_frames, d)
        files = [p.relative_to(d) for p in sorted(d.rglob("*.usda"))]
        assert files and files == [p.relative_to(baked[mode]) for p in sorted(baked[mode].rglob("*.usda"))]
        for f in files:
            assert filecmp.cmp(d / f, baked[mode] / f, shallow=False), f


def test_rebake_in_single_mode_removes_old_clips(beeswarm_bin, tmp_path):
    bake_usda(beeswarm_bin, CLIP_FRAMES, tmp_path)
    assert (tmp_path / "usda_test.clips").is_dir()
    bake_usda(beeswarm_bin, 0, tmp_path)
    assert not (tmp_path / "usda_test.clips").exists()
    assert run_validators(open_stage(tmp_path)) == []


@pytest.mark.parametrize("clip_frames", [0, CLIP_FRAMES])
def test_interrupted_bake_keeps_the_previous_cache(beeswarm_bin, tmp_path, clip_frames):
    """Ctrl-C in the middle of a bake: the earlier cache is byte for byte intact, and no
    temporary or scratch file is left."""
    import json
    import signal

    out = tmp_path / "out"
    bake_usda(beeswarm_bin, clip_frames, out)
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    long_shot = shot_text(clip_frames).replace(f"frames = [{FIRST}, {LAST}]", "frames = [1, 100000]")
    (tmp_path / "long.toml").write_text(long_shot)
    proc = subprocess.Popen(
        [beeswarm_bin, "bake", str(tmp_path / "long.toml"), "--out", str(out),
         "--format", "usda,csv", "--progress", "json"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for line in proc.stdout:
            event = json.loads(line)
            if event.get("event") == "progress" and event["done"] >= 2 * CLIP_FRAMES + 3:
                break  # frames (and, with clips, finished clip layers) are in flight
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode != 0
    after = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert sorted(after) == sorted(before)
    assert all(after[p] == before[p] for p in before)
