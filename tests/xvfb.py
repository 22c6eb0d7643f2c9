"""A private X display for the tests that open windows (the viewer, the docs' viewer blocks)."""
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
