"""`.ci/gpu-check` (the GPU check command, docs/platforms.md) end to end in its quick form: the
context, the context and known-answer GPU tests, a JUnit XML and the summary table."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
def test_gpu_check_quick_writes_its_reports(tmp_path):
    out = tmp_path / "gc"
    env = dict(os.environ, PYTHON=sys.executable)
    for key in ("CELLGL_PATH", "CELLGL_BACKEND", "CELLGL_DEVICE", "CELLGL_SELFCHECK"):
        env.pop(key, None)
    r = subprocess.run(["bash", ".ci/gpu-check", str(out), "--quick", "--no-bench"], cwd=REPO,
                       env=env, capture_output=True, text=True, timeout=900)
    if r.returncode == 2:
        pytest.skip(f"no OpenGL context here: {r.stdout[-500:]}")
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-2000:]
    for name in ("info.txt", "info.json", "pytest.log", "junit.xml", "failures.txt", "summary.md"):
        assert (out / name).is_file(), name
    suite = ET.parse(out / "junit.xml").getroot()
    suite = suite if suite.tag == "testsuite" else suite.find("testsuite")
    assert int(suite.get("tests")) >= 10 and int(suite.get("failures")) == 0
    summary = (out / "summary.md").read_text()
    assert "| known-answer check | " in summary and "passed" in summary
    assert "| benchmark | not run (--no-bench) |" in summary
    assert (out / "failures.txt").read_text() == ""
    assert summary.strip() in r.stdout


def test_gpu_check_refuses_an_unknown_option():
    r = subprocess.run(["bash", ".ci/gpu-check", "--fast"], cwd=REPO, capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 3
    assert r.stderr.strip() == ("gpu-check: unknown option --fast (accepted: --quick, --no-bench, "
                                "-- PYTEST_ARGS)")
