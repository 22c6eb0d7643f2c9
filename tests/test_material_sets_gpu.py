"""Material sets as DDS and KTX2 with their mip chains (issue 45, item 3: "each as PNG (default)
or DDS/KTX2 with mips"): ``cellgl bake RECIPE --material ENGINE --map-format dds|ktx2 --mips``.

The files are read with tests/test_texfiles.py's parsers (written from the DDS and KTX 2.0
specifications, not from the writer) and decoded with texture2ddecoder."""
from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys

import numpy as np
import pytest

from cellgl.io import gpu_textures
from cellgl.bake import material_sets as M
from cellgl.bake.core import bake
from cellgl.io.spec import BakeError

pytest.importorskip("texture2ddecoder")
pytest.importorskip("etcpak")

from test_texfiles import DXGI, decode, parse_dds, parse_ktx2, psnr   # noqa: E402  (tests/ is on sys.path)
from test_material_sets import _read                                 # noqa: E402

SIZE = (40, 28)            # not multiples of 4; levels 40x28, 20x14, 10x7, 5x3, 2x1, 1x1
#: PSNR floor (dB) of every level's decoded samples against the packed samples before encoding
#: (measured on flagstone, SIZE's chain, worst level of every engine: BC7 sRGB colour 37.9, BC7
#: linear packed maps 30.5 (Unreal's ORM at 5x3), BC5 normals 32.2, BC4 masks 32.3; the PNG
#: bake's floors in tests/test_texfiles.py are alike)
FLOORS = {"BC7_UNORM_SRGB": 36.0, "BC7_UNORM": 28.5, "BC5_UNORM": 30.0, "BC4_UNORM": 30.0}


def _expected_dxgi(m: M.MapSpec) -> int:
    """The format each kind of map must get (the issue's choice, spelled out here, not taken from
    material_sets): colour BC7 sRGB, a normal BC5, a packed map BC7 linear, an 8-bit mask BC4,
    16-bit height R16_UNORM."""
    if m.layout == ("color",):
        return 99
    if m.layout == ("normal",):
        return 83
    if len(m.layout) > 1:
        return 98
    return 56 if m.bits == 16 else 80


@pytest.fixture(scope="module")
def alone(tmp_path_factory):
    """The bake of one channel alone at a size and bit depth (what `cellgl bake --channels C` writes)."""
    root = tmp_path_factory.mktemp("alone")
    cache = {}

    def get(channel, bits, convention, w, h):
        key = (channel, bits, convention, w, h)
        if key not in cache:
            out = root / f"{channel}_{bits}_{convention}_{w}x{h}.png"
            bake("flagstone", out, size=(w, h), channels=[channel], bit_depth=bits, progress=False,
                 sets=[f"normal_convention={convention}"])
            cache[key] = _read(out).reshape(h, w, -1)
        return cache[key]
    return get


def _packed_from_alone(alone, m: M.MapSpec, convention: str, w: int, h: int, bits: int) -> np.ndarray:
    top = (1 << bits) - 1
    parts = []
    for s in m.layout:
        if s == "1":
            parts.append(np.full((h, w, 1), top))
        elif s.startswith("1-"):
            parts.append(top - alone(s[2:], bits, convention, w, h).astype(np.int64))
        else:
            parts.append(alone(s, bits, convention, w, h))
    a = np.concatenate(parts, axis=-1)
    return a[..., 0] if a.shape[-1] == 1 else a


def _capture(monkeypatch):
    """Record the images gpu_textures.packed_levels gets: the packed maps before block encoding."""
    seen = []
    real = gpu_textures.packed_levels

    def spy(fmt, images):
        images = list(images)
        seen.append((fmt.name, [a.copy() for a in images]))
        return real(fmt, images)

    monkeypatch.setattr(gpu_textures, "packed_levels", spy)
    return seen


CASES = [(e, ".dds") for e in M.ENGINES if e != "gltf"] + [("unreal", ".ktx2"), ("unity-hdrp", ".ktx2")]


@pytest.mark.parametrize("engine,ext", CASES)
def test_gpu_sets_hold_every_level_rendered_packed_and_encoded(ctx, tmp_path, monkeypatch, alone, engine, ext):
    eng = M.ENGINES[engine]
    seen = _capture(monkeypatch)
    fmt = ext[1:]
    paths = M.bake_material("flagstone", tmp_path / "s", engine, size=SIZE, map_format=fmt, mips=True,
                            progress=False)
    png = M.bake_material("flagstone", tmp_path / "p", engine, size=SIZE, progress=False)
    manifest = json.loads((tmp_path / "s" / "manifest.json").read_text())
    assert [p.name for p in paths] == [f["file"] for f in manifest["files"]]
    assert sorted(os.listdir(tmp_path / "s")) == sorted(p.name for p in paths)       # the set, whole
    assert f"--map-format {fmt} --mips" in manifest["command"]
    assert len(seen) == len(eng.maps)
    sizes = [(max(1, SIZE[0] >> k), max(1, SIZE[1] >> k)) for k in range(max(SIZE).bit_length())]
    for m, entry, png_path, (fmt_name, images) in zip(eng.maps, manifest["files"], png, seen):
        assert entry["file"].endswith(ext) and entry["format"] == fmt.upper()
        data = (tmp_path / "s" / entry["file"]).read_bytes()
        f = parse_dds(data) if ext == ".dds" else parse_ktx2(data)
        dxgi = _expected_dxgi(m)
        assert f["dxgi"] == dxgi and (f["width"], f["height"]) == SIZE and f["depth"] is None
        srgb = DXGI[dxgi][3]
        assert srgb == m.srgb and entry["color_space"].startswith("sRGB" if srgb else "linear (data, not colour")
        assert entry["texel_format"] == DXGI[dxgi][0].replace("_UNORM_SRGB", "_SRGB")
        assert [lv["size"] for lv in entry["levels"]] == [list(s) for s in sizes]
        assert [lv[0][:2] for lv in f["levels"]] == sizes
        block = DXGI[dxgi][1] == 4
        bits = 8 if block else m.bits
        assert entry["bit_depth"] == bits
        if ext == ".ktx2":
            meta = json.loads(f["kv"]["cellgl"].rstrip(b"\0"))
            assert meta["levels"] == len(sizes) and meta["map"] == m.suffix and meta["format"] == fmt_name
        for k, ((w, h, z), blob) in enumerate(f["levels"]):
            packed = images[k]
            # the packed map before encoding: exactly the channels baked alone at this level's size
            ref = _packed_from_alone(alone, m, eng.normal, w, h, bits)
            assert packed.shape[:2] == (h, w) and np.array_equal(packed, ref), (engine, m.suffix, k)
            if k == 0 and bits == m.bits:                      # level 0: the PNG set's map
                assert np.array_equal(packed.reshape(_read(png_path).shape), _read(png_path))
            got = decode(dxgi, (w, h, z), blob)[0]
            if not block:                                      # R16 height: the bits themselves
                assert np.array_equal(got[..., 0], packed)
                continue
            n = {83: 2, 80: 1}.get(dxgi, packed.shape[-1] if packed.ndim == 3 else 1)
            p = psnr(got[..., :n], packed.reshape(h, w, -1)[..., :n])
            assert p >= FLOORS[DXGI[dxgi][0]], (engine, m.suffix, k, p)
            if n == 3:
                assert (got[..., 3] == 255).all()              # opaque


def test_gltf_refuses_block_maps_and_zstd_needs_ktx2(tmp_path):
    for fmt in ("dds", "ktx2"):
        with pytest.raises(BakeError, match=f"--material gltf --map-format {fmt}: a glTF 2.0 image is PNG or JPEG; "
                                            "KTX2 only through KHR_texture_basisu"):
            M.bake_material("flagstone", tmp_path / "x", "gltf", size=SIZE, map_format=fmt)
    with pytest.raises(BakeError, match="--zstd with --map-format dds: zstd supercompression is a KTX2 feature"):
        M.bake_material("flagstone", tmp_path / "x", "unreal", size=SIZE, map_format="dds", supercompression="zstd")
    with pytest.raises(BakeError, match="map format 'bmp'; accepted: png, dds, ktx2"):
        M.bake_material("flagstone", tmp_path / "x", "unreal", size=SIZE, map_format="bmp")
    with pytest.raises(BakeError, match="a 2D texture's sides are at most 16384"):
        M.bake_material("flagstone", tmp_path / "x", "unreal", size=(16385, 4), map_format="ktx2")
    # every level of the biggest map (RGB(A) samples) and its blocks, over the budget: refused up front
    with pytest.raises(BakeError, match=r"size 4096x4096 to dds: a map \(T_<name>_BC.dds\) holds its 13 level\(s\)' "
                                        r"samples and its file's bytes, about 86 MB, more than --memory 64 MB; "
                                        r"accepted --memory 86 or more"):
        M.bake_material("flagstone", tmp_path / "x", "unreal", size=4096, map_format="dds", mips=True,
                        memory_budget=64 << 20)
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("existing", [False, True])
def test_a_failed_gpu_set_leaves_the_folder_as_it_was(ctx, tmp_path, monkeypatch, existing):
    out = tmp_path / "set"
    if existing:
        out.mkdir()
        (out / "T_flagstone_BC.dds").write_bytes(b"old")
    real, calls = gpu_textures.packed_levels, []

    def failing(fmt, images):
        calls.append(fmt)
        if len(calls) == 3:                     # the third map: two are written by then
            raise OSError(28, "No space left on device")
        return real(fmt, images)

    monkeypatch.setattr(gpu_textures, "packed_levels", failing)
    with pytest.raises(OSError):
        M.bake_material("flagstone", out, "unreal", size=SIZE, map_format="dds", mips=True, progress=False)
    assert len(calls) == 3
    assert sorted(os.listdir(tmp_path)) == (["set"] if existing else [])      # no hidden folder left
    if existing:
        assert os.listdir(out) == ["T_flagstone_BC.dds"] and (out / "T_flagstone_BC.dds").read_bytes() == b"old"


def test_command_line_ktx2_zstd_remakes_the_same_bytes(ctx, tmp_path):
    run = [sys.executable, "-m", "cellgl", "bake", "flagstone", "--material", "godot", "-o", str(tmp_path / "g"),
           "--size", "24x16", "--map-format", "ktx2", "--mips", "--zstd", "-q"]
    proc = subprocess.run(run, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    manifest = json.loads((tmp_path / "g" / "manifest.json").read_text())
    assert manifest["command"].endswith("--size 24x16 --map-format ktx2 --mips --zstd")
    for f in manifest["files"][:-2]:
        assert parse_ktx2((tmp_path / "g" / f["file"]).read_bytes())["scheme"] == 2          # zstd
    words = shlex.split(manifest["command"].replace(str(tmp_path / "g"), str(tmp_path / "again")))
    again = subprocess.run([sys.executable, "-m", "cellgl", *words[1:], "-q"], capture_output=True, text=True,
                           timeout=300)
    assert again.returncode == 0, again.stderr
    for f in manifest["files"][:-2]:            # the maps: deterministic, bit for bit
        assert (tmp_path / "again" / f["file"]).read_bytes() == (tmp_path / "g" / f["file"]).read_bytes()
    bad = subprocess.run(run[:-1] + ["--compress", "bc1"], capture_output=True, text=True, timeout=300)
    assert bad.returncode != 0 and "--compress bc1: not with --material" in bad.stderr
