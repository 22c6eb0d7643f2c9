"""Shader text: include resolution, defines, line map, error mapping. No GL."""

from __future__ import annotations

from pathlib import Path

import pytest

from cellgl.gl import glsl


def write(root: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return root


@pytest.fixture
def tree(tmp_path):
    return write(tmp_path, {
        "main.comp": (
            "#version 430\n"                 # 1
            '#include "lib/a.glsl"\n'        # 2
            '#include "lib/b.glsl"\n'        # 3
            "void main() {}\n"               # 4
        ),
        "lib/a.glsl": (
            "// a line 1\n"
            '#include "b.glsl"\n'
            "float a() { return b(); }\n"
        ),
        "lib/b.glsl": (
            "// b line 1\n"
            '#include "a.glsl"  // cycle: harmless\n'
            "float b() { return 1.0; }\n"
        ),
    })


def lines_of(src: glsl.Source) -> list[str]:
    return src.text.splitlines()


def test_shader_dir_is_source_tree_or_package():
    d = glsl.shader_dir()
    assert d.name == "shaders"
    assert d.is_dir()


def test_include_once_markers_and_order(tree):
    src = glsl.load("main.comp", root=tree)
    assert lines_of(src) == [
        "#version 430",
        "// begin lib/a.glsl",
        "// a line 1",
        "// begin lib/b.glsl",
        "// b line 1",
        "float b() { return 1.0; }",
        "// end lib/b.glsl",
        "float a() { return b(); }",
        "// end lib/a.glsl",
        "void main() {}",
    ]
    assert src.files == ["main.comp", "lib/a.glsl", "lib/b.glsl"]
    assert src.text.endswith("\n")
    assert len(src.line_map) == len(lines_of(src))


def test_line_map_points_at_original_lines(tree):
    src = glsl.load("main.comp", root=tree)
    files = {rel: (tree / rel).read_text().splitlines() for rel in src.files}
    for k, line in enumerate(lines_of(src), start=1):
        rel, num = src.line_map[k - 1]
        if line.startswith(("// begin ", "// end ")):
            # markers point at the #include that produced them
            assert "#include" in files[rel][num - 1]
        else:
            assert files[rel][num - 1] == line, (k, rel, num)
    assert src.origin(6) == ("lib/b.glsl", 3)
    assert src.origin(0) is None and src.origin(999) is None


def test_defines_after_version(tree):
    defines = {"CELL_FLAG": True, "CELL_OFF": False, "CELL_N": 3, "CELL_X": 0.1,
               "CELL_NAME": "vec3(1.0)", "CELL_EMPTY": None}
    src = glsl.load("main.comp", defines, root=tree)
    lines = lines_of(src)
    assert lines[0] == "#version 430"
    assert lines[1:7] == [
        "#define CELL_FLAG 1",
        "#define CELL_OFF 0",
        "#define CELL_N 3",
        "#define CELL_X 0.1",
        "#define CELL_NAME vec3(1.0)",
        "#define CELL_EMPTY",
    ]
    assert src.line_map[1] == (glsl.DEFINES_FILE, 1)
    assert src.line_map[7] == ("main.comp", 2)  # "// begin lib/a.glsl"
    assert src.origin(len(lines)) == ("main.comp", 4)


def test_defines_without_version_go_on_top(tmp_path):
    write(tmp_path, {"x.frag": "void main() {}\n"})
    src = glsl.load("x.frag", {"A": 1}, root=tmp_path)
    assert lines_of(src) == ["#define A 1", "void main() {}"]
    assert src.line_map == [(glsl.DEFINES_FILE, 1), ("x.frag", 1)]


def test_float_defines_round_trip():
    value = 0.1 + 0.2
    line = glsl.format_define("F", value)
    assert float(line.split()[-1]) == value
    assert glsl.format_define("G", 1e-30) == "#define G 1e-30"
    with pytest.raises(ValueError, match="not finite"):
        glsl.format_define("H", float("nan"))
    with pytest.raises(ValueError, match="identifier"):
        glsl.format_define("1BAD", 1)
    with pytest.raises(ValueError, match="unsupported"):
        glsl.format_define("L", [1, 2])


def test_numpy_and_enum_defines():
    import enum

    import numpy as np

    class Metric(enum.IntEnum):
        EUCLID = 2

    assert glsl.format_define("M", Metric.EUCLID) == "#define M 2"
    assert glsl.format_define("N", np.int32(7)) == "#define N 7"
    assert glsl.format_define("B", np.bool_(True)) == "#define B 1"
    assert float(glsl.format_define("F", np.float32(0.1)).split()[-1]) == float(np.float32(0.1))


def test_missing_include_names_file_and_line(tmp_path):
    write(tmp_path, {"m.comp": "#version 430\n\n#include \"lib/nope.glsl\"\n"})
    with pytest.raises(glsl.ShaderError) as info:
        glsl.load("m.comp", root=tmp_path)
    msg = str(info.value)
    assert "m.comp:3" in msg and "lib/nope.glsl" in msg


def test_missing_entry_file(tmp_path):
    with pytest.raises(glsl.ShaderError, match="absent.comp"):
        glsl.load("absent.comp", root=tmp_path)


def test_library_with_version_rejected(tmp_path):
    write(tmp_path, {"m.comp": '#version 430\n#include "lib/v.glsl"\n',
                     "lib/v.glsl": "// ok\n#version 450\n"})
    with pytest.raises(glsl.ShaderError, match=r"lib/v\.glsl:2.*#version"):
        glsl.load("m.comp", root=tmp_path)


def test_include_outside_root_rejected(tmp_path):
    write(tmp_path, {"m.comp": '#include "../evil.glsl"\n'})
    with pytest.raises(glsl.ShaderError, match="outside"):
        glsl.load("m.comp", root=tmp_path)


def test_malformed_include_rejected(tmp_path):
    write(tmp_path, {"m.comp": "#include lib/a.glsl\n"})
    with pytest.raises(glsl.ShaderError, match=r"m\.comp:1: malformed"):
        glsl.load("m.comp", root=tmp_path)


def test_resolve_library(tree):
    src = glsl.resolve_library(["lib/b.glsl", "lib/a.glsl"], root=tree)
    text = src.text
    assert "#version" not in text
    assert src.files == ["lib/b.glsl", "lib/a.glsl"]
    assert lines_of(src)[0] == "// begin lib/b.glsl"
    assert lines_of(src)[-1] == "// end lib/b.glsl"  # a.glsl came in via b.glsl
    assert text.count("float a()") == 1 and text.count("float b()") == 1
    with pytest.raises(TypeError):
        glsl.resolve_library("lib/a.glsl", root=tree)


def test_resolve_library_rejects_version(tmp_path):
    write(tmp_path, {"lib/v.glsl": "#version 430\n"})
    with pytest.raises(glsl.ShaderError, match="#version"):
        glsl.resolve_library(["lib/v.glsl"], root=tmp_path)


def test_a_template_is_included_each_time(tmp_path):
    """A file marked `#pragma cellgl include_each_time` (lib/ring_loop.glsl) comes in at every
    #include, its names set by the includer's #defines; the marker line is dropped, the line map
    still points at the template's lines, and ordinary files still come in once."""
    write(tmp_path, {
        "m.comp": ("#version 430\n"
                   '#include "lib/a.glsl"\n'
                   "#define NAME first\n"
                   '#include "lib/t.glsl"\n'
                   "#define NAME second\n"
                   '#include "lib/t.glsl"\n'),
        "lib/a.glsl": "float a() { return 1.0; }\n",
        "lib/t.glsl": ("// a template\n"
                       "#pragma cellgl include_each_time  // the marker\n"
                       '#include "a.glsl"\n'
                       "float NAME() { return a(); }\n"
                       "#undef NAME\n"),
    })
    src = glsl.load("m.comp", root=tmp_path)
    lines = lines_of(src)
    assert lines.count("float NAME() { return a(); }") == 2
    assert lines.count("float a() { return 1.0; }") == 1
    assert not any("pragma" in ln for ln in lines)
    assert src.files == ["m.comp", "lib/a.glsl", "lib/t.glsl"]
    at = [src.origin(k + 1) for k, ln in enumerate(lines) if ln.startswith("float NAME")]
    assert at == [("lib/t.glsl", 4), ("lib/t.glsl", 4)]
    lib = glsl.resolve_library(["lib/t.glsl", "lib/t.glsl"], root=tmp_path)
    assert lines_of(lib).count("float NAME() { return a(); }") == 2


def test_a_template_including_itself_is_an_error(tmp_path):
    write(tmp_path, {"m.comp": '#include "lib/t.glsl"\n',
                     "lib/t.glsl": '#pragma cellgl include_each_time\n#include "u.glsl"\n',
                     "lib/u.glsl": '#include "t.glsl"\n'})
    with pytest.raises(glsl.ShaderError, match=r"lib/u\.glsl:1: 'lib/t\.glsl' .* includes itself"):
        glsl.load("m.comp", root=tmp_path)


def test_shader_dir_monkeypatch_is_used(tree, monkeypatch):
    monkeypatch.setattr(glsl, "shader_dir", lambda: tree)
    assert glsl.load("main.comp").files[0] == "main.comp"


# ---- map_error -------------------------------------------------------------------------------


@pytest.fixture
def src(tree):
    # output line 6 is lib/b.glsl:3, line 8 is lib/a.glsl:3
    return glsl.load("main.comp", root=tree)


def test_map_error_mesa(src):
    msg = "0:6(12): error: `x' undeclared\n0:8(1): warning: unused\n"
    out = glsl.map_error(msg, src)
    assert out == "lib/b.glsl:3(12): error: `x' undeclared\nlib/a.glsl:3(1): warning: unused\n"


def test_map_error_nvidia(src):
    msg = '0(6) : error C1008: undefined variable "x"'
    assert glsl.map_error(msg, src) == 'lib/b.glsl:3 : error C1008: undefined variable "x"'


def test_map_error_glslang(src):
    msg = "ERROR: 0:8: 'x' : undeclared identifier\nERROR: 1 compilation errors.  No code generated."
    out = glsl.map_error(msg, src)
    assert out.splitlines()[0] == "ERROR: lib/a.glsl:3: 'x' : undeclared identifier"
    assert out.splitlines()[1] == "ERROR: 1 compilation errors.  No code generated."


def test_map_error_leaves_unknown_lines(src):
    msg = "0:999(3): error: far away\nsome other text 0:6 in the middle\n"
    assert glsl.map_error(msg, src) == msg


def test_map_error_inside_moderngl_message(src):
    msg = "GLSL Compiler failed\n\ncompute_shader\n==============\n0:6(14): error: `foo' undeclared\n"
    assert "lib/b.glsl:3(14): error: `foo' undeclared" in glsl.map_error(msg, src)


def test_the_search_and_the_walks_share_one_ring_loop():
    """shaders/lib: the ring loop is written once (ring_loop.glsl), the search's and the walks'
    instances of it come from that file's lines, each under its walker's name."""
    walks = glsl.resolve_library(["lib/features.glsl"])
    search = glsl.resolve_library(["lib/cellular.glsl"])
    assert lines_of(walks).count("// begin lib/ring_loop.glsl") == 2
    assert lines_of(search).count("// begin lib/ring_loop.glsl") == 1
    heads = [k for k, ln in enumerate(lines_of(walks)) if ln.startswith("void _CELL_RINGS(")]
    assert [walks.origin(k + 1)[0] for k in heads] == ["lib/ring_loop.glsl"] * 2
    names = [ln.split()[2] for ln in lines_of(walks) if ln.startswith("#define _CELL_RINGS ")]
    assert names == ["_cell_search_rings", "_cell_walk_ring_loop"]
