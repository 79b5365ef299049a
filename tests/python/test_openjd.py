"""A wedge as an Open Job Description job, run by openjd-cli (PyPI) as a farm would.

`openjd check` must pass every template beeswarm writes (job.yaml, and template.yaml that
makes the wedge folder a Deadline Cloud job bundle), and `openjd run` must bake every
variant and gather the contact sheet, with caches identical to `beeswarm wedge --run`'s.
"""
import os
import pathlib
import shutil
import struct
import subprocess
import sys

import pytest

from conftest import _missing

SHOT = """# A small shot for a wedge of four variants.
[scene]
name = "meadow"
frames = [1, 12]
seed = 1

[[swarm]]
name = "bees"
count = 20
preset = "grassland"
spawn = { shape = "box", center = [0.0, 1.1, 0.0], size = [2.0, 1.0, 2.0] }

[output]
formats = ["glb", "csv"]
"""


@pytest.fixture(scope="session")
def openjd():
    """The openjd command: BEESWARM_OPENJD, else beside this Python (the test venv), else PATH."""
    path = os.environ.get("BEESWARM_OPENJD") or str(pathlib.Path(sys.executable).parent / "openjd")
    if not pathlib.Path(path).is_file():
        path = shutil.which("openjd")
    if not path:
        _missing("openjd-cli (pip install openjd-cli)")
    return path


def png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", head[16:24])


def wedge(beeswarm_bin, tmp_path, out, *extra):
    shot = tmp_path / "meadow.toml"
    shot.write_text(SHOT)
    return subprocess.run(
        [beeswarm_bin, "wedge", str(shot), "--vary", "seed=1..2",
         "--vary", "swarm.bees.params.speed=0.8,1.2", "--checkpoint-every", "5",
         "--out", str(out), *extra],
        check=True, capture_output=True, text=True,
    )


def test_openjd_checks_and_runs_the_wedge_job(beeswarm_bin, openjd, tmp_path):
    w = tmp_path / "wedge"
    wedge(beeswarm_bin, tmp_path, w)
    for template in (w / "job.yaml", w / "template.yaml"):
        check = subprocess.run([openjd, "check", str(template)], capture_output=True, text=True)
        assert check.returncode == 0, check.stdout + check.stderr
        assert "passes validation checks" in check.stdout

    run = subprocess.run([openjd, "run", str(w / "job.yaml")], capture_output=True, text=True)
    log = run.stdout + run.stderr
    assert run.returncode == 0, log
    assert "Session ended successfully" in log, log

    tracks = {}
    for k in range(1, 5):
        caches = w / "caches" / f"meadow_{k}"
        names = sorted(p.name for p in caches.iterdir())
        # Every cache and the preview, and no checkpoint left behind.
        assert names == [f"meadow_{k}.beeswarm.json", f"meadow_{k}.glb", f"meadow_{k}.preview.png",
                         f"meadow_{k}.tracks.csv"], names
        rows = (caches / f"meadow_{k}.tracks.csv").read_text().splitlines()
        assert len(rows) == 1 + 20 * 12
        tracks[k] = [r.split(",", 1)[1] for r in rows[1:]]
    # Four different variants: no two bake the same flight.
    assert len({tuple(t) for t in tracks.values()}) == 4

    sheet = w / "meadow.contact.png"
    width, height = png_size(sheet)
    preview_w, _ = png_size(w / "caches" / "meadow_1" / "meadow_1.preview.png")
    assert width > 4 * preview_w // 2 and height > 100, (width, height)

    # The plain local runner bakes the same caches.
    local = tmp_path / "local"
    wedge(beeswarm_bin, tmp_path, local, "--run", "--quiet")
    for k in range(1, 5):
        for suffix in ("glb", "tracks.csv", "preview.png", "beeswarm.json"):
            name = f"meadow_{k}.{suffix}"
            a = (w / "caches" / f"meadow_{k}" / name).read_bytes()
            b = (local / "caches" / f"meadow_{k}" / name).read_bytes()
            assert a == b, name


def test_one_task_of_the_bundle_bakes_one_variant(beeswarm_bin, openjd, tmp_path):
    """A farm runs the bundle's tasks one by one: Variant=3 bakes variant 3 alone."""
    w = tmp_path / "wedge"
    wedge(beeswarm_bin, tmp_path, w)
    run = subprocess.run(
        [openjd, "run", str(w / "template.yaml"), "--step", "Bake", "-tp", "Variant=3"],
        capture_output=True, text=True,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert (w / "caches" / "meadow_3" / "meadow_3.tracks.csv").is_file()
    assert not (w / "caches" / "meadow_1").exists()
