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


@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
@pytest.mark.parametrize("args, message", [
    ([""], "gpu-check: OUTDIR is empty (leave it out for gpu-check-out/)"),
    (["a", "b"], "gpu-check: one OUTDIR only, got 'a' and 'b' (PYTEST_ARGS go after --)"),
    (["{tmp}/out"], "gpu-check: cannot write {tmp}/out/info.txt: it is not a file"),
])
def test_gpu_check_refuses_a_bad_outdir_in_one_line(tmp_path, args, message):
    """OUTDIR empty (it wrote into the current folder), given twice (the second silently won),
    or a report name taken by a folder (it ended with "no OpenGL context: nothing to test")."""
    (tmp_path / "out" / "info.txt").mkdir(parents=True)
    args = [a.format(tmp=tmp_path) for a in args]
    r = subprocess.run(["bash", str(REPO / ".ci" / "gpu-check"), *args, "--no-bench"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=60)
    assert (r.returncode, r.stderr.strip(), r.stdout) == (3, message.format(tmp=tmp_path), "")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]      # nothing made


def test_the_gpu_benchmark_leaves_no_temporary_folder(tmp_path, monkeypatch):
    """benchmarks/bench_gpu.py (run by .ci/gpu-check) left a cellgl-bench-* and a
    cellgl-shader-cache-* folder in the temporary directory on every run."""
    import importlib.util
    import json
    import tempfile
    from types import SimpleNamespace

    spec = importlib.util.spec_from_file_location("bench_gpu", REPO / "benchmarks" / "bench_gpu.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    seen = []

    def run(cmd, **kw):        # the child processes themselves are not what is checked here
        seen.append(kw.get("env", {}))
        return SimpleNamespace(returncode=0, stderr="",
                               stdout=json.dumps({"first": 0.5, "second": 0.25}))

    monkeypatch.setattr(bench.subprocess, "run", run)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    assert bench.rows_bake(16, 1)[0]["row"] == "bake"
    assert [r["compile_s"] for r in bench.rows_compile()] == [0.25, 0.25, 0.25]
    assert seen and list(tmp_path.iterdir()) == []
    assert all("CELLGL_DRIVER_SHADER_CACHE" not in env for env in seen)   # the default measured
