"""Run the fenced code blocks of README.md and docs/*.md as a user would (for tests/test_docs.py).

What runs
    ```python           in one Python interpreter per document (``python`` of the venv, started in
                        the document's working directory, like ``python`` typed at the clone root):
                        the blocks of a document share one namespace, in order.
    ```sh / ```bash / ```shell
                        with bash (``set -eo pipefail``: the first failing command fails the block).
    ```console          ``$ COMMAND`` lines, each followed by the output it must print (stdout and
                        stderr together, trailing spaces ignored; a line ``...`` matches any lines).
                        A command shown without output must succeed.
    Anything else (```text, ```json, ```glsl, ...) is a listing and is not run.

Where: each document gets a fresh copy of the clone (the files git tracks, plus new files it does
not ignore) in a temporary directory, with ``.venv`` linked in; its blocks run there, in order, so
a block can use the files and variables of the blocks above it. ``.venv/bin`` is first on PATH
(as after ``source .venv/bin/activate``). After each block the files it wrote are checked: none
empty, images decode, ``.npy``/``.json``/``.zarr`` load, no ``.cellgl-*`` temporary file left
behind; every ``-o FILE`` / ``> FILE`` of a shell command must exist afterwards (or, for several
channels or frames, ``STEM_*``).

Markers: HTML comments on the lines right above a fence (several may stack), invisible on GitHub::

    <!-- docs-test: skip: REASON -->          not run; REASON says why (a cluster, the network...)
    <!-- docs-test: replace "OLD" "NEW" -->   run with OLD replaced by NEW (scale a slow command
                                              down; the doc says how long the full one takes)
    <!-- docs-test: timeout: SECONDS -->      instead of the default of DEFAULT_TIMEOUT seconds
    <!-- docs-test: interactive -->           each command opens a window and waits for the user:
                                              a window titled 'cellgl...' must appear on the
                                              display, the command must still be running, with no
                                              error printed, INTERACTIVE_SECONDS later, and is
                                              then closed

A failure names the document, the line of the fence (and of the failing command or the Python
traceback's line in the document), the command, and the last lines of its output.
"""
from __future__ import annotations

import json
import os
import re
import select
import shlex
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from docs_checks import (check_outputs, console_matches, missing_outputs, snapshot,  # noqa: F401
                         x11_window_names)

ROOT = Path(__file__).resolve().parents[1]

DEFAULT_TIMEOUT = 300.0           # seconds per block: the slowest take about 60 s on a busy 2-core machine
INTERACTIVE_SECONDS = 3.0         # how long an interactive command must stay up once its window is there
PYTHON_LANGS = {"python", "py", "python3"}
SHELL_LANGS = {"sh", "bash", "shell"}
CONSOLE_LANGS = {"console"}
RUN_LANGS = PYTHON_LANGS | SHELL_LANGS | CONSOLE_LANGS
TAIL_LINES = 25                   # output lines shown with a failure

_FENCE = re.compile(r"^(?P<indent>[ \t]*)(?P<fence>`{3,}|~{3,})[ \t]*(?P<info>[^`\s]*)[^`]*$")
_MARKER = re.compile(r"^\s*<!--\s*docs-test:(?P<body>.*?)-->\s*$")
_ANY_MARKER = re.compile(r"^\s*<!--.*docs-test")      # a marker line that _MARKER does not take


class DocError(Exception):
    """A document that cannot be run as it stands (a bad marker); the message names doc:line."""


@dataclass
class Block:
    doc: str                      # path relative to the repository, e.g. "docs/scale.md"
    line: int                     # 1-based line of the opening fence
    lang: str
    code: str                     # the block as written
    skip: str | None = None       # the reason, when marked skip
    replaces: list = field(default_factory=list)
    timeout: float = DEFAULT_TIMEOUT
    interactive: bool = False

    @property
    def id(self) -> str:
        return f"{self.doc}:{self.line}"

    @property
    def runs(self) -> bool:
        return self.lang in RUN_LANGS

    def text(self) -> str:
        """The code that runs: the block with its replace markers applied."""
        code = self.code
        for old, new in self.replaces:
            code = code.replace(old, new)
        return code


# ------------------------------------------------------------------------------------------------
# parsing
# ------------------------------------------------------------------------------------------------

def documents(root: Path = ROOT) -> list[Path]:
    """README.md and docs/*.md, in that order."""
    return [p for p in [root / "README.md", *sorted((root / "docs").glob("*.md"))] if p.is_file()]


def parse(path: Path, root: Path = ROOT) -> list[Block]:
    """The fenced blocks of one markdown file, with their markers. Raises :class:`DocError` for a
    marker that is malformed, unknown, not right above a fence, or stale (replace text absent)."""
    doc = path.relative_to(root).as_posix() if path.is_absolute() else str(path)
    lines = path.read_text(encoding="utf-8").split("\n")
    blocks: list[Block] = []
    pending: list[tuple[int, str]] = []      # markers waiting for their fence
    i = 0
    while i < len(lines):
        text = lines[i]
        m = _MARKER.match(text)
        if m:
            pending.append((i + 1, m.group("body").strip()))
            i += 1
            continue
        if _ANY_MARKER.search(text):
            raise DocError(f"{doc}:{i + 1}: a docs-test marker must be one whole line "
                           f"'<!-- docs-test: ... -->', got {text.strip()!r}")
        f = _FENCE.match(text)
        if not f:
            if pending and text.strip():
                raise DocError(f"{doc}:{pending[0][0]}: docs-test marker not right above a fence "
                               f"(line {i + 1} comes between: {text.strip()[:60]!r})")
            if pending and not text.strip():
                raise DocError(f"{doc}:{pending[0][0]}: docs-test marker must be on the line right "
                               "above the fence (a blank line follows it)")
            i += 1
            continue
        indent, fence, info = f.group("indent"), f.group("fence"), f.group("info").lower()
        start = i
        body = []
        i += 1
        while i < len(lines):
            close = lines[i].strip()
            if close.startswith(fence[0] * len(fence)) and set(close) <= {fence[0]}:
                break
            ln = lines[i]
            body.append(ln[len(indent):] if ln.startswith(indent) else ln.lstrip())
            i += 1
        else:
            raise DocError(f"{doc}:{start + 1}: the fence opened here is never closed")
        i += 1
        block = Block(doc, start + 1, info.strip("{}."), "\n".join(body) + "\n")
        for line_no, body_text in pending:
            _apply_marker(block, line_no, body_text)
        pending = []
        if block.runs and block.skip is None and re.search(r"\.ci/(setup|run)\b", block.code):
            raise DocError(f"{block.id}: a block that runs .ci/setup or .ci/run must be marked "
                           "'<!-- docs-test: skip: ... -->' (it is what CI runs around these tests)")
        if block.lang in PYTHON_LANGS:
            _check_python(block)
        blocks.append(block)
    if pending:
        raise DocError(f"{doc}:{pending[0][0]}: docs-test marker at the end of the file, above no fence")
    return blocks


def _check_python(block: Block) -> None:
    """Valid Python, and a block that uses ``cellgl.`` imports it itself: a user copies one block."""
    import ast

    try:
        tree = ast.parse(block.text())
    except SyntaxError as exc:
        raise DocError(f"{block.doc}:{block.line + (exc.lineno or 0)}: not valid Python: {exc.msg}") from None
    used = any(isinstance(n, ast.Name) and n.id == "cellgl" and isinstance(n.ctx, ast.Load) for n in ast.walk(tree))
    imported = any(isinstance(n, ast.Import) and any(a.name.split(".")[0] == "cellgl" and a.asname is None
                                                     for a in n.names) for n in ast.walk(tree))
    if used and not imported and block.skip is None:
        raise DocError(f"{block.id}: the block uses cellgl without 'import cellgl': copied alone it "
                       "fails with NameError")


def _apply_marker(block: Block, line_no: int, body: str) -> None:
    where = f"{block.doc}:{line_no}"
    name, _, rest = body.partition(":") if not body.startswith("replace") else ("replace", "", body[7:])
    name, rest = name.strip(), rest.strip()
    if not block.runs:
        raise DocError(f"{where}: docs-test marker above a ```{block.lang} block, which is not run "
                       f"(run: {', '.join(sorted(RUN_LANGS))})")
    if name == "skip":
        if not rest:
            raise DocError(f"{where}: 'docs-test: skip' needs a reason: <!-- docs-test: skip: REASON -->")
        block.skip = rest
    elif name == "replace":
        try:
            args = shlex.split(rest)
        except ValueError as exc:
            raise DocError(f"{where}: docs-test replace: {exc}") from None
        if len(args) != 2 or not args[0]:
            raise DocError(f'{where}: docs-test replace takes two quoted strings, "OLD" "NEW"; got {rest!r}')
        if args[0] not in block.code:
            raise DocError(f"{where}: docs-test replace: {args[0]!r} does not occur in the block at "
                           f"line {block.line} (a stale marker?)")
        block.replaces.append((args[0], args[1]))
    elif name == "timeout":
        try:
            block.timeout = float(rest)
        except ValueError:
            block.timeout = -1.0
        if not 1 <= block.timeout <= 600:
            raise DocError(f"{where}: docs-test timeout: {rest!r}; accepted: seconds, 1..600")
    elif name == "interactive" and not rest:
        if block.lang not in SHELL_LANGS:
            raise DocError(f"{where}: docs-test interactive is for shell blocks")
        block.interactive = True
    else:
        raise DocError(f"{where}: unknown docs-test marker {body!r}; accepted: 'skip: REASON', "
                       "'replace \"OLD\" \"NEW\"', 'timeout: SECONDS', 'interactive'")


# ------------------------------------------------------------------------------------------------
# the working directory: a copy of the clone
# ------------------------------------------------------------------------------------------------

_NOT_CLONED = {".git", ".venv", "__pycache__", ".pytest_cache", "build", "dist"}


def clone_files(root: Path = ROOT) -> list[str]:
    """The repository's files as a fresh clone has them (git's tracked and not-ignored files)."""
    try:
        out = subprocess.run(["git", "-C", str(root), "ls-files", "-z", "--cached", "--others",
                              "--exclude-standard"], capture_output=True, check=True, timeout=60).stdout
        names = sorted({n for n in out.decode().split("\0") if n})
    except (OSError, subprocess.SubprocessError):
        names = []
        for dirpath, dirnames, filenames in os.walk(root):
            dirnames[:] = [d for d in dirnames if d not in _NOT_CLONED and not d.endswith(".egg-info")]
            names += [os.path.relpath(os.path.join(dirpath, f), root) for f in filenames]
    return [n for n in names if os.path.lexists(root / n) and not (root / n).is_dir()]


def make_clone(dest: Path, root: Path = ROOT) -> Path:
    dest.mkdir(parents=True, exist_ok=True)
    for name in clone_files(root):
        target = dest / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(root / name, target, follow_symlinks=False)
    venv = root / ".venv"
    if venv.is_dir() and not (dest / ".venv").exists():
        (dest / ".venv").symlink_to(venv, target_is_directory=True)
    return dest


def venv_bin(root: Path = ROOT) -> Path:
    b = root / ".venv" / "bin"
    return b if (b / "python").exists() else Path(sys.executable).parent


def user_env(root: Path = ROOT) -> dict:
    """The environment of a user who ran ``source .venv/bin/activate`` in the clone."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "PYTEST_CURRENT_TEST")}
    b = venv_bin(root)
    env["PATH"] = f"{b}{os.pathsep}{env.get('PATH', '')}"
    env["VIRTUAL_ENV"] = str(b.parent)
    env.setdefault("LC_ALL", "C.UTF-8")
    return env


# ------------------------------------------------------------------------------------------------
def shell_commands(code: str) -> list[tuple[int, str]]:
    """(1-based line in the block, command) of each command line, continuations joined."""
    out, buf, first = [], "", 0
    for k, ln in enumerate(code.split("\n"), 1):
        if not buf:
            first = k
        if ln.rstrip().endswith("\\"):
            buf += ln.rstrip()[:-1] + " "
            continue
        buf += ln
        if buf.strip() and not buf.strip().startswith("#"):
            out.append((first, buf))
        buf = ""
    return out


def tail(text: str, n: int = TAIL_LINES) -> str:
    # as a terminal shows it: a progress bar redrawn with \r leaves only its last state
    lines = [ln.rstrip("\r").split("\r")[-1].rstrip() for ln in text.split("\n")]
    lines = [ln for ln in lines if ln.strip()]
    shown = lines[-n:]
    more = f"    ... ({len(lines) - n} lines above)\n" if len(lines) > n else ""
    return more + "\n".join("    " + ln for ln in shown) if shown else "    (no output)"


# ------------------------------------------------------------------------------------------------
# running
# ------------------------------------------------------------------------------------------------

_KERNEL = r'''
def _docs_kernel():
    import json, os, sys, traceback
    # requests come on a private copy of stdin, results go to a private copy of stdout: what the
    # blocks (and the processes they start) see as fds 0, 1, 2 is /dev/null and their output file
    requests = os.fdopen(os.dup(0), "r")
    results = os.fdopen(os.dup(1), "w", buffering=1)
    devnull = os.open(os.devnull, os.O_RDWR)
    os.dup2(devnull, 0)
    os.dup2(devnull, 1)
    ns = sys.modules["__main__"].__dict__
    for request in requests:
        req = json.loads(request)
        fd = os.open(req["output"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        sys.stdout.flush(); sys.stderr.flush()
        saved = os.dup(2)
        os.dup2(fd, 1); os.dup2(fd, 2); os.close(fd)
        error = None
        try:
            exec(compile("\n" * req["line"] + req["code"], req["file"], "exec"), ns)
        except SystemExit as exc:
            if exc.code not in (None, 0):
                error = "SystemExit: %r" % (exc.code,)
        except BaseException as exc:
            error = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__.tb_next))
        sys.stdout.flush(); sys.stderr.flush()
        os.dup2(devnull, 1); os.dup2(saved, 2); os.close(saved)
        results.write(json.dumps({"error": error}) + "\n")
_docs_kernel()
'''


class BlockFailed(Exception):
    """A block failed; the message is the whole report (doc:line, command, output)."""


class DocSession:
    """One document's run: its working directory, its Python interpreter, the blocks done."""

    def __init__(self, doc: str, workdir: Path, private: Path, root: Path = ROOT):
        self.doc, self.workdir, self.private, self.root = doc, workdir, private, root
        private.mkdir(parents=True, exist_ok=True)
        self.env = user_env(root)
        self.kernel: subprocess.Popen | None = None
        self.done: dict[int, str | None] = {}     # fence line -> None (passed) or the failure
        self._n = 0
        self._cloned = False

    # -- helpers --------------------------------------------------------------------------------
    def _file(self, what: str) -> Path:
        self._n += 1
        return self.private / f"{self._n:03d}-{what}"

    def _fail(self, block: Block, why: str, command: str | None = None, output: str = "",
              line: int | None = None) -> BlockFailed:
        at = f"{block.doc}:{line}" if line else block.id
        msg = [f"{at}: ```{block.lang} block (fence at line {block.line}) {why}"]
        if command is not None:
            msg.append(f"  command: {command.strip()}")
        if block.replaces:
            msg.append("  run with: " + "; ".join(f"{o!r} -> {n!r}" for o, n in block.replaces))
        msg.append(f"  in: {self.workdir}")
        msg.append("  output (last lines):\n" + tail(output))
        return BlockFailed("\n".join(msg))

    # -- the public part ------------------------------------------------------------------------
    def run(self, block: Block) -> None:
        """Run ``block`` (raises :class:`BlockFailed`); skipped blocks are the caller's business."""
        if not self._cloned:
            make_clone(self.workdir, self.root)
            self._cloned = True
        before = snapshot(self.workdir)
        try:
            if block.lang in PYTHON_LANGS:
                commands = []
                self._run_python(block)
            elif block.lang in CONSOLE_LANGS:
                commands = self._run_console(block)
            elif block.interactive:
                commands = []
                self._run_interactive(block)
            else:
                commands = [c for _, c in shell_commands(block.text())]
                self._run_shell(block)
        except BlockFailed as exc:
            self.done[block.line] = str(exc)
            raise
        after = snapshot(self.workdir)
        problems = check_outputs(self.workdir, before, after)
        problems += [f"did not write {m}" for m in missing_outputs(self.workdir, commands)]
        if problems:
            self.done[block.line] = "output check failed"
            raise self._fail(block, "ran, but its output files are wrong:\n  " + "\n  ".join(problems))
        self.done[block.line] = None

    def close(self) -> None:
        k, self.kernel = self.kernel, None
        if k is None:
            return
        try:
            k.stdin.close()
            k.wait(30)
        except (OSError, subprocess.TimeoutExpired):
            pass
        _kill_group(k)

    # -- Python -----------------------------------------------------------------------------------
    def _start_kernel(self) -> subprocess.Popen:
        if self.kernel is None:
            self._kernel_err = self._file("python-stderr.txt")
            with open(self._kernel_err, "wb") as err:
                self.kernel = subprocess.Popen(
                    [str(venv_bin(self.root) / "python"), "-u", "-c", _KERNEL], cwd=self.workdir,
                    env=self.env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=err,
                    start_new_session=True)
        return self.kernel

    def _run_python(self, block: Block) -> None:
        k = self._start_kernel()
        out = self._file("python.txt")
        req = {"code": block.text(), "line": block.line, "file": block.doc, "output": str(out)}
        try:
            k.stdin.write((json.dumps(req) + "\n").encode())
            k.stdin.flush()
        except OSError:
            pass
        reply, deadline = b"", time.monotonic() + block.timeout
        while not reply.endswith(b"\n"):
            left = deadline - time.monotonic()
            ready = select.select([k.stdout], [], [], max(0.0, left))[0] if left > 0 else []
            if not ready:
                self.kernel = None
                _kill_group(k)
                raise self._fail(block, f"timed out after {block.timeout:g} s", output=_read(out))
            chunk = os.read(k.stdout.fileno(), 65536)
            if not chunk:
                self.kernel = None
                rc = k.wait()
                raise self._fail(block, f"killed its Python interpreter (exit status {rc})",
                                 output=_read(out) + "\n" + _read(self._kernel_err))
            reply += chunk
        error = json.loads(reply)["error"]
        if error:
            m = re.findall(rf'File "{re.escape(block.doc)}", line (\d+)', error)
            line = int(m[-1]) if m else None
            raise self._fail(block, f"raised {error.strip().splitlines()[-1]}", output=_read(out) + "\n" + error,
                             line=line, command=_line_of(block, line))

    # -- shell ------------------------------------------------------------------------------------
    def _spawn(self, argv: list, out: Path) -> subprocess.Popen:
        with open(out, "wb") as f:
            return subprocess.Popen(argv, cwd=self.workdir, env=self.env, stdin=subprocess.DEVNULL,
                                    stdout=f, stderr=subprocess.STDOUT, start_new_session=True)

    def _wait(self, p: subprocess.Popen, timeout: float) -> int | None:
        try:
            return p.wait(timeout)
        except subprocess.TimeoutExpired:
            return None
        finally:
            if p.returncode is not None:
                _kill_group(p)        # background children the commands left running

    def _run_shell(self, block: Block) -> None:
        script, out, errline = self._file("block.sh"), self._file("shell.txt"), self._file("errline")
        curline = self._file("curline")
        # the header on line 1, the code at the document's line numbers, so $LINENO is the doc line;
        # the ERR trap records the failing command's line, the DEBUG trap the running one's
        head = (f"set -eo pipefail; trap 'echo $LINENO > {shlex.quote(str(errline))}' ERR; "
                f"trap 'echo $LINENO > {shlex.quote(str(curline))}' DEBUG")
        script.write_text(head + "\n" * block.line + block.text())
        p = self._spawn(["bash", str(script)], out)
        rc = self._wait(p, block.timeout)
        if rc is None:
            _kill_group(p)
            line = _command_start(block, _int(curline))
            raise self._fail(block, f"timed out after {block.timeout:g} s", command=_line_of(block, line),
                             output=_read(out), line=line)
        if rc != 0:
            line = _command_start(block, _int(errline))
            raise self._fail(block, f"failed (exit status {rc})", command=_line_of(block, line),
                             output=_read(out), line=line)

    def _run_interactive(self, block: Block) -> None:
        display = self.env.get("DISPLAY")
        for k, cmd in shell_commands(block.text()):
            out = self._file("interactive.txt")
            p = self._spawn(["bash", "-c", cmd], out)
            line = block.line + k
            # the window must appear (its title names cellgl), then the command must stay up
            deadline, seen = time.monotonic() + block.timeout, None
            while display and seen is None and p.poll() is None and time.monotonic() < deadline:
                names = x11_window_names(display)
                if names is None:
                    break               # no libX11 to ask: the staying-up check alone
                seen = next((n for n in names if "cellgl" in n), None)
                if seen is None:
                    time.sleep(0.25)
            if display and seen is None and p.poll() is None and time.monotonic() >= deadline:
                _kill_group(p)
                raise self._fail(block, f"opened no window titled 'cellgl...' within {block.timeout:g} s",
                                 command=cmd, output=_read(out), line=line)
            rc = self._wait(p, INTERACTIVE_SECONDS)
            if rc is not None:
                raise self._fail(block, f"exited (status {rc}) instead of staying open for "
                                        f"{INTERACTIVE_SECONDS:g} s", command=cmd, output=_read(out), line=line)
            _kill_group(p)
            text = _read(out)
            if "Traceback" in text or "error:" in text.lower():
                raise self._fail(block, "printed an error while open", command=cmd, output=text, line=line)

    # -- console ----------------------------------------------------------------------------------
    def _run_console(self, block: Block) -> list[str]:
        """Runs the commands; returns those shown without output (they must succeed and write
        what they name; the others may show an error)."""
        commands = []
        try:
            items = console_items(block.text())
        except DocError as exc:
            raise self._fail(block, str(exc)) from None
        for line, cmd, expected in items:
            if not expected:
                commands.append(cmd)
            out = self._file("console.txt")
            p = self._spawn(["bash", "-c", cmd], out)
            rc = self._wait(p, block.timeout)
            at = block.line + line
            if rc is None:
                _kill_group(p)
                raise self._fail(block, f"timed out after {block.timeout:g} s", command=cmd,
                                 output=_read(out), line=at)
            got = _read(out)
            if not expected and rc != 0:
                raise self._fail(block, f"failed (exit status {rc})", command=cmd, output=got, line=at)
            if not console_matches(expected, got):
                raise self._fail(block, "printed something else than the document shows:\n  expected:\n"
                                 + tail("\n".join(expected), 1000) + "\n  got:", command=cmd, output=got, line=at)
        return commands


def console_items(code: str) -> list[tuple[int, str, list[str]]]:
    """(1-based line of the command in the block, command, expected output lines)."""
    items: list = []
    cont = False
    for k, ln in enumerate(code.rstrip("\n").split("\n"), 1):
        if cont:
            items[-1][1] += "\n" + ln
            cont = ln.rstrip().endswith("\\")
        elif ln.startswith("$ ") or ln.rstrip() == "$":
            items.append([k, ln[2:], []])
            cont = ln.rstrip().endswith("\\")
        elif items:
            items[-1][2].append(ln.rstrip())
        elif ln.strip():
            raise DocError(f"console block: line {k} is output before any '$ ' command")
    for it in items:
        while it[2] and not it[2][-1]:
            it[2].pop()
    return [tuple(it) for it in items]


def _command_start(block: Block, line: int | None) -> int | None:
    """The first line of the (possibly continued) command that ends on doc line ``line``."""
    if line is None:
        return None
    lines = block.code.split("\n")
    k = line - block.line - 1
    while 0 < k < len(lines) and lines[k - 1].rstrip().endswith("\\"):
        k -= 1
    return block.line + 1 + k if 0 <= k < len(lines) else line


def _line_of(block: Block, line: int | None) -> str | None:
    """The text of document line ``line`` (inside ``block``), continuation lines joined."""
    if line is None:
        return None
    lines = block.text().split("\n")
    k = line - block.line - 1
    if not 0 <= k < len(lines):
        return None
    text = lines[k]
    while text.rstrip().endswith("\\") and k + 1 < len(lines):
        k += 1
        text = text.rstrip()[:-1] + " " + lines[k].strip()
    return text


def _int(path: Path) -> int | None:
    try:
        return int(path.read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return None


def _read(path: Path) -> str:
    try:
        return path.read_bytes().decode("utf-8", "replace")
    except OSError:
        return ""


def _kill_group(p: subprocess.Popen) -> None:
    """End the process group a block started (its background children too)."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(p.pid, sig)
        except (ProcessLookupError, PermissionError):
            break
        try:
            p.wait(5)
        except subprocess.TimeoutExpired:
            continue
        if sig == signal.SIGTERM:
            time.sleep(0.2)       # let the group's other members go too
    try:
        p.wait(5)
    except subprocess.TimeoutExpired:
        pass
