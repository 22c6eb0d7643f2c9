"""Every fenced Python and shell block of README.md and docs/*.md runs as written.

One test per block (id ``DOC:LINE``, the line of its fence), in document order; the blocks of a
document share a working directory (a fresh copy of the clone) and a Python namespace. How blocks
run, what is checked and the markers (``<!-- docs-test: skip: REASON -->``, ``replace``,
``timeout``, ``interactive``) are in tests/docs_runner.py. Selecting one block (``-k
'textures.md:361'``) runs the blocks above it in its document first.

The second half tests the runner itself on small made-up documents.
"""
from __future__ import annotations

import time
from pathlib import Path

import pytest

import docs_runner as dr
from docs_runner import Block, BlockFailed, DocError, DocSession
from xvfb import require_gpu, some_display

ROOT = dr.ROOT


def _collect():
    blocks, errors = [], []
    for path in dr.documents(ROOT):
        try:
            blocks += dr.parse(path, ROOT)
        except DocError as exc:
            errors.append(str(exc))
    return blocks, errors


BLOCKS, PARSE_ERRORS = _collect()
RUNNABLE = [b for b in BLOCKS if b.runs]
BY_DOC: dict[str, list[Block]] = {}
for _b in RUNNABLE:
    BY_DOC.setdefault(_b.doc, []).append(_b)


@pytest.fixture(scope="module")
def display():
    """$DISPLAY, or an Xvfb started here for the blocks that open windows (None: no display)."""
    with some_display(missing_ok=True) as disp:
        yield disp


@pytest.fixture(scope="module")
def sessions(tmp_path_factory, display):
    made: dict[str, DocSession] = {}

    def get(doc: str) -> DocSession:
        if doc not in made:
            name = doc.replace("/", "_").replace(".md", "")
            s = DocSession(doc, tmp_path_factory.mktemp(f"docs-{name}-clone"),
                           tmp_path_factory.mktemp(f"docs-{name}-runner"), ROOT)
            if display:
                s.env["DISPLAY"] = display
            made[doc] = s
        return made[doc]

    get.display = display
    yield get
    for s in made.values():
        s.close()


def test_documents_parse_and_their_markers_are_valid():
    """Markers are well formed, right above a fence, not stale; .ci/setup and .ci/run are skipped."""
    assert not PARSE_ERRORS, "\n".join(PARSE_ERRORS)
    assert len(RUNNABLE) >= 20          # the runner sees the blocks at all


def _needs_display(block: Block) -> bool:
    return block.interactive or "cellgl view" in block.text() or "python -m cellgl.viewer" in block.text()


@pytest.mark.slow
@pytest.mark.parametrize("block", RUNNABLE, ids=[b.id for b in RUNNABLE])
def test_doc_block(block, sessions):
    if block.skip is not None:
        pytest.skip(f"{block.id}: {block.skip}")
    if _needs_display(block) and not sessions.display:
        if require_gpu():
            pytest.fail(f"{block.id}: needs a display: no DISPLAY and no Xvfb", pytrace=False)
        pytest.skip(f"{block.id}: needs a display (no DISPLAY, no Xvfb)")
    s = sessions(block.doc)
    for earlier in BY_DOC[block.doc]:
        if earlier.line >= block.line:
            break
        if earlier.skip is not None:
            continue
        if earlier.line not in s.done:
            try:
                s.run(earlier)
            except BlockFailed:
                pass
        if s.done[earlier.line] is not None:
            pytest.fail(f"{block.id}: not run: the block above it at {earlier.id} failed "
                        f"(its own test says why)", pytrace=False)
    failure = None
    try:
        s.run(block)
    except BlockFailed as exc:
        failure = str(exc)
    if failure:
        pytest.fail(failure, pytrace=False)


# ------------------------------------------------------------------------------------------------
# the runner itself, on made-up documents
# ------------------------------------------------------------------------------------------------

def _doc(tmp_path: Path, text: str) -> tuple[list[Block], DocSession]:
    root = tmp_path / "repo"
    (root / "docs").mkdir(parents=True, exist_ok=True)
    (root / "data.txt").write_text("a file of the clone\n")
    (root / "docs" / "t.md").write_text(text)
    blocks = dr.parse(root / "docs" / "t.md", root)
    return blocks, DocSession("docs/t.md", tmp_path / "work", tmp_path / "private", root)


def _run_all(blocks, session):
    try:
        for b in blocks:
            if b.runs and b.skip is None:
                session.run(b)
    finally:
        session.close()


FENCE = "```"


def test_runner_python_blocks_share_a_namespace_and_report_the_failing_line(tmp_path):
    blocks, s = _doc(tmp_path, f"""# t

{FENCE}python
import numpy as np
from PIL import Image
x = np.zeros((4, 5, 3), np.uint8)
{FENCE}

{FENCE}python
Image.fromarray(x).save("x.png")
print(open("data.txt").read())
{FENCE}

{FENCE}python
y = 1
y = undefined_name + 1
{FENCE}
""")
    with pytest.raises(BlockFailed) as exc:
        _run_all(blocks, s)
    msg = str(exc.value)
    assert msg.startswith("docs/t.md:16: ```python block (fence at line 14) raised NameError"), msg
    assert "command: y = undefined_name + 1" in msg
    assert (s.workdir / "x.png").is_file() and s.done[3] is None and s.done[9] is None


def test_runner_shell_failure_names_the_command_and_its_output(tmp_path):
    blocks, s = _doc(tmp_path, f"""{FENCE}sh
echo one > one.txt
ls --no-such-option \\
   data.txt
echo never
{FENCE}
""")
    with pytest.raises(BlockFailed) as exc:
        _run_all(blocks, s)
    msg = str(exc.value)
    assert msg.startswith("docs/t.md:3: ```sh block (fence at line 1) failed (exit status 2)"), msg
    assert "command: ls --no-such-option" in msg and "no-such-option" in msg.split("output")[1]
    assert not (s.workdir / "never").exists()


@pytest.mark.parametrize("command, problem", [
    ("printf 'not a png' > broken.png", "broken.png: does not read back as .png"),
    ("touch empty.npy", "wrote an empty file: empty.npy"),
    ("python -c 'pass' -o missing.png || true", "did not write missing.png"),
    ("echo x > .out.cellgl-1@h.abc.part.png", "left a temporary file behind"),
])
def test_runner_checks_the_files_a_block_writes(tmp_path, command, problem):
    blocks, s = _doc(tmp_path, f"{FENCE}bash\n{command}\n{FENCE}\n")
    with pytest.raises(BlockFailed) as exc:
        _run_all(blocks, s)
    assert problem in str(exc.value), str(exc.value)


def test_runner_markers(tmp_path):
    blocks, s = _doc(tmp_path, f"""<!-- docs-test: skip: needs a cluster -->
{FENCE}sh
exit 1
{FENCE}

<!-- docs-test: replace "--size 4096" "--size 8" -->
<!-- docs-test: timeout: 30 -->
{FENCE}sh
python -c "import sys; assert sys.argv[1:] == ['--size', '8'], sys.argv" --size 4096
{FENCE}

<!-- docs-test: timeout: 1 -->
{FENCE}sh
sleep 20
{FENCE}
""")
    assert blocks[0].skip == "needs a cluster" and blocks[1].timeout == 30
    s.run(blocks[1])
    t0 = time.monotonic()
    with pytest.raises(BlockFailed, match=r"docs/t.md:14: .*timed out after 1 s\n  command: sleep 20"):
        s.run(blocks[2])
    assert time.monotonic() - t0 < 15
    s.close()


@pytest.mark.parametrize("text, error", [
    ('<!-- docs-test: skipp: x -->\n```sh\ntrue\n```\n', "unknown docs-test marker"),
    ('<!-- docs-test: skip: -->\n```sh\ntrue\n```\n', "needs a reason"),
    ('<!-- docs-test: replace "4096" "64" -->\n```sh\ntrue\n```\n', "does not occur in the block"),
    ('<!-- docs-test: skip: x -->\n\n```sh\ntrue\n```\n', "right above the fence"),
    ('<!-- docs-test: skip: x -->\n```text\ntrue\n```\n', "not run"),
    ('```sh\nbash .ci/run\n```\n', "must be marked"),
    ('<!-- docs-test: skip: x\n-->\n```sh\ntrue\n```\n', "one whole line"),
    ('```python\nr = cellgl.load_recipe("f1")\n```\n', "without 'import cellgl'"),
    ('```python\nx = [1,\n```\n', "not valid Python"),
])
def test_runner_refuses_bad_markers(tmp_path, text, error):
    """A marker that would be silently ignored is an error naming the document and line."""
    with pytest.raises(DocError, match=error) as exc:
        _doc(tmp_path, "# t\n" + text)
    assert str(exc.value).startswith(("docs/t.md:2:", "docs/t.md:3:")), str(exc.value)   # the fence, or the line


def test_runner_prose_may_mention_the_markers(tmp_path):
    blocks, _ = _doc(tmp_path, "Mark it with `<!-- docs-test: skip: REASON -->` above the fence.\n"
                               "<!-- an ordinary comment -->\n```sh\ntrue\n```\n")
    assert len(blocks) == 1 and blocks[0].skip is None and blocks[0].line == 3


def test_runner_console_blocks_compare_output(tmp_path):
    blocks, s = _doc(tmp_path, f"""{FENCE}console
$ echo '{{"a": 1}}' > a.json
$ python -c "print('one'); print('two'); print('three')"
one
...
three
$ echo hello
goodbye
{FENCE}
""")
    with pytest.raises(BlockFailed) as exc:
        _run_all(blocks, s)
    msg = str(exc.value)
    assert msg.startswith("docs/t.md:7: ```console block (fence at line 1) printed something else"), msg
    assert "goodbye" in msg and "hello" in msg
    assert (s.workdir / "a.json").is_file()


def test_runner_interactive_commands_must_stay_open(tmp_path, display):
    blocks, s = _doc(tmp_path, f"""<!-- docs-test: interactive -->
<!-- docs-test: timeout: 2 -->
{FENCE}sh
sleep 60                 # no window: fails where there is a display to look at
true
{FENCE}
""")
    s.env.pop("DISPLAY", None)
    if display:
        s.env["DISPLAY"] = display
        with pytest.raises(BlockFailed, match=r"docs/t.md:4: .*opened no window titled 'cellgl...' within 2 s"):
            s.run(blocks[0])
        assert dr.x11_window_names(display) is not None        # libX11 answers: the check is real
        s.env.pop("DISPLAY")
    with pytest.raises(BlockFailed, match=r"docs/t.md:5: .*exited \(status 0\) instead of staying open"):
        s.run(blocks[0])
    s.close()
