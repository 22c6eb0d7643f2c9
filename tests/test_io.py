"""cellgl.io.formats: the PNG/EXR/TIFF/NPY writers read back exactly, stream, and write atomically."""

from __future__ import annotations

import os
import struct
import zlib

import numpy as np
import pytest
from PIL import Image

from cellgl.io import formats as io


def _bands(a, rows):
    for y in range(0, a.shape[0], rows):
        yield a[y:y + rows]


def _tiles(a, th, tw):
    for y in range(0, a.shape[0], th):
        for x in range(0, a.shape[1], tw):
            yield a[y:y + th, x:x + tw]


def _read_png_raw(path):
    """Independent minimal PNG decoder (all five filter types), 8/16-bit, no interlace."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, text = 8, b"", {}
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        tag, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        (crc,) = struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])
        assert crc == zlib.crc32(tag + body), tag
        if tag == b"IHDR":
            w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert interlace == 0
        elif tag == b"IDAT":
            idat += body
        elif tag == b"tEXt":
            k, v = body.split(b"\0", 1)
            text[k.decode("latin-1")] = v.decode("latin-1")
        pos += 12 + n
    samples = {0: 1, 4: 2, 2: 3, 6: 4}[ctype]
    bpp = samples * depth // 8
    stride = w * bpp
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, stride + 1)
    out = np.zeros((h, stride), np.int32)
    prev = np.zeros(stride, np.int32)
    for y in range(h):
        f, line = raw[y, 0], raw[y, 1:].astype(np.int32)
        cur = np.zeros(stride, np.int32)
        if f == 0:
            cur = line
        elif f == 2:
            cur = (line + prev) & 255
        else:
            for i in range(stride):
                a = cur[i - bpp] if i >= bpp else 0
                b, c = prev[i], (prev[i - bpp] if i >= bpp else 0)
                if f == 1:
                    pred = a
                elif f == 3:
                    pred = (a + b) // 2
                else:
                    p = a + b - c
                    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                    pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                cur[i] = (line[i] + pred) & 255
        out[y] = cur
        prev = cur
    arr = out.astype(np.uint8)
    if depth == 16:
        arr = arr.view(">u2").astype(np.uint16)
    arr = arr.reshape(h, w, samples)
    return (arr[..., 0] if samples == 1 else arr), depth, text


@pytest.mark.parametrize("samples", [1, 3, 4])
@pytest.mark.parametrize("depth", [8, 16])
def test_png_roundtrip(tmp_path, samples, depth):
    rng = np.random.default_rng(samples * depth)
    dt = np.uint8 if depth == 8 else np.uint16
    shape = (37, 29) if samples == 1 else (37, 29, samples)
    a = rng.integers(0, np.iinfo(dt).max + 1, size=shape, dtype=dt)
    p = tmp_path / "a.png"
    io.write_png(p, _bands(a, 8), 29, 37, samples, depth, text={"cellgl-recipe": "{\"x\": 1}"})
    b, d, text = _read_png_raw(p)
    assert d == depth and b.dtype == dt and np.array_equal(a, b)
    assert text == {"cellgl-recipe": "{\"x\": 1}"}
    # Pillow agrees (for 16-bit RGB(A) it reduces to the high byte).
    im = np.asarray(Image.open(p))
    if depth == 8:
        assert np.array_equal(im, a)
    elif samples == 1:
        assert np.array_equal(im.astype(np.uint16), a)
    else:
        assert np.array_equal(im, (a >> 8).astype(np.uint8))


def test_png_rejects_wrong_rows(tmp_path):
    a = np.zeros((4, 5), np.uint8)
    with pytest.raises(ValueError, match="rows"):
        io.write_png(tmp_path / "x.png", [a], 5, 6, 1, 8)
    with pytest.raises(ValueError, match="bit depth 12"):
        io.write_png(tmp_path / "x.png", [a], 5, 4, 1, 12)


def test_exr_roundtrip(tmp_path):
    OpenEXR = pytest.importorskip("OpenEXR")
    rng = np.random.default_rng(1)
    h, w = 21, 13
    data = {"R": rng.random((h, w), np.float32), "Y": rng.random((h, w)).astype(np.float16),
            "id": rng.integers(0, 2**32, size=(h, w), dtype=np.uint32)}
    p = tmp_path / "a.exr"
    bands = ({k: v[y:y + 5] for k, v in data.items()} for y in range(0, h, 5))
    io.write_exr(p, bands, w, h, {k: v.dtype for k, v in data.items()},
                 attributes={"cellgl_recipe": "{}"})
    f = OpenEXR.File(str(p), separate_channels=True)
    got = {k: c.pixels for k, c in f.channels().items()}
    assert set(got) == set(data)
    for k in data:
        assert got[k].dtype == data[k].dtype and np.array_equal(got[k], data[k]), k
    assert f.header()["cellgl_recipe"] == "{}"


def test_tiff_tiled_roundtrip(tmp_path):
    tifffile = pytest.importorskip("tifffile")
    rng = np.random.default_rng(2)
    a = rng.random((40, 50, 4), np.float32)
    p = tmp_path / "a.tif"
    io.write_tiff(p, _tiles(a, 16, 32), a.shape, a.dtype, (16, 32), rgb=True, description="hi")
    with tifffile.TiffFile(p) as t:
        page = t.pages[0]
        assert page.is_tiled and (page.tilelength, page.tilewidth) == (16, 32)
        assert page.description == "hi"
        assert np.array_equal(page.asarray(), a)
    v = rng.integers(0, 2**32, size=(3, 20, 30), dtype=np.uint32)
    tiles = (t for z in range(3) for t in _tiles(v[z], 16, 16))
    io.write_tiff(tmp_path / "v.tif", tiles, v.shape, v.dtype, (16, 16))
    assert np.array_equal(tifffile.imread(tmp_path / "v.tif"), v)
    with pytest.raises(ValueError, match="multiples of 16"):
        io.write_tiff(p, [], a.shape, a.dtype, (10, 16))


def test_npy_pieces(tmp_path):
    a = np.arange(2 * 6 * 7, dtype=np.float32).reshape(2, 6, 7)
    pieces = [((slice(None), slice(y, y + 4), slice(x, x + 4)), a[:, y:y + 4, x:x + 4])
              for y in (4, 0) for x in (4, 0)]
    io.write_npy(tmp_path / "a.npy", pieces, a.shape, a.dtype)
    assert np.array_equal(np.load(tmp_path / "a.npy"), a)


def test_atomic_success_and_failure(tmp_path):
    dest = tmp_path / "out.png"
    dest.write_bytes(b"old")
    with io.atomic_path(dest) as tmp:
        assert tmp.parent == tmp_path and tmp.name.endswith(".png") and tmp != dest
        tmp.write_bytes(b"new")
        assert dest.read_bytes() == b"old"
    assert dest.read_bytes() == b"new"
    assert sorted(os.listdir(tmp_path)) == ["out.png"]
    assert (os.stat(dest).st_mode & 0o777) == (0o666 & ~_umask())

    for exc in (RuntimeError("boom"), KeyboardInterrupt()):
        with pytest.raises(type(exc)):
            with io.atomic_path(dest) as tmp:
                tmp.write_bytes(b"half")
                raise exc
        assert dest.read_bytes() == b"new"
        assert sorted(os.listdir(tmp_path)) == ["out.png"]


def test_atomic_png_interrupted_midway(tmp_path):
    dest = tmp_path / "x.png"

    def bands():
        yield np.zeros((4, 8), np.uint8)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        with io.atomic_path(dest) as tmp:
            io.write_png(tmp, bands(), 8, 8, 1, 8)
    assert os.listdir(tmp_path) == []


def _umask():
    m = os.umask(0)
    os.umask(m)
    return m


def _serial_png(bands, width, height, samples, depth) -> bytes:
    """The PNG of one zlib stream compressed on one thread (level 6), filter "up", IDAT chunks of
    about 1 MiB: what write_png gives for an image of one deflate block."""
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    dtype = np.dtype(">u2") if depth == 16 else np.dtype(np.uint8)
    row = width * samples * dtype.itemsize
    comp, prev, out, pending = zlib.compressobj(6), np.zeros(row, np.uint8), [], bytearray()
    out.append(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, depth,
                                                                 {1: 0, 2: 4, 3: 2, 4: 6}[samples], 0, 0, 0)))
    for band in bands:
        raw = np.ascontiguousarray(band, dtype=dtype).view(np.uint8).reshape(len(band), row)
        filt = np.concatenate([np.full((len(raw), 1), 2, np.uint8),
                               np.concatenate([(raw[:1] - prev), raw[1:] - raw[:-1]])], axis=1)
        prev = raw[-1].copy()
        pending += comp.compress(filt.tobytes())
        if len(pending) >= 1 << 20:
            out.append(chunk(b"IDAT", bytes(pending)))
            pending.clear()
    pending += comp.flush()
    return b"".join(out) + chunk(b"IDAT", bytes(pending)) + chunk(b"IEND", b"")


def _png_pixels(data: bytes, width, height, samples, depth) -> np.ndarray:
    """The pixels of a PNG of filter "up" on every row (zlib checks the stream's Adler-32)."""
    at, idat = 8, bytearray()
    while at < len(data):
        n, tag = struct.unpack(">I4s", data[at:at + 8])
        if tag == b"IDAT":
            idat += data[at + 8:at + 8 + n]
        at += 12 + n
    size = depth // 8
    rows = np.frombuffer(zlib.decompress(bytes(idat)), np.uint8).reshape(height, 1 + width * samples * size)
    assert np.all(rows[:, 0] == 2)
    raw = np.cumsum(rows[:, 1:], axis=0, dtype=np.uint8)           # "up", mod 256
    raw = raw.view(">u2") if depth == 16 else raw
    return raw.reshape((height, width, samples) if samples > 1 else (height, width))


@pytest.mark.parametrize("samples,depth", [(3, 8), (4, 16), (1, 8)])
def test_png_encodes_on_threads_while_the_next_band_is_made(tmp_path, monkeypatch, samples, depth):
    """Each band is filtered on a thread of its own while the caller makes the next one (a bake's
    GPU renders it) and compressed in deflate blocks on every core: one valid zlib stream of the
    pixels, whose bytes depend neither on the bands nor on the cores, and those of one serial zlib
    stream for an image of one block."""
    import threading

    rng = np.random.default_rng(samples + depth)
    W, H, rows = 1200 if samples == 1 else 700, 2000, 300
    top = 255 if depth == 8 else 65535
    img = rng.integers(0, top + 1, (H, W, samples) if samples > 1 else (H, W)).astype(
        np.uint8 if depth == 8 else np.uint16)
    img[::7] = img[0]                       # some runs, so that the stream has matches across bands
    bands = [img[i:i + rows] for i in range(0, H, rows)]
    assert H * (1 + W * samples * depth // 8) > 2 * io.DEFLATE_BLOCK     # three blocks or more
    where = []
    real = zlib.compressobj

    def spy(*args):
        c = real(*args)

        class Spy:
            def compress(self, data):
                where.append(threading.get_ident())
                return c.compress(data)

            def flush(self, mode=zlib.Z_FINISH):
                return c.flush(mode)
        return Spy()

    monkeypatch.setattr(io.zlib, "compressobj", spy)
    path = tmp_path / "t.png"
    io.write_png(path, iter(bands), W, H, samples, depth)
    assert len(where) >= 3 and threading.get_ident() not in where
    monkeypatch.setattr(io.zlib, "compressobj", real)
    data = path.read_bytes()
    assert np.array_equal(_png_pixels(data, W, H, samples, depth), img)
    other = tmp_path / "u.png"                          # other bands, one core: the same bytes
    monkeypatch.setattr(io, "usable_cores", lambda: 1)
    io.write_png(other, iter([img[i:i + 77] for i in range(0, H, 77)]), W, H, samples, depth)
    assert other.read_bytes() == data
    small = img[:40]                                    # one block: one serial zlib stream's bytes
    io.write_png(other, iter([small[:25], small[25:]]), W, 40, samples, depth)
    assert other.read_bytes() == _serial_png([small], W, 40, samples, depth)

    def failing():
        yield bands[0]
        raise KeyError("the render failed")

    with pytest.raises(KeyError, match="render failed"):
        io.write_png(tmp_path / "u.png", failing(), W, H, samples, depth)
