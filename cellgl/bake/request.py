"""What a bake request may ask for beyond a file's own limits: the outputs of an animation and of a
distributed bake, the default size and working memory, the tile a render pass gets, and the
command line's size, channel, whole-number, memory and ``--set`` arguments checked into values
(:class:`~cellgl.io.spec.BakeError` naming the value and what is accepted). The formats, their
limits and each channel's encoding are the files layer's (:mod:`cellgl.io.spec`)."""
from __future__ import annotations

from collections.abc import Iterable

from cellgl.io.spec import CHANNELS, FORMATS, BakeError, accepted_list, check_size

__all__ = ["ANIMATED", "DISTRIBUTED", "accepted_outputs", "MAX_TILE", "DEFAULT_SIZE", "DEFAULT_BUDGET",
           "RENDER_BYTES_PER_PIXEL", "parse_size", "int_arg", "parse_channels", "MIN_BUDGET", "MAX_BUDGET",
           "check_budget", "parse_sets"]

#: extensions of one animated file that loops (``--frames N``, :mod:`cellgl.bake.frames`)
ANIMATED = (".webp", ".gif")
#: extensions of a distributed bake: a Zarr folder written on Dask (:func:`cellgl.dask.bake_zarr`)
DISTRIBUTED = (".zarr",)


def accepted_outputs() -> str:
    """Every output extension ``cellgl bake`` accepts, with what each needs: the one list its
    errors and help give (from :data:`FORMATS`, :data:`ANIMATED`, :data:`DISTRIBUTED`)."""
    return (f"{accepted_list(FORMATS)} (an image, or with --frames N a numbered sequence); "
            f"{accepted_list(ANIMATED)} (one animated file, with --frames N); "
            f"{accepted_list(DISTRIBUTED)} (a folder baked on Dask)")


MAX_TILE = 2048           #: largest tile side one render pass gets
DEFAULT_SIZE = (512, 512)
DEFAULT_BUDGET = 256 << 20  #: bytes of working memory a bake aims to stay within
#: working memory of render() per pixel beyond its outputs, for one channel (GPU buffers and
#: read-back on llvmpipe, measured: about 230 bytes); half as much again per extra channel
RENDER_BYTES_PER_PIXEL = 256


def parse_size(text: str) -> tuple[int, int, int | None]:
    """Parse ``W``, ``WxH`` or ``WxHxD`` into ``(W, H, D or None)``.

    Raises
    ------
    BakeError
        Malformed text, or a side outside 1..MAX_SIDE, slices outside 1..MAX_SLICES, or more
        than MAX_VOXELS in all.
    """
    parts = str(text).strip().lower().replace("*", "x").split("x")
    try:
        nums = [int(p) for p in parts]
    except ValueError:
        nums = []
    if not 1 <= len(nums) <= 3:
        raise BakeError(f"--size {text!r}: expected W, WxH or WxHxD with whole numbers, "
                        f"e.g. 512, 1024x512 or 64x64x16")
    w, h, d = nums[0], (nums[1] if len(nums) > 1 else nums[0]), (nums[2] if len(nums) > 2 else None)
    check_size(w, h, d, f"--size {text}")
    return w, h, d


def int_arg(flag: str, text, lo: int, hi: int) -> int:
    """A command line whole number ``text`` for ``flag``, checked to lie in ``lo..hi``."""
    try:
        v = int(str(text).strip())
    except ValueError:
        raise BakeError(f"{flag} {text!r}: expected a whole number in {lo}..{hi}") from None
    if not lo <= v <= hi:
        raise BakeError(f"{flag} {v}: out of range; accepted {lo}..{hi}")
    return v


def parse_channels(values: str | Iterable[str]) -> tuple[str, ...]:
    """Normalise channel names (comma lists allowed, ``f1`` == ``F1``); reject unknown ones."""
    if isinstance(values, str):
        values = [values]
    out: list[str] = []
    lookup = {c.lower(): c for c in CHANNELS}
    for v in values:
        for part in str(v).split(","):
            part = part.strip()
            if not part:
                continue
            name = lookup.get(part.lower())
            if name is None:
                raise BakeError(f"--channels {part!r}: unknown channel; accepted "
                                f"{accepted_list(CHANNELS)}")
            if name not in out:
                out.append(name)
    if not out:
        raise BakeError(f"--channels: no channel given; accepted {accepted_list(CHANNELS)}")
    return tuple(out)


#: the working memory a bake may be given, in bytes: ``--memory`` 1..2^20 MB
MIN_BUDGET, MAX_BUDGET = 1 << 20, 1 << 40


def check_budget(budget) -> int:
    """``bake(..., memory_budget=)`` checked as ``--memory`` is: whole bytes in 1 MiB..1 TiB."""
    import numbers

    if isinstance(budget, bool) or not isinstance(budget, numbers.Integral) \
            or not MIN_BUDGET <= budget <= MAX_BUDGET:
        raise BakeError(f"memory_budget {budget!r}: accepted a whole number of bytes in {MIN_BUDGET}.."
                        f"{MAX_BUDGET} (1 MiB..1 TiB; the command line's --memory 1..{MAX_BUDGET >> 20} MB)")
    return int(budget)


def parse_sets(sets: Iterable[str]) -> list[str]:
    if isinstance(sets, (str, bytes)):
        raise BakeError(f"sets={sets!r}: expected a list of NAME=VALUE strings, e.g. sets=[{sets!r}] "
                        f"(a string alone would be read letter by letter)")
    try:
        sets = list(sets)
    except TypeError:
        raise BakeError(f"sets={sets!r}: expected a list of NAME=VALUE strings, e.g. sets=['seed=7']") from None
    out = []
    for s in sets:
        name, eq, value = str(s).partition("=")
        if not eq or not name.strip() or not value.strip():
            raise BakeError(f"--set {s!r}: expected NAME=VALUE, e.g. --set seed=7")
        out.append(f"{name.strip()}={value.strip()}")
    return out
