"""Shared fixtures for the Python-side tests (USD, glTF validator, Blender).

scripts/test sets:
  BEESWARM_BIN            the release binary to test
  BEESWARM_NODE_MODULES   a node_modules folder holding gltf-validator
  BEESWARM_REQUIRE_TOOLS  "1": a missing tool fails the test instead of skipping it
"""
import os
import pathlib
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SHARED_DATA = ROOT.parent / "shared" / "data"


def _missing(what):
    if os.environ.get("BEESWARM_REQUIRE_TOOLS") == "1":
        pytest.fail(f"{what} is required here (BEESWARM_REQUIRE_TOOLS=1) but missing")
    pytest.skip(f"{what} is not available; run ./scripts/test to install it")


@pytest.fixture(scope="session")
def beeswarm_bin():
    path = os.environ.get("BEESWARM_BIN") or str(ROOT / "target" / "release" / "beeswarm")
    if not pathlib.Path(path).is_file():
        _missing(f"the beeswarm binary ({path})")
    return path


@pytest.fixture(scope="session")
def node_modules():
    path = os.environ.get("BEESWARM_NODE_MODULES", "")
    if not path or not (pathlib.Path(path) / "gltf-validator").is_dir() or not shutil.which("node"):
        _missing("node with the gltf-validator package (BEESWARM_NODE_MODULES)")
    return path


@pytest.fixture(scope="session")
def shared_data():
    if not SHARED_DATA.is_dir():
        pytest.skip(f"{SHARED_DATA} is absent: the recorded insect flights are not available here")
    return SHARED_DATA


def bake(bin_path, shot_text, out_dir, *args, name="shot.toml"):
    """Writes a shot and bakes it; returns the completed process (check=True)."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    shot = out_dir / name
    shot.write_text(shot_text)
    return subprocess.run(
        [bin_path, "bake", str(shot), "--out", str(out_dir), "--progress", "none", *args],
        check=True, capture_output=True, text=True,
    )


def read_tracks(path):
    """Tracks CSV → {id: {frame: row dict of floats}}."""
    import csv
    tracks = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            bee = int(row["id"])
            frame = int(row["frame"])
            # A channel another swarm's model records is empty for this bee: None.
            tracks.setdefault(bee, {})[frame] = {k: float(v) if v != "" else None
                                                 for k, v in row.items()}
    return tracks
