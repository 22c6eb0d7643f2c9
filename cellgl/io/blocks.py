"""BCn block compression of 8-bit images on every core: :func:`encode_levels`.

The blocks are encoded by `etcpak <https://pypi.org/project/etcpak/>`_ (the maintained PyPI
wrapper of Bartosz Taudul's etcpak; BC1, BC3, BC4, BC5 and BC7), nothing here: this module only
pads images to whole 4 x 4 blocks, cuts them into bands of block rows and runs the bands on a
pool of worker processes. etcpak holds the GIL while it encodes (a thread beside it stalls), so
the pool is of processes (``forkserver``: a clean interpreter that never held a GL context, forked
per worker; a band travels as bytes), one per usable core (:func:`cellgl.io.formats.usable_cores`),
started on first use and kept for the process's later encodes; work of a few bands or a single
core is encoded in this process. Blocks are independent and the
block stream of a BCn texture is row-major by block rows, so the bands' bytes joined are the
whole image's, bit for bit.

Inputs are ``(H, W)`` or ``(H, W, S)`` uint8, taken as RGBA band by band (etcpak's order;
missing channels 0, a missing alpha 255): BC1/BC3/BC7 encode RGB(A), BC4 the red channel, BC5
red and green. Sides need not be multiples of 4: the image is padded to whole blocks
by repeating its last row and column (readers use the top-left ``W x H`` texels of the blocks,
as the DDS and KTX2 specifications say), so the padding costs no precision at the edges.
"""
from __future__ import annotations

import multiprocessing
import threading
from concurrent.futures import ProcessPoolExecutor
from collections.abc import Sequence

import numpy as np

from cellgl.io.formats import usable_cores

__all__ = ["BLOCK_BYTES", "have_encoder", "block_count", "pad_to_blocks", "encode", "encode_levels"]

#: bytes per 4 x 4 block
BLOCK_BYTES = {"bc1": 8, "bc3": 16, "bc4": 8, "bc5": 16, "bc7": 16}
#: block rows per band sent to a worker
_BAND_ROWS = 64
#: fewer block rows than this in all: encode here (a pool costs about 0.1 s to start)
_POOL_MIN_ROWS = 2 * _BAND_ROWS


_POOLS: dict[int, ProcessPoolExecutor] = {}
_POOLS_LOCK = threading.Lock()


def _pool(workers: int) -> ProcessPoolExecutor:
    """The process pool of ``workers`` (started on first use, kept for the next encodes: its
    start costs a few tenths of a second; shut down at exit; a broken one is replaced)."""
    with _POOLS_LOCK:
        pool = _POOLS.get(workers)
        if pool is None or getattr(pool, "_broken", False):
            pool = _POOLS[workers] = ProcessPoolExecutor(
                workers, mp_context=multiprocessing.get_context("forkserver"), initializer=_worker_init)
        return pool


def _worker_init() -> None:
    """A worker leaves Ctrl-C to the bake (which drops the bands not started), printing nothing."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def have_encoder() -> bool:
    try:
        import etcpak  # noqa: F401
    except ImportError:
        return False
    return True


def block_count(width: int, height: int) -> tuple[int, int]:
    """Blocks across and down: ``(ceil(W / 4), ceil(H / 4))``."""
    return -(-int(width) // 4), -(-int(height) // 4)


def pad_to_blocks(rgba: np.ndarray) -> np.ndarray:
    """``rgba`` (H, W, 4) padded to whole 4 x 4 blocks by repeating its last row and column."""
    h, w = rgba.shape[:2]
    bw, bh = block_count(w, h)
    if (bw * 4, bh * 4) == (w, h):
        return np.ascontiguousarray(rgba)
    return np.pad(rgba, ((0, bh * 4 - h), (0, bw * 4 - w), (0, 0)), mode="edge")


#: BC7 modes etcpak may use: all but mode 6, whose endpoints' p-bits it sets so that an opaque
#: texel can decode to alpha 254 (a third of a flagstone bake's texels did); without it every
#: texel decodes opaque, for about 1.7 dB of PSNR (flagstone 256^2: 45.9 dB instead of 47.6)
BC7_MODES = 0xFF & ~(1 << 6)


def _encode_band(fmt: str, data: bytes, width: int, height: int, perceptual: bool = True) -> bytes:
    """One band of whole blocks (runs in a worker)."""
    import etcpak

    if fmt == "bc7":
        params = etcpak.BC7CompressBlockParams()
        params.m_mode_mask = BC7_MODES
        if not perceptual:          # data (normals): every channel's error counts the same
            params.init_linear_weights()
            params.m_perceptual = False
        return etcpak.compress_bc7(data, width, height, params)
    return getattr(etcpak, f"compress_{fmt}")(data, width, height)


def _check(fmt: str, a: np.ndarray) -> None:
    if fmt not in BLOCK_BYTES:
        raise ValueError(f"block format {fmt!r}: accepted {', '.join(BLOCK_BYTES)}")
    if a.dtype != np.uint8 or a.ndim not in (2, 3) or (a.ndim == 3 and not 1 <= a.shape[2] <= 4) \
            or 0 in a.shape:
        raise ValueError(f"block encoding takes (H, W) or (H, W, 1..4) uint8; got {a.dtype} {a.shape}")


def _rgba(a: np.ndarray) -> np.ndarray:
    """(h, w) / (h, w, S) uint8 as etcpak's (h, w, 4) RGBA: missing channels 0, alpha 255."""
    if a.ndim == 3 and a.shape[2] == 4:
        return np.ascontiguousarray(a)
    out = np.zeros(a.shape[:2] + (4,), np.uint8)
    out[..., 3] = 255
    if a.ndim == 2:
        out[..., 0] = a
    else:
        out[..., :a.shape[2]] = a
    return out


def _bands(fmt: str, a: np.ndarray, perceptual: bool) -> list[tuple[str, bytes, int, int, bool]]:
    rows = _BAND_ROWS * 4
    out = []
    for y in range(0, a.shape[0], rows):
        p = pad_to_blocks(_rgba(a[y:y + rows]))
        out.append((fmt, p.tobytes(), p.shape[1], p.shape[0], perceptual))
    return out


def encode(fmt: str, rgba: np.ndarray, perceptual: bool = True) -> bytes:
    """The BCn blocks of one image, in this process."""
    return encode_levels(fmt, [rgba], workers=1, perceptual=perceptual)[0]


def encode_levels(fmt: str, images: Sequence[np.ndarray], workers: int | None = None,
                  perceptual: bool = True) -> list[bytes]:
    """The BCn blocks of each image (mip levels, slices), on ``workers`` processes (default:
    every usable core). Each result is ``block_count(W, H)`` blocks, row-major. ``perceptual``
    (BC7): weigh the colour channels' errors as the eye does (etcpak's default, for sRGB colour);
    False for data, every channel alike."""
    for a in images:
        _check(fmt, a)
    jobs = [_bands(fmt, a, perceptual) for a in images]
    flat = [j for js in jobs for j in js]
    workers = usable_cores() if workers is None else max(1, int(workers))
    total_rows = sum(-(-a.shape[0] // 4) for a in images)
    if workers == 1 or len(flat) < 2 or total_rows < _POOL_MIN_ROWS:
        done = [_encode_band(*j) for j in flat]
    else:
        pool = _pool(workers)
        futures = [pool.submit(_encode_band, *j) for j in flat]
        try:
            done = [f.result() for f in futures]
        except BaseException:       # Ctrl-C, a failed band: the bands not started are dropped
            for f in futures:
                f.cancel()
            raise
    out, i = [], 0
    for js in jobs:
        out.append(b"".join(done[i:i + len(js)]))
        i += len(js)
    return out
