"""Recipe schema: the strict checks every recipe kind shares (cellular recipes here, PUPs recipes
in :mod:`cellgl.pups.recipe`): the error type, value coercion against a :class:`Param` of a
parameter table, ``--set`` text parsing, channel lists.

Errors name the field path, the bad value and what is accepted.
"""
from __future__ import annotations

import difflib
import math
import numbers

from cellgl.texture.params import Param

__all__ = ["RecipeError", "VERSION", "CHANNELS", "check_channels", "parse_value"]

VERSION = 1
#: channels a recipe can produce (``outputs``; ``cellgl.render(channels=...)``)
CHANNELS = ("color", "height", "normal", "id", "F1", "F2", "F3", "F4")


class RecipeError(ValueError):
    """A recipe (or a ``--set``) is invalid; the message names the field and what is accepted."""


def _err(path: str, value, accepted: str, problem: str = "") -> RecipeError:
    problem = problem or "invalid value"
    return RecipeError(f"{path}: {problem} {value!r}; accepted: {accepted}")


def _suggest(name: str, names) -> str:
    close = difflib.get_close_matches(name, list(names), n=3)
    return f" (did you mean {', '.join(close)}?)" if close else ""


def _coerce(p: Param, value, path: str):
    """Validate one parameter value (already parsed from JSON) and return it normalised."""
    if p.type == "float":
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise _err(path, value, p.range_text(), "expected a number, got")
        v = float(value)
        if not math.isfinite(v) or v < p.lo or v > p.hi:
            raise _err(path, value, p.range_text(), "out of range:")
        return v
    if p.type == "int":
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            raise _err(path, value, "an integer in " + p.range_text(), "expected an integer, got")
        if value < p.lo or value > p.hi:
            raise _err(path, value, "an integer in " + p.range_text(), "out of range:")
        return int(value)
    if p.type == "bool":
        if not isinstance(value, bool):
            raise _err(path, value, p.range_text(), "expected true or false, got")
        return value
    if p.type == "enum":
        key = value.strip().lower().replace("-", "_") if isinstance(value, str) else None
        if key not in p.choices:
            raise _err(path, value, p.range_text(), "unknown choice")
        return key
    if p.type == "color":
        ok = isinstance(value, (list, tuple)) and len(value) == 3 and all(
            isinstance(c, numbers.Real) and not isinstance(c, bool) and 0.0 <= c <= 1.0 for c in value)
        if not ok:
            raise _err(path, value, p.range_text(), "expected a colour, got")
        return tuple(float(c) for c in value)
    raise AssertionError(p.type)


def parse_value(p: Param, name: str, text: str):
    """Parse the text of ``--set name=text`` for table parameter ``p`` (any recipe kind's table)."""
    try:
        if p.type == "float":
            return float(text)
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
    except ValueError:
        raise RecipeError(f"--set {name}={text}: cannot parse {text!r}; accepted: "
                          + ("an integer in " if p.type == "int" else "") + p.range_text()) from None


def check_channels(channels, allowed=CHANNELS, unknown: str = "unknown channel {!r}") -> tuple:
    """``channels`` (a name or names) as a tuple, each in ``allowed``; ``unknown`` words the
    error for one that is not (formatted with the name)."""
    if isinstance(channels, str):
        channels = (channels,)
    channels = tuple(channels)
    if not channels:
        raise ValueError("channels must name at least one of: " + ", ".join(allowed))
    for c in channels:
        if c not in allowed:
            raise ValueError(f"{unknown.format(c)}; accepted: {', '.join(allowed)}")
    return channels
