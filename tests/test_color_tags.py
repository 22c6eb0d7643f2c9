"""Colour is what it says (issue 45 item 5): a colour PNG carries an sRGB chunk (and the gAMA /
cHRM the PNG specification pairs with it); data maps (height, normal, id, F1..F4) carry no colour
chunk at all; the cellgl metadata names the colour channel's colour space, and no data channel's."""
from __future__ import annotations

import json
import struct
import zlib

from PIL import Image

from cellgl.bake import core as B
from cellgl.io.formats import write_png

import numpy as np


def _chunks(path) -> dict[bytes, bytes]:
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, out, order = 8, {}, []
    while pos < len(data):
        n, tag = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        assert struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])[0] == zlib.crc32(tag + body)
        out.setdefault(tag, body)
        order.append(tag)
        pos += 12 + n
    if b"sRGB" in out:
        assert order.index(b"sRGB") < order.index(b"IDAT")        # before the image data
    return out


def test_write_png_tags_only_when_asked(tmp_path):
    img = np.zeros((2, 3, 3), np.uint8)
    write_png(tmp_path / "c.png", [img], 3, 2, 3, 8, srgb=True)
    write_png(tmp_path / "d.png", [img], 3, 2, 3, 8)
    c, d = _chunks(tmp_path / "c.png"), _chunks(tmp_path / "d.png")
    assert c[b"sRGB"] == b"\0" and struct.unpack(">I", c[b"gAMA"]) == (45455,)
    assert struct.unpack(">8I", c[b"cHRM"]) == (31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000)
    assert not {b"sRGB", b"gAMA", b"cHRM", b"iCCP"} & set(d)
    with Image.open(tmp_path / "c.png") as im:
        assert "srgb" in im.info


def test_bake_tags_colour_and_leaves_data_untagged(ctx, tmp_path):
    paths = B.bake("flagstone", tmp_path / "t.png", size=8, channels=("color", "height", "normal", "id", "F1"),
                   progress=False)
    for p in paths:
        chunks = _chunks(p)
        channel = p.stem.split("_", 1)[1]
        if channel == "color":
            assert b"sRGB" in chunks and b"gAMA" in chunks
        else:
            assert not {b"sRGB", b"gAMA", b"cHRM", b"iCCP"} & set(chunks), channel
        with Image.open(p) as im:
            assert im.info.get("cellgl") is not None
            meta = json.loads(im.info["cellgl"])
        if channel == "color":
            assert meta["colorspace"] == {"color": "srgb_rec709_scene"}
        else:
            assert "colorspace" not in meta          # data: never listed as colour
