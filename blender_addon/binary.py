"""Finding the `beeswarm` binary: the add-on's preference when set, else PATH, else a
`target/release/beeswarm` (or `target/debug/`) in the repository the add-on sits in,
searched upwards from the add-on's folder."""
import os
import pathlib
import shutil
import time

EXE = "beeswarm.exe" if os.name == "nt" else "beeswarm"
_cache = {"at": 0.0, "value": None, "start": None}


def _executable(p):
    return p is not None and p.is_file() and os.access(p, os.X_OK)


def search_upwards(start, max_levels=8):
    """`target/release/beeswarm` in `start` or one of its parents (release before debug)."""
    here = pathlib.Path(start).resolve()
    for d in [here, *here.parents][: max_levels + 1]:
        for profile in ("release", "debug"):
            cand = d / "target" / profile / EXE
            if _executable(cand):
                return cand
    return None


def discover(start=None, use_cache=True):
    """The binary found without a preference, or None. Cached for two seconds (the panel
    draws often)."""
    start = start or pathlib.Path(__file__).parent
    now = time.monotonic()
    if use_cache and _cache["start"] == str(start) and now - _cache["at"] < 2.0:
        return _cache["value"]
    found = shutil.which("beeswarm")
    found = pathlib.Path(found) if found else search_upwards(start)
    _cache.update(at=now, value=found, start=str(start))
    return found


def resolve(explicit=""):
    """(path or None, message). `explicit`: an operator's or the preference's path."""
    if explicit:
        p = pathlib.Path(os.path.expanduser(explicit))
        if p.is_dir():
            p = p / EXE
        if _executable(p):
            return p, f"beeswarm: {p}"
        if p.exists():
            return None, f"The beeswarm binary at {p} is not executable"
        return None, f"No beeswarm binary at {p}"
    found = discover()
    if found:
        return found, f"beeswarm: {found}"
    return None, ("No beeswarm binary found: put it on PATH, build it with "
                  "`cargo build --release`, or set its path in the add-on's preferences")
