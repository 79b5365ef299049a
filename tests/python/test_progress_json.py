"""The machine-readable progress stream the Blender add-on and farm tools rely on."""
import json
import os
import subprocess

from conftest import read_tracks

SHOT = """
[scene]
name = "progress"
fps = 24
frames = [5, 16]
[[swarm]]
count = 25
[output]
formats = ["csv"]
"""


def test_progress_json_reports_every_frame_then_the_outputs(beeswarm_bin, tmp_path):
    shot = tmp_path / "progress.toml"
    shot.write_text(SHOT)
    out = tmp_path / "caches"
    run = subprocess.run([beeswarm_bin, "bake", str(shot), "--out", str(out), "--progress", "json"],
                         capture_output=True, text=True, check=True)
    events = [json.loads(line) for line in run.stdout.splitlines()]
    progress = [e for e in events if e["event"] == "progress"]
    assert [e["frame"] for e in progress] == list(range(5, 17))
    assert [e["done"] for e in progress] == list(range(1, 13))
    assert all(e["total"] == 12 for e in progress)
    assert all(b["elapsed_s"] >= a["elapsed_s"] >= 0 for a, b in zip(progress, progress[1:]))
    assert events[-1]["event"] == "done"
    outputs = events[-1]["outputs"]
    # The caches, then the cache set's manifest (docs/caches.md).
    assert outputs == [str(out / "progress.tracks.csv"), str(out / "progress.beeswarm.json")]
    assert all(os.path.isabs(p) and os.path.isfile(p) for p in outputs)
    tracks = read_tracks(outputs[0])
    assert len(tracks) == 25 and all(sorted(t) == list(range(5, 17)) for t in tracks.values())


def test_bake_without_a_shot_writes_the_default_into_out(beeswarm_bin, tmp_path):
    subprocess.run([beeswarm_bin, "bake", "--format", "csv", "--frames", "1:6", "--progress", "none", "--quiet"],
                   cwd=tmp_path, check=True, capture_output=True)
    tracks = read_tracks(tmp_path / "out" / "beeswarm_default.tracks.csv")
    assert len(tracks) == 200
