"""Runs `beeswarm bake` as a subprocess and reads its `--progress json` stream without
blocking Blender: one reader thread per pipe feeds a queue that the modal operator drains
on a timer. Nothing here imports bpy, so it is unit-testable on its own.
"""
import json
import os
import queue
import signal
import subprocess
import sys
import threading


class BakeProcess:
    """One running bake. Events from `poll()`:

    ("progress", {"frame": F, "total": T, "elapsed_s": S})
    ("done", {"outputs": [...]})
    ("line", "text")            a stdout line that is not a JSON event
    ("exit", returncode)        always last
    """

    def __init__(self, argv, cwd=None):
        self.argv = list(argv)
        self.events = queue.Queue()
        self.stderr_lines = []
        self.outputs = None
        self.returncode = None
        self.cancelled = False
        self._stderr_lock = threading.Lock()
        kwargs = {}
        if os.name == "posix":
            kwargs["start_new_session"] = True  # Esc kills the bake, not Blender's group
        elif os.name == "nt":
            kwargs["creationflags"] = getattr(subprocess, "CREATE_NO_WINDOW", 0)
        # An argument list, never a shell.
        self.proc = subprocess.Popen(
            self.argv,
            cwd=cwd,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            encoding="utf-8",
            errors="replace",
            bufsize=1,
            **kwargs,
        )
        self._out = threading.Thread(target=self._read_stdout, daemon=True)
        self._err = threading.Thread(target=self._read_stderr, daemon=True)
        self._out.start()
        self._err.start()
        self._waiter = threading.Thread(target=self._wait, daemon=True)
        self._waiter.start()

    # -- reader threads -------------------------------------------------------------------
    def _read_stdout(self):
        for line in self.proc.stdout:
            line = line.strip()
            if not line:
                continue
            try:
                msg = json.loads(line)
            except ValueError:
                self.events.put(("line", line))
                continue
            if not isinstance(msg, dict):
                self.events.put(("line", line))
                continue
            kind = msg.get("event")
            if kind == "done":
                self.outputs = [str(p) for p in msg.get("outputs", [])]
            self.events.put((kind or "line", msg))
        self.proc.stdout.close()

    def _read_stderr(self):
        for line in self.proc.stderr:
            with self._stderr_lock:
                self.stderr_lines.append(line.rstrip("\n"))
        self.proc.stderr.close()

    def _wait(self):
        rc = self.proc.wait()
        # Every stdout event precedes "exit".
        self._out.join()
        self._err.join()
        self.returncode = rc
        self.events.put(("exit", rc))

    # -- control --------------------------------------------------------------------------
    def poll(self):
        """Every event that arrived since the last call, without blocking."""
        out = []
        while True:
            try:
                out.append(self.events.get_nowait())
            except queue.Empty:
                return out

    def wait_event(self, timeout=None):
        try:
            return self.events.get(timeout=timeout)
        except queue.Empty:
            return None

    @property
    def stderr(self):
        with self._stderr_lock:
            return "\n".join(self.stderr_lines)

    def running(self):
        return self.returncode is None

    def cancel(self, grace=2.0):
        """Stops the bake. The binary writes every output atomically, so the previous cache
        stays as it was. SIGTERM first, then SIGKILL after `grace` seconds."""
        self.cancelled = True
        if self.proc.poll() is None:
            try:
                if os.name == "posix":
                    os.killpg(self.proc.pid, signal.SIGTERM)
                else:
                    self.proc.terminate()
            except (ProcessLookupError, PermissionError):
                pass
            try:
                self.proc.wait(timeout=grace)
            except subprocess.TimeoutExpired:
                try:
                    if os.name == "posix":
                        os.killpg(self.proc.pid, signal.SIGKILL)
                    else:
                        self.proc.kill()
                except (ProcessLookupError, PermissionError):
                    pass
                self.proc.wait()
        self._waiter.join(timeout=5.0)


def bake_argv(binary, shot_path, out_dir, formats, extra=()):
    return [
        str(binary), "bake", str(shot_path),
        "--out", str(out_dir),
        "--format", ",".join(formats),
        "--progress", "json",
        *extra,
    ]


def error_message(stderr, returncode, limit=600):
    """The binary's own message (stderr), trimmed for Blender's report line."""
    text = "\n".join(line for line in (stderr or "").splitlines() if line.strip())
    if not text:
        if returncode is not None and returncode < 0:
            return f"beeswarm was killed by signal {-returncode}"
        return f"beeswarm exited with code {returncode} and no message"
    if len(text) > limit:
        text = text[:limit].rstrip() + " …"
    return text


def fraction(event):
    """0..1 from a progress event: `done` frames of `total` (`frame` is the frame number;
    older builds sent only `frame`, counted from 1)."""
    total = event.get("total") or 0
    done = event.get("done", event.get("frame", 0)) or 0
    if total > 0:
        return max(0.0, min(1.0, done / total))
    return 0.0


if __name__ == "__main__":  # a manual check: python runner.py BINARY SHOT OUT
    p = BakeProcess(bake_argv(sys.argv[1], sys.argv[2], sys.argv[3], ["usda", "csv"]))
    while True:
        ev = p.wait_event(1.0)
        if ev:
            print(ev)
            if ev[0] == "exit":
                break
    print(p.stderr)
