"""Bakes in a child process (:mod:`cellgl.blender.bakejob`), polled from Blender's main thread.

The child is Blender's own interpreter (``sys.executable``) with Blender's ``sys.path``: it finds
cellgl and the extension's wheels as the add-on does, makes cellgl's own headless context (EGL on
Linux) and never shares Blender's GL state. Two reader threads drain its pipes (they touch no
``bpy``); a :mod:`bpy.app.timers` function on the main thread shows the progress and, when the
child ends, loads the arrays into the node group. Headless (``bpy.app.background``: no event
loop, no timers) the operators wait for the child instead.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import threading

import bpy

__all__ = ["Job", "JOBS", "start", "run_sync", "cancel_all", "poll"]

#: running jobs by node group name
JOBS: dict[str, Job] = {}
#: the values (hash) whose bake failed, by node group name: Re-bake on Change does not retry them
FAILED: dict[str, str] = {}


class Job:
    """One bake: the child process, its progress and its result."""

    def __init__(self, tree_name: str, job: dict, values_hash: str = ""):
        self.tree_name, self.job, self.values_hash = tree_name, job, values_hash
        self.progress = 0.0
        self.error = ""
        self.data = b""
        self._err_lines: list[str] = []
        env = dict(os.environ)
        paths = [p for p in sys.path if p and os.path.isdir(p)]
        env["PYTHONPATH"] = os.pathsep.join(paths)
        flags = getattr(subprocess, "CREATE_NO_WINDOW", 0)
        self.proc = subprocess.Popen([sys.executable, "-m", "cellgl.blender.bakejob"], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                                     creationflags=flags)
        self._out = threading.Thread(target=self._read_out, daemon=True)
        self._err = threading.Thread(target=self._read_err, daemon=True)
        self._out.start()
        self._err.start()
        assert self.proc.stdin is not None          # (stdin, stdout, stderr: PIPE)
        try:
            self.proc.stdin.write(json.dumps(job).encode())
            self.proc.stdin.close()
        except OSError as exc:
            self.error = f"the bake process did not start: {exc}"

    def _read_out(self):
        assert self.proc.stdout is not None
        self.data = self.proc.stdout.read()

    def _read_err(self):
        assert self.proc.stderr is not None
        for raw in self.proc.stderr:
            line = raw.decode("utf-8", "replace").rstrip()
            if line.startswith("cellgl-progress "):
                try:
                    self.progress = float(line.split()[1])
                except ValueError:
                    pass
            elif line:
                self._err_lines.append(line)

    def done(self) -> bool:
        return self.proc.poll() is not None and not self._out.is_alive() and not self._err.is_alive()

    def wait(self) -> None:
        self.proc.wait()
        self._out.join()
        self._err.join()

    def result(self) -> dict:
        """The arrays; raises RuntimeError with the child's own message if it failed."""
        from cellgl.blender.bakejob import decode

        if self.error:
            raise RuntimeError(self.error)
        if self.proc.returncode != 0:
            errs = [ln for ln in self._err_lines if ln.startswith("cellgl-error ")]
            msg = errs[-1][len("cellgl-error "):] if errs else (" ".join(self._err_lines[-3:])
                                                              or f"exit status {self.proc.returncode}")
            raise RuntimeError(f"cellgl bake failed: {msg}")
        return decode(self.data)

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.wait()


def _apply(job: Job) -> str:
    """Load a finished job into its group; returns an error message or ''."""
    from cellgl.blender.addon import groups

    tree = bpy.data.node_groups.get(job.tree_name)
    if tree is None:
        return f"node group {job.tree_name!r} is gone (renamed or deleted during the bake)"
    try:
        arrays = job.result()
    except RuntimeError as exc:
        FAILED[job.tree_name] = job.values_hash
        tree.cellgl.status = str(exc)
        return str(exc)
    FAILED.pop(job.tree_name, None)
    if job.job["kind"] == "voronoi":
        groups.apply_voronoi_bake(tree, arrays)
    else:
        groups.apply_bake(tree, arrays, job.values_hash)
    tree.cellgl.status = f"baked {tree.cellgl.size} x {tree.cellgl.size}"
    return ""


def run_sync(tree_name: str, job: dict, values_hash: str = "") -> str:
    """Bake and wait (headless, and the tests); returns an error message or ''."""
    j = Job(tree_name, job, values_hash)
    j.wait()
    return _apply(j)


def start(tree_name: str, job: dict, values_hash: str = "") -> None:
    """Bake in the background: progress in the panel and the window's progress cursor."""
    old = JOBS.pop(tree_name, None)
    if old is not None:
        old.kill()
    JOBS[tree_name] = Job(tree_name, job, values_hash)
    tree = bpy.data.node_groups.get(tree_name)
    if tree is not None:
        tree.cellgl.status = "baking"
    wm = bpy.context.window_manager
    if wm is not None and len(JOBS) == 1:
        wm.progress_begin(0, 100)
    if not bpy.app.timers.is_registered(poll):
        bpy.app.timers.register(poll, first_interval=0.1)


def _popup(message: str) -> None:
    wm = bpy.context.window_manager
    if wm is None or not wm.windows:
        print(f"cellgl: {message}", file=sys.stderr)
        return

    def draw(menu, _context):
        menu.layout.label(text=message)

    wm.popup_menu(draw, title="cellgl bake failed", icon="ERROR")


def poll():
    """The timer: progress, finished jobs; returns the next interval (None: stop)."""
    wm = bpy.context.window_manager
    for name, job in list(JOBS.items()):
        if not job.done():
            continue
        del JOBS[name]
        err = _apply(job)
        if err:
            _popup(err)
        else:
            try:
                bpy.ops.ed.undo_push(message="Bake Image")
            except RuntimeError:
                pass
    if wm is not None:
        if JOBS:
            wm.progress_update(int(100 * min(j.progress for j in JOBS.values())))
        else:
            wm.progress_end()
        for win in wm.windows:
            for area in win.screen.areas:
                if area.type == "NODE_EDITOR":
                    area.tag_redraw()
    return 0.2 if JOBS else None


def cancel_all() -> None:
    """Stop every child and the timer (unregister)."""
    for job in list(JOBS.values()):
        job.kill()
    JOBS.clear()
    FAILED.clear()
    if bpy.app.timers.is_registered(poll):
        bpy.app.timers.unregister(poll)
