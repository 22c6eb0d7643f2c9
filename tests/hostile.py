"""What the hostile tests (tests/test_hostile_*.py, one file per subject) share: running cellgl's
command line or a snippet of Python in a fresh interpreter, and the shape of a refusal (exit 2,
one message, no traceback)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
#: the environment of every child process: this tree's cellgl first
ENV = dict(os.environ, PYTHONPATH=str(REPO))


def cli(*args, cwd=REPO, timeout: float = 300, env=None, stdout=subprocess.PIPE) -> subprocess.CompletedProcess:
    """``python -m cellgl ARGS`` in a fresh process (its own GL context, signals, stdout); the
    arguments may be paths or numbers."""
    return subprocess.run([sys.executable, "-m", "cellgl", *map(str, args)], cwd=cwd, stdout=stdout,
                          stderr=subprocess.PIPE, text=True, timeout=timeout, env=env or ENV)


def python(code: str, *args, timeout: float = 300, **env) -> subprocess.CompletedProcess:
    """``code`` in a fresh interpreter with ``sys.argv[1:] = args``, ``env`` added to ENV."""
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], cwd=REPO,
                          capture_output=True, text=True, timeout=timeout, env=dict(ENV, **env))


def refused(r: subprocess.CompletedProcess, *words: str) -> None:
    """Exit status 2, no traceback nor "internal error", every word in the standard error."""
    assert r.returncode == 2, (r.returncode, r.stdout[-1000:] if r.stdout else "", r.stderr[-2000:])
    assert "Traceback" not in r.stderr and "internal error" not in r.stderr, r.stderr[-2000:]
    assert all(w in r.stderr for w in words), r.stderr


def one_line_error(r: subprocess.CompletedProcess, *needles: str) -> None:
    """Exit status 2 and exactly one ``cellgl: error: ...`` line holding every needle."""
    assert r.returncode == 2, (r.returncode, r.stderr[-1500:])
    assert "Traceback" not in r.stderr, r.stderr[-1500:]
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("cellgl: error: "), r.stderr[-1500:]
    for n in needles:
        assert n in lines[0], (n, lines[0][:500])


def main_refuses(capsys, argv, *words: str) -> str:
    """``cli.main(argv)`` in this process returns 2, its standard error holding every word."""
    from cellgl import cli as cellgl_cli

    assert cellgl_cli.main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert "internal error" not in err and all(w in err for w in words), err
    return err


def bake(path, **kw):
    """``io.bake`` of flagstone, 32 x 32 and quiet unless said otherwise."""
    from cellgl.bake import core as B

    kw.setdefault("size", (32, 32))
    kw.setdefault("progress", False)
    return B.bake("flagstone", path, **kw)
