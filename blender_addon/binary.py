"""Finding the `beeswarm` binary, in this order:

1. a path given explicitly: the operator's `binary_path`, else the add-on's preference
   (empty by default; set, it is a deliberate choice and wins, and a wrong one is an error);
2. the binary bundled in the extension, `bin/beeswarm` beside this file
   (scripts/build-extension puts it there), so a fresh install works without PATH;
3. `beeswarm` on PATH;
4. `target/release/beeswarm` (or `target/debug/`) of the repository the add-on folder sits
   in, searched upwards (a development link to blender_addon/).
"""
import json
import os
import pathlib
import shutil
import subprocess
import time

EXE = "beeswarm.exe" if os.name == "nt" else "beeswarm"
_cache = {"at": 0.0, "value": None, "start": None}


def _executable(p):
    return p is not None and p.is_file() and os.access(p, os.X_OK)


def bundled(addon_dir=None):
    """The binary packed into the extension (`bin/beeswarm` in the add-on's folder), or None.
    Blender's installer extracts the zip without file modes, so the first call makes it
    executable again."""
    p = pathlib.Path(addon_dir or pathlib.Path(__file__).parent) / "bin" / EXE
    if not p.is_file():
        return None
    if not os.access(p, os.X_OK):
        try:
            p.chmod(p.stat().st_mode | 0o755)
        except OSError:
            return None
    return p if _executable(p) else None


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
    """The binary found without a preference (bundled, PATH, repository), or None. Cached
    for two seconds (the panel draws often)."""
    start = start or pathlib.Path(__file__).parent
    now = time.monotonic()
    if use_cache and _cache["start"] == str(start) and now - _cache["at"] < 2.0:
        return _cache["value"]
    found = bundled(start)
    if found is None:
        on_path = shutil.which("beeswarm")
        found = pathlib.Path(on_path) if on_path else search_upwards(start)
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
    return None, ("No beeswarm binary found: install the extension zip that "
                  "scripts/build-extension makes (the binary is inside), put beeswarm on "
                  "PATH, or set its path in the add-on's preferences")


# The models a binary too old to list them (no `models` subcommand) or a missing binary
# leaves: the bee model with Table I's presets, as `beeswarm models --json` describes it.
FALLBACK_MODELS = {
    "models": [{
        "name": "bee",
        "summary": "Paper 000, Chen et al.: body oscillation, visual obstacle avoidance with "
                   "roll, curl-noise flight and SPH repulsion (Eq. 1)",
        "default_preset": "nest",
        "presets": [
            {"name": "nest", "doc": "Table I \"around nest\" (350 bees): the defaults"},
            {"name": "grassland", "doc": "Table I \"over grassland\" (1000 bees)"},
            {"name": "optimized", "doc": "Table I \"optimized values\""},
        ],
        "params": [],
        "channels": [],
    }]
}
_models_cache = {}


def models(explicit=""):
    """(document, reason): the binary's `beeswarm models --json`, or the built-in bee-only
    list and why. Cached per binary path and modification time: Blender asks for menu
    items on every redraw, and a subprocess per redraw would stall the UI."""
    path, msg = resolve(explicit)
    if path is None:
        return FALLBACK_MODELS, msg
    try:
        key = (str(path), path.stat().st_mtime_ns)
    except OSError as e:
        return FALLBACK_MODELS, f"Cannot read {path}: {e}"
    if key in _models_cache:
        return _models_cache[key]
    try:
        run = subprocess.run([str(path), "models", "--json"], capture_output=True,
                             text=True, timeout=20)
        if run.returncode != 0:
            last = (run.stderr.strip().splitlines() or [f"exit code {run.returncode}"])[-1]
            raise RuntimeError(last)
        doc = json.loads(run.stdout)
        if not doc.get("models") or not all(m.get("presets") for m in doc["models"]):
            raise RuntimeError("it listed no models")
        result = (doc, "")
    except (OSError, subprocess.SubprocessError, ValueError, RuntimeError) as e:
        result = (FALLBACK_MODELS,
                  f"{path.name} could not list its models ({e}); offering the bee model only")
    _models_cache[key] = result
    return result


def model_info(doc, name):
    """The entry of model `name` in a models document, or None."""
    return next((m for m in doc["models"] if m["name"] == name), None)
