"""The driver matrix, `.ci/drivers` (issue 50; docs/platforms.md, "The drivers tried"): each driver
is the one its variables select, checked by its GL_RENDERER, or the run fails; a driver the
known-answer check refuses is refused in one line. The full matrix (zink, softpipe) takes minutes
and runs from `.ci/run`; here the quick rows and the failure path."""

from __future__ import annotations

import ctypes.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent


def _drivers(tmp_path, *args, **env) -> tuple[subprocess.CompletedProcess, str]:
    e = dict(os.environ, PYTHON=sys.executable, **env)
    r = subprocess.run(["bash", str(REPO / ".ci" / "drivers"), str(tmp_path / "out"), *args],
                       cwd=tmp_path, env=e, capture_output=True, text=True, timeout=300)
    summary = tmp_path / "out" / "summary.md"
    return r, summary.read_text() if summary.exists() else ""


def _mesa() -> bool:
    return bool(ctypes.util.find_library("EGL")) and Path("/usr/lib/x86_64-linux-gnu/dri/swrast_dri.so").exists()


@pytest.mark.skipif(not _mesa(), reason="needs Mesa's EGL software drivers (llvmpipe, softpipe)")
def test_the_quick_rows_pass_and_name_their_driver(tmp_path):
    r, summary = _drivers(tmp_path, "--only", "llvmpipe", "--only", "no-rast")
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-2000:]
    assert "| llvmpipe | llvmpipe (LLVM" in summary and "renderer checked" in summary
    assert "| no-rast | softpipe | none | refused, as it should be" in summary


@pytest.mark.skipif(not _mesa(), reason="needs Mesa's EGL software drivers (llvmpipe, softpipe)")
def test_a_driver_that_is_not_the_one_asked_for_fails_the_run(tmp_path):
    """Mesa falls back without a word when a selection does not take (issue 50: a variable that
    alone falls back to llvmpipe). With Mesa's DRI drivers hidden, softpipe cannot be had: the
    row says so and the run fails, whatever context cellgl got instead (OSMesa's llvmpipe, or none)."""
    r, summary = _drivers(tmp_path, "--only", "softpipe", LIBGL_DRIVERS_PATH=str(tmp_path / "none"))
    assert r.returncode == 1, r.stdout[-3000:]
    assert "| softpipe |" in summary and "NOT THE DRIVER ASKED FOR" in summary, summary


def test_an_unknown_driver_is_refused_with_the_names(tmp_path):
    r, _ = _drivers(tmp_path, "--only", "nvidia")
    assert r.returncode == 3
    assert "unknown driver 'nvidia' (accepted: llvmpipe zink softpipe no-rast osmesa standin)" in r.stderr
