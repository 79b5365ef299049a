"""The bake operator: scene or shot file → `beeswarm bake` subprocess → import.

Interactive: a modal operator with a timer drains the reader thread's queue, drives the
window manager's progress and the status bar; Esc kills the bake (the binary writes its
outputs atomically, so the previous cache stays) and imports nothing. In background mode
(`blender -b`, a farm, the tests) and when called from a script (EXEC_DEFAULT) it runs to
completion synchronously.
"""
import atexit
import os
import pathlib
import re
import shutil
import tempfile
import time

import bpy
from bpy.props import EnumProperty, StringProperty

from . import binary, display, importer, motion, props, runner, shot_builder

_active = {"job": None}  # one bake at a time

FORMAT_FILES = {"USD": ("usda", ".usda"), "GLTF": ("glb", ".glb")}


class BakeError(Exception):
    pass


def _blend_dir():
    path = bpy.data.filepath
    return pathlib.Path(path).parent if path else None


def _unsaved_dir():
    """Where an unsaved file's shots and caches go: a folder in Blender's own temporary
    directory for this session (`bpy.app.tempdir`, one per running Blender, so per open
    file; Blender removes it when it quits), never a folder shared by every Blender."""
    d = pathlib.Path(bpy.app.tempdir or tempfile.gettempdir()) / "beeswarm_unsaved"
    d.mkdir(parents=True, exist_ok=True)
    return d


def cache_dir(settings, shot_name):
    """`<cache folder>/<shot>/`: by default `//beeswarm_cache/<shot>/` beside the .blend;
    for an unsaved file (where `//` means nothing) under Blender's temporary directory."""
    raw = settings.cache_dir or "//beeswarm_cache/"
    if raw.startswith("//") and not bpy.data.filepath:
        base = _unsaved_dir() / "beeswarm_cache"
    else:
        base = pathlib.Path(bpy.path.abspath(raw))
    return base / shot_name


def staging_dir(out_dir):
    """The folder a bake writes into before it replaces the cache (same file system, so
    the final renames are cheap and a cancelled bake leaves the cache untouched)."""
    return out_dir.parent / f".{out_dir.name}.baking"


def _replace_path(src, dst):
    """Moves src over dst (a file, or a folder such as `<name>.clips/`)."""
    if src.is_dir() and dst.exists():
        old = dst.with_name(f".{dst.name}.old")
        shutil.rmtree(old, ignore_errors=True)
        os.replace(dst, old)
        os.replace(src, dst)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(src, dst)


def _written_by_addon(path):
    try:
        with open(path, encoding="utf-8") as f:
            return f.readline().startswith(shot_builder.HEADER_MARK)
    except OSError:
        return False


def _kill_running_bake():
    """Blender quitting or the add-on going away: the bake runs in its own process group,
    so it would outlive Blender otherwise."""
    job = _active["job"]
    if job is not None and job.process is not None and job.process.running():
        job.process.cancel(grace=0.5)
        job.discard()


atexit.register(_kill_running_bake)


_KEY = re.compile(r"\b(swarm|obstacle|target)\[(\d+)\]")


def name_blender_objects(message, shot):
    """The binary names shot keys (`obstacle[2].radius`); after each, the Blender object or
    swarm it came from, so the artist knows what to fix: `obstacle[2] (Blender object
    'post').radius`."""
    if not shot:
        return message
    tables = {"swarm": shot.get("swarm", []), "obstacle": shot.get("obstacle", []),
              "target": shot.get("target", [])}

    def label(m):
        kind, i = m.group(1), int(m.group(2))
        items = tables[kind]
        if i >= len(items) or not items[i].get("name"):
            return m.group(0)
        what = "swarm" if kind == "swarm" else "Blender object"
        return f"{m.group(0)} ({what} '{items[i]['name']}')"
    return _KEY.sub(label, message)


def ensure_swarm(settings):
    """A scene that never had a swarm bakes the default one (as the panel shows it)."""
    if not len(settings.swarms):
        props.add_swarm(settings)


class Job:
    """Everything one bake needs, prepared before the subprocess starts."""

    def __init__(self, context, op):
        scene = context.scene
        self.settings = scene.beeswarm
        self.format = op.format
        # Also baked besides the imported format (the panel's Formats; an operator call
        # bakes only `format` unless it says otherwise).
        self.formats = [self.format] + sorted(set(op.also_formats) - {self.format})
        self.keep_scene_range = False
        self.shot = None
        self.warnings = []
        bin_path, msg = binary.resolve(op.binary_path or props.preference_binary(context))
        if bin_path is None:
            raise BakeError(msg)
        self.binary = bin_path
        self.shot_text = None
        if op.shot_path:
            shot = pathlib.Path(bpy.path.abspath(op.shot_path))
            if not shot.is_file():
                raise BakeError(f"No shot file at {shot}")
            try:
                self.name, self.fps, self.frames = importer.shot_info(str(shot))
            except (OSError, ValueError) as e:  # tomllib.TOMLDecodeError is a ValueError
                # The binary reports it with line and column; let it speak.
                self.name, self.fps, self.frames = shot.stem, None, None
                self.info_error = str(e)
            self.bake_shot = shot
        else:
            ensure_swarm(self.settings)
            try:
                shot, self.warnings = shot_builder.build_shot(scene, self.settings)
            except shot_builder.ShotBuildError as e:
                raise BakeError(str(e)) from None
            self.shot = shot
            self.keep_scene_range = not self.settings.use_scene_frames
            self.name = shot["scene"]["name"]
            self.fps = shot["scene"]["fps"]
            self.frames = tuple(shot["scene"]["frames"])
            source = os.path.basename(bpy.data.filepath) if bpy.data.filepath else "an unsaved file"
            self.shot_text = shot_builder.shot_toml(shot, source)
        self.out_dir = cache_dir(self.settings, self.name)
        # The shot built from the scene lives with its cache, `<cache>/<name>.shot.toml`,
        # and both are replaced together only when the bake succeeds (commit()).
        self.shot_path = (self.out_dir / f"{self.name}.shot.toml" if self.shot_text is not None
                          else self.bake_shot)
        if self.shot_text is not None and self.shot_path.exists() \
                and not _written_by_addon(self.shot_path):
            raise BakeError(f"{self.shot_path} exists and was not written by the add-on; "
                            f"give the shot another name (it would be overwritten)")
        self.staging = staging_dir(self.out_dir)
        shutil.rmtree(self.staging, ignore_errors=True)  # a bake Blender never finished
        self.staging.mkdir(parents=True)
        if self.shot_text is not None:
            self.bake_shot = self.staging / self.shot_path.name
            self.bake_shot.write_text(self.shot_text, encoding="utf-8")
            shot_builder.write_mesh_files(self.shot, self.staging)
        fmts = [FORMAT_FILES[f][0] for f in self.formats]
        self.argv = runner.bake_argv(self.binary, self.bake_shot, self.staging, fmts + ["csv"])
        self.process = None
        self.started = None

    def start(self):
        self.started = time.monotonic()
        try:
            self.process = runner.BakeProcess(self.argv, cwd=str(self.bake_shot.parent))
        except OSError as e:
            self.discard()
            raise BakeError(f"Cannot run {self.binary}: {e}") from None

    def commit(self):
        """After exit 0: every file the bake wrote (and the shot it baked) replaces its
        namesake in the cache folder; then the staging folder goes."""
        self.out_dir.mkdir(parents=True, exist_ok=True)
        for p in sorted(self.staging.iterdir()):
            if p.name.endswith(".tmp"):
                continue
            _replace_path(p, self.out_dir / p.name)
        shutil.rmtree(self.staging, ignore_errors=True)

    def discard(self):
        """A failed or cancelled bake: its partial outputs and its shot go; the cache and
        the shot beside it stay as they were."""
        shutil.rmtree(self.staging, ignore_errors=True)

    def outputs(self):
        """(cache path, tracks CSV path) from the `done` event, else the expected names."""
        ext = FORMAT_FILES[self.format][1]
        # The `done` event names the staging folder's files; they are in out_dir now.
        outs = [self.out_dir / pathlib.Path(p).name for p in (self.process.outputs or [])]
        cache = next((p for p in outs if p.suffix in (ext, ".gltf")), None)
        csv = next((p for p in outs if p.name.endswith(".tracks.csv")), None)
        cache = cache or self.out_dir / f"{self.name}{ext}"
        csv = csv or self.out_dir / f"{self.name}.tracks.csv"
        return cache, csv

    def finish(self, context):
        """After exit 0: import. Returns the collection."""
        cache, csv = self.outputs()
        if not cache.is_file():
            raise BakeError(f"beeswarm reported success but wrote no {cache.name}")
        name = cache.name[: -len(cache.suffix)]
        fps, frames = self.fps, self.frames
        if fps is None or frames is None:
            _, fps, frames = importer.shot_info(str(self.bake_shot))

        def after(collection, objects):
            if self.settings.instance_motion:
                motion.attach(context, name, self.format, objects, csv, frames, collection)
            asset = self.settings.asset
            if asset is not None and self.format == "USD":
                if asset.name in collection.all_objects:
                    raise BakeError(f"The insect asset '{asset.name}' is part of the swarm")
                if not display.use_asset(objects, asset):
                    raise BakeError(f"No instancer in {cache.name} to draw '{asset.name}' on")
            display.apply(context.scene, objects)

        try:
            return importer.import_cache(context, name, str(cache), self.format, fps, frames,
                                         after=after, set_range=not self.keep_scene_range)
        except Exception as e:
            raise BakeError(f"Import of {cache.name} failed: {e}") from e

    def keep_failed_shot(self):
        """A failing bake's shot (built from the scene) is worth reading, but not beside the
        cache it did not make: it moves to Blender's session temp folder and the message
        points there."""
        if self.shot_text is None or not self.bake_shot.is_file():
            return None
        kept = pathlib.Path(bpy.app.tempdir or tempfile.gettempdir()) / "beeswarm_failed"
        kept.mkdir(parents=True, exist_ok=True)
        kept = kept / self.bake_shot.name
        shutil.copyfile(self.bake_shot, kept)
        return kept

    def failure(self):
        text = name_blender_objects(
            runner.error_message(self.process.stderr, self.process.returncode), self.shot)
        kept = self.keep_failed_shot()
        if kept is not None:
            text = text.replace(str(self.bake_shot), str(kept))
        if self.shot is not None and f"{self.name}.shot.toml:" in text:
            # The quoted lines are the shot file's, in its Y-up axes.
            text += "\n(The shot file is Y-up: its [x, y, z] is Blender's (x, −z, y).)"
        return text


class BEESWARM_OT_bake(bpy.types.Operator):
    """Bake the swarm with the beeswarm binary and import the cache (Esc cancels)"""

    bl_idname = "beeswarm.bake"
    bl_label = "Bake Swarm"
    # UNDO: one undo step per bake; undoing it restores the previous import (a glTF swarm
    # entirely; a USD swarm's objects, which read the cache file now on disk).
    bl_options = {"REGISTER", "UNDO"}

    shot_path: StringProperty(name="Shot File", subtype="FILE_PATH", default="",
                              description="Shot to bake; empty = build the shot from the scene")
    format: EnumProperty(name="Format", items=props.FORMATS, default="USD",
                         description="The cache to bake and import")
    also_formats: EnumProperty(name="Also Bake", items=props.FORMATS, options={"ENUM_FLAG"},
                               default=set(), description="Caches baked besides `format`")
    binary_path: StringProperty(name="Binary", subtype="FILE_PATH", default="",
                                description="beeswarm binary; empty = the add-on's preference")

    _timer = None
    _job = None

    @classmethod
    def poll(cls, context):
        return context.scene is not None and _active["job"] is None

    # -- synchronous (background, scripts) ------------------------------------------------
    def execute(self, context):
        job = self._prepare(context)
        if job is None:
            return {"CANCELLED"}
        if not self._start(job):
            return {"CANCELLED"}
        _active["job"] = job
        try:
            last = 0.0
            while True:
                ev = job.process.wait_event(timeout=0.5)
                if ev is None:
                    continue
                kind, payload = ev
                if kind == "progress" and time.monotonic() - last > 2.0 and bpy.app.background:
                    last = time.monotonic()
                    print(f"beeswarm: frame {payload.get('frame')} "
                          f"({payload.get('done', '?')}/{payload.get('total')})", flush=True)
                if kind == "exit":
                    break
        except BaseException:  # Ctrl-C in a background Blender: stop the bake too
            job.process.cancel()
            job.discard()
            _active["job"] = None
            raise
        try:
            return self._complete(context, job)
        finally:
            _active["job"] = None

    # -- interactive ------------------------------------------------------------------------
    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        job = self._prepare(context)
        if job is None or not self._start(job):
            return {"CANCELLED"}
        _active["job"] = job
        self._job = job
        wm = context.window_manager
        wm.progress_begin(0, 100)
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        self._status(context, f"Baking {job.name}… (Esc to cancel)")
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        job = self._job
        if event.type == "ESC" and event.value == "PRESS":
            job.process.cancel()
            job.discard()
            self._end_modal(context)
            msg = f"Bake of {job.name} cancelled; the previous cache is unchanged"
            context.scene.beeswarm.last_message = msg
            self.report({"WARNING"}, msg)
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        exited = False
        for kind, payload in job.process.poll():
            if kind == "progress":
                frac = runner.fraction(payload)
                context.window_manager.progress_update(frac * 100.0)
                self._status(context, f"Baking {job.name}: frame {payload.get('frame')} "
                                      f"({payload.get('done', '?')}/{payload.get('total')}), "
                                      f"{payload.get('elapsed_s', 0):.1f} s (Esc to cancel)")
            elif kind == "exit":
                exited = True
        if not exited:
            return {"RUNNING_MODAL"}
        self._end_modal(context)
        return self._complete(context, job)

    def cancel(self, context):  # Blender closing the window mid-bake
        if self._job is not None and self._job.process is not None:
            self._job.process.cancel()
            self._job.discard()
        self._end_modal(context)

    # -- shared -------------------------------------------------------------------------------
    def _prepare(self, context):
        try:
            job = Job(context, self)
        except BakeError as e:
            self._fail(context, str(e))
            return None
        except OSError as e:
            self._fail(context, f"Cannot write the shot: {e}")
            return None
        if job.settings.asset is not None and job.format != "USD":
            job.warnings.append(f"Insect Asset '{job.settings.asset.name}' is used with USD "
                                f"only; the glTF bees keep their own meshes")
        for w in job.warnings:
            self.report({"WARNING"}, w)
        return job

    def _start(self, job):
        try:
            job.start()
        except BakeError as e:
            self._fail(bpy.context, str(e))
            return False
        return True

    def _complete(self, context, job):
        rc = job.process.returncode
        if rc != 0:
            message = job.failure()
            job.discard()
            self._fail(context, f"Bake failed: {message}")
            return {"CANCELLED"}
        try:
            job.commit()
        except OSError as e:
            job.discard()
            self._fail(context, f"Cannot move the new cache into {job.out_dir}: {e}")
            return {"CANCELLED"}
        try:
            coll = job.finish(context)
        except BakeError as e:
            self._fail(context, str(e))
            return {"CANCELLED"}
        secs = time.monotonic() - job.started
        msg = f"Baked {coll.name} in {secs:.1f} s → {job.outputs()[0]}"
        context.scene.beeswarm.last_message = msg
        self.report({"INFO"}, msg)
        return {"FINISHED"}

    def _fail(self, context, msg):
        try:
            context.scene.beeswarm.last_message = "Error: " + msg.splitlines()[0]
        except Exception:
            pass
        self.report({"ERROR"}, msg)

    def _status(self, context, text):
        try:
            context.workspace.status_text_set(text)
        except Exception:
            pass

    def _end_modal(self, context):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
            wm.progress_end()
        self._status(context, None)
        _active["job"] = None


class BEESWARM_OT_write_shot(bpy.types.Operator):
    """Write the shot built from the scene to a TOML file, without baking"""

    bl_idname = "beeswarm.write_shot"
    bl_label = "Write Shot File"

    filepath: StringProperty(subtype="FILE_PATH", default="")

    def execute(self, context):
        ensure_swarm(context.scene.beeswarm)
        try:
            shot, warnings = shot_builder.build_shot(context.scene, context.scene.beeswarm)
        except shot_builder.ShotBuildError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        for w in warnings:
            self.report({"WARNING"}, w)
        path = self.filepath or str((_blend_dir() or _unsaved_dir())
                                    / f"{shot['scene']['name']}.shot.toml")
        path = pathlib.Path(bpy.path.abspath(path))
        if path.exists() and not _written_by_addon(path):
            self.report({"ERROR"}, f"{path} exists and was not written by the add-on")
            return {"CANCELLED"}
        source = os.path.basename(bpy.data.filepath) if bpy.data.filepath else "an unsaved file"
        path.write_text(shot_builder.shot_toml(shot, source), encoding="utf-8")
        shot_builder.write_mesh_files(shot, path.parent)
        self.report({"INFO"}, f"Wrote {path}")
        return {"FINISHED"}


class BEESWARM_OT_write_wedge(bpy.types.Operator):
    """Write a wedge of the scene's shot: variant shots and an Open Job Description job
    (docs/farm.md). Each --vary is KEY=VALUES, e.g. seed=1..4 swarm.bees.params.speed=0.8,1.2"""

    bl_idname = "beeswarm.write_wedge"
    bl_label = "Wedge…"

    vary: StringProperty(name="Vary", default="seed=1..4",
                         description="KEY=VALUES, several separated by spaces (beeswarm wedge --vary)")
    out_dir: StringProperty(name="Folder", subtype="DIR_PATH", default="",
                            description="The wedge folder (default: //beeswarm_wedge/<shot>/)")

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        import shlex
        import subprocess

        settings = context.scene.beeswarm
        bin_path, msg = binary.resolve(props.preference_binary(context))
        if bin_path is None:
            self.report({"ERROR"}, msg)
            return {"CANCELLED"}
        try:
            varies = shlex.split(self.vary)
        except ValueError as e:
            self.report({"ERROR"}, f"Vary: {e}")
            return {"CANCELLED"}
        if not varies:
            self.report({"ERROR"}, "Vary: give at least one KEY=VALUES, e.g. seed=1..4")
            return {"CANCELLED"}
        if settings.source == "FILE":
            shot_path = pathlib.Path(bpy.path.abspath(settings.shot_file))
            name = shot_path.name.split(".")[0]
        else:
            ensure_swarm(settings)
            try:
                shot, warnings = shot_builder.build_shot(context.scene, settings)
            except shot_builder.ShotBuildError as e:
                self.report({"ERROR"}, str(e))
                return {"CANCELLED"}
            for w in warnings:
                self.report({"WARNING"}, w)
            name = shot["scene"]["name"]
            shot_path = (_blend_dir() or _unsaved_dir()) / f"{name}.shot.toml"
            if shot_path.exists() and not _written_by_addon(shot_path):
                self.report({"ERROR"}, f"{shot_path} exists and was not written by the add-on")
                return {"CANCELLED"}
            source = os.path.basename(bpy.data.filepath) if bpy.data.filepath else "an unsaved file"
            shot_path.write_text(shot_builder.shot_toml(shot, source), encoding="utf-8")
        if self.out_dir:
            out = pathlib.Path(bpy.path.abspath(self.out_dir))
        elif bpy.data.filepath:
            out = _blend_dir() / "beeswarm_wedge" / name
        else:
            out = _unsaved_dir() / "beeswarm_wedge" / name
        args = [str(bin_path), "wedge", str(shot_path), "--out", str(out), "--quiet"]
        for v in varies:
            args += ["--vary", v]
        r = subprocess.run(args, capture_output=True, text=True)
        if r.returncode != 0:
            message = (r.stderr.strip().splitlines() or [f"exit code {r.returncode}"])[0]
            settings.last_message = f"Error: {message}"
            self.report({"ERROR"}, r.stderr.strip() or message)
            return {"CANCELLED"}
        settings.last_message = f"Wrote a wedge in {out} (openjd run {out / 'job.yaml'})"
        self.report({"INFO"}, settings.last_message)
        return {"FINISHED"}


classes = (BEESWARM_OT_bake, BEESWARM_OT_write_shot, BEESWARM_OT_write_wedge)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    _kill_running_bake()
    _active["job"] = None
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
