"""The package's architecture holds: every module imports alone, there is no import cycle, and
imports only go down the layers of docs/architecture.md (lazy imports inside functions count)."""
from __future__ import annotations

import ast
import importlib.util
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: the layers, bottom first: a module may import modules of its own layer or below, never above.
#: Each entry is a module or a package prefix (every module under it).
#: docs/architecture.md's table is the same map: row ``# = index + 1`` names every module of the layer.
LAYERS = (
    ("files", ("cellgl._version", "cellgl._interrupt", "cellgl._cache", "cellgl.io", "cellgl.presets")),
    ("gl", ("cellgl.gl",)),
    ("basis", ("cellgl.basis",)),
    ("texture", ("cellgl.texture",)),
    ("pups", ("cellgl.pups",)),
    ("recipes", ("cellgl.recipes",)),
    ("front ends", ("cellgl.export", "cellgl.playground", "cellgl.bake", "cellgl.dask", "cellgl.blender")),
    ("public API", ("cellgl",)),
    ("viewer", ("cellgl.viewer",)),
    ("cli", ("cellgl.cli", "cellgl.__main__")),
)


#: source folder -> the package it installs as (pyproject.toml's package-dir)
PACKAGE_DIRS = {"cellgl": "cellgl", "viewer": "cellgl.viewer"}



def import_base(node: ast.ImportFrom, package: str) -> str:
    """The absolute module a ``from ... import`` names (a relative one resolved against ``package``)."""
    base = node.module or ""
    if node.level:
        anchor = package.split(".")[:len(package.split(".")) - node.level + 1]
        base = ".".join(anchor + ([base] if base else []))
    return base

def _modules() -> dict[str, Path]:
    out = {}
    for top, package in PACKAGE_DIRS.items():
        for path in sorted((ROOT / top).rglob("*.py")):
            parts = (package,) + path.relative_to(ROOT / top).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = path
    return out


MODULES = _modules()


def _layer(module: str) -> int:
    """Index in LAYERS of the most specific prefix that holds ``module``."""
    best, best_len = None, -1
    for i, (_, prefixes) in enumerate(LAYERS):
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and len(p) > best_len:
                best, best_len = i, len(p)
    assert best is not None, f"{module} is in no layer: add it to LAYERS (and docs/architecture.md)"
    return best


def _imports(module: str) -> set[str]:
    """The project modules ``module`` imports (at any depth of its code)."""
    path = MODULES[module]
    tree = ast.parse(path.read_text(), str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = import_base(node, package)
            # `from pkg import name`: the submodule pkg.name where there is one, else pkg
            names = [f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else base for a in node.names]
        else:
            continue
        for name in names:
            while name and name not in MODULES:   # `import cellgl.gl.glsl.x` -> the module itself
                name = name.rpartition(".")[0]
            if name and name != module:
                out.add(name)
    return out


GRAPH = {m: _imports(m) for m in MODULES}


def test_every_module_is_in_a_layer():
    for m in MODULES:
        _layer(m)


def test_imports_go_down_the_layers():
    bad = []
    for m, deps in GRAPH.items():
        for d in deps:
            if _layer(d) > _layer(m):
                bad.append(f"{m} ({LAYERS[_layer(m)][0]}) imports {d} ({LAYERS[_layer(d)][0]})")
    assert not bad, "imports against the layer order:\n" + "\n".join(sorted(bad))


def _doc_rows() -> dict[int, str]:
    """docs/architecture.md's layer table: ``#`` -> the "modules" cell."""
    rows = {}
    for line in (ROOT / "docs" / "architecture.md").read_text().splitlines():
        m = re.match(r"^\| (\d+) \| [^|]+ \| (.*) \| [^|]* \|$", line)
        if m:
            rows[int(m.group(1))] = m.group(2)
    return rows


def _on_map(module: str, row: str) -> bool:
    """Whether a row of the map names ``module``: its file (``cellgl/bake/core.py``), a package its
    folder (``cellgl/blender/addon/`` or ``addon/``), a module of a folder its name (```bake```)."""
    path = MODULES[module].relative_to(ROOT).as_posix()
    last = module.rpartition(".")[2]
    if MODULES[module].name == "__init__.py":
        folder = path.rpartition("/")[0]
        return f"`{path}`" in row or f"`{folder}/`" in row or f"`{folder.rpartition('/')[2]}/`" in row
    return f"`{path}`" in row or f"`{last}`" in row or f"`{last}.py`" in row


def test_every_module_is_on_the_map():
    """docs/architecture.md names every module in the row of the layer LAYERS puts it in (the map
    and this test are one table)."""
    rows = _doc_rows()
    assert sorted(rows) == list(range(len(LAYERS) + 1)), sorted(rows)   # + row 0, the shaders
    off = [f"{m} ({LAYERS[_layer(m)][0]}, row {_layer(m) + 1})" for m in sorted(MODULES)
           if not _on_map(m, rows[_layer(m) + 1])]
    assert not off, "modules docs/architecture.md does not name in their layer's row:\n" + "\n".join(off)


def test_folders_list_their_modules_bottom_first():
    """Inside the folders of the GL, basis, texture and PUPs layers, a module imports only modules
    the map's row lists before it (docs/architecture.md: "in the order listed, bottom first")."""
    rows = _doc_rows()
    bad = []
    for i, (name, (folder, *_)) in enumerate(LAYERS):
        if name not in ("gl", "basis", "texture", "pups"):
            continue
        order = {n: k for k, n in enumerate(dict.fromkeys(re.findall(r"`(\w+)`", rows[i + 1])))}
        for m in sorted(MODULES):
            if m.startswith(folder + "."):
                for d in sorted(GRAPH[m]):
                    a, b = m[len(folder) + 1:].partition(".")[0], d[len(folder) + 1:].partition(".")[0]
                    if d.startswith(folder + ".") and order[b] > order[a]:
                        bad.append(f"{m} imports {d}, listed after it")
    assert not bad, "\n".join(bad)


#: what depends on a recipe's kind (cellular texture or PUPs): loading a recipe or a preset,
#: listing presets, telling kinds and files apart, rendering, evaluating, a recipe's parameter
#: table, the largest side. Above the recipes layer these come from cellgl.recipes, which picks
#: the kind, never from cellgl.texture or cellgl.pups (docs/architecture.md, "Why the cut is here").
KIND_ENTRY_POINTS = {"load_recipe", "list_presets", "render", "evaluate", "is_pups", "is_path",
                     "load_pups_preset", "pups_preset_names", "PUPS_PARAMS", "MAX_SIDE"}
KIND_LAYERS = {"texture", "pups"}


def _kind_entry_imports(module: str, graph_layer=None) -> list[str]:
    """The kind entry points ``module`` takes from a kind's layer: ``from cellgl.texture.x import
    render``, or ``texture.render`` on a name bound to a kind's module."""
    path = MODULES[module]
    tree = ast.parse(path.read_text(), str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    layer = graph_layer or _layer

    def kind(name: str) -> bool:
        while name and name not in MODULES:
            name = name.rpartition(".")[0]
        return bool(name) and LAYERS[layer(name)][0] in KIND_LAYERS

    bound, out = {}, []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.asname and kind(a.name):
                    bound[a.asname] = a.name
        elif isinstance(node, ast.ImportFrom):
            base = import_base(node, package)
            for a in node.names:
                sub = f"{base}.{a.name}"
                if sub in MODULES and kind(sub):
                    bound[a.asname or a.name] = sub
                elif kind(base) and a.name in KIND_ENTRY_POINTS:
                    out.append(f"{module}:{node.lineno} imports {a.name} from {base}")
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr in KIND_ENTRY_POINTS:
            chain, v = [], node.value
            while isinstance(v, ast.Attribute):
                chain.append(v.attr)
                v = v.value
            if isinstance(v, ast.Name):
                name = ".".join([bound.get(v.id, v.id)] + chain[::-1])
                if (v.id in bound or name.startswith("cellgl.")) and kind(name):
                    out.append(f"{module}:{node.lineno} uses {name}.{node.attr}")
    return out


def test_front_ends_reach_the_kinds_through_recipes():
    """The rule the map states: above the recipes layer, nothing imports a kind's entry points."""
    recipes = [i for i, (name, _) in enumerate(LAYERS) if name == "recipes"][0]
    bad = [hit for m in sorted(MODULES) if _layer(m) > recipes for hit in _kind_entry_imports(m)]
    assert not bad, "kind entry points taken past cellgl.recipes:\n" + "\n".join(bad)


def test_the_kind_rule_can_fail(tmp_path, monkeypatch):
    """The check above sees both spellings of a kind's entry point."""
    src = tmp_path / "m.py"
    src.write_text("from cellgl.texture.recipe import list_presets\n"
                   "from cellgl import texture\n"
                   "def f(r):\n    return texture.render(r, 8, 8)\n")
    monkeypatch.setitem(MODULES, "cellgl.io.fake", src)
    hits = _kind_entry_imports("cellgl.io.fake", lambda m: 6 if m == "cellgl.io.fake" else _layer(m))
    assert hits == ["cellgl.io.fake:1 imports list_presets from cellgl.texture.recipe",
                    "cellgl.io.fake:4 uses cellgl.texture.render"], hits


def _underscore_imports(module: str) -> list[str]:
    """``"importer: module._name"`` for each underscore name ``module`` takes from another cellgl
    module: ``from cellgl.x import _name`` or ``x._name`` on a name bound to a cellgl module."""
    path = MODULES[module]
    tree = ast.parse(path.read_text(), str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]

    def owner(name: str) -> str:
        while name and name not in MODULES:
            name = name.rpartition(".")[0]
        return name

    def private(name: str) -> bool:
        return name.startswith("_") and not name.startswith("__")

    bound, out = {}, set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if owner(a.name):
                    bound[a.asname or a.name.partition(".")[0]] = a.name if a.asname else a.name.partition(".")[0]
        elif isinstance(node, ast.ImportFrom):
            base = import_base(node, package)
            for a in node.names:
                if f"{base}.{a.name}" in MODULES:
                    bound[a.asname or a.name] = f"{base}.{a.name}"
                elif private(a.name) and owner(base) and owner(base) != module:
                    out.add(f"{module}: {owner(base)}.{a.name}")
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and private(node.attr):
            chain, v = [], node.value
            while isinstance(v, ast.Attribute):
                chain.append(v.attr)
                v = v.value
            if isinstance(v, ast.Name) and v.id in bound:
                name = ".".join([bound[v.id]] + chain[::-1])
                if name in MODULES and name != module:
                    out.add(f"{module}: {name}.{node.attr}")
    return sorted(out)


#: underscore names still taken across modules: none (a name another module takes is public to
#: the package); the list only shrinks
UNDERSCORE_IMPORTS_LEFT: set[str] = set()


def test_no_underscore_name_crosses_modules():
    """A name another cellgl module uses is public to the package: it has no leading underscore."""
    got = {hit for m in sorted(MODULES) for hit in _underscore_imports(m)}
    assert not got - UNDERSCORE_IMPORTS_LEFT, "underscore names imported from another cellgl module " \
        "(drop the underscore: the name is the package's):\n" + "\n".join(sorted(got - UNDERSCORE_IMPORTS_LEFT))
    assert not UNDERSCORE_IMPORTS_LEFT - got, f"renamed since, drop from the list: {UNDERSCORE_IMPORTS_LEFT - got}"


def test_the_underscore_check_sees_both_spellings(tmp_path, monkeypatch):
    src = tmp_path / "m.py"
    src.write_text("from cellgl.texture.schema import _coerce, RecipeError\n"
                   "from cellgl.bake import core as B\n"
                   "import cellgl.io.spec as S\n"
                   "def f():\n    return B._load, S.check, B.__name__, B.bake\n")
    monkeypatch.setitem(MODULES, "cellgl.io.fake", src)
    assert _underscore_imports("cellgl.io.fake") == ["cellgl.io.fake: cellgl.bake.core._load",
                                                      "cellgl.io.fake: cellgl.texture.schema._coerce"]


def test_no_import_cycle():
    # a package's __init__ re-exports its modules; the implicit import of a parent package by its
    # submodules is not an edge
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for d in sorted(GRAPH[m]):
            if m.startswith(d + "."):
                continue
            if state.get(d) == 1:
                cycle = stack[stack.index(d):] + [d]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if d not in state:
                visit(d)
        stack.pop()
        state[m] = 2

    for m in sorted(GRAPH):
        if m not in state:
            visit(m)


def test_the_layer_test_sees_a_cycle(monkeypatch):
    """The checks above can fail: a made-up upward import is caught."""
    monkeypatch.setitem(GRAPH, "cellgl.basis.core", GRAPH["cellgl.basis.core"] | {"cellgl.texture.recipe"})
    with pytest.raises(AssertionError, match="cellgl.basis.core .basis. imports cellgl.texture.recipe"):
        test_imports_go_down_the_layers()


@pytest.mark.parametrize("chunk", range(4))
def test_each_module_imports_alone(chunk):
    """``import M`` in a fresh interpreter works for every module (no hidden order dependence)."""
    mods = [m for m in sorted(MODULES) if not m.endswith("__main__")][chunk::4]   # __main__ runs the CLI
    if importlib.util.find_spec("bpy") is None:     # the Blender add-on imports bpy, as add-ons do
        mods = [m for m in mods if not m.startswith("cellgl.blender.addon")]

    def run(m):
        r = subprocess.run([sys.executable, "-c", f"import {m}"], cwd=ROOT, capture_output=True,
                           text=True, timeout=120)
        return m, r.returncode, r.stderr.strip().splitlines()[-1:] if r.returncode else []

    with ThreadPoolExecutor(4) as pool:
        failed = [f"{m}: {err}" for m, rc, err in pool.map(run, mods) if rc]
    assert not failed, "modules that do not import alone:\n" + "\n".join(failed)


#: lines past which a module is an alarm, not a target. The largest modules that each do one job
#: are about 600 lines (texture/reference.py, pups/presets.py, bake/core.py: the NumPy twin of one
#: shader, a table of presets, one bake); past 800 a module has, every time it was looked at here,
#: been doing two jobs. Reaching the number asks for a split by idea (docs/architecture.md, "Rooms
#: by idea"), never for trimming lines to fit: a cap that tight was a target, and commits trimmed
#: to it. The number says nothing of a smaller module: texture/recipe.py did five jobs in 620
#: lines (review finds those).
MODULE_ALARM = 800
#: the same alarm for a shaders/lib file (its functions have their own cap below): the largest
#: single-idea files are about 500 lines (feature_walk.glsl, texture.glsl)
GLSL_ALARM = 650


def test_modules_stay_small():
    """No module past MODULE_ALARM lines: the alarm that a module does two jobs (split it by idea,
    do not trim it)."""
    big = {m: n for m, p in MODULES.items() if (n := len(p.read_text().splitlines())) > MODULE_ALARM}
    assert not big, f"modules over {MODULE_ALARM} lines (the alarm of a module doing two jobs: " \
        f"split each by idea, see MODULE_ALARM): {big}"


#: the argparse parsers below the command line's floor: the viewer's own program
#: (``python -m cellgl.viewer``) declares its arguments in the viewer, which `cellgl view` reuses
PARSERS_BELOW_THE_CLI = {"cellgl.viewer.cli"}


def _declares_a_parser(module: str) -> bool:
    tree = ast.parse(MODULES[module].read_text())
    return any(isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute)
               and n.func.attr in ("add_argument", "add_parser", "add_subparsers", "ArgumentParser")
               or isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id == "ArgumentParser"
               for n in ast.walk(tree))


def test_command_line_parsers_are_on_the_top_floor():
    """Every command's arguments are declared in the cli layer (cellgl/cli/), which loads the
    commands' modules by import statements, never by a module name in a string."""
    top = [i for i, (name, _) in enumerate(LAYERS) if name == "cli"][0]
    below = {m for m in MODULES if _layer(m) < top and _declares_a_parser(m)}
    assert below == PARSERS_BELOW_THE_CLI, f"argparse parsers below the command line: {below - PARSERS_BELOW_THE_CLI}" \
        f"; gone from the list: {PARSERS_BELOW_THE_CLI - below}"
    strings = [m for m in MODULES if _layer(m) == top and "import_module" in MODULES[m].read_text()]
    assert not strings, f"command modules loaded by name (importlib.import_module): {strings}"
    assert all(f"cellgl.cli.{c}" in GRAPH["cellgl.cli"] for c in ("bake", "export", "presets", "dask", "voronoi",
                                                                  "blender", "playground"))


def test_the_parser_check_can_fail(tmp_path, monkeypatch):
    src = tmp_path / "m.py"
    src.write_text("def add_parser(sub):\n    p = sub.add_parser('x')\n    p.add_argument('--y')\n")
    monkeypatch.setitem(MODULES, "cellgl.recipes", src)
    with pytest.raises(AssertionError, match="parsers below the command line: {'cellgl.recipes'}"):
        test_command_line_parsers_are_on_the_top_floor()


# --------------------------------------------------------------------------------------------
# the shader library (shaders/lib): small files, short functions, honest headers (issue 31)
# --------------------------------------------------------------------------------------------

LIB = ROOT / "shaders" / "lib"
#: generated files (their generator's table is the documentation)
GENERATED = {"texture_params.glsl"}
#: functions over the cap, with the reason (none left); the list only shrinks
LONG_FUNCTIONS: dict[str, int] = {}


def _glsl_functions(text: str):
    """(name, lines) of every function defined at the top level of a library file."""
    lines = text.split("\n")
    i = 0
    while i < len(lines):
        m = re.match(r"^[A-Za-z_][\w\[\]]*\s+(\w+)\s*\(", lines[i])
        if m and not lines[i].rstrip().endswith(";"):
            j = i
            while j < len(lines) and lines[j] != "}":
                j += 1
            yield m.group(1), j - i + 1
            i = j
        i += 1


def _glsl_header(text: str) -> str:
    out = []
    for ln in text.split("\n"):
        if not ln.startswith("//"):
            break
        out.append(ln)
    return "\n".join(out)


def test_glsl_library_files_stay_small():
    """No shaders/lib file past GLSL_ALARM lines (the alarm of two jobs, as MODULE_ALARM), no
    function past ~80."""
    big = {p.name: n for p in LIB.glob("*.glsl") if (n := len(p.read_text().splitlines())) > GLSL_ALARM}
    assert not big, f"shaders/lib files over {GLSL_ALARM} lines (split by idea): {big}"
    long = {f"{p.name}:{name}": n for p in LIB.glob("*.glsl") for name, n in _glsl_functions(p.read_text())
            if n > LONG_FUNCTIONS.get(name, 80)}
    assert not long, f"shaders/lib functions over 80 lines: {long}"


def _named(name: str, macro: str, seen=()) -> bool:
    """Whether the header of lib file ``name`` names ``macro``, itself or through "those of X.glsl"."""
    head = _glsl_header((LIB / name).read_text())
    if re.search(rf"\b{macro}\b", head):
        return True
    return any(other not in seen and _named(other, macro, seen + (name,))
               for other in re.findall(r"those of (\w+\.glsl)", head))


def test_glsl_library_headers_name_their_macros_and_includes():
    """Each library file lists every macro its directives read, and #includes every lib file its
    header says it requires (so it compiles included alone)."""
    missing = []
    for p in sorted(LIB.glob("*.glsl")):
        if p.name in GENERATED:
            continue
        text = p.read_text()
        defaults = set(re.findall(r"^#ifndef\s+(\w+)", text, re.M))
        own = set(re.findall(r"^#define\s+(\w+)", text, re.M)) - defaults
        read = {m for ln in text.split("\n") if re.match(r"\s*#\s*(if|elif|ifdef|ifndef)\b", ln)
                for m in re.findall(r"\bCELL_\w+", ln)}
        for m in sorted(read - own):
            if not m.startswith(("CELL_DIST_", "CELL_METRIC_", "CELL_DMAP_", "CELL_TEX_")) and not _named(p.name, m):
                missing.append(f"{p.name}: {m}")
        req = re.search(r"Requires: ([^.]*)", _glsl_header(text))
        included = set(re.findall(r'^#include "(\w+\.glsl)"', text, re.M))
        for r in re.findall(r"(\w+\.glsl)", req.group(1) if req else ""):
            if (LIB / r).exists() and r not in included and r != p.name:
                # a file may require one that a file it includes includes
                if not any(r in re.findall(r'^#include "(\w+\.glsl)"', (LIB / i).read_text(), re.M) for i in included):
                    missing.append(f"{p.name}: requires {r} without including it")
    assert not missing, "\n".join(missing)


def test_glsl_sentinel_is_named_once():
    """The "nothing found yet" distance is CELL_FAR (walk.glsl), not a literal written everywhere."""
    hits = {p.name: p.read_text().count("3.0e38") for p in LIB.glob("*.glsl")}
    assert {k: v for k, v in hits.items() if v} == {"walk.glsl": 1}
