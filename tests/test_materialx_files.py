"""``cellgl export --target materialx -o DIR`` on disk (issue 48, items 9-11): every name the
export writes is unique, the set of files lands whole or not at all (a failed export leaves the
previous set untouched, a new one removes the previous set's files and nothing else), and the
output folder gets the messages every command gives. Needs neither MaterialX nor usd-core,
except the test that validates a document."""
from __future__ import annotations

import errno
import json
import os
from pathlib import Path

import pytest

from cellgl.export import materialx_files
from cellgl.export.materialx_docs import export_materialx
from cellgl.export.snippets import ExportError


_BASIS: list = []


@pytest.fixture(autouse=True)
def _basis_once(monkeypatch):
    """The basis nodes compiled once for the module (they are the same for every export)."""
    from cellgl.export import materialx_basis

    real = materialx_basis.basis_nodes

    def cached():
        if not _BASIS:
            _BASIS.extend(real())
        return list(_BASIS)

    monkeypatch.setattr(materialx_basis, "basis_nodes", cached)


def _recipe(tmp_path: Path, name: str, base: str = "f1") -> Path:
    from cellgl.recipes import load_recipe

    d = load_recipe(base).to_dict()
    d["name"] = name
    path = tmp_path / f"r{abs(hash(name))}.json"
    path.write_text(json.dumps(d))
    return path


def _cli(args, capsys):
    from cellgl.cli import main

    rc = main(["export", "--target", "materialx", *args])
    return rc, capsys.readouterr().err


def _tree(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _no_temporaries(*folders: Path) -> None:
    for f in folders:
        left = [p.name for p in f.rglob("*") if ".cellgl-" in p.name]
        assert not left, left


# ------------------------------------------------------------------------------ item 9: unique names


def test_recipe_named_like_a_basis_node_is_refused(tmp_path, capsys):
    """It exported with exit 0: two nodedefs of one name, the basis node's code overwritten."""
    path = _recipe(tmp_path, "cellular2d-euclidean-poisson")
    rc, err = _cli([str(path), "-o", str(tmp_path / "mx")], capsys)
    assert rc == 2, err
    assert ("the basis node 'cellgl_cellular2d_euclidean_poisson' and recipe 'cellular2d-euclidean-poisson' "
            "would both write the MaterialX element 'ND_cellgl_cellular2d_euclidean_poisson'") in err
    assert "rename the recipe" in err
    assert not (tmp_path / "mx").exists()
    # without the basis nodes there is nothing to collide with
    export_materialx(tmp_path / "alone", [str(path)], basis=False)
    assert (tmp_path / "alone" / "genglsl" / "cellgl_cellular2d_euclidean_poisson.glsl").is_file()


@pytest.mark.parametrize("a, b, kind, name", [
    ("my-stone", "my_stone", "MaterialX element", "ND_cellgl_my_stone"),       # the same once sanitised
    ("Stone", "stone", "file", "genglsl/cellgl_stone.glsl"),                    # one file on macOS, Windows
    ("M", "texture", "MaterialX element", "M_texture"),                          # the material of one, the node of the other
    ("stone", "stone-abs", "shader code name", "cellgl_stone_abs_vec3"),         # the code of both in one shader
    ("a-b", "aB", "shader code name", "CellglAB"),                               # their code's structs
    ("f1", "f1", "MaterialX element", "ND_cellgl_f1"),                           # given twice
])
def test_two_recipes_that_would_write_one_name_are_refused(tmp_path, a, b, kind, name):
    with pytest.raises(ExportError) as e:
        export_materialx(tmp_path / "mx", [str(_recipe(tmp_path, a)), str(_recipe(tmp_path, b))], basis=False)
    msg = str(e.value)
    assert f"recipe {a!r} and recipe {b!r} would both write the {kind} " in msg, msg
    assert name in msg, msg
    assert not (tmp_path / "mx").exists()


def test_distinct_names_export_and_the_materials_validate(tmp_path):
    """Names that only share a prefix are fine: the documents pass MaterialX's validate()."""
    mx = pytest.importorskip("MaterialX")
    out = tmp_path / "mx"
    export_materialx(out, [str(_recipe(tmp_path, "stone")), str(_recipe(tmp_path, "stone-dark")), "flagstone"])
    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    for name in (materialx_files.DEFS, materialx_files.MATERIALS):
        doc = mx.createDocument()
        mx.readFromXmlFile(doc, str(out / name))
        doc.importLibrary(lib)
        assert doc.validate() == (True, ""), name


def test_names_of_materialx_s_library_are_refused(tmp_path):
    """A recipe named `ND-lama` wrote the element ND_lama_surface, a nodedef of MaterialX's library."""
    with pytest.raises(ExportError) as e:
        export_materialx(tmp_path / "mx", [str(_recipe(tmp_path, "ND-lama"))], basis=False)
    assert "recipe 'ND-lama': its materials' names would start with 'ND_'" in str(e.value)
    assert "ND_lama_surface" in str(e.value) and not (tmp_path / "mx").exists()
    export_materialx(tmp_path / "mx", [str(_recipe(tmp_path, "NDx-lama"))], basis=False)


def test_the_library_prefixes_are_those_of_materialx():
    """Every name of MaterialX's standard library with a '_' starts with one of the prefixes
    the export refuses (a later MaterialX with another prefix fails here)."""
    mx = pytest.importorskip("MaterialX")
    from cellgl.export.materialx_docs import MX_LIBRARY_PREFIXES

    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    heads = {e.getName().split("_")[0] for e in lib.getChildren() if "_" in e.getName()}
    assert heads <= set(MX_LIBRARY_PREFIXES), heads - set(MX_LIBRARY_PREFIXES)
    assert not any(e.getName().startswith(("M_", "cellgl")) for e in lib.getChildren())


def test_documents_are_well_formed_xml(tmp_path):
    """The library's comment said `--target`: "--" is not allowed in an XML comment (MaterialX's
    own parser let it pass; a strict one refuses the file)."""
    from xml.etree import ElementTree

    export_materialx(tmp_path, ["f1"], basis=False)
    for name in (*materialx_files.LIBRARIES, materialx_files.MATERIALS):
        ElementTree.parse(tmp_path / name)


# ------------------------------------------------------------------------------ item 10: whole or nothing


def _fail_on_write(monkeypatch, after: int):
    """The ``after``-th file written fails as on a full disk."""
    import builtins

    count = [0]

    def fake_open(path, mode="r", *a, **kw):
        if "w" in mode:
            count[0] += 1
            if count[0] > after:
                raise OSError(errno.ENOSPC, "No space left on device", str(path))
        return builtins.open(path, mode, *a, **kw)

    monkeypatch.setattr(materialx_files, "open", fake_open, raising=False)


def test_a_failed_export_into_a_new_folder_leaves_nothing(tmp_path, monkeypatch, capsys):
    _fail_on_write(monkeypatch, 5)          # the five documents, then a code file
    rc, err = _cli(["f1", "-o", str(tmp_path / "mx")], capsys)
    assert rc == 2 and "No space left on device" in err, err
    assert str(tmp_path / "mx" / "genglsl") in err and ".cellgl-" not in err      # names the output
    assert os.listdir(tmp_path) == []


def test_a_failed_re_export_leaves_the_previous_set_untouched(tmp_path, monkeypatch, capsys):
    out = tmp_path / "mx"
    export_materialx(out, ["flagstone"], basis=False)
    (out / "notes.txt").write_text("mine")
    before = _tree(out)
    for after in (0, 2, 4):         # fails writing the new set
        with monkeypatch.context() as m:
            _fail_on_write(m, after)
            with pytest.raises(OSError) as e:
                export_materialx(out, ["f1"], basis=False)
        assert e.value.errno == errno.ENOSPC and str(out) in e.value.filename and ".cellgl-" not in str(e.value)
        assert _tree(out) == before
    real = os.replace
    for k in (0, 3, 7, 30):         # the (k+1)-th move fails (the previous set aside, the new one in): all undone
        calls = [0]

        def replace(a, b, k=k, calls=calls):
            calls[0] += 1
            if calls[0] == k + 1:
                raise OSError(errno.EIO, "Input/output error", str(b))
            return real(a, b)

        with monkeypatch.context() as m:
            m.setattr(materialx_files.os, "replace", replace)
            with pytest.raises(OSError) as e:
                export_materialx(out, ["f1"], basis=k == 30)
        assert e.value.errno == errno.EIO and ".cellgl-" not in str(e.value), e.value
        assert _tree(out) == before
    _no_temporaries(tmp_path)


def _lib_set(name: str) -> dict[str, str]:
    """A small set: a library naming one code file."""
    lib = (f'<?xml version="1.0"?>\n<materialx version="1.39">\n  <implementation name="IM_{name}" '
           f'file="genglsl/cellgl_{name}.glsl" target="genglsl" />\n</materialx>\n')
    return {materialx_files.IMPLS["genglsl"]: lib, f"genglsl/cellgl_{name}.glsl": f"// {name}\n"}


def test_two_exports_into_one_folder_land_one_after_the_other(tmp_path, monkeypatch):
    """The second export reads which files are the previous set once it holds the folder, so
    the set it replaces is the one the first export wrote, not the one before (which left the
    first export's code file behind)."""
    import threading
    import time

    out = tmp_path / "mx"
    materialx_files.write_set(_lib_set("x"), out)
    real, inside, go = materialx_files._swap, threading.Event(), threading.Event()

    def swap(*a):
        if threading.current_thread().name == "first":
            inside.set()
            go.wait(30)
        return real(*a)

    monkeypatch.setattr(materialx_files, "_swap", swap)
    first = threading.Thread(target=materialx_files.write_set, args=(_lib_set("a"), out), name="first")
    second = threading.Thread(target=materialx_files.write_set, args=(_lib_set("b"), out), name="second")
    first.start()
    assert inside.wait(30)
    second.start()
    time.sleep(0.5)                 # the second one waits for the folder's lock
    go.set()
    first.join(30)
    second.join(30)
    assert set(_tree(out)) == set(_lib_set("b"))
    _no_temporaries(tmp_path)


def test_a_file_in_the_way_is_refused_before_any_work(tmp_path, capsys):
    """`mkdir mx; touch mx/genosl`: the library was written naming code files never written."""
    out = tmp_path / "mx"
    out.mkdir()
    (out / "genosl").write_text("a file")
    rc, err = _cli(["f1", "-o", str(out)], capsys)
    assert rc == 2 and f"output {str(out / 'genosl')!r} is a file, not a directory" in err, err
    assert _tree(out) == {"genosl": b"a file"}
    (out / "genosl").unlink()
    (out / "cellgl_defs.mtlx").mkdir()
    rc, err = _cli(["f1", "-o", str(out)], capsys)
    assert rc == 2 and "is a directory" in err
    assert sorted(os.listdir(out)) == ["cellgl_defs.mtlx"]


def test_a_new_export_replaces_the_previous_set_and_keeps_the_users_files(tmp_path):
    """hull over flagstone left genglsl/cellgl_flagstone.glsl behind."""
    out = tmp_path / "mx"
    export_materialx(out, ["flagstone"], basis=False)
    (out / "notes.txt").write_text("mine")
    (out / "genglsl" / "mine.glsl").write_text("mine")
    (out / "genglsl" / "cellgl_by_hand.glsl").write_text("mine: the library does not name it")
    written = export_materialx(out, ["hull"], basis=False)
    new = {p.relative_to(out).as_posix() for p in written}
    assert new == {"cellgl_defs.mtlx", "cellgl_genglsl_impl.mtlx", "cellgl_genosl_impl.mtlx", "cellgl_materials.mtlx",
                   "cellgl_materials.usda", "genglsl/cellgl_hull.glsl", "genosl/cellgl_hull.osl"}
    assert set(_tree(out)) == new | {"notes.txt", "genglsl/mine.glsl", "genglsl/cellgl_by_hand.glsl"}
    assert "flagstone" not in (out / "cellgl_materials.usda").read_text()
    # a library that names a file of another form deletes nothing of that name
    lib = out / "cellgl_genosl_impl.mtlx"
    lib.write_text(lib.read_text().replace("genosl/cellgl_hull.osl", "notes.txt"))
    export_materialx(out, ["f1"], basis=False)
    assert (out / "notes.txt").read_text() == "mine"
    _no_temporaries(tmp_path)


def test_baked_maps_land_with_the_set_and_go_with_it(tmp_path, monkeypatch):
    """Issue 46 item 5: --bake-maps writes the baked materials' maps into textures/ as part of
    the set: a failed re-export leaves them, a new export removes those the previous
    materials named (every tile of a <UDIM> name) and nothing else there."""
    out = tmp_path / "mx"
    written = export_materialx(out, ["flagstone"], basis=False, bake_maps=8, udim="1001-1002")
    maps = {f"textures/cellgl_flagstone_{c}.{k}.png" for c in ("color", "normal") for k in (1001, 1002)}
    assert maps <= {p.relative_to(out).as_posix() for p in written}
    assert all(_tree(out)[m].startswith(b"\x89PNG") for m in maps)
    (out / "textures" / "mine.png").write_bytes(b"mine")
    before = _tree(out)
    real = os.replace
    calls = [0]

    def replace(a, b):
        calls[0] += 1
        if calls[0] == 4:
            raise OSError(errno.EIO, "Input/output error", str(b))
        return real(a, b)

    with monkeypatch.context() as m:
        m.setattr(materialx_files.os, "replace", replace)
        with pytest.raises(OSError):
            export_materialx(out, ["f1"], basis=False, bake_maps=8)
    assert _tree(out) == before
    with monkeypatch.context() as m:          # the disk fills up while a map is copied in
        _fail_on_write(m, 8)                # 5 documents, 2 code files, then the maps
        with pytest.raises(OSError) as e:
            export_materialx(out, ["flagstone"], basis=False, bake_maps=8)
    assert e.value.errno == errno.ENOSPC and e.value.filename.endswith("textures/cellgl_flagstone_normal.png")
    assert _tree(out) == before
    export_materialx(out, ["f1"], basis=False, bake_maps=8)
    assert sorted(p.name for p in (out / "textures").iterdir()) == ["cellgl_f1_color.png", "mine.png"]
    export_materialx(out, ["f1"], basis=False)      # no maps: the previous ones go
    assert sorted(p.name for p in (out / "textures").iterdir()) == ["mine.png"]
    (out / "textures" / "mine.png").unlink()
    export_materialx(out, ["f1"], basis=False, bake_maps=4)
    export_materialx(out, ["f1"], basis=False)
    assert not (out / "textures").exists()          # emptied by the export: gone
    _no_temporaries(tmp_path)


def test_bake_maps_and_udim_bad_input(tmp_path, capsys):
    for args, msg in ((["--bake-maps", "0"], "--bake-maps 0: width 0 is out of range; accepted 1..65536"),
                      (["--bake-maps", "8x8"], "--bake-maps '8x8': give one side in pixels, 1..65536"),
                      (["--udim", "1001-1200"], "accepted tile numbers 1001..1100")):
        rc, err = _cli(["f1", "-o", str(tmp_path / "mx"), *args], capsys)
        assert rc == 2 and msg in err, err
        assert not (tmp_path / "mx").exists()
    from cellgl.cli import main

    assert main(["export", "f1", "--udim", "1001", "-o", str(tmp_path / "f1.glsl")]) == 2
    assert "--bake-maps and --udim are options of --target materialx" in capsys.readouterr().err
    assert not (tmp_path / "f1.glsl").exists()


def test_an_emptied_code_folder_goes_and_a_users_one_stays(tmp_path):
    out = tmp_path / "mx"
    export_materialx(out, ["f1"], basis=False)
    files = materialx_files.write_set({materialx_files.DEFS: "<?xml version=\"1.0\"?>\n<materialx version=\"1.39\" />\n"}, out)
    assert [p.name for p in files] == ["cellgl_defs.mtlx"]
    assert sorted(os.listdir(out)) == ["cellgl_defs.mtlx"]       # genglsl/, genosl/ emptied and gone


def test_the_one_file_library_of_earlier_versions_goes(tmp_path):
    """Issue 46 item 5: the library is now definitions apart from implementations; an export
    over a set of an earlier version removes its cellgl_nodes.mtlx (whose nodedefs would meet
    the new ones) and the code files it names, and nothing else."""
    out = tmp_path / "mx"
    out.mkdir()
    (out / "genglsl").mkdir()
    (out / "cellgl_nodes.mtlx").write_text(
        '<?xml version="1.0"?>\n<materialx version="1.39">\n  <nodedef name="ND_cellgl_old" node="cellgl_old" />\n'
        '  <implementation name="IM_cellgl_old_genglsl" nodedef="ND_cellgl_old" file="genglsl/cellgl_old.glsl" '
        'target="genglsl" />\n</materialx>\n')
    (out / "genglsl" / "cellgl_old.glsl").write_text("// old")
    (out / "genglsl" / "mine.glsl").write_text("mine")
    export_materialx(out, ["f1"], basis=False)
    assert set(_tree(out)) == {"cellgl_defs.mtlx", "cellgl_genglsl_impl.mtlx", "cellgl_genosl_impl.mtlx",
                               "cellgl_materials.mtlx", "cellgl_materials.usda", "genglsl/cellgl_f1.glsl",
                               "genosl/cellgl_f1.osl", "genglsl/mine.glsl"}


def test_a_stale_temporary_folder_of_a_killed_export_is_swept(tmp_path):
    dead = tmp_path / ".mx.cellgl-999999999@{}.0123abcd.export".format(
        __import__("cellgl.io.tempfiles", fromlist=["_HOST"])._HOST)
    dead.mkdir()
    (dead / "cellgl_nodes.mtlx").write_text("half")
    export_materialx(tmp_path / "mx", ["f1"], basis=False)
    assert sorted(os.listdir(tmp_path)) == ["mx"]


# ------------------------------------------------------------------------------ item 11: -o as bake's


def test_output_messages_are_those_of_bake(tmp_path, monkeypatch, capsys):
    from cellgl.cli import main

    monkeypatch.chdir(tmp_path)
    Path("afile").write_text("keep")
    rc, err = _cli(["f1", "-o", "afile/sub"], capsys)
    assert rc == 2 and "output 'afile/sub': 'afile' is a file, not a directory" in err, err
    assert main(["bake", "f1", "-o", "afile/sub.png"]) == 2
    assert "output 'afile/sub.png': 'afile' is a file, not a directory" in capsys.readouterr().err
    rc, err = _cli(["f1", "-o", ""], capsys)
    assert rc == 2 and "output '' is an empty name; give a directory name" in err, err
    assert main(["bake", "f1", "-o", ""]) == 2
    assert "output '' is an empty name; give a file name" in capsys.readouterr().err
    # the neighbours: a snippet export, an animated bake, the playground site
    for argv, what in ((["export", "f1", "-o", ""], "a file name"), (["bake", "f1", "--frames", "2", "-o", ""], "a file name"),
                       (["playground", "-o", ""], "a directory name")):
        assert main(argv) == 2, argv
        assert f"output '' is an empty name; give {what}" in capsys.readouterr().err, argv
    assert os.listdir(".") == ["afile"]          # nothing written into the current folder


@pytest.fixture
def small_tmpfs(tmpfs):
    """A 256 KiB tmpfs (root only; skipped elsewhere)."""
    return tmpfs("256k", "small")


def test_a_really_full_disk_leaves_the_previous_set_untouched(small_tmpfs, capsys):
    import shutil

    out = small_tmpfs / "mx"
    export_materialx(out, ["f1"], basis=False)
    before = _tree(out)
    filler = small_tmpfs / "filler"
    with open(filler, "wb") as f:       # leave 16 KiB: less than the new set needs
        f.write(b"\0" * max(0, shutil.disk_usage(small_tmpfs).free - (16 << 10)))
    rc, err = _cli(["flagstone", "-o", str(out)], capsys)
    assert rc == 2 and "No space left on device" in err, err
    assert _tree(out) == before
    assert sorted(os.listdir(small_tmpfs)) == ["filler", "mx"]
    _no_temporaries(small_tmpfs)
    filler.unlink()
    assert _cli(["hull", "-o", str(small_tmpfs / "new")], capsys)[0] == 2       # the basis too: > 256 KiB
    assert sorted(os.listdir(small_tmpfs)) == ["mx"]
