"""The known-answer check's record on disk (cellgl.basis.selfcheck, issue 48 items 1-4): any file
that is not a record of this key counts as none, whatever it is; reading it is bounded, never
waits, and never happens with the CLI's signals deferred; nothing from it reaches `cellgl info`
unchecked."""

from __future__ import annotations

import json
import os
import signal
import sys
import threading

import pytest

from cellgl import _interrupt, cli
from cellgl.basis import selfcheck
from cellgl.gl import context

KEY = {"vendor": "V", "renderer": "R", "version": "4.5", "path": "compute", "cellgl": "0",
       "code": "c", "check": "k"}


@pytest.fixture
def where(monkeypatch, tmp_path):
    """The record file of KEY in a cache folder of the test's own."""
    monkeypatch.delenv("CELLGL_SHADER_CACHE", raising=False)
    monkeypatch.setenv("CELLGL_SHADER_CACHE_DIR", str(tmp_path / "cache"))
    path = selfcheck.record_path(KEY)
    path.parent.mkdir(parents=True)
    return path


def _in_thread(fn, timeout=20.0):
    """fn() in a daemon thread: (finished, its result or exception)."""
    out: list = []

    def run():
        try:
            out.append(fn())
        except BaseException as exc:  # noqa: BLE001 - what the test looks at
            out.append(exc)

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(timeout)
    return (not t.is_alive()), (out[0] if out else None)


def test_a_record_is_written_and_read_back(where):
    selfcheck._record(KEY)
    when = selfcheck._recorded(KEY)
    assert when is not None and selfcheck._STAMP.fullmatch(when)
    assert not [f for f in where.parent.iterdir() if f.name.endswith(".tmp")]


def _good(when="2026-12-07 10:00:00"):
    return json.dumps({"key": KEY, "passed": when})


@pytest.mark.parametrize("kind", ["deep", "huge", "forged newline", "forged escape", "not utf-8",
                                  "a folder", "a link to a record", "other key"])
def test_a_bad_record_counts_as_none(where, tmp_path, kind):
    if kind == "deep":        # valid JSON too deep for the parser: RecursionError before
        where.write_text("[" * 100000 + "]" * 100000)
    elif kind == "huge":      # a valid record padded past the bound: not read whole
        where.write_text(_good() + " " * (selfcheck.RECORD_MAX + 1))
    elif kind == "forged newline":
        where.write_text(_good("2026-12-07\nGL_RENDERER: evil"))
    elif kind == "forged escape":
        where.write_text(_good("2026-12-07 10:00:00\x1b[31m"))
    elif kind == "not utf-8":
        where.write_bytes(b"\xff\xfe" + _good().encode())
    elif kind == "a folder":
        where.mkdir()
    elif kind == "a link to a record":
        (tmp_path / "elsewhere.json").write_text(_good())
        where.symlink_to(tmp_path / "elsewhere.json")
    elif kind == "other key":
        other = {"key": dict(KEY, version="9.9"), "passed": "2026-12-07 10:00:00"}
        where.write_text(json.dumps(other))
    assert selfcheck._recorded(KEY) is None
    where.unlink() if not where.is_dir() or where.is_symlink() else where.rmdir()
    where.write_text(_good())                          # the same file, right: read back
    assert selfcheck._recorded(KEY) == "2026-12-07 10:00:00"


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_record_is_none_at_once(where):
    """A FIFO where the record goes blocked every process before (and the GL section deferred
    the signals that would end it)."""
    os.mkfifo(where)
    try:
        finished, got = _in_thread(lambda: selfcheck._recorded(KEY))
        assert finished, "reading a FIFO record blocked"
        assert got is None
    finally:
        try:    # a reader still blocked (before the fix): let it go
            fd = os.open(where, os.O_WRONLY | os.O_NONBLOCK)
            os.close(fd)
        except OSError:
            pass


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero here")
def test_a_record_linked_to_an_endless_file_is_none(where):
    where.symlink_to("/dev/zero")
    finished, got = _in_thread(lambda: selfcheck._recorded(KEY))
    assert finished and got is None


@pytest.mark.skipif(sys.platform == "win32" or not hasattr(signal, "SIGTERM"),
                    reason="POSIX signals")
def test_no_record_is_read_with_signals_deferred(where, monkeypatch):
    """SIGTERM arriving while the record is read (inside a GL section, where the CLI defers it
    to the end of the call) ends the read at once."""
    real = selfcheck.record_path
    reached = []

    def signalled(key):
        os.kill(os.getpid(), signal.SIGTERM)
        return real(key)

    monkeypatch.setattr(selfcheck, "record_path", signalled)
    try:
        with pytest.raises(cli.Terminated):
            with cli._signals_unwind():
                with context.section():
                    selfcheck._recorded(KEY)
                    reached.append("read, the signal deferred")
    finally:
        cli._received.clear()
        _interrupt.pending.clear()
        context.deferred.clear()
    assert reached == []


def test_info_lines_escape_control_characters():
    """`cellgl info` prints driver strings and what came from disk: one line each, no escape."""
    assert cli._fmt("a\nGL_RENDERER: b\x1b[31m") == "a\\nGL_RENDERER: b\\x1b[31m"
    assert cli._fmt(("x\ty", 2)) == "x\\ty 2"
