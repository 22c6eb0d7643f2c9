"""A private X display for the tests that open windows (the viewer, the docs' viewer blocks),
and what those tests do when there is none."""
from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import time


@contextlib.contextmanager
def xvfb_display(timeout: float = 20.0):
    """Start Xvfb on a free display and yield its name (":N"); None if Xvfb is missing or did
    not start. The server is stopped when the block ends."""
    xvfb = shutil.which("Xvfb")
    if not xvfb:
        yield None
        return
    r, w = os.pipe()
    proc = subprocess.Popen([xvfb, "-displayfd", str(w), "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
                            pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(w)
    num, deadline = b"", time.time() + timeout
    while time.time() < deadline and not num.endswith(b"\n"):
        chunk = os.read(r, 16)
        if not chunk:
            break
        num += chunk
    os.close(r)
    try:
        yield ":" + num.decode().strip() if num.strip() else None
    finally:
        proc.terminate()
        proc.wait(10)


def require_gpu() -> bool:
    """``CELLGL_REQUIRE_GPU=1``: a missing context or display fails the test instead of skipping
    it (the GPU CI jobs)."""
    return os.environ.get("CELLGL_REQUIRE_GPU", "").strip().lower() in ("1", "true", "yes")


def unavailable(msg: str):
    """Skip the test for ``msg``; fail it under ``CELLGL_REQUIRE_GPU=1``."""
    import pytest

    if require_gpu():
        pytest.fail(f"CELLGL_REQUIRE_GPU=1 but {msg}", pytrace=False)
    pytest.skip(msg)


@contextlib.contextmanager
def some_display(missing_ok: bool = False, export: bool = False):
    """$DISPLAY, or an Xvfb started for the block. Without one: ``None`` with ``missing_ok``,
    else :func:`unavailable`. ``export``: set $DISPLAY to the Xvfb for the block."""
    if os.environ.get("DISPLAY"):
        yield os.environ["DISPLAY"]
        return
    with xvfb_display() as disp:
        if disp is None and not missing_ok:
            unavailable("no DISPLAY and no Xvfb (apt-get install xvfb)" if not shutil.which("Xvfb")
                        else "Xvfb did not start")
        if disp is None or not export:
            yield disp
            return
        os.environ["DISPLAY"] = disp
        try:
            yield disp
        finally:
            del os.environ["DISPLAY"]
