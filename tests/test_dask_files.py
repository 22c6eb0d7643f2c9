"""The small JSON files the Dask front end reads back (a scheduler file, a sweep's manifest):
like the known-answer check's record (tests/test_selfcheck_record.py), any file there that is
not what it should be is one clear error or counts as another's, whatever it is (too deep a JSON,
a FIFO, an endless file): never a RecursionError, a hang or a read without end (issue 48)."""

from __future__ import annotations

import json
import os

import pytest

pytest.importorskip("dask", reason="the cellgl[dask] extra is not installed")

from cellgl.dask import DaskError  # noqa: E402
from cellgl.cli import dask as dcli  # noqa: E402
from cellgl.dask import variations  # noqa: E402

DEEP = "[" * 100000 + "]" * 100000


def test_a_scheduler_file_nested_too_deep_is_one_error(tmp_path):
    f = tmp_path / "sched.json"
    f.write_text(DEEP)
    with pytest.raises(DaskError, match=r"^--scheduler .*sched\.json: not a Dask scheduler file "
                                        r"\(JSON nested too deeply\)$"):
        dcli.check_scheduler(str(f))


@pytest.mark.parametrize("kind", ["deep", "fifo", "endless", "folder"])
def test_a_manifest_that_is_not_one_is_another_sweeps(tmp_path, kind):
    """A sweep folder whose manifest is not this sweep's is refused ("holds another sweep"):
    before, too deep a JSON raised RecursionError and a FIFO or /dev/zero was waited on or read
    for ever."""
    manifest = tmp_path / variations.MANIFEST
    if kind == "deep":
        manifest.write_text(DEEP)
    elif kind == "fifo":
        if not hasattr(os, "mkfifo"):
            pytest.skip("no FIFOs here")
        os.mkfifo(manifest)
    elif kind == "endless":
        if not os.path.exists("/dev/zero"):
            pytest.skip("no /dev/zero here")
        manifest.symlink_to("/dev/zero")
    else:
        manifest.mkdir()
    with pytest.raises(DaskError, match="holds another sweep"):
        variations._check_manifest(tmp_path, {"variations": 2})


def test_this_sweeps_manifest_is_recognised(tmp_path):
    (tmp_path / variations.MANIFEST).write_text(json.dumps({"variations": 2}))
    assert variations._check_manifest(tmp_path, {"variations": 2}) is True
    assert variations._check_manifest(tmp_path / "none", {"variations": 2}) is False
