"""Recipe schema: the strict checks every recipe kind shares (cellular recipes here, PUPs recipes
in :mod:`cellgl.pups.recipe`): the error type, value coercion against a :class:`Param` of a
parameter table, ``--set`` text parsing, channel lists.

Errors name the field path, the bad value and what is accepted.
"""
from __future__ import annotations

import difflib
import math
import numbers

import numpy as np

from cellgl.texture.params import Param

__all__ = ["RecipeError", "VERSION", "CHANNELS", "check_channels", "check_name_doc", "check_version", "check_tile", "whole_number", "parse_value", "read_json",
           "MAX_NAME", "MAX_DOC", "MAX_RECIPE_BYTES", "coerce", "value_error", "suggest"]

VERSION = 1
#: channels a recipe can produce (``outputs``; ``cellgl.render(channels=...)``)
CHANNELS = ("color", "height", "normal", "id", "F1", "F2", "F3", "F4", "roughness", "ao", "metallic")


class RecipeError(ValueError):
    """A recipe (or a ``--set``) is invalid; the message names the field and what is accepted."""


#: most digits an integer literal in a recipe may have (seeds are 32-bit: 10 digits)
MAX_INT_DIGITS = 40


def _parse_int(text: str) -> int:
    digits = len(text.lstrip("-"))
    if digits > MAX_INT_DIGITS:
        raise RecipeError(f"an integer literal of {digits} digits; no recipe value has more "
                          f"than {MAX_INT_DIGITS}")
    return int(text)


#: largest recipe file read, in bytes (a recipe is a few KiB: the largest preset is 8 KiB)
MAX_RECIPE_BYTES = 1 << 20


def _read_capped(path) -> bytes:
    """The bytes of recipe file ``path``: a regular file of at most :data:`MAX_RECIPE_BYTES`
    (opened without blocking, so a FIFO or a device is refused, not waited on or read for ever)."""
    import os
    import stat

    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    with os.fdopen(fd, "rb") as f:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise RecipeError(f"recipe {str(path)!r} is not a regular file; accepted: a recipe "
                              ".json file or a preset name")
        raw = f.read(MAX_RECIPE_BYTES + 1)
    if len(raw) > MAX_RECIPE_BYTES:
        raise RecipeError(f"recipe {str(path)!r} is larger than {MAX_RECIPE_BYTES >> 10} KiB; "
                          f"accepted: at most {MAX_RECIPE_BYTES} bytes (a recipe is a few KiB)")
    return raw


def read_json(path) -> object:
    """The JSON value in recipe file ``path``; RecipeError naming the file otherwise.

    Unreadable files, text that is not UTF-8, malformed JSON, integer literals of more than
    :data:`MAX_INT_DIGITS` digits and nesting too deep for the parser each get a message
    instead of a traceback.
    """
    import json
    from pathlib import Path

    path = Path(path)
    try:
        raw = _read_capped(path)
    except OSError as exc:
        raise RecipeError(f"cannot read recipe {str(path)!r}: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise RecipeError(f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset "
                          f"{exc.start}, line {line}); save the recipe as UTF-8") from None
    try:
        return json.loads(text, parse_int=_parse_int)
    except json.JSONDecodeError as exc:
        raise RecipeError(f"{path}: not valid JSON: {exc}") from None
    except RecursionError:
        raise RecipeError(f"{path}: JSON nested too deeply (a recipe is a few levels deep)") from None
    except RecipeError as exc:
        raise RecipeError(f"{path}: {exc}") from None


#: longest recipe name (it names files, shader functions and page entries; presets use <= 24)
MAX_NAME = 64
#: longest recipe doc string, in characters (it is copied into every snippet's header)
MAX_DOC = 4096


def check_version(version) -> int:
    """A recipe file's ``cellgl_recipe``, checked: the whole number :data:`VERSION` (``true``,
    which Python counts as 1, and ``1.0`` are not versions)."""
    if type(version) is not int or version != VERSION:
        raise value_error("cellgl_recipe", version, f"the whole number {VERSION}",
                          "unsupported recipe version")
    return version


def check_name_doc(name, doc) -> tuple[str, str]:
    """A recipe's ``name`` and ``doc``, checked: strings, the name one line of 1 to
    :data:`MAX_NAME` characters, not blank, the doc at most :data:`MAX_DOC`; RecipeError
    otherwise."""
    for key, value in (("name", name), ("doc", doc)):
        if not isinstance(value, str):
            raise value_error(key, value, "a string", "expected a string, got")
    if not name.strip():
        raise value_error("name", name, f"one line of 1..{MAX_NAME} printable characters, not blank "
                          "(it names files, shader functions and page entries)", "empty name")
    if len(name) > MAX_NAME:
        raise RecipeError(f"name: {len(name)} characters ({_shown(name[:24])}...); accepted: at most "
                          f"{MAX_NAME} characters")
    if len(doc) > MAX_DOC:
        raise RecipeError(f"doc: {len(doc)} characters ({_shown(doc[:24])}...); accepted: at most "
                          f"{MAX_DOC} characters")
    # Both are copied into exported shaders' comments and the playground's page: no control or
    # invisible format character (U+202E reorders the text a reader sees: "Trojan Source").
    for key, value, most in (("name", name, MAX_NAME), ("doc", doc, MAX_DOC)):
        bad = next((c for c in value if not c.isprintable()), None)
        if bad is not None:
            import unicodedata

            what = {"Cc": "control character", "Cf": "invisible format character"}.get(
                unicodedata.category(bad), "unprintable character")
            raise RecipeError(f"{key}: {_shown(value[:80])} holds the {what} U+{ord(bad):04X}; "
                              f"accepted: one line of at most {most} printable characters")
    return name, doc


def _shown(value) -> str:
    """``repr(value)`` for a message: long ones shortened (a 5000-digit integer has no repr)."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 200:
        return f"<an integer of about {int(value.bit_length() * 0.30103) + 1} digits>"
    text = repr(value)
    return text if len(text) <= 100 else f"{text[:80]}... ({len(text)} characters)"


def value_error(path: str, value, accepted: str, problem: str = "") -> RecipeError:
    """The error for a bad value at ``path``: the problem, the value (shortened) and what is accepted."""
    problem = problem or "invalid value"
    return RecipeError(f"{path}: {problem} {_shown(value)}; accepted: {accepted}")


def suggest(name: str, names) -> str:
    """``" (did you mean a, b?)"`` for the names close to ``name``, or ``""``."""
    close = difflib.get_close_matches(name, list(names), n=3)
    return f" (did you mean {', '.join(close)}?)" if close else ""


def coerce(p: Param, value, path: str):
    """Validate one parameter value (already parsed from JSON) and return it normalised."""
    if p.type == "float":
        assert p.lo is not None and p.hi is not None    # every number parameter has its range
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise value_error(path, value, p.range_text(), "expected a number, got")
        try:
            v = float(value)
        except OverflowError:  # an integer beyond float range
            v = math.inf
        if not math.isfinite(v) or v < p.lo or v > p.hi:
            raise value_error(path, value, p.range_text(), "out of range:")
        return v
    if p.type == "int":
        assert p.lo is not None and p.hi is not None
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            raise value_error(path, value, "an integer in " + p.range_text(), "expected an integer, got")
        if int(value) < p.lo or int(value) > p.hi:
            raise value_error(path, value, "an integer in " + p.range_text(), "out of range:")
        return int(value)
    if p.type == "bool":
        if not isinstance(value, bool):
            raise value_error(path, value, p.range_text(), "expected true or false, got")
        return value
    if p.type == "enum":
        key = value.strip().lower().replace("-", "_") if isinstance(value, str) else None
        assert p.choices is not None                    # every enum parameter names its choices
        if key not in p.choices:
            raise value_error(path, value, p.range_text(), "unknown choice")
        return key
    if p.type == "color":
        ok = isinstance(value, (list, tuple)) and len(value) == 3 and all(
            isinstance(c, numbers.Real) and not isinstance(c, bool) and 0.0 <= float(c) <= 1.0 for c in value)
        if not ok:
            raise value_error(path, value, p.range_text(), "expected a colour, got")
        return tuple(float(c) for c in value)
    raise AssertionError(p.type)


def parse_value(p: Param, name: str, text: str):
    """Parse the text of ``--set name=text`` for table parameter ``p`` (any recipe kind's table)."""
    shown = text if len(text) <= 80 else f"{text[:60]}... ({len(text)} characters)"
    try:
        if p.type == "float":
            v = float(text)
            if math.isinf(v) and "inf" not in text.lower():     # digits past float range, not "inf"
                raise RecipeError(f"--set {name}={shown}: out of range (beyond any float, not just "
                                  f"the parameter's); accepted: {p.range_text()}")
            return v
        if p.type == "int":
            return int(text, 0)
        if p.type == "bool":
            low = text.lower()
            if low in ("1", "true", "yes", "on"):
                return True
            if low in ("0", "false", "no", "off"):
                return False
            raise ValueError
        if p.type == "color":
            return [float(c) for c in text.strip("[]() ").split(",")]
        return text
    except RecipeError:
        raise
    except ValueError:
        raise RecipeError(f"--set {name}={shown}: cannot parse {shown!r}; accepted: "
                          + ("an integer in " if p.type == "int" else "") + p.range_text()) from None


def check_channels(channels, allowed=CHANNELS, unknown: str = "unknown channel {!r}") -> tuple:
    """``channels`` (a name or names) as a tuple, each in ``allowed``; ``unknown`` words the
    error for one that is not (formatted with the name)."""
    if isinstance(channels, str):
        channels = (channels,)
    try:
        channels = tuple(channels)
    except TypeError:           # None, a number: not a sequence of names
        raise ValueError(f"channels must be a name or a sequence of names among: {', '.join(allowed)}; "
                         f"got {channels!r}") from None
    if not channels:
        raise ValueError("channels must name at least one of: " + ", ".join(allowed))
    for c in channels:
        if c not in allowed:
            raise ValueError(f"{unknown.format(c)}; accepted: {', '.join(allowed)}")
    return channels


def whole_number(name: str, value, lo: int, hi: int) -> int:
    """``value`` checked to be a whole number (a Python or NumPy integer, not a boolean: ``True``
    is not a size) in ``lo..hi``; ValueError naming ``name``, the value and the range."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
            or not lo <= value <= hi:
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {_shown(value)}")
    return int(value)


def check_tile(width, height, x0=0, y0=0, tile_w=None, tile_h=None, *, max_side: int) -> tuple[int, int]:
    """A render's image and tile arguments checked (every recipe kind's ``render``): ``width``
    and ``height`` whole numbers in 1..``max_side``, the tile ``[x0, x0 + tile_w) x [y0, y0 +
    tile_h)`` whole numbers inside the image (``tile_w``/``tile_h`` None: to the image's edge).
    Returns the tile's ``(tile_w, tile_h)``."""
    width = whole_number("width", width, 1, max_side)
    height = whole_number("height", height, 1, max_side)
    x0 = whole_number("x0", x0, 0, width - 1)
    y0 = whole_number("y0", y0, 0, height - 1)
    tw = width - x0 if tile_w is None else whole_number("tile_w", tile_w, 1, width - x0)
    th = height - y0 if tile_h is None else whole_number("tile_h", tile_h, 1, height - y0)
    return tw, th
